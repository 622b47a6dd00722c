// The staged solve: the stage table, one stage's solve (SolveStage), and what the weighted rounds
// do between solves: outlier rejection, variance components; the divergence check.
#include <algorithm>
#include <chrono>
#include <cstdio>

#include "calib/calibration_steps.h"

namespace omni::calib {

// The stages. The pinhole first (the misalignment is small, so the ideal geometry with refined
// fx, fy, cx, cy brings every corner within a few pixels), then the misalignment with the
// pinhole and the lens distortion, then every refined group (the mirror shapes, if asked). The
// pinhole stage holds the distortion: over the rings' narrow radii radial distortion trades with
// the focal length, and freed there from 0 it went to dist_k1 -0.30, dist_k2 +1.16 on
// big_rig_real_lens (truth -0.12, 0.05; the first version saw -1.6 with fx 3% off). Held in the
// alignment stage too, that lens (the rings' outer edge 1.3% in) was emulated by the mirrors'
// heights (tz +5.3 / +5.8 mm, reflex dz +2.2 mm, fx +2.6%: 0.38 px rms after 65 iterations, 41
// of them failed steps) until the next stage walked back. Freed with the misalignment it reaches
// the same optimum directly (realistic_scene: 20 iterations instead of 65 + 22; bench_calibrate's
// answer unchanged to 1e-8 sigma).
//
// The robust stages solve with a subset of the corners (SelectRobustStageCorners) and without the
// lip points (Calibrate() says why).
//
// Stop rules. The pinhole stage only brings the corners within reach of the alignment stage (the
// ideal geometry cannot fit them: 7 px rms); beyond a few iterations it traded failed steps for 1%
// of its cost (bench_calibrate: 7.04 px after 4 iterations, 7.17 after 8, 7.23 after 15). The
// later stages start at (all) or next to (reweight, final) the previous stage's optimum, where the
// Gauss-Newton step is good: Ceres' default initial trust region (1e4: Levenberg-Marquardt
// damping 1e-4 of the Jacobi-scaled diagonal) crawled along the flat camera-rotation valley while
// the region grew x3 per step (final rounds 8 + 6 iterations; with these 3 + 1 and the same
// answer to 1e-5 sigma). A step that fails only shrinks the region.
namespace {
constexpr RigBlockSet kPinhole = BlockSetOf({kCameraBlock});
constexpr RigBlockSet kAlignment =
    BlockSetOf({kCameraBlock, kDistortionBlock, kPose1Block, kPose2Block, kReflexBlock});
constexpr RigBlockSet kEveryGroup = {};  // with all_groups: every group the Refinement names
}  // namespace

// clang-format off
// Stage: name, groups, all_groups, robust, Selection {corner_subset, lips},
//        StopRule {iteration_cap, initial_trust_region, whitened, answer}
const Stage kRobustStages[3] = {
    {"pinhole",   kPinhole,    false, true,  {true,  false}, {8, 0,   false, false}},
    {"alignment", kAlignment,  false, true,  {true,  false}, {0, 0,   false, false}},
    {"all",       kEveryGroup, true,  true,  {true,  false}, {0, 1e6, false, false}},
};
const Stage kReweightStage =
    {"reweight",  kEveryGroup, true,  false, {true,  true},  {0, 1e8, true,  false}};
const Stage kFinalStage =
    {"final",     kEveryGroup, true,  false, {false, true},  {0, 1e8, true,  true}};
const Stage kScoreStage =
    {"score",     kEveryGroup, true,  false, {false, false}, {0, 1e4, false, true}};
// clang-format on

RigBlockSet StageGroups(const Stage& stage, const Refinement& refined) {
  return stage.all_groups ? refined.groups : stage.groups & refined.groups;
}

namespace {

// The solve's status per iteration for a terminal's status line (CalibrationOptions::status).
class StatusCallback : public ceres::IterationCallback {
 public:
  StatusCallback(const std::function<void(const std::string&)>& status, const std::string& stage)
      : status_(status), stage_(stage) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    if (status_) status_("stage " + stage_ + ", iteration " + std::to_string(summary.iteration));
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const std::function<void(const std::string&)>& status_;
  std::string stage_;
};

// What a stage starts from, to undo it if it ends worse.
struct Snapshot {
  RigParams rig;
  std::vector<std::array<double, 6>> poses;
  std::vector<double> phi;
  double rim_radius = 0;
};

Snapshot TakeSnapshot(const RigState& rig, const ObservationSet& observations) {
  Snapshot s{rig.params, {}, {}, observations.rim_radius[0]};
  for (const auto& p : observations.placements) s.poses.push_back(p.cam_from_target);
  for (const auto& l : observations.lips) s.phi.push_back(l.phi[0]);
  return s;
}

void Restore(const Snapshot& s, RigState* rig, ObservationSet* observations) {
  rig->params = s.rig;
  for (size_t p = 0; p < observations->placements.size(); ++p) {
    observations->placements[p].cam_from_target = s.poses[p];
  }
  for (size_t i = 0; i < observations->lips.size(); ++i) observations->lips[i].phi[0] = s.phi[i];
  observations->rim_radius[0] = s.rim_radius;
  SyncRimRadius(observations);
}

// The solver's options for `stage` on `problem`: Schur elimination of the poses and azimuths, the
// stop rule's cap, trust region and tolerances.
ceres::Solver::Options SolverOptions(const Stage& stage, const CalibrationOptions& options,
                                     RigParams* rig, ObservationSet* observations,
                                     const ceres::Problem& problem) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  auto* ordering = new ceres::ParameterBlockOrdering;
  for (auto& p : observations->placements) {
    if (problem.HasParameterBlock(p.cam_from_target.data())) {
      ordering->AddElementToGroup(p.cam_from_target.data(), 0);
    }
  }
  for (auto& l : observations->lips) {
    if (problem.HasParameterBlock(l.phi.data())) ordering->AddElementToGroup(l.phi.data(), 0);
  }
  for (int b = 0; b < kRigBlockCount; ++b) {
    double* block = BlockIn(rig, static_cast<RigBlockId>(b));
    if (problem.HasParameterBlock(block)) ordering->AddElementToGroup(block, 1);
  }
  // The rim circle's radius is shared by many azimuths: eliminated with the rig, not before it.
  if (problem.HasParameterBlock(observations->rim_radius.data())) {
    ordering->AddElementToGroup(observations->rim_radius.data(), 1);
  }
  so.linear_solver_ordering.reset(ordering);
  so.num_threads = std::max(1, options.solver.threads);
  so.max_num_iterations = stage.stop.iteration_cap > 0
                              ? std::min(options.solver.max_iterations, stage.stop.iteration_cap)
                              : options.solver.max_iterations;
  if (stage.stop.initial_trust_region > 0) {
    so.initial_trust_region_radius = stage.stop.initial_trust_region;
  }
  // Tight tolerances: the camera's rotation against the mirror bodies is a long, nearly flat
  // valley (a principal-point shift plus tilts of both mirrors); with looser ones the robust
  // stages stopped ~4 sigma short along it (the cost still falling by 1e-10 relative per step).
  // But not below the cost's rounding: near the optimum a step changes the cost by ~1e-10
  // absolute (~5e-15 relative) either way, so with 1e-15 half of all iterations were failed
  // steps at that noise floor (bench_calibrate: 99-115 iterations). The robust stages only feed
  // the next stage.
  // The weighted rounds are whitened: their cost is chi^2 / 2 (about half the residual rows), so
  // a Gauss-Newton step that lowers it by d moved the parameters by ~sqrt(2 d) sigma, and here
  // each step is ~10x shorter than the one before (bench_calibrate: the cost fell by 2e3, 17,
  // 3e-2, 1e-4, 1e-6). They stop once a step lowers it by less than kWeightedStepCost: the
  // answer is then within ~0.01 sigma of the converged one (measured: <= 8e-4 sigma from a 1e-14
  // relative tolerance, with 4 fewer full iterations: 0.5 s).
  constexpr double kWeightedStepCost = 1e-2;
  so.function_tolerance =
      stage.stop.whitened ? kWeightedStepCost / (0.5 * std::max(1, problem.NumResiduals()))
                          : 1e-11;
  so.gradient_tolerance = 1e-16;
  so.parameter_tolerance = 1e-14;
  return so;
}

// The stage's progress line.
std::string StageLine(const Stage& stage, const StageReport& report,
                      const ceres::Solver::Summary& summary) {
  // A stage before the answer's that stops at its iteration cap (the pinhole stage's few
  // iterations: it only brings every corner within pixels) is not a failure: the next goes on.
  const bool capped = !report.converged && !stage.stop.answer &&
                      summary.termination_type == ceres::NO_CONVERGENCE;
  const std::string stage_status =
      report.undone      ? "ENDED WORSE: undone"
      : report.converged ? "converged"
      : capped           ? "stopped at its cap of " + std::to_string(report.iterations) +
                               " iterations (the next stage goes on from here)"
                         : "NOT converged: " + summary.message;
  char buf[384];
  std::snprintf(buf, sizeof(buf),
                "stage %-11s %6d obs  rms %8.3f -> %7.3f px  %3d iterations  %s  %.2f s "
                "(residuals %.2f, jacobians %.2f, linear solver %.2f)",
                stage.name, report.n_observations, report.initial_rms_px, report.final_rms_px,
                report.iterations, stage_status.c_str(), report.seconds,
                summary.residual_evaluation_time_in_seconds,
                summary.jacobian_evaluation_time_in_seconds, summary.linear_solver_time_in_seconds);
  std::string line = buf;
  if (report.n_lip_points > 0) {
    std::snprintf(buf, sizeof(buf), "; %d lip points rms %.3f -> %.3f px", report.n_lip_points,
                  report.initial_lip_rms_px, report.final_lip_rms_px);
    line += buf;
  }
  return line;
}

}  // namespace

StageReport SolveStage(const Stage& stage, const CalibrationOptions& options,
                       const Weights& weights, const Refinement& refined, RigState* rig,
                       ObservationSet* observations, CostCache* costs) {
  const auto t0 = std::chrono::steady_clock::now();
  const Snapshot before = TakeSnapshot(*rig, *observations);
  std::unique_ptr<ceres::LossFunction> loss;
  const double scale = options.solver.loss_scale_px;
  if (stage.robust && options.solver.loss == "huber") loss.reset(new ceres::HuberLoss(scale));
  if (stage.robust && options.solver.loss == "cauchy") loss.reset(new ceres::CauchyLoss(scale));
  ProblemOptions po;
  po.groups = StageGroups(stage, refined);
  po.loss = loss.get();
  po.selection = stage.selection;
  po.held_without_columns = true;
  MarkProjectable(*rig, po.selection, observations);
  const std::unique_ptr<CalibrationProblem> built =
      BuildProblem(rig, observations, weights, refined, po, costs);
  ceres::Problem& problem = built->problem;
  StageReport report;
  report.name = stage.name;
  report.n_observations = built->n_corners;
  report.initial_rms_px = CornerRms(*rig, *observations, 0, nullptr);
  report.n_lip_points = stage.selection.lips ? built->n_lips : 0;
  if (report.n_lip_points) report.initial_lip_rms_px = LipRms(*rig, observations->lips, nullptr);

  ceres::Solver::Options so = SolverOptions(stage, options, &rig->params, observations, problem);
  StatusCallback status(options.status, stage.name);
  if (options.status) {
    so.callbacks.push_back(&status);
    Status(options, std::string("stage ") + stage.name + ", starting");
  }
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  SyncRimRadius(observations);
  report.iterations = static_cast<int>(summary.iterations.size()) - 1;
  report.converged = summary.termination_type == ceres::CONVERGENCE;
  report.termination = summary.message;
  report.final_rms_px = CornerRms(*rig, *observations, 0, nullptr);
  if (report.n_lip_points) report.final_lip_rms_px = LipRms(*rig, observations->lips, nullptr);
  // Worse: the solver's own cost rose (it never accepts such a step; a cost that fails to
  // evaluate at the end would show here), or the corners' RMS rose by more than 2%: the corners
  // are what the rig is calibrated from, and a stage that trades them for other residuals has
  // been pulled off by them (lip points on the wrong curve took a stage from 0.56 to
  // 1.38 px). Such a stage is undone and said so; the calibration goes on from where it began.
  const bool worse = summary.final_cost > summary.initial_cost ||
                     report.final_rms_px > 1.02 * report.initial_rms_px + 1e-3;
  if (worse) {
    Restore(before, rig, observations);
    report.undone = true;
  }
  report.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Progress(options, StageLine(stage, report, summary));
  if (summary.termination_type == ceres::FAILURE) {
    throw CalibrationError(std::string("the solve failed in stage '") + stage.name +
                           "': " + summary.message);
  }
  return report;
}

namespace {

// An observation is an outlier when its residual exceeds outlier_px or, once the groups' noise is
// known, 5 robust sigmas of its group (a 2-D Gaussian residual exceeds 5 sigma with probability
// 4e-6; a wrong corner id ~1 px off with corner noise ~0.1-0.2 px does).
double OutlierThreshold(double outlier_px, double robust_sigma) {
  return robust_sigma > 0 ? std::min(outlier_px, 5.0 * robust_sigma) : outlier_px;
}

}  // namespace

int RejectOutliers(const RigState& rig, const Weights& weights, const Selection& selection,
                   double outlier_px, ObservationSet* observations) {
  int n = 0;
  for (auto& o : observations->corners) {
    // On the corner subset only its corners are fitted (the others' poses are the subset's).
    if (o.rejected || (selection.corner_subset && !o.in_robust_stages)) continue;
    Eigen::Vector2d px;
    if (!Reproject(rig, *observations, o, &px)) continue;
    const double r = (px - o.pixel).norm();
    if (r > OutlierThreshold(outlier_px, weights.robust_sigma[o.mirror - 1])) {
      o.rejected = true;
      observations->rejected.push_back({o.image, o.target, o.id, o.mirror, o.pixel, r, "outlier"});
      ++n;
    }
  }
  for (auto& l : observations->lips) {
    if (!selection.lips || !l.Used()) continue;
    Eigen::Vector2d px;
    if (!ReprojectLip(rig, l, &px)) continue;
    const double scaled = std::sqrt(static_cast<double>(l.members)) * (px - l.pixel).norm();
    if (scaled > OutlierThreshold(outlier_px, weights.robust_sigma[2])) {
      l.rejected = true;
      ++n;
    }
  }
  return n;
}

void EstimateVarianceComponents(const RigState& rig, const ObservationSet& observations,
                                const Refinement& refined, bool corner_subset,
                                bool lip_correlation, Weights* weights) {
  // Residuals per group, and each placement's corners per ring (its 6 pose unknowns are shared
  // between the rings in proportion).
  double ssr[3] = {0, 0, 0};
  int count[3] = {0, 0, 0};
  std::vector<std::vector<double>> norms(3);
  std::vector<std::array<int, 2>> per_placement(observations.placements.size(), {0, 0});
  for (const auto& o : observations.corners) {
    Eigen::Vector2d px;
    if (o.rejected || (corner_subset && !o.in_robust_stages) ||
        !Reproject(rig, observations, o, &px)) {
      continue;
    }
    const int g = o.mirror - 1;
    ssr[g] += (px - o.pixel).squaredNorm();
    norms[g].push_back((px - o.pixel).norm());
    ++count[g];
    ++per_placement[o.placement][g];
  }
  std::vector<LipResidual> lip_residuals;
  const Eigen::Vector2d centre(rig.params.camera[kCx], rig.params.camera[kCy]);
  for (const auto& l : observations.lips) {
    Eigen::Vector2d px;
    if (!l.Used() || !ReprojectLip(rig, l, &px)) continue;
    // A normal point's residual scaled by sqrt(members): the noise of one detected point.
    const Eigen::Vector2d r = std::sqrt(static_cast<double>(l.members)) * (px - l.pixel);
    ssr[2] += r.squaredNorm();
    norms[2].push_back(r.norm());
    ++count[2];
    // Across the edge ~ radially about the principal point (the lips' images are near-circles
    // about it); the along-edge part is absorbed by the point's azimuth.
    lip_residuals.push_back({static_cast<int>(l.path) * 100000 + static_cast<int>(l.radius * 100),
                             l.phi[0], r.dot((px - centre).normalized())});
  }
  // Unknowns: poses to the corner groups, one azimuth per lip point to the lips, the rig
  // parameters to every group in proportion to its residual rows.
  double pose_share[2] = {0, 0};
  for (const auto& c : per_placement) {
    const int total = c[0] + c[1];
    if (total == 0) continue;
    for (int g = 0; g < 2; ++g) pose_share[g] += 6.0 * c[g] / total;
  }
  int n_rig = 0;
  for (int b = 0; b < kRigBlockCount; ++b) {
    const RigBlockId g = static_cast<RigBlockId>(b);
    if (!refined.groups[g]) continue;
    n_rig += kRigBlocks[g].size - static_cast<int>(HeldCoordinates(refined, g).size());
  }
  const double rows_total = 2.0 * (count[0] + count[1] + count[2]);
  const char* names[3] = {"corners ring 1", "corners ring 2", "lips"};
  weights->components.clear();
  for (int g = 0; g < 3; ++g) {
    if (count[g] == 0) continue;
    VarianceComponent c;
    c.group = names[g];
    c.count = count[g];
    c.ssr_px2 = ssr[g];
    const double nuisance = g < 2 ? pose_share[g] : count[g];
    c.redundancy = 2.0 * count[g] - nuisance - n_rig * 2.0 * count[g] / rows_total;
    if (!(c.redundancy > 0)) continue;
    // Per-axis sigma; lips: two rows per point but one is absorbed by the azimuth, so this is the
    // noise across the edge.
    c.sigma_px = std::sqrt(ssr[g] / c.redundancy);
    if (g == 2 && lip_correlation) c.correlation_factor = LipCorrelationFactor(lip_residuals);
    c.weight_sigma_px = c.sigma_px * std::sqrt(c.correlation_factor);
    weights->sigma[g] = std::max(c.weight_sigma_px, 1e-3);
    // Robust per-axis sigma from the median residual norm (2-D: Rayleigh median 1.1774 sigma;
    // lips 1-D across the edge: 0.6745 sigma).
    std::nth_element(norms[g].begin(), norms[g].begin() + norms[g].size() / 2, norms[g].end());
    weights->robust_sigma[g] = norms[g][norms[g].size() / 2] / (g < 2 ? 1.1774 : 0.6745);
    weights->components.push_back(c);
  }
}

void CheckDiverged(const RigParams& rig) {
  for (const RigParameter& p : RigParameterTable()) {
    const double value = *ParameterOf(rig, p.name);
    double beyond = p.diverged_beyond;
    // A single mirror nobody designed for us: its start's camera distance is a guess (init's
    // rim-to-horizon assumption, a rough --camera_distance), so tz may move by tens of mm; only a
    // lens past the mirror's vertex is no camera.
    if (rig.Single() && std::string(p.name) == "mirror1.tz") beyond = std::max(beyond, rig.vertex_z);
    if (beyond > 0 && !(std::abs(value) <= beyond)) {
      throw CalibrationError(std::string("the solve diverged: ") + p.name + " went to " +
                             std::to_string(value) +
                             " (beyond any assembly error); check the starting model and the "
                             "target definitions (square size)");
    }
  }
  for (double v : rig.camera) {
    if (!std::isfinite(v)) throw CalibrationError("the solve diverged: the camera parameters are not finite");
  }
  for (double v : rig.distortion) {
    if (!std::isfinite(v)) throw CalibrationError("the solve diverged: the camera parameters are not finite");
  }
}

}  // namespace omni::calib
