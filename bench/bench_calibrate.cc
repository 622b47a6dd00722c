// Speed and memory of the calibration solve (a 20-image session of ~10k corner
// observations in <= 5 s wall on 2 cores, peak memory <= 1 GB; then <= 2 s). A timed run,
// not a Google Benchmark loop (one solve is seconds): the misaligned big rig's exact corners from
// synthetic's fast path plus 0.1 px noise, lips as the detector reports them, the ideal
// design as the start, the session's default solver options (2 threads).
//   bench_calibrate [images=20] [targets_per_image=4] [values_out.txt]
// values_out.txt (optional): one line per refined parameter "name value sigma" (internal units),
// to compare two builds' answers (a speed change must not move them by more than ~0.1 sigma).
//
// Scene mode (a big, near session: <= 10 s wall for 24 images):
//   bench_calibrate SCENE.yaml RIG.yaml [corner_noise_px=0.05] [lip_profiles=360] [values_out.txt]
// the scene file's placements through RIG (the truth) on the fast path, exact corners plus
// Gaussian noise, lips from the truth with 0.03 px noise (lip_profiles 0: none), started from
// RIG's ideal design (every pose, the reflex plane and the distortion zero, the principal point
// at the image centre, fx = fy = 1450 px as in the design files).
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <ctime>
#include <map>
#include <random>
#include <string>
#include <thread>

#include <Eigen/Eigenvalues>

#include <glog/logging.h>

#include "calib/calibrate.h"
#include "calib/session_options.h"
#include "io/detections_file.h"
#include "io/model_file.h"
#include "io/session_file.h"
#include "model/lip.h"
#include "model/model_compare.h"
#include "model/rig_model.h"
#include "model/rig_parameters.h"
#include "tests/calib/calib_test_util.h"

using namespace omni;

namespace {

// Monte Carlo mode (the sigmas within 20% on a realistic-preset session):
//   bench_calibrate montecarlo SESSION.yaml DETECTIONS.yaml [solves=50] [workers=2]
// calibrates the session's real detections once (from the session's model, its options): the
// reference R0. Then each of `solves` synthetic sessions keeps exactly the observations R0 used,
// each replaced by its value under R0 plus white Gaussian noise of the group's measured sigma:
// corners projected from R0's target poses with R0's per-ring sigma per axis, lip edge points
// moved to the nearest point of R0's band edge (model/lip.h DistanceToLipEdgeImage) with R0's
// lip RMS across the edge as the per-axis sigma. Each is solved from R0's rig (its own session
// options, one thread per solve, `workers` solves at a time). Per parameter: the spread of the
// solves against the mean predicted pixel-noise sigma (CalibrationUncertainty::noise_sigma, the
// covariance without the considered parameters' share: the synthetic noise is white and
// unbiased, p1 = p2 = 0 held exactly), and the bias; then the spread's chi^2 against the solves'
// mean noise covariance (pseudo-inverse of its Jacobi-scaled form, so the camera-rotation valley's
// near-gauge counts by its own eigenvalue): mean d^T C^+ d over the solves, ~rank if the
// covariance's shape is right too. R0's own variance components are printed beside.

// RIG's ideal design: what a user starts from (sample_configs/big_rig_ideal.yaml's camera).
RigParams IdealDesignOf(const RigParams& rig, int width, int height) {
  RigParams ideal = rig;
  ideal.kind = ModelKind::kIdeal;
  ideal.camera = {1450.0, 1450.0, (width - 1) / 2.0, (height - 1) / 2.0, 0.0};
  ideal.distortion = {};
  ideal.mirror1_pose = {};
  ideal.mirror2_pose = {};
  ideal.reflex = {};
  ideal.calibration.reset();
  return ideal;
}

void Report(const calib::CalibrationResult& result, const RigParams& truth, double wall_s,
            double cpu_s, int images, size_t corners, size_t lip_points, int threads,
            const char* values_out) {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("images %d, corner observations %zu, lip edge points %zu, threads %d\n", images,
              corners, lip_points, threads);
  std::printf("solve: %.2f s wall, %.2f s CPU (%s), rms %.3f px over %d observations\n", wall_s,
              cpu_s, result.solve.converged ? "converged" : "NOT converged",
              result.residuals.rms_px, result.residuals.n_observations);
  std::printf("peak memory (whole process, max RSS): %.1f MB\n", usage.ru_maxrss / 1024.0);
  std::printf("%s", calib::ResultTable(result, &truth).c_str());
  double worst = 0;
  std::string worst_name;
  for (size_t i = 0; i < result.estimate.names.size(); ++i) {
    if (!testing::IsMisalignment(result.estimate.names[i]) || !(result.uncertainty.sigma(i) > 0))
      continue;
    const double z =
        std::abs(result.estimate.values(i) - testing::TruthValue(truth, result.estimate.names[i])) /
        result.uncertainty.sigma(i);
    if (z > worst) worst = z, worst_name = result.estimate.names[i];
  }
  const RigModel true_model(truth), calibrated(result.estimate.rig);
  const ProjectionDifference m1 = CompareProjectionsInMirror1(true_model, calibrated, 1000);
  const ProjectionDifference cam = CompareProjections(true_model, calibrated, 1000);
  std::printf("worst misalignment |value-truth|/sigma %.2f (%s); projection at 1 m RMS: mirror 1's "
              "body %.3f / %.3f px, C %.3f / %.3f px (ring 1 / ring 2)\n",
              worst, worst_name.c_str(), m1.rms_px[0], m1.rms_px[1], cam.rms_px[0],
              cam.rms_px[1]);
  if (values_out) {
    std::ofstream out(values_out);
    out.precision(17);
    for (size_t i = 0; i < result.estimate.names.size(); ++i) {
      out << result.estimate.names[i] << " " << result.estimate.values(i) << " "
          << result.uncertainty.sigma(i) << "\n";
    }
  }
}

int RunScene(int argc, char** argv) {
  const RigParams truth_rig = io::ReadModelFile(argv[2]);
  const double corner_noise = argc > 3 ? std::atof(argv[3]) : 0.05;
  const int lip_profiles = argc > 4 ? std::atoi(argv[4]) : 360;
  testing::SyntheticSession session;
  const RigParams truth = testing::MakeSceneSession(truth_rig, argv[1], &session);
  Observations detections = testing::NoisyDetections(session, corner_noise, 3);
  if (lip_profiles > 0) testing::AddLipDetections(truth, 0.03, 4, &detections, lip_profiles);
  size_t corners = 0, lip_points = 0;
  for (const auto& image : detections.images) {
    corners += image.corners.size();
    for (const auto& lip : image.lips) lip_points += lip.points.size();
  }
  calib::CalibrationOptions options;
  options.progress = [](const std::string& line) { std::printf("  %s\n", line.c_str()); };
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t cpu0 = std::clock();
  const calib::CalibrationResult result = calib::Calibrate(
      IdealDesignOf(truth, session.scene.width, session.scene.height), session.targets,
      detections, options);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
  Report(result, truth, wall_s, cpu_s, static_cast<int>(detections.images.size()), corners,
         lip_points, options.solver.threads, argc > 5 ? argv[5] : nullptr);
  return 0;
}

// R0's exact value of every observation it used: corners from its target poses, lip points on
// its band edges. Noise is added per solve (Noisy).
struct ExactSession {
  Observations detections;  // exact pixels; lips keep their edge labels
  int corners[2] = {0, 0}, lip_points = 0, lip_dropped = 0;
};

ExactSession ExactOf(const calib::CalibrationResult& r0, const std::vector<TargetSpec>& targets,
                     const Observations& detections) {
  const RigModel model(r0.estimate.rig);
  std::map<std::pair<int, int>, const calib::TargetPlacementEstimate*> pose;
  for (const auto& p : r0.residuals.placements) pose[{p.image, p.target}] = &p;
  std::map<std::tuple<int, int, int, int>, bool> rejected;
  for (const auto& o : r0.residuals.rejected) rejected[{o.image, o.target, o.id, o.mirror}] = true;
  ExactSession out;
  out.detections.session = detections.session;
  for (int i = 0; i < static_cast<int>(detections.images.size()); ++i) {
    const ImageObservations& in = detections.images[i];
    ImageObservations image;
    image.file = in.file;
    image.width = in.width;
    image.height = in.height;
    for (const auto& o : in.corners) {
      const auto it = pose.find({i, o.target});
      if (it == pose.end() || rejected.count({i, o.target, o.id, MirrorIndex(o.mirror)})) continue;
      const Eigen::Vector3d& w = it->second->rotation;
      const Eigen::Matrix3d r = w.norm() > 0
                                    ? Eigen::AngleAxisd(w.norm(), w / w.norm()).toRotationMatrix()
                                    : Eigen::Matrix3d::Identity();
      const Eigen::Vector3d point =
          r * CornerInTarget(targets[o.target], o.id) + it->second->translation;
      const auto px = model.Project(point, o.mirror);
      if (!px) continue;
      CornerObservation exact = o;
      exact.pixel = *px;
      image.corners.push_back(exact);
      ++out.corners[MirrorIndex(o.mirror) - 1];
    }
    for (const auto& edge : in.lips) {
      if (!edge.path || !edge.circle) continue;
      const LipPath path = *edge.path;
      const LipCircle circle = *edge.circle;
      LipEdgeObservation exact = edge;
      exact.points.clear();
      for (const auto& p : edge.points) {
        Eigen::Vector2d nearest;
        // Points R0 could have left out as outliers (a few robust sigmas) are left out here too.
        if (DistanceToLipEdgeImage(model, path, circle, p, &nearest) <= 1.0) {
          exact.points.push_back(nearest);
        } else {
          ++out.lip_dropped;
        }
      }
      out.lip_points += static_cast<int>(exact.points.size());
      if (!exact.points.empty()) image.lips.push_back(exact);
    }
    out.detections.images.push_back(image);
  }
  return out;
}

Observations Noisy(const ExactSession& exact, const double corner_sigma_px[2],
                     double lip_sigma_px, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  Observations d = exact.detections;
  for (auto& image : d.images) {
    for (auto& o : image.corners) {
      const double s = corner_sigma_px[MirrorIndex(o.mirror) - 1];
      o.pixel += s * Eigen::Vector2d(unit(rng), unit(rng));
    }
    for (auto& edge : image.lips) {
      for (auto& p : edge.points) p += lip_sigma_px * Eigen::Vector2d(unit(rng), unit(rng));
    }
  }
  return d;
}

int RunMonteCarlo(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: bench_calibrate montecarlo SESSION.yaml DETECTIONS.yaml "
                         "[solves=50] [workers=2]\n");
    return 2;
  }
  const io::Session session = io::ReadSessionFile(argv[2]);
  const Observations detections = io::ReadDetectionsFile(argv[3]);
  const int solves = argc > 4 ? std::max(2, std::atoi(argv[4])) : 50;
  const int workers = argc > 5 ? std::max(1, std::atoi(argv[5])) : 2;
  const RigParams start = io::ReadModelFile(session.model_path);
  calib::CalibrationOptions options = calib::OptionsFromSession(session);
  const auto t0 = std::chrono::steady_clock::now();
  const calib::CalibrationResult r0 = calib::Calibrate(start, session.targets, detections, options);
  std::printf(
      "reference R0 (the session's detections): %.1f s wall, rms %.4f px over %d corners, "
      "%d lip points (%d normal points), lips rms %.4f px\n",
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
      r0.residuals.rms_px, r0.residuals.n_observations, r0.residuals.n_lip_points,
      r0.residuals.n_lip_normal_points, r0.residuals.lip_rms_px);
  double corner_sigma[2] = {0, 0};
  for (const auto& g : r0.uncertainty.variance_components) {
    std::printf("  R0 %-15s s %.4f px per axis, correlation factor %.2f, weighted as %.4f px\n",
                g.group.c_str(), g.sigma_px, g.correlation_factor, g.weight_sigma_px);
    if (g.group == "corners ring 1") corner_sigma[0] = g.sigma_px;
    if (g.group == "corners ring 2") corner_sigma[1] = g.sigma_px;
  }
  const double lip_sigma = options.use_lips ? r0.residuals.lip_rms_px : 0.0;
  const ExactSession exact = ExactOf(r0, session.targets, detections);
  std::printf("synthetic sessions: %d / %d corners (rings 1 / 2) at %.4f / %.4f px per axis, %d lip "
              "points at %.4f px per axis (%d farther than 1 px from R0's edge left out); %d "
              "solves from R0's rig, %d at a time, one thread each\n",
              exact.corners[0], exact.corners[1], corner_sigma[0], corner_sigma[1],
              exact.lip_points, lip_sigma, exact.lip_dropped, solves, workers);

  options.progress = nullptr;
  options.solver.threads = 1;
  std::vector<calib::CalibrationResult> results(solves);
  std::vector<std::string> errors(solves);
  std::vector<double> seconds(solves, 0);
  const auto t1 = std::chrono::steady_clock::now();
  auto run = [&](int first) {
    for (int k = first; k < solves; k += workers) {
      const auto ts = std::chrono::steady_clock::now();
      try {
        results[k] = calib::Calibrate(r0.estimate.rig, session.targets,
                                      Noisy(exact, corner_sigma, lip_sigma, 1000 + k), options);
      } catch (const std::exception& e) {
        errors[k] = e.what();
      }
      seconds[k] = std::chrono::duration<double>(std::chrono::steady_clock::now() - ts).count();
    }
  };
  std::vector<std::thread> pool;
  for (int w = 1; w < workers; ++w) pool.emplace_back(run, w);
  run(0);
  for (auto& t : pool) t.join();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();

  // Per parameter over the solves with the most common list of observable parameters (white lip
  // noise may tell the synthetic sessions more than R0's own, e.g. dist_k3 freed).
  std::map<std::vector<std::string>, int> lists;
  for (int k = 0; k < solves; ++k) {
    if (errors[k].empty()) ++lists[results[k].estimate.names];
  }
  std::vector<std::string> names = r0.estimate.names;
  int most = 0;
  for (const auto& [list, count] : lists) {
    if (count > most) most = count, names = list;
  }
  if (names != r0.estimate.names) {
    std::printf("the solves' observable parameters differ from R0's:");
    for (const auto& name : names) {
      if (std::find(r0.estimate.names.begin(), r0.estimate.names.end(), name) ==
          r0.estimate.names.end()) {
        std::printf(" +%s", name.c_str());
      }
    }
    for (const auto& name : r0.estimate.names) {
      if (std::find(names.begin(), names.end(), name) == names.end()) {
        std::printf(" -%s", name.c_str());
      }
    }
    std::printf("\n");
  }
  std::vector<int> good;
  for (int k = 0; k < solves; ++k) {
    if (!errors[k].empty()) {
      std::printf("solve %d failed: %s\n", k, errors[k].c_str());
    } else if (results[k].estimate.names != names) {
      std::printf("solve %d: other parameters observable than the others' (left out)\n", k);
    } else {
      good.push_back(k);
    }
  }
  const int n = static_cast<int>(good.size());
  std::printf("%d of %d solves used, %.1f s wall (%.1f s per solve on one thread)\n", n, solves,
              wall, [&] { double s = 0; for (double x : seconds) s += x; return s / solves; }());
  if (n < 2) return 1;
  {
    std::map<std::string, std::pair<double, double>> groups;  // mean s, mean tau
    for (int k : good) {
      for (const auto& g : results[k].uncertainty.variance_components) {
        groups[g.group].first += g.sigma_px / n;
        groups[g.group].second += g.correlation_factor / n;
      }
    }
    for (const auto& [name, v] : groups) {
      std::printf("  solves' %-15s mean s %.4f px per axis, correlation factor %.2f\n",
                  name.c_str(), v.first, v.second);
    }
  }
  const int p = static_cast<int>(names.size());
  Eigen::VectorXd reference(p);  // R0's value of each parameter
  for (int i = 0; i < p; ++i) reference(i) = *ParameterOf(r0.estimate.rig, names[i]);
  Eigen::MatrixXd x(n, p);
  Eigen::VectorXd predicted = Eigen::VectorXd::Zero(p);
  for (int a = 0; a < n; ++a) {
    x.row(a) = results[good[a]].estimate.values.transpose();
    predicted += results[good[a]].uncertainty.noise_sigma / n;
  }
  const Eigen::VectorXd mean = x.colwise().mean().transpose();
  const Eigen::MatrixXd d = x.rowwise() - mean.transpose();
  const Eigen::VectorXd spread = (d.array().square().colwise().sum() / (n - 1)).sqrt().transpose();
  std::printf("%-14s %14s %12s %12s %7s %12s\n", "parameter", "R0 value", "spread", "predicted",
              "ratio", "bias/spread");
  double worst = 0;
  std::string worst_name;
  for (int i = 0; i < p; ++i) {
    const double ratio = spread(i) / predicted(i);
    const double bias = (mean(i) - reference(i)) / spread(i);
    std::printf("%-14s %14.6g %12.4g %12.4g %7.3f %12.2f\n", names[i].c_str(), reference(i),
                spread(i), predicted(i), ratio, bias);
    if (std::abs(ratio - 1) > worst) worst = std::abs(ratio - 1), worst_name = names[i];
  }
  std::printf("ratio sd from sampling alone ~ 1/sqrt(2 n) = %.3f; worst |ratio - 1| %.3f (%s)\n",
              1 / std::sqrt(2.0 * n), worst, worst_name.c_str());

  // chi^2 of the spread against the predicted pixel-noise covariance (each solve's covariance
  // minus its considered share, averaged over the solves: R0's own would weigh the lips by the
  // real session's correlation factor, the synthetic white lip noise gives ~1), Jacobi-scaled,
  // pseudo-inverse at 1e-10 of the largest eigenvalue.
  Eigen::MatrixXd noise_cov = Eigen::MatrixXd::Zero(p, p);
  for (int a = 0; a < n; ++a) {
    const calib::CalibrationResult& r = results[good[a]];
    Eigen::MatrixXd c = r.uncertainty.covariance;
    if (r.uncertainty.considered_sensitivity.cols() ==
            r.uncertainty.considered_column_sigma.size() &&
        r.uncertainty.considered_sensitivity.rows() == p) {
      c -= r.uncertainty.considered_sensitivity *
           r.uncertainty.considered_column_sigma.array().square().matrix().asDiagonal() *
           r.uncertainty.considered_sensitivity.transpose();
    }
    noise_cov += c / n;
  }
  const Eigen::VectorXd scale = noise_cov.diagonal().cwiseMax(1e-300).cwiseSqrt();
  std::printf("mean noise covariance: sqrt(diagonal) / mean noise_sigma in %.4f .. %.4f\n",
              scale.cwiseQuotient(predicted).minCoeff(), scale.cwiseQuotient(predicted).maxCoeff());
  const Eigen::MatrixXd scaled = scale.cwiseInverse().asDiagonal() * noise_cov *
                                 scale.cwiseInverse().asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
  const double tol = 1e-10 * eig.eigenvalues().maxCoeff();
  int rank = 0;
  double chi2 = 0;
  Eigen::VectorXd per_direction = Eigen::VectorXd::Zero(p);
  for (int a = 0; a < n; ++a) {
    const Eigen::VectorXd z = eig.eigenvectors().transpose() *
                              (d.row(a).transpose().cwiseQuotient(scale));
    for (int k = 0; k < p; ++k) {
      if (eig.eigenvalues()(k) <= tol) continue;
      per_direction(k) += z(k) * z(k) / eig.eigenvalues()(k) / (n - 1);
    }
  }
  for (int k = 0; k < p; ++k) {
    if (eig.eigenvalues()(k) <= tol) continue;
    ++rank;
    chi2 += per_direction(k);
  }
  std::printf("chi^2 of the spread against the predicted noise covariance: %.2f per solve for %d "
              "directions (expected %d; sampling sd ~%.2f)\n", chi2, rank, rank,
              std::sqrt(2.0 * rank / n));
  std::printf("per eigen-direction (Jacobi-scaled eigenvalue ascending: variance ratio): ");
  for (int k = 0; k < p; ++k) {
    if (eig.eigenvalues()(k) > tol) std::printf("%.2g:%.2f ", eig.eigenvalues()(k), per_direction(k));
  }
  std::printf("\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  FLAGS_minloglevel = 2;  // Ceres's per-trial-step warnings, as in the CLI
  if (argc > 1 && std::string(argv[1]) == "montecarlo") return RunMonteCarlo(argc, argv);
  if (argc > 2 && std::string(argv[1]).size() > 5 &&
      std::string(argv[1]).substr(std::string(argv[1]).size() - 5) == ".yaml") {
    return RunScene(argc, argv);
  }
  synthetic::RandomPlacement random;
  random.images = argc > 1 ? std::atoi(argv[1]) : 20;
  random.targets_min = random.targets_max = argc > 2 ? std::atoi(argv[2]) : 4;
  random.range_min_mm = 500;
  random.range_max_mm = 2000;
  random.seed = 11;
  const auto session = testing::MakeSession(
      testing::MisalignedRig(), random,
      {testing::Chessboard(7, 10, 40.0), testing::Chessboard(8, 9, 45.0),
       testing::Chessboard(6, 11, 50.0), testing::Chessboard(9, 12, 35.0)});
  Observations detections = testing::NoisyDetections(session, 0.1, 3);
  testing::AddLipDetections(testing::MisalignedRig(), 0.05, 4, &detections, 360);
  size_t corners = 0, lip_points = 0;
  for (const auto& image : detections.images) {
    corners += image.corners.size();
    for (const auto& lip : image.lips) lip_points += lip.points.size();
  }

  calib::CalibrationOptions options;  // the session defaults: all but the shapes, 2 threads
  options.estimate = DefaultEstimateBlocks();
  options.progress = [](const std::string& line) { std::printf("  %s\n", line.c_str()); };
  // OMNI_PROFILE=off|hold|free|auto, OMNI_PROFILE_SIGMA_MM: the mirrors' profiles (default as a
  // session's).
  if (const char* profile = std::getenv("OMNI_PROFILE")) options.profile = profile;
  if (const char* sigma = std::getenv("OMNI_PROFILE_SIGMA_MM")) options.profile_sigma_mm = std::atof(sigma);
  const auto t0 = std::chrono::steady_clock::now();
  std::clock_t cpu0 = std::clock();
  const calib::CalibrationResult result =
      calib::Calibrate(testing::IdealRig(), session.targets, detections, options);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
  Report(result, testing::MisalignedRig(), wall_s, cpu_s, random.images, corners, lip_points,
         options.solver.threads, argc > 3 ? argv[3] : nullptr);
  return 0;
}
