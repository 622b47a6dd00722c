// The rig-body tolerances (design/rig_body.h): the quantities against a direct construction with
// Eigen's own rotations, their invariance when the camera turns against the bodies (what makes
// them decidable), the sigma against a Monte Carlo over the covariance, the advice in the
// camera-rotation valley, and the tolerance file's keys.
#include "design/rig_body.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "design/tolerance_file.h"
#include "io/model_file.h"
#include "model/hyperboloid.h"
#include "model/rig_parameters.h"

namespace omni::design {
namespace {

RigParams BigRig() {
  return io::ReadModelFile(std::string(OMNI_SAMPLE_DIR) + "/big_rig_ideal.yaml");
}

Eigen::Matrix3d Tilt(double rx, double ry) {
  const Eigen::Vector3d w(rx, ry, 0);
  return w.norm() > 0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                      : Eigen::Matrix3d::Identity();
}

// The tilt (rx, ry) whose rotation sends +z where `rotation` does (the spin about the axis is
// no parameter of a mirror), and t unchanged.
void SetPose(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& t, std::array<double, 5>* pose) {
  const Eigen::Vector3d n = rotation * Eigen::Vector3d::UnitZ();
  const double theta = std::acos(std::clamp(n.z(), -1.0, 1.0));
  const double s = std::sin(theta) / theta;
  (*pose)[0] = -n.y() / s;
  (*pose)[1] = n.x() / s;
  (*pose)[2] = t.x();
  (*pose)[3] = t.y();
  (*pose)[4] = t.z();
}

TEST(RigBody, QuantitiesOfAMirror2PoseAgainstAnAlignedMirror1) {
  RigParams rig = BigRig();
  rig.mirror2_pose = {0.004, -0.003, 0.21, -0.12, 0.15};
  const RigBodyQuantities q = RigBodyQuantitiesOf(rig);
  const double vertex = HyperboloidSheet<double>::Mirror2(rig.mirror2_shape[kShapeC],
                                                           rig.mirror2_shape[kShapeK], rig.d).VertexZ();
  const Eigen::Matrix3d r = Tilt(0.004, -0.003);
  const Eigen::Vector3d v = r * Eigen::Vector3d(0, 0, vertex) + Eigen::Vector3d(0.21, -0.12, 0.15);
  EXPECT_NEAR(q.mirror2_decentre_mm.x(), v.x(), 1e-12);
  EXPECT_NEAR(q.mirror2_decentre_mm.y(), v.y(), 1e-12);
  EXPECT_NEAR(q.mirror2_spacing_mm, v.z() - vertex, 1e-12);
  EXPECT_NEAR(q.mirror2_tilt_rad.x(), (r * Eigen::Vector3d::UnitZ()).x(), 1e-15);
  EXPECT_NEAR(q.mirror2_tilt_rad.y(), (r * Eigen::Vector3d::UnitZ()).y(), 1e-15);
  EXPECT_NEAR(q.camera_decentre_mm.norm(), 0, 1e-15);
  EXPECT_NEAR(q.camera_tilt_rad.norm(), 0, 1e-15);
}

TEST(RigBody, TurningTheCameraMovesOnlyItsOwnTilt) {
  RigParams rig = BigRig();
  rig.mirror1_pose = {0.003, -0.002, 0.30, -0.20, 0.10};
  rig.mirror2_pose = {-0.001, 0.004, 0.05, 0.12, -0.20};
  const RigBodyQuantities before = RigBodyQuantitiesOf(rig);
  // The camera turned by ~0.3 deg about its centre: both mirror poses in C turn with it.
  const Eigen::Matrix3d turn = (Eigen::AngleAxisd(0.004, Eigen::Vector3d::UnitX()) *
                                Eigen::AngleAxisd(-0.003, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(0.002, Eigen::Vector3d::UnitZ())).toRotationMatrix();
  for (auto* pose : {&rig.mirror1_pose, &rig.mirror2_pose}) {
    const Eigen::Vector3d t((*pose)[2], (*pose)[3], (*pose)[4]);
    SetPose(turn * Tilt((*pose)[0], (*pose)[1]), turn * t, pose);
  }
  const RigBodyQuantities after = RigBodyQuantitiesOf(rig);
  EXPECT_NEAR(after.mirror2_decentre_mm.norm(), before.mirror2_decentre_mm.norm(), 1e-9);
  EXPECT_NEAR(after.mirror2_tilt_rad.norm(), before.mirror2_tilt_rad.norm(), 1e-12);
  EXPECT_NEAR(after.mirror2_spacing_mm, before.mirror2_spacing_mm, 1e-9);
  EXPECT_NEAR(after.camera_decentre_mm.norm(), before.camera_decentre_mm.norm(), 1e-9);
  EXPECT_GT(std::abs(after.camera_tilt_rad.norm() - before.camera_tilt_rad.norm()), 1e-3);
}

TEST(RigBody, SigmaMatchesMonteCarloOverTheCovariance) {
  RigParams rig = BigRig();
  rig.mirror1_pose = {0.002, -0.001, 0.10, -0.05, 0.02};
  rig.mirror2_pose = {0.003, 0.002, 0.25, 0.10, 0.12};
  // A random covariance of the ten pose parameters (sigmas ~1e-4 rad, ~0.02 mm).
  std::vector<std::string> names;
  for (RigBlockId b : {kPose1Block, kPose2Block}) {
    for (int i = 0; i < 5; ++i) names.push_back(BlockParameters(b)[i].name);
  }
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, 1);
  Eigen::MatrixXd a(10, 10);
  for (int i = 0; i < 10; ++i) {
    for (int j = 0; j < 10; ++j) a(i, j) = g(rng) * (i % 5 < 2 ? 1e-4 : 2e-2) / 3;
  }
  const Eigen::MatrixXd cov = a * a.transpose();
  CalibrationInfo info;
  info.parameters = names;
  for (int i = 0; i < 10; ++i) {
    info.values.push_back(*ParameterOf(rig, names[i]));
    info.sigma.push_back(std::sqrt(cov(i, i)));
    for (int j = 0; j < 10; ++j) info.covariance.push_back(cov(i, j));
  }
  rig.calibration = info;
  RigBodyTolerance tol;
  tol.mirror2_decentre_mm = tol.mirror2_tilt_rad = tol.mirror2_spacing_mm = 1;
  tol.camera_decentre_mm = 1;
  const auto checks = CheckRigBody(rig, tol, NamedCovariance(rig));
  ASSERT_EQ(checks.size(), 4u);
  const Eigen::MatrixXd l = cov.llt().matrixL();
  const int runs = 4000;
  std::vector<double> sum(4, 0), sum2(4, 0);
  for (int run = 0; run < runs; ++run) {
    Eigen::VectorXd z(10);
    for (int i = 0; i < 10; ++i) z(i) = g(rng);
    const Eigen::VectorXd dx = l * z;
    RigParams drawn = rig;
    for (int i = 0; i < 10; ++i) *ParameterOf(&drawn, names[i]) += dx(i);
    const RigBodyQuantities q = RigBodyQuantitiesOf(drawn);
    const double v[4] = {q.mirror2_decentre_mm.norm(), q.mirror2_tilt_rad.norm(),
                         std::abs(q.mirror2_spacing_mm), q.camera_decentre_mm.norm()};
    for (int k = 0; k < 4; ++k) {
      sum[k] += v[k];
      sum2[k] += v[k] * v[k];
    }
  }
  for (int k = 0; k < 4; ++k) {
    const double spread = std::sqrt(sum2[k] / runs - sum[k] * sum[k] / (runs * runs));
    ASSERT_TRUE(checks[k].sigma.has_value());
    EXPECT_NEAR(*checks[k].sigma / spread, 1.0, 0.08) << checks[k].name;
    EXPECT_EQ(checks[k].frame, "mirror1");
  }
}

TEST(RigBody, NoMoveIsAdvisedInTheCameraRotationValley) {
  ToleranceCheck c;
  c.name = "camera.tilt_to_axis";
  c.unit = "rad";
  c.frame = "mirror1";
  c.value = 0.02;
  c.limit = 0.01;
  c.components = {0.02, 0};
  c.parameters = {"camera.tilt_to_axis.x", "camera.tilt_to_axis.y"};
  c.verdict = Verdict::kFail;
  c.valley_correlation = 0.999;
  EXPECT_EQ(Correction(c), "");
  EXPECT_NE(RotationValleyNote(c), "");
  c.valley_correlation = 0.3;
  EXPECT_NE(Correction(c).find("tilt the camera by (-0.573, "), std::string::npos)
      << Correction(c);
}

std::string Write(const std::string& text) {
  const std::string path = ::testing::TempDir() + "rig_body_tolerances.yaml";
  std::ofstream(path) << "format: omnistereo-tolerances/1\n" << text;
  return path;
}

std::string ErrorOf(const std::string& text) {
  try {
    ReadToleranceFile(Write(text));
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(RigBody, ToleranceFileTakesBodyKeysAndRefusesMixedFrames) {
  const ToleranceFile file = ReadToleranceFile(
      Write("mirror2: {decentre_to_mirror1: 0.1, tilt_to_mirror1_deg: 0.2, spacing: 0.15}\n"
            "camera: {decentre_to_axis: 0.5, tilt_to_axis_deg: 1}\n"));
  EXPECT_DOUBLE_EQ(file.spec.rig_body.mirror2_decentre_mm, 0.1);
  EXPECT_NEAR(file.spec.rig_body.mirror2_tilt_rad, 0.2 * M_PI / 180, 1e-15);
  EXPECT_DOUBLE_EQ(file.spec.rig_body.mirror2_spacing_mm, 0.15);
  EXPECT_DOUBLE_EQ(file.spec.rig_body.camera_decentre_mm, 0.5);
  EXPECT_LT(file.spec.mirror[1].tilt_rad, 0);  // not toleranced against the camera
  std::string e = ErrorOf("mirror2: {tilt_deg: 0.3, tilt_to_mirror1_deg: 0.1}\n");
  EXPECT_NE(e.find("mirror2.tilt_to_mirror1_deg: expected the part toleranced in one frame"),
            std::string::npos) << e;
  EXPECT_NE(e.find("mirror2.tilt_deg"), std::string::npos) << e;
  e = ErrorOf("mirror1: {decentre: 0.3}\ncamera: {decentre_to_axis: 0.5}\n");
  EXPECT_NE(e.find("camera.decentre_to_axis: expected the part toleranced in one frame"),
            std::string::npos) << e;
  e = ErrorOf("mirror2: {spaceing: 0.1}\n");
  EXPECT_NE(e.find("mirror2.spaceing: expected one of"), std::string::npos) << e;
  // The sample file (older keys only) still reads.
  EXPECT_EQ(ReadToleranceFile(std::string(OMNI_SAMPLE_DIR) + "/tolerances.yaml")
                .spec.mirror[0].decentre_mm,
            0.3);
}

}  // namespace
}  // namespace omni::design
