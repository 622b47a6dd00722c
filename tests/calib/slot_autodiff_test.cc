// calib/slot_autodiff.h against the oracle ceres::DynamicAutoDiffCostFunction over the same functors
// (corner costs through each mirror, lip costs along every path) on the misaligned big rig: the
// same residuals and Jacobians, including the columns the slot version writes as zeros without
// differentiating (blocks declared no-derivative, held coordinates, constant blocks).
#include <ceres/dynamic_autodiff_cost_function.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "calib/corner_cost.h"
#include "calib/lip_cost.h"
#include "model/lip.h"
#include "model/rig_model.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

// The oracle: plain automatic differentiation of `functor` over its rig blocks, then `extra`
// nuisance blocks of the given sizes.
template <typename Functor>
std::unique_ptr<ceres::CostFunction> Plain(Functor* functor, std::vector<int> extra) {
  auto* cost = new ceres::DynamicAutoDiffCostFunction<Functor, 4>(functor);
  for (RigBlockId b : Functor::kBlocks) cost->AddParameterBlock(kRigBlocks[b].size);
  for (int size : extra) cost->AddParameterBlock(size);
  cost->SetNumResiduals(2);
  return std::unique_ptr<ceres::CostFunction>(cost);
}

// Evaluates `cost` with Jacobians for the blocks whose `want` is true (others nullptr).
struct Evaluation {
  bool ok = false;
  std::vector<double> residuals;
  std::vector<std::vector<double>> jacobians;  // empty where not asked
};

Evaluation Evaluate(const ceres::CostFunction& cost, const std::vector<double*>& blocks,
                    const std::vector<bool>& want) {
  Evaluation e;
  const auto& sizes = cost.parameter_block_sizes();
  e.residuals.assign(cost.num_residuals(), NAN);
  e.jacobians.resize(sizes.size());
  std::vector<double*> jac(sizes.size(), nullptr);
  for (size_t i = 0; i < sizes.size(); ++i) {
    if (!want[i]) continue;
    e.jacobians[i].assign(cost.num_residuals() * sizes[i], NAN);
    jac[i] = e.jacobians[i].data();
  }
  e.ok = cost.Evaluate(blocks.data(), e.residuals.data(), jac.data());
  return e;
}

// Slot Jacobians equal the plain ones (held columns: zero) to rounding.
void ExpectSame(const ceres::CostFunction& plain, const ceres::CostFunction& slot,
                const std::vector<double*>& blocks, const std::vector<bool>& want,
                const std::vector<uint32_t>& held, int* nonzero_columns_seen) {
  const Evaluation p = Evaluate(plain, blocks, std::vector<bool>(blocks.size(), true));
  const Evaluation s = Evaluate(slot, blocks, want);
  ASSERT_TRUE(p.ok);
  ASSERT_TRUE(s.ok);
  for (size_t r = 0; r < p.residuals.size(); ++r) EXPECT_EQ(p.residuals[r], s.residuals[r]);
  const auto& sizes = plain.parameter_block_sizes();
  for (size_t i = 0; i < sizes.size(); ++i) {
    if (!want[i]) continue;
    for (int r = 0; r < plain.num_residuals(); ++r) {
      for (int k = 0; k < sizes[i]; ++k) {
        const double pv = p.jacobians[i][r * sizes[i] + k];
        const double sv = s.jacobians[i][r * sizes[i] + k];
        if (held[i] >> k & 1u) {
          EXPECT_EQ(sv, 0.0) << "block " << i << " coordinate " << k;
        } else {
          EXPECT_NEAR(sv, pv, 1e-9 * (1 + std::abs(pv))) << "block " << i << " coordinate " << k;
          *nonzero_columns_seen += pv != 0;
        }
      }
    }
  }
}

class SlotAutoDiffTest : public ::testing::Test {
 protected:
  void SetUp() override {
    rig_ = testing::MisalignedRig();
    // Machined mirrors (issue 40): the profile blocks' columns are compared too.
    rig_.profile1 = DefaultProfileShape(rig_, Mirror::kOne);
    rig_.profile2 = DefaultProfileShape(rig_, Mirror::kTwo);
    rig_.mirror1_profile = {0.004, -0.002, 0.001, 0.0005, 0.001, -0.0008};
    rig_.mirror2_profile = {-0.003, 0.002, -0.001, 0.0004, -0.0006, 0.0009};
    fixed_ = std::make_shared<const RigFixed>(FixedOf(rig_));
  }
  RigParams rig_;
  std::shared_ptr<const RigFixed> fixed_;
};

TEST_F(SlotAutoDiffTest, CornerCostsMatchPlainAutoDiff) {
  const RigModel model(rig_);
  const Eigen::Vector3d corner_in_target(40, 80, 0);
  const Eigen::Vector3d rotation(0.1, -0.2, 0.3);
  int checked[2] = {0, 0};
  for (double azimuth = 0; azimuth < 2 * M_PI; azimuth += 0.7) {
    for (double height : {-300.0, 0.0, 300.0}) {
      const Eigen::Vector3d point_in_cam(900 * std::cos(azimuth), 900 * std::sin(azimuth), height);
      // The pose block that puts corner_in_target at point_in_cam.
      double pose[6] = {rotation.x(), rotation.y(), rotation.z(), 0, 0, 0};
      const Vec3<double> rotated = CornerInCam(pose, corner_in_target);
      for (int k = 0; k < 3; ++k) pose[3 + k] = point_in_cam[k] - rotated[k];
      for (Mirror mirror : {Mirror::kOne, Mirror::kTwo}) {
        const auto pixel = model.Project(point_in_cam, mirror);
        if (!pixel) continue;
        const Eigen::Vector2d observed = *pixel + Eigen::Vector2d(0.3, -0.2);
        BlockMasks held_masks{};
        held_masks[kCameraBlock] = 0b10000;  // skew
        held_masks[kDistortionBlock] = 0b11100;  // p1, p2, k3
        std::unique_ptr<ceres::CostFunction> plain, slot, slot_none_held;
        std::vector<double*> blocks;
        int n_nonzero = 0;
        if (mirror == Mirror::kOne) {
          plain = Plain(new Mirror1CornerCost{observed, corner_in_target, fixed_}, {6});
          slot.reset(Mirror1CornerCost::Create(observed, corner_in_target, fixed_, held_masks));
          slot_none_held.reset(Mirror1CornerCost::Create(observed, corner_in_target, fixed_));
          blocks = {rig_.camera.data(),       rig_.distortion.data(),
                    rig_.mirror1_shape.data(), rig_.mirror1_profile.data(),
                    rig_.mirror1_pose.data(),  rig_.reflex.data(), pose};
          // Every block asked; then shapes constant and the camera/distortion held coordinates.
          ExpectSame(*plain, *slot, blocks, std::vector<bool>(7, true),
                     {0b10000, 0b11100, 0, 0, 0, 0, 0}, &n_nonzero);
          ExpectSame(*plain, *slot, blocks, {true, true, false, false, true, true, true},
                     {0b10000, 0b11100, 0, 0, 0, 0, 0}, &n_nonzero);
        } else {
          plain = Plain(new Mirror2CornerCost{observed, corner_in_target, fixed_}, {6});
          slot.reset(Mirror2CornerCost::Create(observed, corner_in_target, fixed_, held_masks));
          slot_none_held.reset(Mirror2CornerCost::Create(observed, corner_in_target, fixed_));
          blocks = {rig_.camera.data(),        rig_.distortion.data(), rig_.mirror1_pose.data(),
                    rig_.reflex.data(),        rig_.mirror2_shape.data(),
                    rig_.mirror2_profile.data(), rig_.mirror2_pose.data(), pose};
          ExpectSame(*plain, *slot, blocks, std::vector<bool>(8, true),
                     {0b10000, 0b11100, 0, 0, 0, 0, 0, 0}, &n_nonzero);
          ExpectSame(*plain, *slot, blocks, {true, true, true, true, false, false, true, true},
                     {0b10000, 0b11100, 0, 0, 0, 0, 0, 0}, &n_nonzero);
        }
        // Built with none held: every column.
        ExpectSame(*plain, *slot_none_held, blocks, std::vector<bool>(blocks.size(), true),
                   std::vector<uint32_t>(blocks.size(), 0), &n_nonzero);
        EXPECT_GT(n_nonzero, 40);  // the comparison saw real derivatives
        ++checked[MirrorIndex(mirror) - 1];
      }
    }
  }
  EXPECT_GE(checked[0], 5);
  EXPECT_GE(checked[1], 5);
}

TEST_F(SlotAutoDiffTest, LipCostsMatchPlainAutoDiffOnEveryPath) {
  const RigModel model(rig_);
  for (LipPath path :
       {LipPath::kDirect, LipPath::kViaMirror1, LipPath::kViaReflex, LipPath::kViaMirror2}) {
    // The calibration's relaxed bounds for lip residuals (lips lie at the mirrors' rims).
    RigFixed relaxed = *fixed_;
    relaxed.r_sys += 30;
    if (LipOwner(path) == Mirror::kOne) {
      relaxed.r_ref = 0;
    } else {
      relaxed.r_ref += 30;
      relaxed.r_cam = 0;
    }
    const auto lip_fixed = std::make_shared<const RigFixed>(relaxed);
    int checked = 0;
    for (LipCircle circle : {LipCircle::kInner, LipCircle::kOuter}) {
      const Lip& lip = LipOf(rig_, path);
      const double radius = circle == LipCircle::kInner ? lip.r_inner : lip.r_outer;
      for (double phi0 = 0.1; phi0 < 2 * M_PI; phi0 += 0.4) {
        const auto pixel = ProjectLipPoint(model, path, circle, phi0);
        if (!pixel) continue;
        const Eigen::Vector2d observed = *pixel + Eigen::Vector2d(-0.2, 0.25);
        double phi[1] = {phi0};
        BlockMasks held_masks{};
        held_masks[kCameraBlock] = 0b10000;
        held_masks[kDistortionBlock] = 0b11100;
        const std::unique_ptr<ceres::CostFunction> plain =
            Plain(new LipPointCost{observed, path, radius, lip.z, lip_fixed}, {1});
        std::unique_ptr<ceres::CostFunction> slot(
            LipPointCost::Create(observed, path, radius, lip.z, lip_fixed, held_masks));
        std::unique_ptr<ceres::CostFunction> slot_none_held(
            LipPointCost::Create(observed, path, radius, lip.z, lip_fixed));
        const std::vector<double*> blocks = {
            rig_.camera.data(),        rig_.distortion.data(),   rig_.mirror1_shape.data(),
            rig_.mirror1_pose.data(),  rig_.reflex.data(),       rig_.mirror2_shape.data(),
            rig_.mirror2_pose.data(), rig_.mirror1_profile.data(), rig_.mirror2_profile.data(),
            phi};
        int n_nonzero = 0;
        ExpectSame(*plain, *slot, blocks, std::vector<bool>(10, true),
                   {0b10000, 0b11100, 0, 0, 0, 0, 0, 0, 0, 0}, &n_nonzero);
        ExpectSame(*plain, *slot, blocks,
                   {true, true, false, true, true, false, true, false, false, true},
                   {0b10000, 0b11100, 0, 0, 0, 0, 0, 0, 0, 0}, &n_nonzero);
        ExpectSame(*plain, *slot_none_held, blocks, std::vector<bool>(10, true),
                   std::vector<uint32_t>(10, 0), &n_nonzero);
        EXPECT_GT(n_nonzero, 20) << LipPathName(path);
        ++checked;
      }
    }
    EXPECT_GE(checked, 4) << LipPathName(path);
  }
}

// A single mirror's edge as a mirror circle of free radius (RimCirclePointCost, on a tilted,
// offset sphere): the same Jacobians as plain automatic differentiation, the radius block's
// included; at any radius the same residual as the fixed circle's cost at that radius and its sag.
TEST(SlotAutoDiffSingle, RimCircleCostMatchesPlainAutoDiffAndTheFixedCircle) {
  RigParams rig = MakeSingleRig(Conic<double>{40.0, 0.0}, LensKind::kPerspective, 100, 30, 5,
                                Pinhole<double>{1800, 1800, 644.7, 508.1, 0}, 1280, 1024);
  rig.kind = ModelKind::kNoncentral;
  rig.mirror1_pose = {0.006, -0.0065, 0.4, -0.3, 0.2};
  rig.distortion = {-0.02, 0.004, 1e-4, 2e-4, 0};
  RigFixed relaxed = FixedOf(rig);
  relaxed.r_sys += 30;
  relaxed.r_ref = 0;
  const auto fixed = std::make_shared<const RigFixed>(relaxed);
  const Conic<double> conic{rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeK]};
  int checked = 0;
  for (double radius : {28.85, 30.0}) {
    const double z = rig.vertex_z + conic.Sag(radius * radius);
    for (double phi0 = 0.1; phi0 < 2 * M_PI; phi0 += 0.7) {
      Eigen::Vector2d pixel;
      ASSERT_TRUE(ProjectLipPoint(RigBlocksOf(rig), *fixed, LipPath::kDirect, radius, z, phi0,
                                  &pixel));
      const Eigen::Vector2d observed = pixel + Eigen::Vector2d(-0.2, 0.25);
      double phi[1] = {phi0};
      double radius_block[1] = {radius};
      const std::unique_ptr<ceres::CostFunction> plain = Plain(
          new RimCirclePointCost{LipPointCost{observed, LipPath::kDirect, 0, 0, fixed, 0}}, {1, 1});
      std::unique_ptr<ceres::CostFunction> slot(RimCirclePointCost::Create(observed, fixed));
      const std::vector<double*> blocks = {
          rig.camera.data(),        rig.distortion.data(),   rig.mirror1_shape.data(),
          rig.mirror1_pose.data(),  rig.reflex.data(),       rig.mirror2_shape.data(),
          rig.mirror2_pose.data(), rig.mirror1_profile.data(), rig.mirror2_profile.data(),
          phi,                      radius_block};
      int n_nonzero = 0;
      ExpectSame(*plain, *slot, blocks, std::vector<bool>(11, true), std::vector<uint32_t>(11, 0),
                 &n_nonzero);
      EXPECT_GT(n_nonzero, 20);
      // The radius moves the point across the edge: a non-zero column.
      const Evaluation e = Evaluate(*slot, blocks, std::vector<bool>(11, true));
      EXPECT_GT(std::hypot(e.jacobians[10][0], e.jacobians[10][1]), 1.0);
      // The fixed circle at that radius (LipPointCost follows the conic's sag there too).
      std::unique_ptr<ceres::CostFunction> fixed_circle(
          LipPointCost::Create(observed, LipPath::kDirect, radius, z, fixed));
      const std::vector<double*> lip_blocks(blocks.begin(), blocks.end() - 1);
      const Evaluation f = Evaluate(*fixed_circle, lip_blocks, std::vector<bool>(10, false));
      ASSERT_TRUE(f.ok);
      for (int r = 0; r < 2; ++r) EXPECT_NEAR(e.residuals[r], f.residuals[r], 1e-12);
      ++checked;
    }
  }
  EXPECT_GE(checked, 10);
}

}  // namespace
}  // namespace omni::calib
