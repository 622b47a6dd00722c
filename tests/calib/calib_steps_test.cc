// The calibration's steps on their own (calib/calibration_steps.h): the stage table names the
// parameter table's blocks; HeldCoordinates; BuildProblem wires each corner's cost to the rig's
// blocks and its placement's pose, and each lip point's to the rig's blocks and its azimuth.
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include "calib/calibration_steps.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

std::vector<const Stage*> AllStages() {
  return {&kRobustStages[0], &kRobustStages[1], &kRobustStages[2], &kReweightStage, &kFinalStage};
}

// The options' Check(): the session keys named, the defaults fine.
TEST(CalibSteps, OptionsCheckNamesTheSessionKey) {
  CalibrationOptions o;
  EXPECT_EQ(o.Check(), "");
  o.estimate = {"camera", "mirror3_pose"};
  EXPECT_EQ(o.Check(), "estimate: unknown parameter group 'mirror3_pose'");
  o.estimate.clear();  // estimate: []: the model held, the poses scored (Calibrate)
  EXPECT_EQ(o.Check(), "");
  o = CalibrationOptions();
  o.profile = "sometimes";
  EXPECT_EQ(o.Check(), "profile: expected auto, free, hold or off, got 'sometimes'");
  o.profile = "auto";
  o.profile_sigma_mm = 0;
  EXPECT_EQ(o.Check().rfind("profile_sigma_mm: expected", 0), 0u) << o.Check();
  o.profile = "off";  // no tolerance needed without a profile
  EXPECT_EQ(o.Check(), "");
}

TEST(CalibSteps, TheStageTableNamesTheParameterTablesBlocks) {
  for (const Stage* stage : AllStages()) {
    // A stage refines named groups of the table, or all the Refinement names.
    EXPECT_NE(stage->groups.none(), !stage->all_groups) << stage->name;
  }
  for (const Stage& stage : kRobustStages) {
    EXPECT_TRUE(stage.robust) << stage.name;
    EXPECT_TRUE(stage.selection.corner_subset) << stage.name;
    EXPECT_FALSE(stage.selection.lips) << stage.name;
    EXPECT_FALSE(stage.stop.whitened) << stage.name;
  }
  for (const Stage* stage : {&kReweightStage, &kFinalStage}) {
    EXPECT_FALSE(stage->robust) << stage->name;
    EXPECT_TRUE(stage->selection.lips) << stage->name;
    EXPECT_TRUE(stage->stop.whitened) << stage->name;
  }
  EXPECT_TRUE(kReweightStage.selection.corner_subset);
  EXPECT_FALSE(kFinalStage.selection.corner_subset);
  EXPECT_TRUE(kFinalStage.stop.answer);
}

TEST(CalibSteps, AStageRefinesItsGroupsOfThoseRefined) {
  CalibrationOptions options;
  options.estimate = {"camera", "mirror1_pose"};
  const Refinement refined = RefinementOf(options);
  EXPECT_EQ(StageGroups(kRobustStages[0], refined), BlockSetOf({kCameraBlock}));
  EXPECT_EQ(StageGroups(kRobustStages[1], refined), BlockSetOf({kCameraBlock, kPose1Block}));
  EXPECT_EQ(StageGroups(kRobustStages[2], refined), refined.groups);
  EXPECT_EQ(StageGroups(kFinalStage, refined), refined.groups);
}

TEST(CalibSteps, HeldCoordinatesFollowTheRefinement) {
  Refinement refined = RefinementOf(CalibrationOptions());
  auto index = [](const char* name) { return FindRigParameter(name)->index; };
  EXPECT_EQ(HeldCoordinates(refined, kCameraBlock), std::vector<int>({index("skew")}));
  EXPECT_EQ(HeldCoordinates(refined, kDistortionBlock),
            std::vector<int>({index("dist_p1"), index("dist_p2"), index("dist_k3")}));
  EXPECT_TRUE(HeldCoordinates(refined, kPose1Block).empty());
  EXPECT_EQ(HeldCoordinates(refined, kProfile1Block).size(), size_t{kProfileTerms});
  // The solve's held columns: those of the blocks it refines in part; none of a block held whole.
  refined.groups.set(kProfile1Block);
  const BlockMasks held = HeldColumns(refined.groups, refined);
  EXPECT_EQ(held[kCameraBlock], 1u << index("skew"));
  EXPECT_EQ(held[kDistortionBlock],
            (1u << index("dist_p1")) | (1u << index("dist_p2")) | (1u << index("dist_k3")));
  EXPECT_EQ(held[kProfile1Block], 0u);
  refined.dist_k3 = true;
  refined.profile_free[0] = true;
  EXPECT_EQ(HeldCoordinates(refined, kDistortionBlock),
            std::vector<int>({index("dist_p1"), index("dist_p2")}));
  EXPECT_TRUE(HeldCoordinates(refined, kProfile1Block).empty());
  EXPECT_EQ(HeldCoordinates(refined, kProfile2Block).size(), size_t{kProfileTerms});
}

TEST(CalibSteps, DistK3IsFreedWhereTheCovarianceSaysTheRadiiTellItApart) {
  const RigParams rig = testing::IdealRig();
  std::vector<Observation> corners(1);
  corners[0].pixel = Eigen::Vector2d(rig.camera[kCx] + 0.4 * rig.camera[kFx], rig.camera[kCy]);
  CalibrationOptions options;
  Refinement refined = RefinementOf(options);
  CalibrationResult result;
  CovarianceFindings findings;
  EXPECT_FALSE(DecideDistK3(findings, rig, corners, options, &refined, &result));  // no probe
  EXPECT_TRUE(result.solve.notes.empty());
  findings.k3_evaluated = true;
  findings.k3_sigma = 0.5;
  findings.k3_growth = 3.0;
  EXPECT_FALSE(DecideDistK3(findings, rig, corners, options, &refined, &result));
  EXPECT_FALSE(refined.dist_k3);
  ASSERT_EQ(result.solve.notes.size(), 1u);
  EXPECT_NE(result.solve.notes[0].find("dist_k3 held at"), std::string::npos)
      << result.solve.notes[0];
  EXPECT_NE(result.solve.notes[0].find("r <= 0.400"), std::string::npos) << result.solve.notes[0];
  findings.k3_growth = 1.5;
  EXPECT_TRUE(DecideDistK3(findings, rig, corners, options, &refined, &result));
  EXPECT_TRUE(refined.dist_k3);
  EXPECT_NE(result.solve.notes.back().find("dist_k3 refined"), std::string::npos)
      << result.solve.notes.back();
  EXPECT_EQ(HeldCoordinates(refined, kDistortionBlock).size(), 2u);
}

TEST(CalibSteps, BuildProblemWiresEachObservationToTheRigsBlocks) {
  testing::SyntheticSession session;
  const RigParams truth = testing::SmallCleanSessionWithoutTangential(&session);
  Observations detections = testing::NoisyDetections(session, 0.05, 7);
  testing::AddLipDetections(truth, 0.05, 7, &detections, 36);
  CalibrationOptions options;
  Refinement refined = RefinementOf(options);
  RigParams params = truth;
  const ProfileState profiles = SetUpProfiles(truth, options, &params, &refined);
  EXPECT_FALSE(profiles.given[0] || profiles.given[1]);
  RigState rig = RigStateOf(params);
  ObservationSet observations = CollectObservations(detections, session.targets, params, options);
  ASSERT_FALSE(observations.lips.empty());
  CostCache costs;
  InitialisePoses(&rig, options, &observations, &costs);
  InitialiseLipAzimuths(rig, &observations.lips);

  ProblemOptions po;
  po.groups = StageGroups(kFinalStage, refined);
  po.selection = kFinalStage.selection;
  MarkProjectable(rig, po.selection, &observations);
  const std::unique_ptr<CalibrationProblem> built =
      BuildProblem(&rig, &observations, Weights(), refined, po, &costs);
  ASSERT_GT(built->n_corners, 100);
  ASSERT_GT(built->n_lips, 0);
  ASSERT_EQ(built->pixel_blocks.size(), size_t(built->n_corners + built->n_lips));

  RigParams& r = rig.params;
  size_t k = 0;
  for (const Observation& o : observations.corners) {
    if (o.rejected || !o.projectable) continue;
    double* pose = observations.placements[o.placement].cam_from_target.data();
    const std::vector<double*> expected =
        o.mirror == 1
            ? std::vector<double*>{r.camera.data(), r.distortion.data(), r.mirror1_shape.data(),
                                   r.mirror1_profile.data(), r.mirror1_pose.data(),
                                   r.reflex.data(), pose}
            : std::vector<double*>{r.camera.data(), r.distortion.data(), r.mirror1_pose.data(),
                                   r.reflex.data(), r.mirror2_shape.data(),
                                   r.mirror2_profile.data(), r.mirror2_pose.data(), pose};
    std::vector<double*> blocks;
    built->problem.GetParameterBlocksForResidualBlock(built->pixel_blocks[k++], &blocks);
    ASSERT_EQ(blocks, expected) << "corner " << k;
  }
  for (const LipObservation& l : observations.lips) {
    if (!l.Used() || !l.projectable) continue;
    std::vector<double*> blocks;
    built->problem.GetParameterBlocksForResidualBlock(built->pixel_blocks[k++], &blocks);
    ASSERT_EQ(blocks.size(), 10u);
    EXPECT_EQ(blocks.front(), r.camera.data());
    EXPECT_EQ(blocks.back(), l.phi.data());
  }
  // What is not refined is constant: the shapes (not in estimate) and the profiles (held until
  // DecideProfiles frees them).
  EXPECT_TRUE(built->problem.IsParameterBlockConstant(r.mirror1_shape.data()));
  EXPECT_TRUE(built->problem.IsParameterBlockConstant(r.mirror2_profile.data()));
  EXPECT_FALSE(built->problem.IsParameterBlockConstant(r.mirror1_pose.data()));
}

}  // namespace
}  // namespace omni::calib
