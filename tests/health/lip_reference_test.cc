// The check measured from the calibration photos' lips (health/lip_reference.h), on evidence
// simulated from a known rig whose mirror-2 lip edge the detector places with a bias: the same in
// every photo, up to 1.2 px inwards over 30 deg of azimuth (as where a thin red band's blurred
// edges merge, docs/experiments.md). The oracle is that imposed bias.
#include <gtest/gtest.h>

#include <cmath>

#include "health/check.h"
#include "health/drift.h"
#include "health/lip_reference.h"
#include "io/model_file.h"
#include "tests/health/simulated_evidence.h"

namespace omni::health {
namespace {

const double kDeg = M_PI / 180;

// The detector's bias across the mirror-2 lip's outer edge at its circle's azimuth phi (px).
double Bias(LipPath path, double phi) {
  if (path != LipPath::kViaMirror2) return 0;
  const double d = std::remainder(phi - 100 * kDeg, 2 * M_PI) / (15 * kDeg);
  return -1.2 * std::exp(-0.5 * d * d) + 0.3 * std::cos(phi);
}

std::vector<ImageEvidence> Photos(const RigParams& now, int count, unsigned seed) {
  std::vector<ImageEvidence> photos;
  for (int k = 0; k < count; ++k) photos.push_back(Simulate(now, 1500, 0.1, 0.15, seed + k, Bias));
  return photos;
}

class LipReferenceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    stored_.calibration = CalibrationInfo{};  // no covariance: the bins' own errors alone
  }
  RigParams stored_ =
      io::ReadModelFile(std::string(OMNI_SOURCE_DIR) + "/sample_configs/big_rig_misaligned.yaml");
};

TEST_F(LipReferenceTest, LearntBinsAreTheDetectorsBiasAndItsScatter) {
  const CheckOptions options;
  const std::vector<LipReferenceBin> reference =
      LearnLipReference(RigModel(stored_), Photos(stored_, 6, 10), options);
  ASSERT_GE(reference.size(), 60u);  // 3 edges x 24 sectors, less the few a sector misses
  for (const LipReferenceBin& bin : reference) {
    // The imposed bias averaged over the sector's whole degrees (the points' azimuths).
    double sum = 0;
    const int first = static_cast<int>(std::lround(bin.azimuth_deg - 7.5));
    for (int a = first; a < first + 15; ++a) {
      sum += Bias(bin.edge == "via_mirror2 r_outer" ? LipPath::kViaMirror2 : LipPath::kDirect,
                  a * kDeg);
    }
    const double truth = sum / 15;
    SCOPED_TRACE(bin.edge + " at " + std::to_string(bin.azimuth_deg) + " deg");
    EXPECT_EQ(bin.photos, 6);
    // The mean of 6 x ~15 points of 0.15 px noise: 0.016 px; 4 of those, and 0.02 px for the
    // first-order distance and a sector's uneven points.
    EXPECT_NEAR(bin.mean_px, truth, 4 * 0.15 / std::sqrt(90.0) + 0.02);
    // One photo's bin mean scatters as 0.15 px / sqrt(~15 points) = 0.039 px; learnt from 6
    // photos and 4 photos' worth of its edge's it is good to 24% (one sd), and 70 bins reach 3
    // sd; where the bias is steep inside a sector (0.03 px per deg at 127.5 deg), which points
    // fall into it changes from photo to photo too: at most twice 0.039 px.
    EXPECT_GT(bin.scatter_px, 0.039 * (1 - 3 * 0.24));
    EXPECT_LT(bin.scatter_px, 2 * 0.039);
  }
  // Fewer than three photos cannot tell a photo's scatter: no reference.
  EXPECT_TRUE(LearnLipReference(RigModel(stored_), Photos(stored_, 2, 10), options).empty());
}

TEST_F(LipReferenceTest, CheckMeasuresChangeSinceCalibrationNotTheDetectorsBias) {
  const std::vector<ImageEvidence> calibration = Photos(stored_, 6, 10);
  const std::vector<ImageEvidence> field = Photos(stored_, 3, 50);
  // Without the reference the detector's bias alone reads as a drift.
  const CheckResult unreferenced = CheckRig(stored_, field);
  EXPECT_EQ(unreferenced.verdict, Verdict::kDrifted) << "chi^2 " << unreferenced.chi2;
  EXPECT_EQ(unreferenced.referenced_lip_bins, 0);

  RigParams stored = stored_;
  stored.calibration->lip_reference = LearnLipReference(RigModel(stored_), calibration, {});
  stored.calibration->lip_reference_sectors = CheckOptions{}.azimuth_bins;
  // The unchanged rig: OK from the field photos together and each alone, and on the
  // calibration photos themselves.
  const CheckResult together = CheckRig(stored, field);
  EXPECT_EQ(together.verdict, Verdict::kOk) << "chi^2 " << together.chi2 << " for " << together.dof;
  EXPECT_EQ(together.referenced_lip_bins, together.lip_bins);
  for (const ImageEvidence& photo : field) {
    const CheckResult one = CheckRig(stored, {photo});
    EXPECT_EQ(one.verdict, Verdict::kOk) << "chi^2 " << one.chi2 << " for " << one.dof;
  }
  EXPECT_EQ(CheckRig(stored, calibration).verdict, Verdict::kOk);
  // Mirror 2 knocked by 0.2 mm along x after calibration, the same detector: DRIFTED, mirror 2.
  for (const char* coordinate : {"mirror2.tx", "mirror2.rx"}) {
    Eigen::VectorXd amount(1);
    amount[0] = std::string(coordinate) == "mirror2.tx" ? 0.2 : 0.2 * kDeg;
    const RigParams knocked = ApplyDrift(stored_, {DriftCoordinateIndex(coordinate)}, amount);
    const CheckResult moved = CheckRig(stored, Photos(knocked, 3, 80));
    EXPECT_EQ(moved.verdict, Verdict::kDrifted) << coordinate;
    EXPECT_EQ(moved.named_group, "mirror2") << coordinate;
  }
}

// Too few matches to tell (60, under min_matches): unreferenced lips cannot tell a move from
// their bias (CheckTest.TooFewMatchesCannotTell), referenced ones can say it moved, never OK.
TEST_F(LipReferenceTest, FewMatchesTheReferencedLipsAloneMaySayDriftedNotOk) {
  RigParams stored = stored_;
  stored.calibration->lip_reference = LearnLipReference(RigModel(stored_), Photos(stored_, 6, 10), {});
  stored.calibration->lip_reference_sectors = CheckOptions{}.azimuth_bins;
  const ImageEvidence same = Simulate(stored_, 60, 0.1, 0.15, 90, Bias);
  const CheckResult unchanged = CheckRig(stored, {same});
  EXPECT_EQ(unchanged.verdict, Verdict::kCannotTell) << unchanged.reason;
  Eigen::VectorXd amount(1);
  amount[0] = 0.2;
  const RigParams knocked = ApplyDrift(stored_, {DriftCoordinateIndex("mirror2.tx")}, amount);
  const ImageEvidence moved = Simulate(knocked, 60, 0.1, 0.15, 90, Bias);
  const CheckResult referenced = CheckRig(stored, {moved});
  EXPECT_EQ(referenced.verdict, Verdict::kDrifted) << referenced.reason;
  EXPECT_NE(referenced.reason.find("few ring-to-ring matches"), std::string::npos)
      << referenced.reason;
  EXPECT_EQ(CheckRig(stored_, {moved}).verdict, Verdict::kCannotTell);
}

TEST_F(LipReferenceTest, AReferenceOfOtherSectorsIsNotUsed) {
  RigParams stored = stored_;
  stored.calibration->lip_reference = LearnLipReference(RigModel(stored_), Photos(stored_, 4, 10), {});
  stored.calibration->lip_reference_sectors = 24;
  EXPECT_GT(LipReference(stored, 24).size(), 0);
  EXPECT_TRUE(LipReference(stored, 36).empty());
  EXPECT_TRUE(LipReference(stored_, 24).empty());
}

}  // namespace
}  // namespace omni::health
