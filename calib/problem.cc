// The Ceres problem of the calibration: each corner's cost wired to the rig's parameter blocks and
// its placement's pose, each lip point's to the rig's blocks and its azimuth, the priors on the
// refined shapes and freed profiles, and the held coordinates (BuildProblem).
#include <ceres/ceres.h>

#include "calib/calibration_steps.h"
#include "calib/corner_cost.h"
#include "calib/lip_cost.h"

namespace omni::calib {

std::vector<int> HeldCoordinates(const Refinement& refined, const std::string& group) {
  std::vector<int> held;
  auto hold = [&](SolveRole role) {
    for (const RigParameter* p : ParametersWithRole(role)) {
      if (group == p->block) held.push_back(p->index);
    }
  };
  if (!refined.skew) hold(SolveRole::kSkew);
  if (!refined.tangential) hold(SolveRole::kTangential);
  if (!refined.dist_k3) hold(SolveRole::kHighRadial);
  for (int m = 0; m < 2; ++m) {
    if (group == kProfileGroups[m] && !refined.profile_free[m]) {
      for (int k = 0; k < kProfileTerms; ++k) held.push_back(k);
    }
  }
  return held;
}

ceres::CostFunction* CornerCost(const RigState& rig, const Observation& o, size_t i,
                                CostCache* costs) {
  if (costs->corners.size() <= i) costs->corners.resize(i + 1);
  if (!costs->corners[i]) {
    costs->corners[i].reset(
        o.mirror == 1 ? Mirror1CornerCost::Create(o.pixel, o.corner_in_target,
                                                  rig.corner_bounds[0], &costs->held_camera,
                                                  &costs->held_distortion)
                      : Mirror2CornerCost::Create(o.pixel, o.corner_in_target,
                                                  rig.corner_bounds[1], &costs->held_camera,
                                                  &costs->held_distortion));
  }
  return costs->corners[i].get();
}

ceres::CostFunction* LipCost(const RigState& rig, const LipObservation& l, size_t i,
                             CostCache* costs) {
  if (costs->lips.size() <= i) costs->lips.resize(i + 1);
  if (!costs->lips[i]) {
    costs->lips[i].reset(LipPointCost::Create(l.pixel, l.path, l.radius, l.z,
                                              LipBounds(rig, l.path), &costs->held_camera,
                                              &costs->held_distortion, rig.fixed.r_ref));
  }
  return costs->lips[i].get();
}

ceres::ResidualBlockId AddCornerResidual(size_t i, ceres::LossFunction* loss, RigState* rig,
                                         ObservationSet* observations, CostCache* costs,
                                         ceres::Problem* problem) {
  const Observation& o = observations->corners[i];
  ceres::CostFunction* cost = CornerCost(*rig, o, i, costs);
  double* pose = observations->placements[o.placement].cam_from_target.data();
  RigParams& r = rig->params;
  // The blocks in the order of calib/corner_cost.h's residuals.
  if (o.mirror == 1) {
    return problem->AddResidualBlock(cost, loss, r.camera.data(), r.distortion.data(),
                                     r.mirror1_shape.data(), r.mirror1_profile.data(),
                                     r.mirror1_pose.data(), r.reflex.data(), pose);
  }
  return problem->AddResidualBlock(cost, loss, r.camera.data(), r.distortion.data(),
                                   r.mirror1_pose.data(), r.reflex.data(), r.mirror2_shape.data(),
                                   r.mirror2_profile.data(), r.mirror2_pose.data(), pose);
}

namespace {

// The priors on the refined shapes (options' priors) and on the freed profiles (the machining
// tolerance about the starting model's profile), each added as a residual block of its own.
void AddPriors(const std::set<std::string>& groups, const Refinement& refined, RigParams* rig,
               CalibrationProblem* p) {
  // Shape priors (only where the shape is refined).
  for (const RigBlock& b : kRigBlocks) {
    if (!b.prior) continue;
    const std::string shape = b.name;
    const auto prior = refined.shape_priors.find(shape);
    if (!groups.count(shape) || prior == refined.shape_priors.end()) continue;
    double* block = BlockIn(rig, shape);
    const double sigmas[2] = {prior->second.sigma_c, prior->second.sigma_k};
    for (int k = 0; k < 2; ++k) {
      if (!(sigmas[k] > 0)) continue;
      p->prior_costs.emplace_back(new ceres::AutoDiffCostFunction<ScalarPriorCost, 1, 2>(
          new ScalarPriorCost{k, block[k], sigmas[k]}));
      p->prior_blocks.push_back(
          p->problem.AddResidualBlock(p->prior_costs.back().get(), nullptr, block));
    }
  }
  // Freed profiles: the machining tolerance as a prior around the starting model's profile.
  for (int m = 0; m < 2; ++m) {
    if (!groups.count(kProfileGroups[m]) || !refined.profile_free[m]) continue;
    double* block = BlockIn(rig, kProfileGroups[m]);
    for (int k = 0; k < kProfileTerms; ++k) {
      p->prior_costs.emplace_back(
          new ceres::AutoDiffCostFunction<ScalarPriorCost, 1, kProfileTerms>(
              new ScalarPriorCost{k, refined.profile_mean[m][k], refined.profile_sigma_mm}));
      p->prior_blocks.push_back(
          p->problem.AddResidualBlock(p->prior_costs.back().get(), nullptr, block));
    }
  }
}

// The rig's blocks outside `groups`, or held whole, constant; a block's held coordinates held by
// a subset manifold.
void HoldRigCoordinates(const std::set<std::string>& groups, const Refinement& refined,
                        RigParams* rig, ceres::Problem* problem) {
  for (const RigBlock& b : kRigBlocks) {
    const std::string g = b.name;
    double* block = BlockIn(rig, g);
    if (!problem->HasParameterBlock(block)) continue;
    const std::vector<int> held = HeldCoordinates(refined, g);
    if (!groups.count(g) || static_cast<int>(held.size()) == b.size) {
      problem->SetParameterBlockConstant(block);
    } else if (!held.empty()) {
      problem->SetManifold(block, new ceres::SubsetManifold(b.size, held));
    }
  }
}

}  // namespace

std::unique_ptr<CalibrationProblem> BuildProblem(RigState* rig, ObservationSet* observations,
                                                 const Weights& weights,
                                                 const Refinement& refined,
                                                 const ProblemOptions& options, CostCache* costs) {
  auto built = std::make_unique<CalibrationProblem>();
  CalibrationProblem& p = *built;
  // Each group's residuals weighted with 1 / weights.sigma^2 (a scaled loss keeps the robust
  // loss's threshold in pixels).
  ceres::LossFunction* group_loss[3];
  for (int g = 0; g < 3; ++g) {
    p.group_losses.emplace_back(new ceres::ScaledLoss(
        options.loss, 1.0 / (weights.sigma[g] * weights.sigma[g]), ceres::DO_NOT_TAKE_OWNERSHIP));
    group_loss[g] = p.group_losses.back().get();
  }
  // A normal point weighs as its members would: members / weights.sigma^2 (one loss per count).
  auto lip_loss = [&](int members) {
    auto& slot = p.lip_losses[members];
    if (!slot) {
      slot.reset(new ceres::ScaledLoss(options.loss,
                                       members / (weights.sigma[2] * weights.sigma[2]),
                                       ceres::DO_NOT_TAKE_OWNERSHIP));
    }
    return slot.get();
  };
  // The corners: each over the rig's blocks and its placement's pose (AddCornerResidual).
  for (size_t i = 0; i < observations->corners.size(); ++i) {
    Observation& o = observations->corners[i];
    if (o.rejected || (options.selection.corner_subset && !o.in_robust_stages)) continue;
    Eigen::Vector2d px;
    o.projectable = Reproject(*rig, *observations, o, &px);
    if (!o.projectable) continue;
    p.pixel_blocks.push_back(AddCornerResidual(i, group_loss[o.mirror - 1], rig, observations,
                                               costs, &p.problem));
    ++p.n_corners;
  }
  // The lip points: each over the rig's blocks and its azimuth (calib/lip_cost.h's order).
  RigParams& r = rig->params;
  for (size_t i = 0; i < (options.selection.lips ? observations->lips.size() : 0); ++i) {
    LipObservation& l = observations->lips[i];
    if (!l.Used()) continue;
    Eigen::Vector2d px;
    l.projectable = ReprojectLip(*rig, l, &px);
    if (!l.projectable) continue;
    p.pixel_blocks.push_back(p.problem.AddResidualBlock(
        LipCost(*rig, l, i, costs), lip_loss(l.members), r.camera.data(), r.distortion.data(),
        r.mirror1_shape.data(), r.mirror1_pose.data(), r.reflex.data(), r.mirror2_shape.data(),
        r.mirror2_pose.data(), r.mirror1_profile.data(), r.mirror2_profile.data(), l.phi.data()));
    ++p.n_lips;
  }
  AddPriors(options.groups, refined, &r, &p);
  HoldRigCoordinates(options.groups, refined, &r, &p.problem);
  return built;
}

}  // namespace omni::calib
