#include "calib/monte_carlo.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <thread>
#include <tuple>

#include <Eigen/Eigenvalues>

#include "calib/solve_benchmark.h"
#include "io/text_append.h"
#include "model/lip.h"
#include "model/rig_model.h"
#include "model/rig_parameters.h"

namespace omni::calib {

ExactSession ExactOf(const CalibrationResult& r0, const std::vector<TargetSpec>& targets,
                     const Observations& detections) {
  const RigModel model(r0.estimate.rig);
  std::map<std::pair<int, int>, const TargetPlacementEstimate*> pose;
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

MeasuredNoise MeasuredNoiseOf(const CalibrationResult& r0, bool use_lips) {
  MeasuredNoise noise;
  for (const auto& g : r0.uncertainty.variance_components) {
    if (g.group == "corners ring 1") noise.corner_sigma_px[0] = g.sigma_px;
    if (g.group == "corners ring 2") noise.corner_sigma_px[1] = g.sigma_px;
  }
  noise.lip_sigma_px = use_lips ? r0.residuals.lip_rms_px : 0.0;
  return noise;
}

std::string ReferenceText(const CalibrationResult& r0, double seconds) {
  std::string out;
  io::AppendFormat(&out, "reference R0 (the session's detections): %.1f s wall, rms %.4f px over "
                   "%d corners, %d lip points (%d normal points), lips rms %.4f px\n", seconds,
                   r0.residuals.rms_px, r0.residuals.n_observations, r0.residuals.n_lip_points,
                   r0.residuals.n_lip_normal_points, r0.residuals.lip_rms_px);
  for (const auto& g : r0.uncertainty.variance_components) {
    io::AppendFormat(&out, "  R0 %-15s s %.4f px per axis, correlation factor %.2f, weighted as "
                     "%.4f px\n", g.group.c_str(), g.sigma_px, g.correlation_factor,
                     g.weight_sigma_px);
  }
  return out;
}

std::string SyntheticSessionsText(const ExactSession& exact, const MeasuredNoise& noise,
                                  int solves, int workers) {
  std::string out;
  io::AppendFormat(&out, "synthetic sessions: %d / %d corners (rings 1 / 2) at %.4f / %.4f px per "
                   "axis, %d lip points at %.4f px per axis (%d farther than 1 px from R0's edge "
                   "left out); %d solves from R0's rig, %d at a time, one thread each\n",
                   exact.corners[0], exact.corners[1], noise.corner_sigma_px[0],
                   noise.corner_sigma_px[1], exact.lip_points, noise.lip_sigma_px,
                   exact.lip_dropped, solves, workers);
  return out;
}

MonteCarloSolves SolveNoisySessions(const CalibrationResult& r0,
                                    const std::vector<TargetSpec>& targets,
                                    const ExactSession& exact, const double corner_sigma_px[2],
                                    double lip_sigma_px, const CalibrationOptions& options,
                                    int solves, int workers) {
  MonteCarloSolves out;
  out.results.resize(solves);
  out.errors.resize(solves);
  out.seconds.assign(solves, 0);
  const auto t1 = std::chrono::steady_clock::now();
  auto run = [&](int first) {
    for (int k = first; k < solves; k += workers) {
      const auto ts = std::chrono::steady_clock::now();
      try {
        out.results[k] = Calibrate(r0.estimate.rig, targets,
                                   Noisy(exact, corner_sigma_px, lip_sigma_px, 1000 + k), options);
      } catch (const std::exception& e) {
        out.errors[k] = e.what();
      }
      out.seconds[k] = std::chrono::duration<double>(std::chrono::steady_clock::now() - ts).count();
    }
  };
  std::vector<std::thread> pool;
  for (int w = 1; w < workers; ++w) pool.emplace_back(run, w);
  run(0);
  for (auto& t : pool) t.join();
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  return out;
}

namespace {

// The most common list of observable parameters over the solves that did not fail (white lip
// noise may tell the synthetic sessions more than R0's own, e.g. dist_k3 freed; R0's when none
// is more common); where it differs from R0's, a line "+name -name" appended to *out.
std::vector<std::string> CommonParameters(const CalibrationResult& r0,
                                          const MonteCarloSolves& solves, std::string* out) {
  const int count = static_cast<int>(solves.results.size());
  std::map<std::vector<std::string>, int> lists;
  for (int k = 0; k < count; ++k) {
    if (solves.errors[k].empty()) ++lists[solves.results[k].estimate.names];
  }
  std::vector<std::string> names = r0.estimate.names;
  int most = 0;
  for (const auto& [list, count] : lists) {
    if (count > most) most = count, names = list;
  }
  if (names == r0.estimate.names) return names;
  const auto in = [](const std::vector<std::string>& list, const std::string& name) {
    return std::find(list.begin(), list.end(), name) != list.end();
  };
  io::AppendFormat(out, "the solves' observable parameters differ from R0's:");
  for (const auto& name : names) {
    if (!in(r0.estimate.names, name)) io::AppendFormat(out, " +%s", name.c_str());
  }
  for (const auto& name : r0.estimate.names) {
    if (!in(names, name)) io::AppendFormat(out, " -%s", name.c_str());
  }
  io::AppendFormat(out, "\n");
  return names;
}

// The solves that succeeded with exactly `names` observable; the others named in *out.
std::vector<int> UsableSolves(const MonteCarloSolves& solves, const std::vector<std::string>& names,
                              std::string* out) {
  std::vector<int> good;
  for (int k = 0; k < static_cast<int>(solves.results.size()); ++k) {
    if (!solves.errors[k].empty()) {
      io::AppendFormat(out, "solve %d failed: %s\n", k, solves.errors[k].c_str());
    } else if (solves.results[k].estimate.names != names) {
      io::AppendFormat(out, "solve %d: other parameters observable than the others' (left out)\n",
                       k);
    } else {
      good.push_back(k);
    }
  }
  return good;
}

double MeanSeconds(const MonteCarloSolves& solves) {
  double s = 0;
  for (double x : solves.seconds) s += x;
  return s / static_cast<int>(solves.results.size());
}

// Per variance-component group, its mean sigma and correlation factor over the used solves.
std::string VarianceComponentLines(const MonteCarloSolves& solves, const std::vector<int>& good) {
  const int n = static_cast<int>(good.size());
  std::map<std::string, std::pair<double, double>> groups;  // mean s, mean tau
  for (int k : good) {
    for (const auto& g : solves.results[k].uncertainty.variance_components) {
      groups[g.group].first += g.sigma_px / n;
      groups[g.group].second += g.correlation_factor / n;
    }
  }
  std::string out;
  for (const auto& [name, v] : groups) {
    io::AppendFormat(&out, "  solves' %-15s mean s %.4f px per axis, correlation factor %.2f\n",
                     name.c_str(), v.first, v.second);
  }
  return out;
}

// The used solves' values per parameter against R0's: each solve's deviation from their mean,
// the spread (sample sd), the mean and the mean predicted pixel-noise sigma.
struct Spread {
  Eigen::VectorXd reference, mean, spread, predicted;
  Eigen::MatrixXd deviations;  // solve x parameter
};
Spread SpreadOf(const CalibrationResult& r0, const MonteCarloSolves& solves,
                const std::vector<int>& good, const std::vector<std::string>& names) {
  const int n = static_cast<int>(good.size()), p = static_cast<int>(names.size());
  Spread s;
  s.reference.resize(p);
  for (int i = 0; i < p; ++i) s.reference(i) = *ParameterOf(r0.estimate.rig, names[i]);
  Eigen::MatrixXd x(n, p);
  s.predicted = Eigen::VectorXd::Zero(p);
  for (int a = 0; a < n; ++a) {
    x.row(a) = solves.results[good[a]].estimate.values.transpose();
    s.predicted += solves.results[good[a]].uncertainty.noise_sigma / n;
  }
  s.mean = x.colwise().mean().transpose();
  s.deviations = x.rowwise() - s.mean.transpose();
  s.spread = (s.deviations.array().square().colwise().sum() / (n - 1)).sqrt().transpose();
  return s;
}

// Per parameter: R0's value, the spread, the predicted sigma, their ratio and the bias; the
// worst ratio against what sampling alone explains.
std::string ParameterTable(const std::vector<std::string>& names, const Spread& s) {
  const int n = static_cast<int>(s.deviations.rows()), p = static_cast<int>(names.size());
  std::string out;
  io::AppendFormat(&out, "%-14s %14s %12s %12s %7s %12s\n", "parameter", "R0 value", "spread",
                   "predicted", "ratio", "bias/spread");
  double worst = 0;
  std::string worst_name;
  for (int i = 0; i < p; ++i) {
    const double ratio = s.spread(i) / s.predicted(i);
    const double bias = (s.mean(i) - s.reference(i)) / s.spread(i);
    io::AppendFormat(&out, "%-14s %14.6g %12.4g %12.4g %7.3f %12.2f\n", names[i].c_str(),
                     s.reference(i), s.spread(i), s.predicted(i), ratio, bias);
    if (std::abs(ratio - 1) > worst) worst = std::abs(ratio - 1), worst_name = names[i];
  }
  io::AppendFormat(&out, "ratio sd from sampling alone ~ 1/sqrt(2 n) = %.3f; worst |ratio - 1| "
                   "%.3f (%s)\n", 1 / std::sqrt(2.0 * n), worst, worst_name.c_str());
  return out;
}

// The predicted pixel-noise covariance: each used solve's covariance minus its considered share,
// averaged over the solves (R0's own would weigh the lips by the real session's correlation
// factor; the synthetic white lip noise gives ~1).
Eigen::MatrixXd MeanNoiseCovariance(const MonteCarloSolves& solves, const std::vector<int>& good,
                                    int p) {
  const int n = static_cast<int>(good.size());
  Eigen::MatrixXd noise_cov = Eigen::MatrixXd::Zero(p, p);
  for (int a = 0; a < n; ++a) {
    const CalibrationUncertainty& u = solves.results[good[a]].uncertainty;
    Eigen::MatrixXd c = u.covariance;
    if (u.considered_sensitivity.cols() == u.considered_column_sigma.size() &&
        u.considered_sensitivity.rows() == p) {
      c -= u.considered_sensitivity *
           u.considered_column_sigma.array().square().matrix().asDiagonal() *
           u.considered_sensitivity.transpose();
    }
    noise_cov += c / n;
  }
  return noise_cov;
}

// chi^2 of the spread against the noise covariance, Jacobi-scaled, pseudo-inverse at 1e-10 of
// the largest eigenvalue (the camera-rotation valley's near-gauge counts by its own
// eigenvalue): per solve in all and per eigen-direction.
std::string ChiSquareText(const Eigen::MatrixXd& noise_cov, const Spread& s) {
  const int n = static_cast<int>(s.deviations.rows()), p = static_cast<int>(noise_cov.rows());
  std::string out;
  const Eigen::VectorXd scale = noise_cov.diagonal().cwiseMax(1e-300).cwiseSqrt();
  io::AppendFormat(&out, "mean noise covariance: sqrt(diagonal) / mean noise_sigma in %.4f .. "
                   "%.4f\n", scale.cwiseQuotient(s.predicted).minCoeff(),
                   scale.cwiseQuotient(s.predicted).maxCoeff());
  const Eigen::MatrixXd scaled = scale.cwiseInverse().asDiagonal() * noise_cov *
                                 scale.cwiseInverse().asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
  const double tol = 1e-10 * eig.eigenvalues().maxCoeff();
  int rank = 0;
  double chi2 = 0;
  Eigen::VectorXd per_direction = Eigen::VectorXd::Zero(p);
  for (int a = 0; a < n; ++a) {
    const Eigen::VectorXd z = eig.eigenvectors().transpose() *
                              (s.deviations.row(a).transpose().cwiseQuotient(scale));
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
  io::AppendFormat(&out, "chi^2 of the spread against the predicted noise covariance: %.2f per "
                   "solve for %d directions (expected %d; sampling sd ~%.2f)\n", chi2, rank, rank,
                   std::sqrt(2.0 * rank / n));
  io::AppendFormat(&out, "per eigen-direction (Jacobi-scaled eigenvalue ascending: variance "
                   "ratio): ");
  for (int k = 0; k < p; ++k) {
    if (eig.eigenvalues()(k) > tol) {
      io::AppendFormat(&out, "%.2g:%.2f ", eig.eigenvalues()(k), per_direction(k));
    }
  }
  io::AppendFormat(&out, "\n");
  return out;
}

}  // namespace

std::string MonteCarloSummary(const CalibrationResult& r0, const MonteCarloSolves& solves,
                              int* used) {
  std::string out;
  const std::vector<std::string> names = CommonParameters(r0, solves, &out);
  const std::vector<int> good = UsableSolves(solves, names, &out);
  const int n = static_cast<int>(good.size()), count = static_cast<int>(solves.results.size());
  io::AppendFormat(&out, "%d of %d solves used, %.1f s wall (%.1f s per solve on one thread)\n",
                   n, count, solves.wall_s, MeanSeconds(solves));
  *used = n;
  if (n < 2) return out;
  out += VarianceComponentLines(solves, good);
  const Spread spread = SpreadOf(r0, solves, good, names);
  out += ParameterTable(names, spread);
  out += ChiSquareText(MeanNoiseCovariance(solves, good, static_cast<int>(names.size())), spread);
  return out;
}

int MonteCarloCheck(const RigParams& start, const std::vector<TargetSpec>& targets,
                    const Observations& detections, CalibrationOptions options, int solves,
                    int workers, const std::function<void(const std::string&)>& print) {
  const TimedSolve reference = SolveTimed(start, targets, detections, options);
  const CalibrationResult& r0 = reference.result;
  print(ReferenceText(r0, reference.wall_s));
  const MeasuredNoise noise = MeasuredNoiseOf(r0, options.use_lips);
  const ExactSession exact = ExactOf(r0, targets, detections);
  print(SyntheticSessionsText(exact, noise, solves, workers));
  options.progress = nullptr;
  options.solver.threads = 1;
  const MonteCarloSolves runs = SolveNoisySessions(r0, targets, exact, noise.corner_sigma_px,
                                                   noise.lip_sigma_px, options, solves, workers);
  int used = 0;
  print(MonteCarloSummary(r0, runs, &used));
  return used;
}

}  // namespace omni::calib
