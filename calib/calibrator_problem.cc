#include "calib/calibrator.h"

namespace omni::calib {

ceres::ResidualBlockId Calibrator::AddCorner(ceres::Problem* problem, size_t i,
                                             ceres::LossFunction* loss) {
  // The blocks in the order of calib/corner_cost.h's residuals.
  double* pose = PoseBlock(obs_[i].placement);
  if (obs_[i].mirror == 1) {
    return problem->AddResidualBlock(CostOf(i), loss, rig_.camera.data(), rig_.distortion.data(),
                                     rig_.mirror1_shape.data(), rig_.mirror1_profile.data(),
                                     rig_.mirror1_pose.data(), rig_.reflex.data(), pose);
  }
  return problem->AddResidualBlock(CostOf(i), loss, rig_.camera.data(), rig_.distortion.data(),
                                   rig_.mirror1_pose.data(), rig_.reflex.data(),
                                   rig_.mirror2_shape.data(), rig_.mirror2_profile.data(),
                                   rig_.mirror2_pose.data(), pose);
}

int Calibrator::BuildProblem(ceres::Problem* problem, const std::set<std::string>& groups,
                             ceres::LossFunction* loss,
                             std::vector<ceres::ResidualBlockId>* corner_blocks,
                             std::vector<ceres::ResidualBlockId>* prior_blocks) {
  // Each group's residuals weighted with 1 / weight_sigma^2 (a scaled loss keeps the robust
  // loss's threshold in pixels).
  group_losses_.clear();
  ceres::LossFunction* group_loss[3];
  for (int g = 0; g < 3; ++g) {
    group_losses_.emplace_back(new ceres::ScaledLoss(
        loss, 1.0 / (weight_sigma_[g] * weight_sigma_[g]), ceres::DO_NOT_TAKE_OWNERSHIP));
    group_loss[g] = group_losses_.back().get();
  }
  // A normal point weighs as its members would: members / weight_sigma^2 (one loss per count).
  lip_losses_.clear();
  auto LipLoss = [&](ceres::LossFunction* base, int members) {
    auto& slot = lip_losses_[members];
    if (!slot) {
      slot.reset(new ceres::ScaledLoss(base, members / (weight_sigma_[2] * weight_sigma_[2]),
                                       ceres::DO_NOT_TAKE_OWNERSHIP));
    }
    return slot.get();
  };
  int n = 0;
  for (size_t i = 0; i < obs_.size(); ++i) {
    Observation& o = obs_[i];
    if (o.rejected || (robust_subset_only_ && !o.in_robust_stages)) continue;
    Eigen::Vector2d px;
    o.projectable = Reproject(o, &px);
    if (!o.projectable) continue;
    const ceres::ResidualBlockId id = AddCorner(problem, i, group_loss[o.mirror - 1]);
    if (corner_blocks) corner_blocks->push_back(id);
    ++n;
  }
  // Lip edge points (pixel rows too: appended to corner_blocks after the corners).
  if (lip_costs_.size() < lips_.size()) lip_costs_.resize(lips_.size());
  last_n_lips_ = 0;
  for (size_t i = 0; i < (lips_in_solve_ ? lips_.size() : 0); ++i) {
    LipObservation& l = lips_[i];
    if (!l.Used()) continue;
    Eigen::Vector2d px;
    l.projectable = ReprojectLip(l, &px);
    if (!l.projectable) continue;
    if (!lip_costs_[i]) {
      lip_costs_[i].reset(LipPointCost::Create(l.pixel, l.path, l.radius, l.z, LipFixed(l.path),
                                               &held_camera_, &held_distortion_, fixed_.r_ref));
    }
    const auto id = problem->AddResidualBlock(
        lip_costs_[i].get(), LipLoss(loss, l.members), rig_.camera.data(), rig_.distortion.data(),
        rig_.mirror1_shape.data(), rig_.mirror1_pose.data(), rig_.reflex.data(),
        rig_.mirror2_shape.data(), rig_.mirror2_pose.data(), rig_.mirror1_profile.data(),
        rig_.mirror2_profile.data(), l.phi.data());
    if (corner_blocks) corner_blocks->push_back(id);
    ++last_n_lips_;
  }
  // Shape priors (only where the shape is refined).
  prior_costs_.clear();
  for (const char* shape : {"mirror1_shape", "mirror2_shape"}) {
    const auto prior = options_.priors.find(shape);
    if (!groups.count(shape) || prior == options_.priors.end()) continue;
    double* block = BlockIn(&rig_, shape);
    const double sigmas[2] = {prior->second.sigma_c, prior->second.sigma_k};
    for (int k = 0; k < 2; ++k) {
      if (!(sigmas[k] > 0)) continue;
      prior_costs_.emplace_back(new ceres::AutoDiffCostFunction<ScalarPriorCost, 1, 2>(
          new ScalarPriorCost{k, block[k], sigmas[k]}));
      const auto id = problem->AddResidualBlock(prior_costs_.back().get(), nullptr, block);
      if (prior_blocks) prior_blocks->push_back(id);
    }
  }
  // Freed profiles: the machining tolerance as a prior around the starting model's profile.
  for (int m = 0; m < 2; ++m) {
    if (!groups.count(kProfileGroups[m]) || !profile_free_[m]) continue;
    double* block = BlockIn(&rig_, kProfileGroups[m]);
    for (int k = 0; k < kProfileTerms; ++k) {
      prior_costs_.emplace_back(new ceres::AutoDiffCostFunction<ScalarPriorCost, 1, kProfileTerms>(
          new ScalarPriorCost{k, profile_start_[m][k], options_.profile_sigma_mm}));
      const auto id = problem->AddResidualBlock(prior_costs_.back().get(), nullptr, block);
      if (prior_blocks) prior_blocks->push_back(id);
    }
  }
  for (const RigBlock& b : kRigBlocks) {
    const std::string g = b.name;
    double* block = BlockIn(&rig_, g);
    if (!problem->HasParameterBlock(block)) continue;
    const std::vector<int> held = HeldCoordinates(g);
    if (!groups.count(g) || static_cast<int>(held.size()) == b.size) {
      problem->SetParameterBlockConstant(block);
    } else if (!held.empty()) {
      problem->SetManifold(block, new ceres::SubsetManifold(b.size, held));
    }
  }
  return n;
}

double Calibrator::Rms(int mirror, int* count) const {
  double ssr = 0;
  int n = 0;
  for (const auto& o : obs_) {
    if (o.rejected || (mirror && o.mirror != mirror)) continue;
    Eigen::Vector2d px;
    if (!Reproject(o, &px)) continue;
    ssr += (px - o.pixel).squaredNorm();
    ++n;
  }
  if (count) *count = n;
  return n ? std::sqrt(ssr / n) : 0.0;
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

}  // namespace

StageReport Calibrator::Solve(const std::string& name, const std::set<std::string>& groups,
                              bool robust) {
  const auto t0 = std::chrono::steady_clock::now();
  // What the stage starts from, to undo it if it ends worse.
  const RigParams rig_before = rig_;
  std::vector<std::array<double, 6>> poses_before;
  for (const auto& p : placements_) poses_before.push_back(p.cam_from_target);
  std::vector<double> phi_before;
  for (const auto& l : lips_) phi_before.push_back(l.phi[0]);
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  std::unique_ptr<ceres::LossFunction> loss;
  const double scale = options_.solver.loss_scale_px;
  if (robust && options_.solver.loss == "huber") loss.reset(new ceres::HuberLoss(scale));
  if (robust && options_.solver.loss == "cauchy") loss.reset(new ceres::CauchyLoss(scale));
  StageReport report;
  report.name = name;
  report.n_observations = BuildProblem(&problem, groups, loss.get(), nullptr, nullptr);
  report.initial_rms_px = Rms(0, nullptr);

  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  auto* ordering = new ceres::ParameterBlockOrdering;
  for (auto& p : placements_) {
    if (problem.HasParameterBlock(p.cam_from_target.data())) {
      ordering->AddElementToGroup(p.cam_from_target.data(), 0);
    }
  }
  for (auto& l : lips_) {
    if (problem.HasParameterBlock(l.phi.data())) ordering->AddElementToGroup(l.phi.data(), 0);
  }
  for (const RigBlock& b : kRigBlocks) {
    const std::string g = b.name;
    double* block = BlockIn(&rig_, g);
    if (problem.HasParameterBlock(block)) ordering->AddElementToGroup(block, 1);
  }
  so.linear_solver_ordering.reset(ordering);
  so.num_threads = std::max(1, options_.solver.threads);
  // The pinhole stage only brings the corners within reach of the alignment stage (the ideal
  // geometry cannot fit them: 7 px rms); beyond a few iterations it traded failed steps for 1% of
  // its cost (bench_calibrate: 7.04 px after 4 iterations, 7.17 after 8, 7.23 after 15).
  so.max_num_iterations = name == "pinhole" ? std::min(options_.solver.max_iterations, 8)
                                            : options_.solver.max_iterations;
  // The later stages start at (all) or next to (final) the previous stage's optimum, where the
  // Gauss-Newton step is good: Ceres' default initial trust region (1e4: Levenberg-Marquardt
  // damping 1e-4 of the Jacobi-scaled diagonal) crawled along the flat camera-rotation valley
  // while the region grew x3 per step (final rounds 8 + 6 iterations; with these 3 + 1 and
  // the same answer to 1e-5 sigma). A step that fails only shrinks the region.
  if (name == "all") so.initial_trust_region_radius = 1e6;
  if (name == "final" || name == "reweight") so.initial_trust_region_radius = 1e8;
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
  const bool weighted = name == "final" || name == "reweight";
  so.function_tolerance =
      weighted ? kWeightedStepCost / (0.5 * std::max(1, problem.NumResiduals())) : 1e-11;
  so.gradient_tolerance = 1e-16;
  so.parameter_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  auto mask = [&](const std::string& group) {
    uint32_t m = 0;
    if (groups.count(group)) {
      for (int k : HeldCoordinates(group)) m |= 1u << k;
    }
    return m;
  };
  held_camera_ = mask("camera");
  held_distortion_ = mask("distortion");
  StatusCallback status(options_.status, name);
  if (options_.status) {
    so.callbacks.push_back(&status);
    Status("stage " + name + ", starting");
  }
  ceres::Solve(so, &problem, &summary);
  held_camera_ = held_distortion_ = 0;
  report.iterations = static_cast<int>(summary.iterations.size()) - 1;
  report.converged = summary.termination_type == ceres::CONVERGENCE;
  report.termination = summary.message;
  report.final_rms_px = Rms(0, nullptr);
  // Worse: the solver's own cost rose (it never accepts such a step; a cost that fails to
  // evaluate at the end would show here), or the corners' RMS rose by more than 2%: the corners
  // are what the rig is calibrated from, and a stage that trades them for other residuals has
  // been pulled off by them (issue 17: lip points on the wrong curve took a stage from 0.56 to
  // 1.38 px). Such a stage is undone and said so; the calibration goes on from where it began.
  const bool worse = summary.final_cost > summary.initial_cost ||
                     report.final_rms_px > 1.02 * report.initial_rms_px + 1e-3;
  if (worse) {
    rig_ = rig_before;
    for (size_t p = 0; p < placements_.size(); ++p) placements_[p].cam_from_target = poses_before[p];
    for (size_t i = 0; i < lips_.size(); ++i) lips_[i].phi[0] = phi_before[i];
    report.undone = true;
  }
  report.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // A stage before the last that stops at its iteration cap (the pinhole stage's few
  // iterations: it only brings every corner within pixels) is not a failure: the next goes on.
  const bool capped = !report.converged && name != "final" &&
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
                name.c_str(), report.n_observations, report.initial_rms_px, report.final_rms_px,
                report.iterations, stage_status.c_str(),
                report.seconds, summary.residual_evaluation_time_in_seconds,
                summary.jacobian_evaluation_time_in_seconds, summary.linear_solver_time_in_seconds);
  Progress(buf);
  if (summary.termination_type == ceres::FAILURE) {
    throw CalibrationError("the solve failed in stage '" + name + "': " + summary.message);
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

int Calibrator::RejectOutliers(bool lips) {
  int n = 0;
  for (auto& o : obs_) {
    // On the corner subset only its corners are fitted (the others' poses are the subset's).
    if (o.rejected || (robust_subset_only_ && !o.in_robust_stages)) continue;
    Eigen::Vector2d px;
    if (!Reproject(o, &px)) continue;
    const double r = (px - o.pixel).norm();
    if (r > OutlierThreshold(options_.solver.outlier_px, robust_sigma_[o.mirror - 1])) {
      o.rejected = true;
      rejected_.push_back({o.image, o.target, o.id, o.mirror, o.pixel, r, "outlier"});
      ++n;
    }
  }
  for (auto& l : lips_) {
    if (!lips || !l.Used()) continue;
    Eigen::Vector2d px;
    if (!ReprojectLip(l, &px)) continue;
    const double scaled = std::sqrt(static_cast<double>(l.members)) * (px - l.pixel).norm();
    if (scaled > OutlierThreshold(options_.solver.outlier_px, robust_sigma_[2])) {
      l.rejected = true;
      ++n;
    }
  }
  return n;
}

void Calibrator::EstimateVarianceComponents(bool lip_correlation) {
  // Residuals per group, and each placement's corners per ring (its 6 pose unknowns are shared
  // between the rings in proportion).
  double ssr[3] = {0, 0, 0};
  int count[3] = {0, 0, 0};
  std::vector<std::vector<double>> norms(3);
  std::vector<std::array<int, 2>> per_placement(placements_.size(), {0, 0});
  for (const auto& o : obs_) {
    Eigen::Vector2d px;
    if (o.rejected || (robust_subset_only_ && !o.in_robust_stages) || !Reproject(o, &px)) continue;
    const int g = o.mirror - 1;
    ssr[g] += (px - o.pixel).squaredNorm();
    norms[g].push_back((px - o.pixel).norm());
    ++count[g];
    ++per_placement[o.placement][g];
  }
  std::vector<LipResidual> lip_residuals;
  const Eigen::Vector2d centre(rig_.camera[2], rig_.camera[3]);
  for (const auto& l : lips_) {
    Eigen::Vector2d px;
    if (!l.Used() || !ReprojectLip(l, &px)) continue;
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
  for (const auto& g : estimate_) {
    n_rig += static_cast<int>(BlockParameterNames(g).size()) -
             static_cast<int>(HeldCoordinates(g).size());
  }
  const double rows_total = 2.0 * (count[0] + count[1] + count[2]);
  const char* names[3] = {"corners ring 1", "corners ring 2", "lips"};
  components_.clear();
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
    weight_sigma_[g] = std::max(c.weight_sigma_px, 1e-3);
    // Robust per-axis sigma from the median residual norm (2-D: Rayleigh median 1.1774 sigma;
    // lips 1-D across the edge: 0.6745 sigma).
    std::nth_element(norms[g].begin(), norms[g].begin() + norms[g].size() / 2, norms[g].end());
    robust_sigma_[g] = norms[g][norms[g].size() / 2] / (g < 2 ? 1.1774 : 0.6745);
    components_.push_back(c);
  }
}

void Calibrator::CheckDiverged() const {
  for (const RigParameter& p : RigParameterTable()) {
    const double value = *ParameterOf(rig_, p.name);
    if (p.diverged_beyond > 0 && !(std::abs(value) <= p.diverged_beyond)) {
      throw CalibrationError(std::string("the solve diverged: ") + p.name + " went to " +
                             std::to_string(value) +
                             " (beyond any assembly error); check the starting model and the "
                             "target definitions (square size)");
    }
  }
  for (int i = 0; i < 5; ++i) {
    if (!std::isfinite(rig_.camera[i]) || !std::isfinite(rig_.distortion[i])) {
      throw CalibrationError("the solve diverged: the camera parameters are not finite");
    }
  }
}

}  // namespace omni::calib
