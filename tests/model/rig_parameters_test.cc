// The parameter table's columns (model/rig_parameters.h) say what the code used to spell by
// name: the model file's older spellings, the coarse groups, the camera-rotation valley, the
// radial powers, the default estimate and the blocks' flat offsets.
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include "model/rig_parameters.h"

namespace omni {
namespace {

TEST(RigParameters, ModelFileSpellingsAreTheOlderOnes) {
  const std::vector<std::pair<std::string, std::string>> spelled = {
      {"camera.fx", "fx"},
      {"camera.skew", "skew"},
      {"camera.dist_k1", "dist_k1"},
      {"distortion.dist_p2", "dist_p2"},
      {"camera.distortion.dist_k3", "dist_k3"},
      {"mirror1.c1", "c1"},
      {"mirror1.k1", "k1"},
      {"mirror2.c2", "c2"},
      {"mirror2.k2", "k2"},
      {"mirror1.reflex.rx", "reflex.rx"},
      {"mirror1.reflex.dz", "reflex.dz"},
      {"mirror1.profile.sag_p1", "mirror1.sag_p1"},
      {"mirror2.profile.sag_sin2", "mirror2.sag_sin2"}};
  for (const auto& [alias, name] : spelled) {
    const RigParameter* p = FindRigParameter(alias);
    ASSERT_NE(p, nullptr) << alias;
    EXPECT_EQ(std::string(p->name), name) << alias;
  }
  for (const RigParameter& p : RigParameterTable()) EXPECT_EQ(FindRigParameter(p.name), &p);
  // Spellings no file ever wrote stay unknown.
  for (const char* unknown : {"mirror1.cam_from_mirror.rx", "design.c1", "mirror2.c1",
                              "camera.distortion.fx", "reflex.reflex.rx", "mirror2.reflex.rx",
                              "mirror1.profile.rx", "mirror2_pose.tx"}) {
    EXPECT_EQ(FindRigParameter(unknown), nullptr) << unknown;
  }
}

TEST(RigParameters, GroupsOfTheBlocks) {
  std::vector<std::string> groups;
  for (const RigParameter& p : RigParameterTable()) groups.push_back(GroupOf(p));
  const std::vector<std::string> want = {
      "camera",  "camera",  "camera",  "camera",  "camera",  "distortion", "distortion",
      "distortion", "distortion", "distortion", "mirror1", "mirror1", "mirror2", "mirror2",
      "mirror1", "mirror1", "mirror1", "mirror1", "mirror1", "mirror2", "mirror2",
      "mirror2", "mirror2", "mirror2", "reflex",  "reflex",  "reflex",  "mirror1",
      "mirror1", "mirror1", "mirror1", "mirror1", "mirror1", "mirror2", "mirror2",
      "mirror2", "mirror2", "mirror2", "mirror2"};
  EXPECT_EQ(groups, want);
}

TEST(RigParameters, RotationValleyRadialPowersAndDrift) {
  std::set<std::string> valley, principal_point, drift;
  for (const RigParameter& p : RigParameterTable()) {
    if (p.valley != RotationValley::kNone) valley.insert(p.name);
    if (p.valley == RotationValley::kPrincipalPoint) principal_point.insert(p.name);
    if (p.drift) drift.insert(p.name);
  }
  EXPECT_EQ(valley, (std::set<std::string>{"mirror1.rx", "mirror1.ry", "mirror2.rx", "mirror2.ry",
                                           "reflex.rx", "reflex.ry", "cx", "cy", "mirror1.tx",
                                           "mirror1.ty", "mirror2.tx", "mirror2.ty"}));
  EXPECT_EQ(principal_point, (std::set<std::string>{"cx", "cy"}));
  EXPECT_EQ(drift, (std::set<std::string>{"fx", "fy", "cx", "cy", "mirror1.rx", "mirror1.ry",
                                          "mirror1.tx", "mirror1.ty", "mirror1.tz", "mirror2.rx",
                                          "mirror2.ry", "mirror2.tx", "mirror2.ty", "mirror2.tz",
                                          "reflex.rx", "reflex.ry", "reflex.dz"}));
  EXPECT_EQ(RadialPower("dist_k1"), 3);
  EXPECT_EQ(RadialPower("dist_k2"), 5);
  EXPECT_EQ(RadialPower("dist_k3"), 7);
  EXPECT_EQ(RadialPower("dist_p1"), 0);
  EXPECT_EQ(RadialPower("fx"), 0);
  EXPECT_EQ(RadialPower("nonsense"), 0);
}

// The roles calib/ reads instead of names: what it holds unless asked (skew, the tangential pair,
// the highest radial term) and what a profile's power term trades with (the focal lengths, the
// mirrors' axial offsets and the reflex plane's).
TEST(RigParameters, SolveRoles) {
  auto names = [](SolveRole role) {
    std::vector<std::string> out;
    for (const RigParameter* p : ParametersWithRole(role)) out.push_back(p->name);
    return out;
  };
  EXPECT_EQ(names(SolveRole::kSkew), std::vector<std::string>({"skew"}));
  EXPECT_EQ(names(SolveRole::kTangential), std::vector<std::string>({"dist_p1", "dist_p2"}));
  EXPECT_EQ(names(SolveRole::kHighRadial), std::vector<std::string>({"dist_k3"}));
  EXPECT_EQ(names(SolveRole::kAxialScale),
            std::vector<std::string>({"fx", "fy", "mirror1.tz", "mirror2.tz", "reflex.dz"}));
  EXPECT_EQ(names(SolveRole::kPlain).size(), 39u - 9u);
  // Held roles are ones a session may consider (an assumed sigma for the held value).
  for (SolveRole role : {SolveRole::kSkew, SolveRole::kTangential, SolveRole::kHighRadial}) {
    for (const RigParameter* p : ParametersWithRole(role)) EXPECT_TRUE(p->considerable) << p->name;
  }
}

TEST(RigParameters, BlocksOffsetsAndDefaults) {
  EXPECT_EQ(BlockOffset(kCameraBlock), 0);
  EXPECT_EQ(BlockOffset(kDistortionBlock), 5);
  EXPECT_EQ(BlockOffset(kShape1Block), 10);
  EXPECT_EQ(BlockOffset(kShape2Block), 12);
  EXPECT_EQ(BlockOffset(kPose1Block), 14);
  EXPECT_EQ(BlockOffset(kPose2Block), 19);
  EXPECT_EQ(BlockOffset(kReflexBlock), 24);
  EXPECT_EQ(BlockOffset(kProfile1Block), 27);
  EXPECT_EQ(BlockOffset(kProfile2Block), 33);
  EXPECT_EQ(DefaultEstimateBlocks(), (std::vector<std::string>{"camera", "distortion", "mirror1_pose",
                                                               "mirror2_pose", "reflex"}));
  for (const RigParameter& p : RigParameterTable()) {
    EXPECT_EQ(std::string(kRigBlocks[BlockOf(p)].name), p.block) << p.name;
    EXPECT_EQ(&BlockParameters(BlockOf(p))[p.index], &p) << p.name;
  }
  RigParams rig;
  EXPECT_EQ(BlockIn(&rig, kPose2Block), rig.mirror2_pose.data());
  EXPECT_EQ(BlockIn(&rig, "mirror2_profile"), rig.mirror2_profile.data());
  EXPECT_EQ(ParameterOf(&rig, "mirror1.reflex.dz"), &rig.reflex[kReflexDz]);
}

// What a hint asks for fits the rig's kind: a single-mirror rig's hints of the parameters it has
// (camera, distortion, mirror 1's shape, pose and profile) never speak of two rings; a folded
// rig's are the table's own.
TEST(RigParameters, HintsFitTheRigKind) {
  for (const RigParameter& p : RigParameterTable()) {
    EXPECT_EQ(ParameterHint(p, RigKind::kFolded), p.hint) << p.name;
    const RigBlockId block = BlockOf(p);
    if (block == kShape2Block || block == kPose2Block || block == kReflexBlock ||
        block == kProfile2Block) {
      continue;  // a single rig has no such parameter
    }
    const std::string hint = ParameterHint(p, RigKind::kSingle);
    EXPECT_FALSE(hint.empty()) << p.name;
    for (const char* ring2 : {"both rings", "rings", "inner", "mirror 2"}) {
      EXPECT_EQ(hint.find(ring2), std::string::npos) << p.name << ": " << hint;
    }
  }
}

}  // namespace
}  // namespace omni
