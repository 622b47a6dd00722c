// The drift coordinates (health/drift.h): a mirror's coordinates are its parameters; the
// camera's move in its mount is one rigid motion of everything the rig puts in C.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "health/drift.h"
#include "io/model_file.h"
#include "model/model_derived.h"
#include "model/rig_parameters.h"

namespace omni::health {
namespace {

const std::string kSampleDir = std::string(OMNI_SOURCE_DIR) + "/sample_configs/";


TEST(Drift, GroupsCoverEveryCoordinateOnce) {
  int total = 0;
  for (const std::string& g : DriftGroups()) total += static_cast<int>(CoordinatesOf(g).size());
  EXPECT_EQ(total, static_cast<int>(DriftCoordinates().size()));
  EXPECT_EQ(CoordinatesOf("mirror2").size(), 5u);
  EXPECT_EQ(CoordinatesOf("reflex").size(), 3u);
}

// The coordinates, their groups and steps as drift.cc listed them before the table held them.
TEST(Drift, CoordinatesInOrderWithTheirSteps) {
  const std::vector<std::pair<std::string, double>> want = {
      {"fx", 0.02},        {"fy", 0.02},        {"cx", 0.02},        {"cy", 0.02},
      {"camera.rx", 2e-5}, {"camera.ry", 2e-5}, {"camera.rz", 2e-5}, {"camera.tx", 2e-3},
      {"camera.ty", 2e-3}, {"camera.tz", 2e-3}, {"mirror1.rx", 2e-5}, {"mirror1.ry", 2e-5},
      {"mirror1.tx", 2e-3}, {"mirror1.ty", 2e-3}, {"mirror1.tz", 2e-3}, {"mirror2.rx", 2e-5},
      {"mirror2.ry", 2e-5}, {"mirror2.tx", 2e-3}, {"mirror2.ty", 2e-3}, {"mirror2.tz", 2e-3},
      {"reflex.rx", 2e-5}, {"reflex.ry", 2e-5}, {"reflex.dz", 2e-3}};
  const auto& all = DriftCoordinates();
  ASSERT_EQ(all.size(), want.size());
  for (size_t i = 0; i < all.size(); ++i) {
    EXPECT_EQ(all[i].name, want[i].first);
    EXPECT_EQ(all[i].step, want[i].second) << all[i].name;
    const bool mount = all[i].name.rfind("camera.", 0) == 0;
    EXPECT_EQ(all[i].rig_parameter, !mount) << all[i].name;
    EXPECT_EQ(all[i].group, mount ? "camera" : GroupOf(*FindRigParameter(all[i].name)));
    if (mount) {
      EXPECT_EQ(all[i].mount_rotation, all[i].name[7] == 'r') << all[i].name;
      EXPECT_EQ(all[i].mount_axis, all[i].name[8] - 'x') << all[i].name;
    }
  }
  EXPECT_EQ(DriftGroups(), (std::vector<std::string>{"camera", "mirror1", "mirror2", "reflex"}));
}

TEST(Drift, RigParameterCoordinatesAddToTheParameter) {
  const RigParams rig = io::ReadModelFile(kSampleDir + "big_rig_misaligned.yaml");
  for (const auto& c : DriftCoordinates()) {
    if (!c.rig_parameter) continue;
    Eigen::VectorXd amount(1);
    amount[0] = 0.01;
    const RigParams moved = ApplyDrift(rig, {DriftCoordinateIndex(c.name)}, amount);
    EXPECT_NEAR(*ParameterOf(moved, c.name) - *ParameterOf(rig, c.name), 0.01, 1e-12) << c.name;
  }
}

// Moving the camera by (dR, dt) in its mount must move every mirror focus, axis and the reflex
// plane by the same rigid motion in C, whatever spin about the mirrors' axes it implies.
TEST(Drift, CameraMoveIsOneRigidMotionOfTheBodies) {
  const RigParams rig = io::ReadModelFile(kSampleDir + "big_rig_misaligned.yaml");
  std::vector<int> coords;
  for (const char* name : {"camera.rx", "camera.ry", "camera.rz", "camera.tx", "camera.ty",
                           "camera.tz"}) {
    coords.push_back(DriftCoordinateIndex(name));
  }
  Eigen::VectorXd amount(6);
  amount << 0.01, -0.02, 0.4, 1.5, -2.0, 0.7;  // a large spin (0.4 rad) on purpose
  const RigParams moved = ApplyDrift(rig, coords, amount);
  const Eigen::Vector3d w = amount.head<3>();
  const Eigen::Matrix3d dR = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  const Eigen::Vector3d dt = amount.tail<3>();
  const ModelDerived before = ComputeModelDerived(rig), after = ComputeModelDerived(moved);
  EXPECT_LT((after.focus1_in_cam - (dR * before.focus1_in_cam + dt)).norm(), 1e-9);
  EXPECT_LT((after.focus2_in_cam - (dR * before.focus2_in_cam + dt)).norm(), 1e-9);
  EXPECT_LT((after.axis1_in_cam - dR * before.axis1_in_cam).norm(), 1e-12);
  EXPECT_LT((after.axis2_in_cam - dR * before.axis2_in_cam).norm(), 1e-12);
  EXPECT_LT((after.reflex_point_in_cam - (dR * before.reflex_point_in_cam + dt)).norm(), 1e-9);
  EXPECT_LT((after.reflex_normal_in_cam - dR * before.reflex_normal_in_cam).norm(), 1e-12);
  // The intrinsics and the mirrors' shapes are untouched.
  EXPECT_EQ(moved.camera, rig.camera);
  EXPECT_EQ(moved.mirror1_shape, rig.mirror1_shape);
}

}  // namespace
}  // namespace omni::health
