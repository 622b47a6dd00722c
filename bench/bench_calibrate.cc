// Speed and memory of the calibration solve (a 20-image session of ~10k corner
// observations in <= 5 s wall on 2 cores, peak memory <= 1 GB; then <= 2 s). A timed run,
// not a Google Benchmark loop (one solve is seconds): the misaligned big rig's exact corners from
// synthetic's fast path plus 0.1 px noise, lips as the detector reports them, the ideal
// design as the start, the session's default solver options (2 threads).
//   bench_calibrate [images=20] [targets_per_image=4] [values_out.txt]
// values_out.txt (optional): one line per refined parameter "name value sigma" (internal units),
// to compare two builds' answers (a speed change must not move them by more than ~0.1 sigma).
//
// Monte Carlo mode (the sigmas within 20% on a realistic-preset session; calib/monte_carlo.h):
//   bench_calibrate montecarlo SESSION.yaml DETECTIONS.yaml [solves=50] [workers=2]
// calibrates the session's real detections once (from the session's model, its options): the
// reference R0, whose variance components are printed; then `solves` synthetic sessions from it,
// each solved with its own session options, one thread per solve, `workers` solves at a time.
//
// Scene mode (a big, near session: <= 10 s wall for 24 images):
//   bench_calibrate SCENE.yaml RIG.yaml [corner_noise_px=0.05] [lip_profiles=360] [values_out.txt]
// the scene file's placements through RIG (the truth) on the fast path, exact corners plus
// Gaussian noise, lips from the truth with 0.03 px noise (lip_profiles 0: none), started from
// RIG's ideal design (every pose, the reflex plane and the distortion zero, the principal point
// at the image centre, fx = fy = 1450 px as in the design files), or from the model file
// OMNI_START_MODEL names (e.g. with measured profiles: bench/measured_profile_scans.py).
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <ctime>
#include <string>

#include <glog/logging.h>

#include "calib/calibrate.h"
#include "calib/monte_carlo.h"
#include "calib/session_options.h"
#include "io/detections_file.h"
#include "io/model_file.h"
#include "io/session_file.h"
#include "model/model_compare.h"
#include "model/rig_model.h"
#include "tests/calib/calib_test_util.h"

using namespace omni;

namespace {

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

// Solves from `start` (its stages' lines on stdout), then the time, memory, the parameter table
// against the truth, the worst misalignment in sigmas and the projection difference at 1 m;
// values_out (may be null): "name value sigma" per refined parameter.
void SolveAndReport(const RigParams& start, const std::vector<TargetSpec>& targets,
                    const Observations& detections, calib::CalibrationOptions options,
                    const RigParams& truth, int images, const char* values_out) {
  size_t corners = 0, lip_points = 0;
  for (const auto& image : detections.images) {
    corners += image.corners.size();
    for (const auto& lip : image.lips) lip_points += lip.points.size();
  }
  options.progress = [](const std::string& line) { std::printf("  %s\n", line.c_str()); };
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t cpu0 = std::clock();
  const calib::CalibrationResult result = calib::Calibrate(start, targets, detections, options);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
  const int threads = options.solver.threads;
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
  // OMNI_START_MODEL: a model file to start from instead (e.g. the design with its mirrors'
  // measured profiles, bench/measured_profile_scans.py).
  const char* start_file = std::getenv("OMNI_START_MODEL");
  SolveAndReport(start_file ? io::ReadModelFile(start_file)
                            : IdealDesignOf(truth, session.scene.width, session.scene.height),
                 session.targets,
                 detections, calib::CalibrationOptions(), truth,
                 static_cast<int>(detections.images.size()), argc > 5 ? argv[5] : nullptr);
  return 0;
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
  const calib::ExactSession exact = calib::ExactOf(r0, session.targets, detections);
  std::printf("synthetic sessions: %d / %d corners (rings 1 / 2) at %.4f / %.4f px per axis, %d lip "
              "points at %.4f px per axis (%d farther than 1 px from R0's edge left out); %d "
              "solves from R0's rig, %d at a time, one thread each\n",
              exact.corners[0], exact.corners[1], corner_sigma[0], corner_sigma[1],
              exact.lip_points, lip_sigma, exact.lip_dropped, solves, workers);
  options.progress = nullptr;
  options.solver.threads = 1;
  const calib::MonteCarloSolves runs = calib::SolveNoisySessions(
      r0, session.targets, exact, corner_sigma, lip_sigma, options, solves, workers);
  int used = 0;
  std::printf("%s", calib::MonteCarloSummary(r0, runs, &used).c_str());
  if (used < 2) return 1;
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
  calib::CalibrationOptions options;  // the session defaults: all but the shapes, 2 threads
  options.estimate = DefaultEstimateBlocks();
  // OMNI_PROFILE=off|hold|free|auto, OMNI_PROFILE_SIGMA_MM: the mirrors' profiles (default as a
  // session's).
  if (const char* profile = std::getenv("OMNI_PROFILE")) options.profile = profile;
  if (const char* sigma = std::getenv("OMNI_PROFILE_SIGMA_MM")) options.profile_sigma_mm = std::atof(sigma);
  SolveAndReport(testing::IdealRig(), session.targets, detections, options,
                 testing::MisalignedRig(), random.images, argc > 3 ? argv[3] : nullptr);
  return 0;
}
