// CompareProjections / CompareProjectionsUpToRotation between two rigs: zero for a rig against
// itself, never larger after the rotation is removed, and the rotation found is the least-squares
// one (turning it by a little more either way about any axis makes the difference grow);
// CompareProjectionsInMirror1 against a direct evaluation built from the pose blocks.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include <Eigen/Geometry>

#include "model/model_compare.h"
#include "tests/model/rig_test_util.h"

namespace omni {
namespace {

double Total(const ProjectionDifference& d) {
  return d.rms_px[0] * d.rms_px[0] + d.rms_px[1] * d.rms_px[1];
}

TEST(ModelCompare, SameRigIsZero) {
  std::mt19937 rng(3);
  const RigModel rig(testing::MisalignedBigRig(&rng, 0.5, 0.3, true));
  Eigen::Vector3d rotation;
  const auto d = CompareProjectionsUpToRotation(rig, rig, 1000, &rotation);
  EXPECT_GT(d.points, 500);
  EXPECT_EQ(d.lost, 0);
  EXPECT_LT(d.rms_px[0] + d.rms_px[1], 1e-9);
  EXPECT_LT(rotation.norm(), 1e-12);
}

TEST(ModelCompare, RotationRemovedIsTheLeastSquaresOne) {
  std::mt19937 rng(5);
  const RigModel truth(testing::MisalignedBigRig(&rng, 0.5, 0.3, true));
  RigParams near = truth.params();  // a calibration's worth of difference
  near.camera[kCx] += 0.8;
  near.mirror1_pose[kRx] += 0.03 * M_PI / 180;
  near.mirror2_pose[kRy] -= 0.02 * M_PI / 180;
  near.distortion[kDistK1] += 0.002;
  const RigModel other(near);
  const ProjectionDifference plain = CompareProjections(truth, other, 1000);
  Eigen::Vector3d rotation;
  const ProjectionDifference aligned =
      CompareProjectionsUpToRotation(truth, other, 1000, &rotation);
  std::printf("plain %.3f / %.3f px, up to a rotation of %.4f deg: %.3f / %.3f px\n",
              plain.rms_px[0], plain.rms_px[1], rotation.norm() * 180 / M_PI, aligned.rms_px[0],
              aligned.rms_px[1]);
  EXPECT_LT(Total(aligned), Total(plain));
  EXPECT_GT(rotation.norm(), 1e-4);  // a pp shift of 0.8 px is mostly a turn of ~0.04 deg
  // The objective at the rotation found, against small turns about each axis: a minimum.
  const double at_minimum = Total(aligned);
  for (int axis = 0; axis < 3; ++axis) {
    for (double sign : {-1.0, 1.0}) {
      // The objective evaluated here directly, at the found rotation turned a little.
      Eigen::Vector3d turned = rotation;
      turned(axis) += sign * 2e-5;  // 0.001 deg
      double sum[2] = {0, 0};
      int n[2] = {0, 0};
      for (const BandPoint& p : StereoBandPoints(truth, 1000)) {
        const Eigen::Matrix3d r =
            Eigen::AngleAxisd(turned.norm(), turned.normalized()).toRotationMatrix();
        for (int m = 0; m < 2; ++m) {
          const auto o = other.Project(r * p.point_in_cam, m == 0 ? Mirror::kOne : Mirror::kTwo);
          if (!o) continue;
          sum[m] += (*o - p.pixel[m]).squaredNorm();
          ++n[m];
        }
      }
      const double total = sum[0] / n[0] + sum[1] / n[1];
      EXPECT_GT(total, at_minimum) << "axis " << axis << " sign " << sign;
    }
  }
}

// cam_from_mirror1 built from its block here, independently of the model's Pose: tilt (rx, ry) as
// a rotation vector with z = 0, then the translation (docs/design.md, Conventions).
Eigen::Isometry3d CamFromMirror1Block(const RigParams& rig) {
  const Eigen::Vector3d tilt(rig.mirror1_pose[kRx], rig.mirror1_pose[kRy], 0);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(tilt.norm(), tilt.normalized()).toRotationMatrix();
  pose.translation() =
      Eigen::Vector3d(rig.mirror1_pose[kTx], rig.mirror1_pose[kTy], rig.mirror1_pose[kTz]);
  return pose;
}

TEST(ModelCompare, InMirror1HoldsThePointsInMirror1sBody) {
  std::mt19937 rng(7);
  const RigModel truth(testing::MisalignedBigRig(&rng, 0.5, 0.3, true));
  RigParams near = truth.params();
  near.camera[kCx] += 0.8;
  near.mirror1_pose[kRx] += 0.03 * M_PI / 180;
  near.mirror1_pose[kRy] -= 0.02 * M_PI / 180;
  near.mirror1_pose[kTx] += 0.2;
  near.mirror2_pose[kRx] += 0.03 * M_PI / 180;
  const RigModel other(near);

  EXPECT_LT(CompareProjectionsInMirror1(truth, truth, 1000).rms_px[0], 1e-9);
  // Direct: p in the truth's C -> the truth's M1 -> the other's C.
  const Eigen::Isometry3d other_from_truth =
      CamFromMirror1Block(near) * CamFromMirror1Block(truth.params()).inverse();
  double sum[2] = {0, 0};
  int n[2] = {0, 0};
  for (const BandPoint& p : StereoBandPoints(truth, 1000)) {
    for (int m = 0; m < 2; ++m) {
      const auto o =
          other.Project(other_from_truth * p.point_in_cam, m == 0 ? Mirror::kOne : Mirror::kTwo);
      if (!o) continue;
      sum[m] += (*o - p.pixel[m]).squaredNorm();
      ++n[m];
    }
  }
  const ProjectionDifference in_mirror1 = CompareProjectionsInMirror1(truth, other, 1000);
  const ProjectionDifference plain = CompareProjections(truth, other, 1000);
  std::printf("in M1 %.3f / %.3f px, plain %.3f / %.3f px\n", in_mirror1.rms_px[0],
              in_mirror1.rms_px[1], plain.rms_px[0], plain.rms_px[1]);
  for (int m = 0; m < 2; ++m) {
    ASSERT_GT(n[m], 500);
    EXPECT_NEAR(in_mirror1.rms_px[m], std::sqrt(sum[m] / n[m]), 1e-9);
    EXPECT_GT(std::abs(in_mirror1.rms_px[m] - plain.rms_px[m]), 0.01);  // the frames differ
  }
  // With mirror 1's pose shared, M1 and C hold the points alike.
  RigParams same_mirror1 = near;
  same_mirror1.mirror1_pose = truth.params().mirror1_pose;
  const ProjectionDifference a = CompareProjectionsInMirror1(truth, RigModel(same_mirror1), 1000);
  const ProjectionDifference b = CompareProjections(truth, RigModel(same_mirror1), 1000);
  EXPECT_NEAR(a.rms_px[0], b.rms_px[0], 1e-12);
  EXPECT_NEAR(a.rms_px[1], b.rms_px[1], 1e-12);
}

// A single mirror's body frame is a convention (the vertex at vertex_z): the same physical rig
// written with its vertex 10 mm higher in M1 and the pose 10 mm lower compares as identical, and a
// real 0.5 mm axial move of the mirror does not.
TEST(ModelCompare, SingleMirrorPointsAreHeldAgainstTheVertex) {
  RigParams a = MakeSingleRig(Conic<double>{30.0, -1.8}, LensKind::kPerspective, 87.8, 30, 6,
                              Pinhole<double>{1600, 1600, 640, 512, 0}, 1280, 1024);
  a.kind = ModelKind::kNoncentral;
  a.mirror1_pose = {0.006, -0.0065, 0.4, -0.3, 0.2};
  RigParams b = a;
  b.vertex_z += 10;
  b.lip1.z += 10;
  // The pose's translation is the M1 origin in C: moving the origin 10 mm down the mirror's own
  // axis keeps every mirror point in place.
  const Eigen::Vector3d axis = RotationFromTilt(a.mirror1_pose[0], a.mirror1_pose[1]) *
                               Eigen::Vector3d::UnitZ();
  for (int k = 0; k < 3; ++k) b.mirror1_pose[2 + k] -= 10 * axis(k);
  const ProjectionDifference same = CompareProjectionsInMirror1(RigModel(a), RigModel(b), 1000);
  EXPECT_GT(same.points, 1000);
  EXPECT_LT(same.rms_px[0], 1e-6);
  EXPECT_EQ(same.rms_px[1], 0);
  RigParams moved = a;
  moved.mirror1_pose[4] += 0.5;
  EXPECT_GT(CompareProjectionsInMirror1(RigModel(a), RigModel(moved), 1000).rms_px[0], 0.5);
}

}  // namespace
}  // namespace omni
