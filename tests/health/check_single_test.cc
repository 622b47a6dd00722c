// The health check of a single-mirror camera (health/check.h): its one ring has no second view
// to match against, so its evidence is the mirror's rim, measured from the calibration photos'
// (lip_reference.h). POV-Ray renders at 640x512 of a misaligned hyperboloid + perspective lens
// in textured rooms (no target): the rim's reference learnt on four photos; a fifth photo of
// the same rig, never seen by the reference, is OK; a photo of the rig after the mirror moved
// 0.4 mm against the camera is DRIFTED (the camera or the mirror named: the rim cannot tell
// which moved); a model without the reference cannot tell, and says why. Refine (health/refine.h)
// from two photos of the moved rig brings the model back to it: the points in the mirror's body
// at 1 m (model/model_compare.h) nearer the moved truth than the stored model put them.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "health/check.h"
#include "health/evidence.h"
#include "health/lip_reference.h"
#include "health/refine.h"
#include "model/central_mirror.h"
#include "model/model_compare.h"
#include "model/rig_model.h"
#include "model/single_rim.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene.h"
#include "tests/render_room.h"

namespace omni::health {
namespace {

RigParams Hyperbolic() {
  CentralMirror central{Conic<double>{30.0, -1.8}, LensKind::kPerspective, 0, 0};
  RigParams rig = synthetic::RigAtImageSize(
      MakeSingleRig(central.mirror, central.lens, central.CameraBelowVertexMm(), 30.0, 6.0,
                    Pinhole<double>{1600, 1600, 641.5, 509.5, 0}, 1280, 1024),
      640, 512);
  rig.kind = ModelKind::kNoncentral;
  rig.mirror1_pose = {0.006, -0.0065, 0.4, -0.3, 0.2};
  return rig;
}

// One render of `rig` in the textured room, its texture shifted by `shift_mm` (another room for
// each photo), as the rim's evidence under `model`.
// Renders are kept by tag: the tests share the moved rig's photo (same rig, room and model).
ImageEvidence RimEvidence(const RigParams& rig, double shift_mm, const RigModel& model,
                          const std::string& tag) {
  static std::map<std::string, ImageEvidence> rendered;
  if (const auto it = rendered.find(tag); it != rendered.end()) return it->second;
  std::string png;
  const cv::Mat image = testing::RenderRoom(
      rig, "check_single_" + tag, Eigen::Vector3d(shift_mm, 0.7 * shift_mm, 0), &png);
  return rendered[tag] =
             CollectEvidence(image, png, /*matcher=*/nullptr, model, io::ToneCurve::kSrgb, false);
}

// The calibration photos' rim, as calibrate records it (four rooms), shared by the tests.
class CheckSingle : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    truth_ = new RigParams(Hyperbolic());
    const RigModel model(*truth_);
    const CheckOptions options;
    std::vector<ImageEvidence> photos;
    for (int k = 0; k < 4; ++k) {
      photos.push_back(RimEvidence(*truth_, 1300.0 * k + 90, model, "cal" + std::to_string(k)));
    }
    calibration_photos_ = new std::vector<ImageEvidence>(photos);
    stored_ = new RigParams(*truth_);
    stored_->calibration = CalibrationInfo{};
    stored_->calibration->lip_reference = LearnLipReference(model, photos, options);
    stored_->calibration->lip_reference_sectors = options.azimuth_bins;
    stored_->calibration->lip_reference_rim_scene_px = RimSceneSigma(*stored_, photos, options);
    std::fprintf(stderr, "scene: %.3f px\n", stored_->calibration->lip_reference_rim_scene_px);
  }
  static void TearDownTestSuite() {
    delete truth_;
    delete stored_;
    delete calibration_photos_;
  }
  static RigParams* truth_;
  static RigParams* stored_;
  static std::vector<ImageEvidence>* calibration_photos_;
};
RigParams* CheckSingle::truth_ = nullptr;
RigParams* CheckSingle::stored_ = nullptr;
std::vector<ImageEvidence>* CheckSingle::calibration_photos_ = nullptr;

TEST_F(CheckSingle, TheRimSaysWhetherTheCameraMovedAgainstTheMirror) {
  const RigParams& truth = *truth_;
  ASSERT_TRUE(RimEdgeIsTheRim(RigModel(truth)));
  const RigModel model(truth);
  const CheckOptions options;
  const std::vector<ImageEvidence>& calibration_photos = *calibration_photos_;
  for (const ImageEvidence& photo : calibration_photos) {
    ASSERT_EQ(photo.lips.size(), 1u);
    EXPECT_TRUE(photo.matches.empty());
  }
  const RigParams& stored = *stored_;
  ASSERT_GE(stored.calibration->lip_reference.size(), 20u);

  // Without the reference: the rim alone cannot tell a move from its detector's bias.
  RigParams no_reference = truth;
  const CheckResult without = CheckRig(no_reference, calibration_photos, options);
  EXPECT_EQ(without.verdict, Verdict::kCannotTell);
  EXPECT_NE(without.reason.find("lip_reference"), std::string::npos) << without.reason;

  // A photo the reference never saw, of the rig unmoved.
  const std::vector<ImageEvidence> unmoved = {RimEvidence(truth, 9100, model, "unmoved")};
  const CheckResult ok = CheckRig(stored, unmoved, options);
  std::fprintf(stderr, "unmoved: chi^2 %.1f for %d (scatter x %.2f), p %.3g: %s\n", ok.chi2,
               ok.dof, ok.rim_scatter_factor, ok.p_value, ok.reason.c_str());
  EXPECT_EQ(ok.verdict, Verdict::kOk) << ok.reason;
  EXPECT_GE(ok.referenced_lip_bins, 20);

  // The mirror moved 0.4 mm sideways against the camera (about 3 px of the rim at this size; the
  // scene's own share, ~0.3 px per coefficient here, leaves ~1.5 px at the edge of significance).
  RigParams moved = truth;
  moved.mirror1_pose[kTx] += 0.4;
  const std::vector<ImageEvidence> knocked = {RimEvidence(moved, 9100, model, "moved")};
  const CheckResult drifted = CheckRig(stored, knocked, options);
  std::fprintf(stderr, "moved: chi^2 %.1f for %d (scatter x %.2f), p %.3g: %s\n", drifted.chi2,
               drifted.dof, drifted.rim_scatter_factor, drifted.p_value, drifted.reason.c_str());
  EXPECT_EQ(drifted.verdict, Verdict::kDrifted);
  ASSERT_FALSE(drifted.groups.empty());
  // Only the camera and the mirror are fitted; either explains the rim's move.
  EXPECT_EQ(drifted.groups.size(), 2u);
  EXPECT_TRUE(drifted.named_group == "camera" || drifted.named_group == "mirror1")
      << drifted.named_group;
}

// Refine from two photos of the rig after the mirror moved 0.4 mm sideways: the rim's move is
// taken up by the parameters the rim determines, and the refined model projects the points in
// the mirror's body at 1 m nearer the moved rig than the stored one did.
TEST_F(CheckSingle, RefineFromTheRimBringsTheModelBackToTheMovedRig) {
  RigParams moved = *truth_;
  moved.mirror1_pose[kTx] += 0.4;
  const RigModel model(*truth_);
  const std::vector<ImageEvidence> knocked = {RimEvidence(moved, 9100, model, "moved"),
                                              RimEvidence(moved, 5300, model, "refine_b")};
  // The check's choice, and the camera instead (the rim cannot tell which moved; either group
  // takes up its move).
  for (const std::vector<std::string>& groups : {std::vector<std::string>{},
                                                 std::vector<std::string>{"camera"}}) {
    RefineOptions options;
    options.groups = groups;
    const RefineResult refined = RefineRig(*stored_, knocked, options);
    std::string names;
    for (const std::string& g : refined.groups) names += g + " ";
    std::fprintf(stderr, "refined groups: %s; before chi^2 %.1f (%s), after chi^2 %.1f (%s)\n",
                 names.c_str(), refined.before.chi2, VerdictName(refined.before.verdict),
                 refined.after.chi2, VerdictName(refined.after.verdict));
    for (const RefinedParameter& p : refined.refined) {
      std::fprintf(stderr, "  %s %.5g -> %.5g (sigma %.3g)\n", p.name.c_str(), p.before, p.after,
                   p.sigma);
    }
    for (const HeldParameter& h : refined.held) std::fprintf(stderr, "  held %s\n", h.name.c_str());
    const RigModel moved_model(moved);
    const double before =
        CompareProjectionsInMirror1(moved_model, RigModel(*stored_), 1000).rms_px[0];
    const double after =
        CompareProjectionsInMirror1(moved_model, RigModel(refined.rig), 1000).rms_px[0];
    std::fprintf(stderr, "points in the mirror's body at 1 m from the moved rig: %.3f -> %.3f px\n",
                 before, after);
    EXPECT_EQ(refined.before.verdict, Verdict::kDrifted);
    EXPECT_FALSE(refined.refined.empty());
    EXPECT_EQ(refined.after.verdict, Verdict::kOk) << refined.after.reason;
    EXPECT_LT(after, 0.3 * before) << names;
  }
}

}  // namespace
}  // namespace omni::health
