// A model file's measured profile (`profile_from:`, io/measured_profile.h): the scan read relative
// to the model file and fitted to the mirror's terms (the generating terms come back: an exact
// scan to rounding, a noisy one within the fit's sigmas, whose covariance is the one the accuracy
// states); written models carry the coefficients, not the scan; each bad input is refused with
// one line naming the model file and key or the scan file and line.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <sstream>

#include <Eigen/Dense>

#include "io/model_file.h"
#include "io_test_util.h"
#include "model/rig_model.h"

namespace omni::io {
namespace {

using omni::testing::ReadText;
using omni::testing::ScratchDir;
using omni::testing::WriteText;

const std::string kExamplePath = std::string(OMNI_TEST_DATA_DIR) + "/model_example.yaml";

// The example model with `extra1` after mirror 1's lip line and `extra2` after mirror 2's.
std::string ModelText(const std::string& extra1, const std::string& extra2) {
  std::string text = ReadText(kExamplePath);
  for (const auto& [lip, extra] : {std::pair<std::string, std::string>{"  lip: {color: blue", extra1},
                                   std::pair<std::string, std::string>{"  lip: {color: red", extra2}}) {
    const size_t at = text.find('\n', text.find(lip)) + 1;
    text.insert(at, extra);
  }
  return text;
}

struct Line {
  double theta_deg;
  double r_from, r_to, step;
};

// Scan rows of the sag `coeffs` (over radii r_min..r_max) plus a piston and N(0, noise^2).
std::string ScanText(const std::array<double, kProfileTerms>& coeffs, double r_min, double r_max,
                     const std::vector<Line>& lines, double piston, double noise, unsigned seed) {
  ProfileShape shape;
  shape.present = true;
  shape.r_min = r_min;
  shape.r_max = r_max;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, noise);
  std::ostringstream text;
  text.precision(17);
  text << "theta_deg,r_mm,sag_mm\n";
  for (const Line& l : lines) {
    for (double r = l.r_from; r <= l.r_to + 1e-9; r += l.step) {
      const double t = l.theta_deg * M_PI / 180;
      const double sag =
          ProfileSag(coeffs.data(), shape, r * std::cos(t), r * std::sin(t), false).z;
      text << l.theta_deg << "," << r << "," << sag + piston + (noise > 0 ? n(rng) : 0) << "\n";
    }
  }
  return text.str();
}

const std::array<double, kProfileTerms> kTerms1 = {0.004, -0.001, 0.0005, 0.0002, 0, 0};
const std::array<double, kProfileTerms> kTerms2 = {-0.003, 0.0008, 0, -0.0003, 0.0006, -0.0004};

// Mirror 1 (radii r_ref 17.226 .. r_sys 37): one scan line, from 17 mm (its first point, under
// the reflex disc, not fitted). Mirror 2 (r_cam 7 .. 37): lines at 0, 60 and 120 deg.
void WriteScans(const ScratchDir& dir, double noise) {
  std::filesystem::create_directories(dir / "scans");
  WriteText(dir / "scans/m1.csv",
            ScanText(kTerms1, 17.226, 37, {{0, 17, 37, 0.25}}, 0.002, noise, 1));
  WriteText(dir / "scans/m2.csv",
            ScanText(kTerms2, 7, 37, {{0, 7, 37, 0.5}, {60, 7.25, 36.75, 0.5}, {120, 7, 37, 0.5}}, -0.001, noise, 2));
}

const char kFrom1[] = "  profile_from: scans/m1.csv\n  profile_accuracy_mm: 0.001\n";
const char kFrom2[] = "  profile_from: scans/m2.csv\n  profile_accuracy_mm: 0.001\n";

TEST(MeasuredProfile, AnExactScanGivesItsTermsAndThePiston) {
  ScratchDir dir;
  WriteScans(dir, 0);
  WriteText(dir / "model.yaml", ModelText(kFrom1, kFrom2));
  const RigParams rig = ReadModelFile(dir / "model.yaml");
  ASSERT_TRUE(rig.profile1.present && rig.profile2.present);
  EXPECT_DOUBLE_EQ(rig.profile1.r_min, 17.226);
  EXPECT_DOUBLE_EQ(rig.profile2.r_min, 7);
  for (int k = 0; k < kProfileTerms; ++k) {
    EXPECT_NEAR(rig.mirror1_profile[k], kTerms1[k], 1e-12) << k;
    EXPECT_NEAR(rig.mirror2_profile[k], kTerms2[k], 1e-12) << k;
  }
  ASSERT_TRUE(rig.measured_profile[0] && rig.measured_profile[1]);
  const MeasuredProfile& m1 = *rig.measured_profile[0];
  EXPECT_EQ(m1.scan_file, "scans/m1.csv");
  EXPECT_DOUBLE_EQ(m1.accuracy_mm, 0.001);
  EXPECT_EQ(m1.scan.size(), 81u);
  EXPECT_EQ(m1.fit.points, 80);  // r = 17 lies under the reflex disc
  EXPECT_NEAR(m1.fit.piston_mm, 0.002, 1e-12);
  EXPECT_LT(m1.fit.residual_pv_mm, 1e-12);
  // One scan line: the astigmatism is not measured (the machining tolerance stays its prior).
  EXPECT_FALSE(m1.fit.measured[4] || m1.fit.measured[5]);
  EXPECT_TRUE(rig.measured_profile[1]->fit.measured[4] && rig.measured_profile[1]->fit.measured[5]);
  EXPECT_NEAR(rig.measured_profile[1]->fit.piston_mm, -0.001, 1e-12);
  // The rig projects through the measured surface: a point seen by both rings moves when the
  // profile is dropped.
  RigParams exact = rig;
  exact.profile1.present = exact.profile2.present = false;
  const Eigen::Vector3d point(900, 300, 200);
  for (Mirror m : {Mirror::kOne, Mirror::kTwo}) {
    const auto a = RigModel(rig).Project(point, m);
    const auto b = RigModel(exact).Project(point, m);
    ASSERT_TRUE(a && b);
    EXPECT_GT((*a - *b).norm(), 0.01);
  }
}

// The fit's covariance is what the stated accuracy gives: over noisy scans drawn with that
// accuracy the terms spread as their sigmas say (an oracle independent of the fit's algebra).
TEST(MeasuredProfile, NoisyScansSpreadAsTheStatedAccuracySays) {
  const int runs = 200;
  Eigen::Matrix<double, kProfileTerms, 1> sum2 = Eigen::Matrix<double, kProfileTerms, 1>::Zero();
  std::array<double, kProfileTerms> sigma{};
  for (int run = 0; run < runs; ++run) {
    ScratchDir dir;
    std::filesystem::create_directories(dir / "scans");
    WriteText(dir / "scans/m2.csv",
              ScanText(kTerms2, 7, 37, {{0, 7, 37, 0.5}, {60, 7.25, 36.75, 0.5}, {120, 7, 37, 0.5}}, 0, 0.001, 100 + run));
    WriteText(dir / "model.yaml", ModelText("", kFrom2));
    const RigParams rig = ReadModelFile(dir / "model.yaml");
    sigma = rig.measured_profile[1]->fit.Sigma();
    for (int k = 0; k < kProfileTerms; ++k) {
      const double e = rig.mirror2_profile[k] - kTerms2[k];
      sum2[k] += e * e;
    }
  }
  for (int k = 0; k < kProfileTerms; ++k) {
    const double spread = std::sqrt(sum2[k] / runs);
    // 200 runs: the spread's own relative sigma is 1/sqrt(400) = 5%; 20% is 4 of them.
    EXPECT_NEAR(spread / sigma[k], 1.0, 0.2) << "term " << k << ": spread " << spread
                                              << " sigma " << sigma[k];
  }
}

// A written model carries the coefficients and the fit (profile_measured:), not the scan: it
// reads back without the scan file, with the same fit, covariance and accuracy; its own
// coefficients (a calibrated model's values) are kept beside the fit.
TEST(MeasuredProfile, AWrittenModelCarriesTheFitNotTheScan) {
  ScratchDir dir;
  WriteScans(dir, 0.001);
  WriteText(dir / "model.yaml", ModelText(kFrom1, kFrom2));
  RigParams rig = ReadModelFile(dir / "model.yaml");
  rig.mirror1_profile[0] += 0.0003;  // as a calibration moves it
  std::filesystem::create_directories(dir / "out");
  WriteModelFile(dir / "out/model.yaml", rig);
  std::filesystem::remove_all(dir / "scans");
  const std::string text = ReadText(dir / "out/model.yaml");
  EXPECT_EQ(text.find("profile_from"), std::string::npos);
  const RigParams back = ReadModelFile(dir / "out/model.yaml");
  EXPECT_EQ(back.mirror1_profile, rig.mirror1_profile);
  EXPECT_EQ(back.mirror2_profile, rig.mirror2_profile);
  for (int m = 0; m < 2; ++m) {
    ASSERT_TRUE(back.measured_profile[m]) << m;
    const MeasuredProfile& a = *rig.measured_profile[m];
    const MeasuredProfile& b = *back.measured_profile[m];
    EXPECT_EQ(b.scan_file, a.scan_file);
    EXPECT_EQ(b.accuracy_mm, a.accuracy_mm);
    EXPECT_TRUE(b.scan.empty());
    EXPECT_EQ(b.fit.coeffs, a.fit.coeffs);
    EXPECT_EQ(b.fit.measured, a.fit.measured);
    EXPECT_EQ(b.fit.covariance, a.fit.covariance);
    EXPECT_EQ(b.fit.points, a.fit.points);
    EXPECT_EQ(b.fit.piston_mm, a.fit.piston_mm);
    EXPECT_EQ(b.fit.residual_pv_mm, a.fit.residual_pv_mm);
    EXPECT_EQ(b.fit.residual_rms_mm, a.fit.residual_rms_mm);
  }
  EXPECT_FALSE(rig.measured_profile[0]->fit.measured[4]);  // one line: no astigmatism measured
  // The text is the model's own: written again, byte for byte the same.
  WriteModelFile(dir / "out/again.yaml", back);
  EXPECT_EQ(ReadText(dir / "out/again.yaml"), text);
}

// The message reading `model` (mirror 1's extra lines, mirror 2's) gives, with the scans
// written as `scan1`, `scan2` (if not empty); "" if it reads.
std::string ErrorOf(const std::string& extra1, const std::string& extra2,
                    const std::string& scan1 = "", const std::string& scan2 = "",
                    const std::string& kind = "noncentral") {
  ScratchDir dir;
  WriteScans(dir, 0);
  if (!scan1.empty()) WriteText(dir / "scans/m1.csv", scan1);
  if (!scan2.empty()) WriteText(dir / "scans/m2.csv", scan2);
  std::string text = ModelText(extra1, extra2);
  text.replace(text.find("kind: noncentral"), 16, "kind: " + kind);
  WriteText(dir / "model.yaml", text);
  try {
    ReadModelFile(dir / "model.yaml");
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    // Strip the scratch folder.
    const size_t at = message.find(dir.path());
    return at == std::string::npos ? message
                                   : message.substr(0, at) + message.substr(at + dir.path().size() + 1);
  }
  return "";
}

void ExpectStarts(const std::string& message, const std::string& start) {
  EXPECT_EQ(message.substr(0, start.size()), start) << message;
}

TEST(MeasuredProfile, RefusesBadModelKeysNamingTheKey) {
  ExpectStarts(ErrorOf("  profile_from: scans/m1.csv\n", ""),
               "model.yaml: mirror1.profile_accuracy_mm: expected a number, got nothing");
  ExpectStarts(ErrorOf("  profile_from: scans/m1.csv\n  profile_accuracy_mm: 0\n", ""),
               "model.yaml: mirror1.profile_accuracy_mm: expected a number > 0, got '0'");
  ExpectStarts(ErrorOf("", "  profile_accuracy_mm: 0.001\n"),
               "model.yaml: mirror2.profile_accuracy_mm: only beside profile_from");
  ExpectStarts(ErrorOf(std::string(kFrom1) + "  profile_max_gap_mm: -1\n", ""),
               "model.yaml: mirror1.profile_max_gap_mm: expected a number > 0");
  ExpectStarts(ErrorOf(std::string(kFrom1) + "  profile: {sag_p1: 0.001}\n", ""),
               "model.yaml: mirror1.profile.sag_p1: no coefficient beside profile_from");
  ExpectStarts(ErrorOf(kFrom1, "", "", "", "ideal"),
               "model.yaml: mirror1.profile_from: no measured profile because kind is ideal");
  ExpectStarts(ErrorOf("  profile_from: scans/none.csv\n  profile_accuracy_mm: 0.001\n", ""),
               "scans/none.csv");
  ExpectStarts(ErrorOf(std::string(kFrom1) + "  profile_measured: {}\n", ""),
               "model.yaml: mirror1.profile_measured: either profile_from");
  ExpectStarts(ErrorOf("  profile_measured: {scan: a.csv}\n", ""),
               "model.yaml: mirror1.profile: a profile map beside profile_measured");
}

TEST(MeasuredProfile, RefusesBadScansNamingTheFileAndLine) {
  // Beyond the rim (r_sys 37).
  ExpectStarts(ErrorOf(kFrom1, "", ScanText(kTerms1, 17.226, 37, {{0, 17, 38, 0.5}}, 0, 0, 1)),
               "scans/m1.csv: line 43: r_mm 37.5: expected a radius on the mirror, 0..37 mm");
  // Inside mirror 2's hole (r_cam 7).
  ExpectStarts(ErrorOf("", kFrom2, "", ScanText(kTerms2, 7, 37, {{0, 5, 37, 0.5}}, 0, 0, 1)),
               "scans/m2.csv: line 2: r_mm 5: expected a radius on the mirror, 7..37 mm (inside "
               "the hole)");
  // Unsorted.
  ExpectStarts(ErrorOf(kFrom1, "", "r_mm,sag_mm\n17,0\n18,0\n17.5,0\n"),
               "scans/m1.csv: line 4: r_mm 17.5 after 18: expected increasing radii");
  // A gap wider than the stated bound (points every 0.5 mm, 0.4 mm allowed).
  ExpectStarts(ErrorOf(std::string(kFrom1) + "  profile_max_gap_mm: 0.4\n", "",
                       ScanText(kTerms1, 17.226, 37, {{0, 17, 37, 0.5}}, 0, 0, 1)),
               "scans/m1.csv: line 2: the scan line at 0 deg has no point between r 17.5 and 18 "
               "mm: expected gaps of at most 0.4 mm");
  // ... and the default, a tenth of the radii (1.98 mm): one missing stretch of 3 mm.
  std::string gappy = "r_mm,sag_mm\n";
  for (double r = 17; r <= 37; r += 0.5) {
    if (r < 25 || r > 28) gappy += std::to_string(r) + ",0\n";
  }
  ExpectStarts(ErrorOf(kFrom1, "", gappy),
               "scans/m1.csv: line 2: the scan line at 0 deg has no point between r 24.5 and "
               "28.5 mm");
  // A sag beyond the profile's bound (0.1 mm): microns written as mm.
  ExpectStarts(ErrorOf(kFrom1, "", ScanText({2.0, 0, 0, 0, 0, 0}, 17.226, 37, {{0, 17, 37, 0.5}}, 0, 0, 1)),
               "scans/m1.csv: line 2: sag_mm -2.029: expected a departure from the conic of at most "
               "0.1 mm");
  // Within the bound point by point, but the fitted terms too steep for a smooth correction.
  ExpectStarts(ErrorOf(kFrom1, "", ScanText({0, 0, 0, 0.03, 0, 0}, 17.226, 37, {{0, 17, 37, 0.25}}, 0, 0, 1)),
               "model.yaml: mirror1.profile_from: a fitted profile with slopes of at most 0.02 rad");
}

}  // namespace
}  // namespace omni::io
