// Single-mirror model files (rig: single): bit-exact round trips for each lens and conic, the
// derived foci against the conic's closed forms, and one clear error per folded-only key or
// impossible mirror, with nothing written.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cstring>
#include <string>

#include "io/model_file.h"
#include "model/central_mirror.h"
#include "tests/io/io_test_util.h"

namespace omni::io {
namespace {

using omni::testing::ScratchDir;
using omni::testing::WriteText;

RigParams SingleRig(LensKind lens, double R, double K) {
  RigParams rig = MakeSingleRig(Conic<double>{R, K}, lens, 70.25, 30, 4.5,
                                Pinhole<double>{812.5, 811.25, 640.125, 512.5, 0}, 1280, 1024);
  rig.kind = ModelKind::kNoncentral;
  rig.mirror1_pose = {0.0031, -0.0042, 0.51, -0.33, 1.27};
  rig.distortion = {-0.031, 0.0042, 1e-4, -2e-4, 0};
  return rig;
}

TEST(SingleModelFile, RoundTripsBitExactly) {
  const ScratchDir dir;
  for (const RigParams& rig : {SingleRig(LensKind::kPerspective, 20.1, -2.3),
                               SingleRig(LensKind::kTelecentric, 16.2, -1.0),
                               SingleRig(LensKind::kPerspective, 45.3, 0.0)}) {
    const std::string path = dir.path() + "/single.yaml";
    WriteModelFile(path, rig);
    const RigParams back = ReadModelFile(path);
    EXPECT_EQ(back.rig, RigKind::kSingle);
    EXPECT_EQ(back.lens, rig.lens);
    EXPECT_EQ(0, std::memcmp(back.mirror1_shape.data(), rig.mirror1_shape.data(), 16));
    EXPECT_EQ(0, std::memcmp(back.mirror1_pose.data(), rig.mirror1_pose.data(), 40));
    EXPECT_EQ(0, std::memcmp(back.camera.data(), rig.camera.data(), 40));
    EXPECT_EQ(0, std::memcmp(back.distortion.data(), rig.distortion.data(), 40));
    EXPECT_EQ(back.vertex_z, rig.vertex_z);
    EXPECT_EQ(back.r_sys, rig.r_sys);
    EXPECT_EQ(back.r_cam, rig.r_cam);
    // Written again: the same text.
    EXPECT_EQ(ModelFileText(back), ModelFileText(rig));
  }
}

// A hyperboloid's far focus in `derived:` is the camera's place for a central camera: at the
// design's CameraBelowVertexMm it is C's origin.
TEST(SingleModelFile, DerivedFarFocusIsTheCentralCameraPlace) {
  CentralMirror central{Conic<double>{20.0, -2.2}, LensKind::kPerspective, 800, 0};
  const RigParams rig = MakeSingleRig(central.mirror, central.lens, central.CameraBelowVertexMm(),
                                      30, 4, Pinhole<double>{800, 800, 640, 480, 0}, 1280, 960);
  const ModelDerived derived = ComputeModelDerived(rig);
  ASSERT_TRUE(derived.has_far_focus);
  EXPECT_LT(derived.far_focus1_in_cam.norm(), 1e-12);
  // The near focus: c = R sqrt(k (k - 2)) above the far one (conic.h).
  double c = 0, k = 0;
  ASSERT_TRUE(central.mirror.ToFocalSeparation(&c, &k));
  EXPECT_NEAR(derived.focus1_in_cam.z(), c, 1e-9);
}

std::string Text() {
  return ModelFileText(SingleRig(LensKind::kPerspective, 20.1, -2.3));
}

void ExpectRefused(const std::string& text, const std::string& needle) {
  const ScratchDir dir;
  const std::string path = dir.path() + "/bad.yaml";
  WriteText(path, text);
  try {
    ReadModelFile(path);
    ADD_FAILURE() << "accepted: " << needle;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

TEST(SingleModelFile, RefusesFoldedKeysAndImpossibleMirrors) {
  const std::string text = Text();
  ExpectRefused(text + "mirror2:\n  cam_from_mirror: {rx: 0, ry: 0, tx: 0, ty: 0, tz: 0}\n",
                "mirror2");
  ExpectRefused(Replace(text, "  R: ", "  c1: 100\n  R: "), "design.c1");
  ExpectRefused(Replace(text, "  cam_from_mirror:", "  reflex: {rx: 0, ry: 0, dz: 0}\n  cam_from_mirror:"),
                "mirror1.reflex");
  // An ellipsoid that closes before the rim: R / sqrt(1 + K) = 20.1 / sqrt(1.5) < 30.
  ExpectRefused(Replace(text, "K: -2.3", "K: 0.5"), "design.K");
  ExpectRefused(Replace(text, "R: 20.1", "R: -3"), "design.R");
  ExpectRefused(Replace(text, "\nrig: single", "\nrig: double"), "rig");
  ExpectRefused(Replace(text, "\nlens: perspective", "\nlens: fisheye"), "lens");
  // A telecentric lens with the folded rig's design.
  std::string folded = ModelFileText(MakeIdealRig(DesignParams{123.488, 241.803, 5.7319, 9.7443,
                                                               233.684, 37.0},
                                                  7.0, Pinhole<double>{1450, 1450, 640, 480, 0},
                                                  1280, 960));
  ExpectRefused(Replace(folded, "units:", "lens: telecentric\nunits:"), "lens");
}

TEST(SingleModelFile, WritesNothingForAnInvalidModel) {
  const ScratchDir dir;
  RigParams rig = SingleRig(LensKind::kPerspective, 20.1, -2.3);
  rig.mirror1_shape[kShapeK] = 0.5;  // closes before the rim
  const std::string path = dir.path() + "/never.yaml";
  EXPECT_THROW(WriteModelFile(path, rig), std::runtime_error);
  struct stat st;
  EXPECT_NE(stat(path.c_str(), &st), 0);
}

}  // namespace
}  // namespace omni::io
