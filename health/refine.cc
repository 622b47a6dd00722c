#include "health/refine.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>

#include <ceres/ceres.h>
#include <opencv2/core.hpp>

#include "calib/covariance.h"
#include "health/drift.h"
#include "health/lip_reference.h"
#include "health/residuals.h"
#include "model/rig_model.h"
#include "model/rig_parameters.h"

namespace omni::health {
namespace {

// Every sample's weighted residual under the stored model moved along `coordinates`, and their
// derivatives by forward differences (one model per coordinate; the samples in parallel).
class SessionCost : public ceres::CostFunction {
 public:
  SessionCost(const RigParams& stored, std::vector<int> coordinates,
              const std::vector<Sample>* samples, std::vector<double> weights)
      : stored_(stored), coordinates_(std::move(coordinates)), samples_(samples),
        weights_(std::move(weights)) {
    set_num_residuals(static_cast<int>(samples_->size()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(coordinates_.size()));
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const int n = static_cast<int>(coordinates_.size());
    const Eigen::Map<const Eigen::VectorXd> x(parameters[0], n);
    if (!Residuals(x, residuals)) return false;
    if (!jacobians || !jacobians[0]) return true;
    const auto& all = DriftCoordinates();
    const int m = num_residuals();
    std::vector<double> moved(m);
    for (int c = 0; c < n; ++c) {
      Eigen::VectorXd xc = x;
      const double step = all[coordinates_[c]].step;
      xc[c] += step;
      if (!Residuals(xc, moved.data())) return false;
      for (int i = 0; i < m; ++i) jacobians[0][i * n + c] = (moved[i] - residuals[i]) / step;
    }
    return true;
  }

 private:
  bool Residuals(const Eigen::VectorXd& x, double* out) const {
    const RigModel model(ApplyDrift(stored_, coordinates_, x));
    std::atomic<bool> ok{true};
    cv::parallel_for_(cv::Range(0, num_residuals()), [&](const cv::Range& range) {
      for (int i = range.start; i < range.end; ++i) {
        const auto r = ResidualUnder(model, (*samples_)[i]);
        // A sample the trial model no longer images (a step far off) fails the step.
        if (!r) {
          ok = false;
          out[i] = 0;
          continue;
        }
        out[i] = weights_[i] * *r;
      }
    });
    return ok;
  }

  RigParams stored_;
  std::vector<int> coordinates_;
  const std::vector<Sample>* samples_;
  std::vector<double> weights_;
};

// Every k-th of the kept samples of one kind (match or lip) so that at most `limit` remain.
void TakeSpread(const std::vector<Sample>& samples, bool matches, int limit,
                std::vector<Sample>* out) {
  std::vector<int> kept;
  for (size_t i = 0; i < samples.size(); ++i) {
    if (samples[i].kept && samples[i].is_match == matches) kept.push_back(static_cast<int>(i));
  }
  const double stride = std::max(1.0, static_cast<double>(kept.size()) / limit);
  for (double k = 0; k < kept.size(); k += stride) out->push_back(samples[kept[static_cast<int>(k)]]);
}

std::string KindOf(const Sample& s) {
  return s.is_match ? "matches"
                    : std::string(LipPathName(s.lip.path)) + " " + LipCircleName(s.lip.circle);
}

// The bins' Jacobian by `coordinates` (columns of check.jacobian), whitened by the bins' data
// errors (scaled by variance_factor); a single mirror's rim bins also by what the scene behind
// the rim moves its harmonics by (check.h RimSceneVariance: the same in every bin of a photo, so
// it does not average down over the bins as their errors do).
Eigen::MatrixXd WhitenedBinJacobian(const RigParams& stored, const CheckResult& check,
                                    const std::vector<int>& coordinates,
                                    double variance_factor = 1) {
  const int m = static_cast<int>(check.bins.size());
  Eigen::MatrixXd J(m, coordinates.size());
  for (int b = 0; b < m; ++b) {
    for (size_t k = 0; k < coordinates.size(); ++k) J(b, k) = check.jacobian(b, coordinates[k]);
  }
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(m, m);
  for (int b = 0; b < m; ++b) {
    C(b, b) = variance_factor * check.bins[b].standard_error * check.bins[b].standard_error;
  }
  if (stored.Paths() < 2) {
    Eigen::MatrixXd H(m, kRimHarmonics);
    for (int b = 0; b < m; ++b) H.row(b) = RimHarmonicsRow(check.bins[b].azimuth_deg).transpose();
    C += RimSceneVariance(stored, check) * H * H.transpose();
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(C);
  return llt.matrixL().solve(J);
}

// chi^2 per degree of freedom of the bins against their data errors alone (the check's own chi^2
// also allows for the stored model's covariance); 1 where there are no spare bins.
double DataChi2PerDof(const CheckResult& check, int n_parameters) {
  const int dof = static_cast<int>(check.bins.size()) - n_parameters;
  if (dof <= 0) return 1.0;
  double chi2 = 0;
  for (const ResidualBin& b : check.bins) {
    chi2 += b.mean * b.mean / (b.standard_error * b.standard_error);
  }
  return chi2 / dof;
}

// A single mirror's rim shows five numbers (harmonics.h: scale, shift, tilt), and a shift of the
// mirror and its tilt move it nearly alike: of a group's candidates, the one whose sigma exceeds
// its bound (the parameter table's unobservable_sigma) by the most is held, and the rest tried
// again, until every one left is determined (holding both of a degenerate pair, as the analysis
// of all at once does, would leave the rim's shift to nothing).
std::vector<int> RimDeterminedCoordinates(const RigParams& stored, std::vector<int> candidates,
                                          RefineResult* result) {
  const auto& all = DriftCoordinates();
  while (!candidates.empty()) {
    const Eigen::MatrixXd J = WhitenedBinJacobian(stored, result->before, candidates);
    Eigen::MatrixXd information = J.transpose() * J;
    const double ridge = 1e-12 * std::max(information.diagonal().maxCoeff(), 1e-300);
    information.diagonal().array() += ridge;
    const Eigen::MatrixXd covariance = information.ldlt().solve(
        Eigen::MatrixXd::Identity(information.rows(), information.cols()));
    int worst = -1;
    double worst_ratio = 1;
    for (size_t k = 0; k < candidates.size(); ++k) {
      const double bound = FindRigParameter(all[candidates[k]].name)->unobservable_sigma;
      const double ratio = std::sqrt(std::max(0.0, covariance(k, k))) / bound;
      if (!(ratio <= worst_ratio)) {
        worst = static_cast<int>(k);
        worst_ratio = ratio;
      }
    }
    if (worst < 0) break;
    const RigParameter* p = FindRigParameter(all[candidates[worst]].name);
    result->held.push_back({p->name, "the rim moves nearly alike under it and the group's other "
                                     "parameters; photos of the target (calibrate) separate them"});
    candidates.erase(candidates.begin() + worst);
  }
  return candidates;
}

// The candidates' coordinates the photos determine (calib/covariance.h on the bins' whitened
// Jacobian); the others go to result->held with the data that would determine them.
std::vector<int> DeterminedCoordinates(const RigParams& stored, const std::vector<int>& candidates,
                                       RefineResult* result) {
  const auto& all = DriftCoordinates();
  if (stored.Paths() < 2) return RimDeterminedCoordinates(stored, candidates, result);
  const Eigen::MatrixXd J_candidates = WhitenedBinJacobian(stored, result->before, candidates);
  calib::RigCovarianceOptions cov_options;
  for (int c : candidates) {
    cov_options.nearly_unobservable_sigma.push_back(FindRigParameter(all[c].name)->unobservable_sigma);
  }
  const calib::RigCovariance observability = calib::RigCovarianceFromSchur(
      J_candidates.transpose() * J_candidates, static_cast<int>(candidates.size()), cov_options);
  std::vector<int> free;
  for (int i : observability.observable) free.push_back(candidates[i]);
  for (size_t i = 0; i < candidates.size(); ++i) {
    if (std::find(observability.observable.begin(), observability.observable.end(),
                  static_cast<int>(i)) == observability.observable.end()) {
      const RigParameter* p = FindRigParameter(all[candidates[i]].name);
      result->held.push_back({p->name, p->hint});
    }
  }
  return free;
}

// One round's Ceres solve of the `free` coordinates from x (moves x; returns the iterations): the
// samples were linearised at the current model, the solve moves from the stored one, so its lips'
// phi and normals are current's (the first-order distance holds for the small moves).
int SolveRound(const RigParams& stored, const std::vector<int>& free, const SampleSet& set,
               int round, const RefineOptions& options, Eigen::VectorXd* x) {
  std::vector<Sample> samples;
  TakeSpread(set.samples, true, options.max_match_samples, &samples);
  TakeSpread(set.samples, false, options.max_lip_samples, &samples);
  std::vector<double> weights;
  for (const Sample& s : samples) {
    const auto sd = set.kind_sd.find(KindOf(s));
    weights.push_back(sd != set.kind_sd.end() && sd->second > 0 ? 1 / sd->second : 1.0);
  }
  Eigen::VectorXd x_round = *x;
  ceres::Problem problem;
  problem.AddResidualBlock(new SessionCost(stored, free, &samples, weights), nullptr,
                           x_round.data());
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = options.max_iterations;
  solver.function_tolerance = 1e-10;
  solver.parameter_tolerance = 1e-10;
  solver.num_threads = 1;  // the cost is parallel inside
  solver.logging_type = ceres::SILENT;
  struct Status : ceres::IterationCallback {
    std::function<void(const std::string&)> f;
    int round = 0;
    ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
      char line[128];
      std::snprintf(line, sizeof(line), "solve %d, iteration %d, cost %.4g", round + 1,
                    s.iteration, s.cost);
      if (f) f(line);
      return ceres::SOLVER_CONTINUE;
    }
  } callback;
  callback.f = options.status;
  callback.round = round;
  solver.callbacks.push_back(&callback);
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  *x = x_round;
  return static_cast<int>(summary.iterations.size());
}

// The refined parameters' covariance from the bins at the solution (data errors only, scaled by
// the bins' chi^2 per degree of freedom when above 1) and result->refined.
void RefinedCovariance(const RigParams& stored, const RigParams& current,
                       const std::vector<int>& free, RefineResult* result) {
  const auto& all = DriftCoordinates();
  result->variance_factor = DataChi2PerDof(result->after, static_cast<int>(free.size()));
  const Eigen::MatrixXd J_free = WhitenedBinJacobian(stored, result->after, free,
                                                     std::max(1.0, result->variance_factor));
  calib::RigCovarianceOptions free_options;
  const calib::RigCovariance cov = calib::RigCovarianceFromSchur(
      J_free.transpose() * J_free, static_cast<int>(free.size()), free_options);
  result->covariance = Eigen::MatrixXd::Zero(free.size(), free.size());
  for (size_t a = 0; a < cov.observable.size(); ++a) {
    for (size_t b = 0; b < cov.observable.size(); ++b) {
      result->covariance(cov.observable[a], cov.observable[b]) = cov.covariance(a, b);
    }
  }
  for (size_t k = 0; k < free.size(); ++k) {
    const std::string& name = all[free[k]].name;
    result->refined.push_back({name, *ParameterOf(stored, name), *ParameterOf(current, name),
                               std::sqrt(std::max(0.0, result->covariance(k, k)))});
  }
}

// The refined model's calibration: the refined values; the covariance keeps the stored entries of
// every other parameter and takes the refinement's block for the refined ones (their
// correlations with the others dropped: the photos measured them anew).
CalibrationInfo RefinedCalibration(const RigParams& stored, const RigParams& current,
                                   const RefineResult& result, size_t n_images) {
  CalibrationInfo info = stored.calibration ? *stored.calibration : CalibrationInfo{};
  std::vector<std::string> names = info.parameters;
  for (const RefinedParameter& p : result.refined) {
    bool present = false;
    for (const std::string& n : names) present = present || FindRigParameter(n) == FindRigParameter(p.name);
    if (!present) names.push_back(p.name);
  }
  const int np = static_cast<int>(names.size());
  const int old_np = static_cast<int>(info.parameters.size());
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(np, np);
  if (static_cast<int>(info.covariance.size()) == old_np * old_np) {
    for (int a = 0; a < old_np; ++a) {
      for (int b = 0; b < old_np; ++b) covariance(a, b) = info.covariance[a * old_np + b];
    }
  }
  const size_t n_free = result.refined.size();
  std::vector<int> index(n_free);
  for (size_t k = 0; k < n_free; ++k) {
    for (int a = 0; a < np; ++a) {
      if (FindRigParameter(names[a]) == FindRigParameter(result.refined[k].name)) index[k] = a;
    }
    for (int a = 0; a < np; ++a) covariance(index[k], a) = covariance(a, index[k]) = 0;
  }
  for (size_t k = 0; k < n_free; ++k) {
    for (size_t l = 0; l < n_free; ++l) covariance(index[k], index[l]) = result.covariance(k, l);
  }
  info.parameters = names;
  info.noise_covariance.clear();  // the stored one describes the old photos alone
  info.values.assign(np, 0);
  info.sigma.assign(np, 0);
  info.covariance.assign(static_cast<size_t>(np) * np, 0);
  for (int a = 0; a < np; ++a) {
    info.values[a] = *ParameterOf(current, names[a]);
    info.sigma[a] = std::sqrt(std::max(0.0, covariance(a, a)));
    for (int b = 0; b < np; ++b) info.covariance[a * np + b] = covariance(a, b);
  }
  info.session = "refine from " + std::to_string(n_images) + " natural image(s)" +
                 (info.session.empty() ? "" : " of the calibration from " + info.session);
  return info;
}

}  // namespace

RefineResult RefineRig(const RigParams& stored_model, const std::vector<ImageEvidence>& images,
                       const RefineOptions& options) {
  // The check's model: a single mirror's rim where its photos show the edge (lip_reference.h
  // AsObserved); the refined values go back into the model as stored.
  const RigParams stored = AsObserved(stored_model);
  const auto t0 = std::chrono::steady_clock::now();
  auto status = [&](const std::string& now) {
    if (options.status) options.status(now);
  };
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  RefineResult result;
  status("the check under the stored model");
  // The samples under the stored model serve the check and the first solve. The lips are
  // measured from the calibration photos' (lip_reference.h) in every round: the solve then finds
  // the move since calibration, not the edge detector's bias.
  // A single mirror's evidence is its rim where the calibration photos measured it (check.h).
  const bool one_ring = stored.Paths() < 2;
  const LipReference reference(stored, options.check.azimuth_bins);
  auto collect = [&](const RigParams& rig) {
    SampleSet set = CollectSamples(RigModel(rig), images, options.check, reference);
    return one_ring ? ReferencedBinsOnly(set) : set;
  };
  SampleSet set = collect(stored);
  result.before = CheckSamples(stored, set, static_cast<int>(images.size()), options.check);
  if (result.before.verdict == Verdict::kCannotTell) {
    throw RefineError("refine: " + result.before.reason +
                      (one_ring ? "; photograph the mirror with its rim in plain sight all round"
                                : "; photograph a textured scene that fills most of the view "
                                  "around the rig"));
  }

  // Candidates: the rig parameters of the chosen groups.
  result.groups = options.groups;
  if (result.groups.empty()) {
    if (result.before.verdict == Verdict::kOk) {
      result.rig = stored_model;
      result.after = result.before;
      result.seconds = elapsed();
      return result;  // nothing moved: nothing refined
    }
    result.groups.push_back(result.before.named_group);
    // A single mirror's rim cannot tell the camera's move from the mirror's (the runner-up is
    // always the other, and the two together are degenerate): the named group alone.
    if (!one_ring && !result.before.runner_up.empty()) {
      result.groups.push_back(result.before.runner_up);
    }
  }
  const auto& all = DriftCoordinates();
  std::vector<int> candidates;
  for (const std::string& group : result.groups) {
    for (int c : CoordinatesOf(group)) {
      if (all[c].rig_parameter) candidates.push_back(c);
    }
  }
  if (candidates.empty()) throw RefineError("refine: no parameter group to refine");
  const std::vector<int> free = DeterminedCoordinates(stored, candidates, &result);
  if (free.empty()) {
    throw RefineError("refine: these photos determine none of the parameters of " +
                      std::to_string(candidates.size()) + " candidates");
  }

  // The solve on the samples, the lips re-linearised between rounds.
  Eigen::VectorXd x = Eigen::VectorXd::Zero(static_cast<int>(free.size()));
  RigParams current = stored;
  for (int round = 0; round < options.rounds; ++round) {
    if (round > 0) set = collect(current);
    result.iterations += SolveRound(stored, free, set, round, options, &x);
    current = ApplyDrift(stored, free, x);
  }

  status("the check under the refined model");
  result.after = CheckRig(current, images, options.check);
  RefinedCovariance(stored, current, free, &result);
  result.rig = ApplyDrift(stored_model, free, x);
  result.rig.calibration = RefinedCalibration(stored_model, result.rig, result, images.size());
  result.seconds = elapsed();
  return result;
}

}  // namespace omni::health
