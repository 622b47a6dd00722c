// The Ceres problem of the calibration: each corner's cost wired to the rig's parameter blocks and
// its placement's pose, each lip point's to the rig's blocks and its azimuth, the priors on the
// refined shapes and freed profiles, and the held coordinates (BuildProblem).
#include <ceres/ceres.h>

#include <Eigen/Cholesky>

#include "calib/calibration_steps.h"
#include "calib/corner_cost.h"
#include "calib/lip_cost.h"

namespace omni::calib {

std::vector<int> HeldCoordinates(const Refinement& refined, RigBlockId group) {
  std::vector<int> held;
  auto hold = [&](SolveRole role) {
    for (const RigParameter* p : ParametersWithRole(role)) {
      if (BlockOf(*p) == group) held.push_back(p->index);
    }
  };
  if (!refined.skew) hold(SolveRole::kSkew);
  if (!refined.tangential) hold(SolveRole::kTangential);
  if (!refined.dist_k3) hold(SolveRole::kHighRadial);
  if (refined.telecentric && group == kPose1Block) held.insert(held.end(), {kTx, kTy, kTz});
  if (refined.hold_mirror_size && group == kShape1Block) {
    held.push_back(kShapeC);
  }
  for (int m = 0; m < 2; ++m) {
    if (group == kProfileGroups[m] && !refined.profile_free[m]) {
      for (int k = 0; k < kProfileTerms; ++k) held.push_back(k);
    }
  }
  return held;
}

BlockMasks HeldColumns(const RigBlockSet& groups, const Refinement& refined) {
  BlockMasks held{};
  for (int b = 0; b < kRigBlockCount; ++b) {
    const RigBlockId id = static_cast<RigBlockId>(b);
    const std::vector<int> coordinates = HeldCoordinates(refined, id);
    // A block outside the groups or held whole is constant: Ceres asks no Jacobian of it.
    if (!groups[id] || static_cast<int>(coordinates.size()) == kRigBlocks[id].size) continue;
    for (int k : coordinates) held[id] |= 1u << k;
  }
  return held;
}

namespace {

// The cost in `slot`, built by `make` with `fixed` unless it was built with that already.
template <typename Make>
ceres::CostFunction* CachedCost(std::vector<CostCache::Cost>* costs, size_t i,
                                const std::shared_ptr<const RigFixed>& fixed, const Make& make) {
  if (costs->size() <= i) costs->resize(i + 1);
  CostCache::Cost& slot = (*costs)[i];
  if (!slot.cost || slot.fixed != fixed) {
    slot.cost.reset(make());
    slot.fixed = fixed;
  }
  return slot.cost.get();
}

// The costs for `held`, made on first use. Found without inserting once there: InitialisePoses'
// threads look the costs up concurrently.
CostCache::Costs& CostsFor(const BlockMasks& held, CostCache* costs) {
  const auto it = costs->by_held.find(held);
  return it != costs->by_held.end() ? it->second : costs->by_held[held];
}

}  // namespace

ceres::CostFunction* CornerCost(const RigState& rig, const Observation& o, size_t i,
                                const BlockMasks& held, CostCache* costs) {
  const std::shared_ptr<const RigFixed>& fixed = rig.corner_bounds[o.mirror - 1];
  return CachedCost(&CostsFor(held, costs).corners, i, fixed, [&] {
    return o.mirror == 1 ? Mirror1CornerCost::Create(o.pixel, o.corner_in_target, fixed, held)
                         : Mirror2CornerCost::Create(o.pixel, o.corner_in_target, fixed, held);
  });
}

ceres::CostFunction* LipCost(const RigState& rig, const LipObservation& l, size_t i,
                             const BlockMasks& held, CostCache* costs, bool radius_free) {
  const std::shared_ptr<const RigFixed>& fixed = LipBounds(rig, l.path);
  return CachedCost(&CostsFor(held, costs).lips, i, fixed, [&]() -> ceres::CostFunction* {
    if (radius_free) return RimCirclePointCost::Create(l.pixel, fixed, held, rig.fixed->r_ref);
    return LipPointCost::Create(l.pixel, l.path, l.radius, l.z, fixed, held, rig.fixed->r_ref);
  });
}

ceres::ResidualBlockId AddCornerResidual(size_t i, ceres::LossFunction* loss,
                                         const BlockMasks& held, RigState* rig,
                                         ObservationSet* observations, CostCache* costs,
                                         ceres::Problem* problem) {
  const Observation& o = observations->corners[i];
  ceres::CostFunction* cost = CornerCost(*rig, o, i, held, costs);
  double* pose = observations->placements[o.placement].cam_from_target.data();
  if (o.mirror == 1) {
    auto blocks = ParameterBlocks(Mirror1CornerCost::kBlocks, &rig->params, pose);
    return problem->AddResidualBlock(cost, loss, blocks.data(), static_cast<int>(blocks.size()));
  }
  auto blocks = ParameterBlocks(Mirror2CornerCost::kBlocks, &rig->params, pose);
  return problem->AddResidualBlock(cost, loss, blocks.data(), static_cast<int>(blocks.size()));
}

void MarkProjectable(const RigState& rig, const Selection& selection,
                     ObservationSet* observations) {
  for (Observation& o : observations->corners) {
    if (o.rejected || (selection.corner_subset && !o.in_robust_stages)) continue;
    Eigen::Vector2d px;
    o.projectable = Reproject(rig, *observations, o, &px);
  }
  if (!selection.lips) return;
  for (LipObservation& l : observations->lips) {
    if (!l.Used()) continue;
    Eigen::Vector2d px;
    l.projectable = ReprojectLip(rig, l, &px);
  }
}

namespace {

// A measured profile's prior: one residual block per row of the whitening L^-1 (covariance =
// L L^T), so that each prior residual is one row as the machining tolerance's are.
void AddMeasuredProfilePrior(const Eigen::Matrix<double, kProfileTerms, kProfileTerms>& covariance,
                             const std::array<double, kProfileTerms>& mean, double* block,
                             CalibrationProblem* p) {
  using Matrix = Eigen::Matrix<double, kProfileTerms, kProfileTerms>;
  const Matrix whitening = covariance.llt().matrixL().solve(Matrix::Identity());
  for (int k = 0; k < kProfileTerms; ++k) {
    LinearPriorCost<kProfileTerms>* cost = new LinearPriorCost<kProfileTerms>{{}, mean};
    for (int j = 0; j < kProfileTerms; ++j) cost->row[j] = whitening(k, j);
    p->prior_costs.emplace_back(
        new ceres::AutoDiffCostFunction<LinearPriorCost<kProfileTerms>, 1, kProfileTerms>(cost));
    p->prior_blocks.push_back(p->problem.AddResidualBlock(p->prior_costs.back().get(), nullptr, block));
  }
}

// The priors on the refined shapes (options' priors) and on the freed profiles (the machining
// tolerance about the starting model's profile), each added as a residual block of its own.
void AddPriors(const RigBlockSet& groups, const Refinement& refined, RigParams* rig,
               CalibrationProblem* p) {
  // Shape priors (only where the shape is refined).
  for (int id = 0; id < kRigBlockCount; ++id) {
    const RigBlock& b = kRigBlocks[id];
    if (!b.prior) continue;
    const auto prior = refined.shape_priors.find(b.name);
    if (!groups[id] || prior == refined.shape_priors.end()) continue;
    double* block = BlockIn(rig, static_cast<RigBlockId>(id));
    const double sigmas[2] = {prior->second.sigma_c, prior->second.sigma_k};
    for (int k = 0; k < 2; ++k) {
      if (!(sigmas[k] > 0)) continue;
      p->prior_costs.emplace_back(new ceres::AutoDiffCostFunction<ScalarPriorCost, 1, 2>(
          new ScalarPriorCost{k, refined.shape_mean[id == kShape1Block ? 0 : 1][k],
                              sigmas[k]}));  // k: kShapeC, kShapeK
      p->prior_blocks.push_back(
          p->problem.AddResidualBlock(p->prior_costs.back().get(), nullptr, block));
    }
  }
  // Freed profiles: the machining tolerance as a prior around the starting model's profile, or
  // a measured profile's fit with its covariance.
  for (int m = 0; m < 2; ++m) {
    if (!groups[kProfileGroups[m]] || !refined.profile_free[m]) continue;
    double* block = BlockIn(rig, kProfileGroups[m]);
    if (refined.profile_covariance[m]) {
      AddMeasuredProfilePrior(*refined.profile_covariance[m], refined.profile_mean[m], block, p);
      continue;
    }
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
void HoldRigCoordinates(const RigBlockSet& groups, const Refinement& refined,
                        RigParams* rig, ceres::Problem* problem) {
  for (int id = 0; id < kRigBlockCount; ++id) {
    const RigBlock& b = kRigBlocks[id];
    const RigBlockId g = static_cast<RigBlockId>(id);
    double* block = BlockIn(rig, g);
    if (!problem->HasParameterBlock(block)) continue;
    const std::vector<int> held = HeldCoordinates(refined, g);
    if (!groups[g] || static_cast<int>(held.size()) == b.size) {
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
  const BlockMasks held =
      options.held_without_columns ? HeldColumns(options.groups, refined) : BlockMasks{};
  // The corners: each over the rig's blocks and its placement's pose (AddCornerResidual).
  for (size_t i = 0; i < observations->corners.size(); ++i) {
    const Observation& o = observations->corners[i];
    if (o.rejected || (options.selection.corner_subset && !o.in_robust_stages)) continue;
    if (!o.projectable) continue;
    p.pixel_blocks.push_back(AddCornerResidual(i, group_loss[o.mirror - 1], held, rig,
                                               observations, costs, &p.problem));
    ++p.n_corners;
  }
  // The lip points: each over the rig's blocks and its azimuth (calib/lip_cost.h's order), and
  // a free-radius rim point over the session's rim radius too.
  RigParams& r = rig->params;
  for (size_t i = 0; i < (options.selection.lips ? observations->lips.size() : 0); ++i) {
    LipObservation& l = observations->lips[i];
    if (!l.Used() || !l.projectable) continue;
    const bool radius_free = observations->RimRadiusFree(l);
    ceres::CostFunction* cost = LipCost(*rig, l, i, held, costs, radius_free);
    if (radius_free) {
      auto blocks = ParameterBlocks(RimCirclePointCost::kBlocks, &r, l.phi.data(),
                                    observations->rim_radius.data());
      p.pixel_blocks.push_back(p.problem.AddResidualBlock(
          cost, lip_loss(l.members), blocks.data(), static_cast<int>(blocks.size())));
    } else {
      auto blocks = ParameterBlocks(LipPointCost::kBlocks, &r, l.phi.data());
      p.pixel_blocks.push_back(p.problem.AddResidualBlock(
          cost, lip_loss(l.members), blocks.data(), static_cast<int>(blocks.size())));
    }
    ++p.n_lips;
  }
  // The rim circle's radius stays inside the mirror (a positive radius below r_sys's reach).
  if (p.problem.HasParameterBlock(observations->rim_radius.data())) {
    p.problem.SetParameterLowerBound(observations->rim_radius.data(), 0, 0.2 * r.r_sys);
    p.problem.SetParameterUpperBound(observations->rim_radius.data(), 0, 2.0 * r.r_sys);
  }
  AddPriors(options.groups, refined, &r, &p);
  HoldRigCoordinates(options.groups, refined, &r, &p.problem);
  return built;
}

}  // namespace omni::calib
