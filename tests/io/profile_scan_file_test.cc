// Reading a measured profile scan (io/profile_scan_file.h): a good scan with several azimuths
// reads every row; each kind of bad scan is refused with one message naming the file, the line
// and what was expected.
#include "io/profile_scan_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "io/file_util.h"
#include "io_test_util.h"

namespace omni::io {
namespace {

using omni::testing::ScratchDir;
using omni::testing::WriteText;

ProfileShape Shape() {
  ProfileShape shape;
  shape.present = true;
  shape.r_min = 17;
  shape.r_max = 37;
  return shape;
}

ProfileScanLimits Limits() {
  ProfileScanLimits limits;
  limits.rim_mm = 40;
  return limits;
}

// Lines at the given azimuths, radii 15..39 mm every 1 mm, a small sag.
std::string ScanText(std::initializer_list<double> azimuths) {
  std::ostringstream text;
  text.precision(17);
  text << "theta_deg,r_mm,sag_mm\n";
  for (double deg : azimuths) {
    for (int r = 15; r <= 39; ++r) text << deg << "," << r << "," << 1e-4 * std::sin(r) << "\n";
  }
  return text.str();
}

// The message of the InputError that reading `text` throws ("" if none).
std::string ErrorOf(const std::string& text, const ProfileScanLimits& limits = Limits()) {
  ScratchDir dir;
  WriteText(dir / "scan.csv", text);
  try {
    ReadProfileScan(dir / "scan.csv", Shape(), limits);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ProfileScanFile, ReadsEveryRowOfEveryLine) {
  ScratchDir dir;
  WriteText(dir / "scan.csv", ScanText({0, 90}));
  const auto scan = ReadProfileScan(dir / "scan.csv", Shape(), Limits());
  ASSERT_EQ(scan.size(), 50u);
  EXPECT_DOUBLE_EQ(scan[25].r_mm, 15);
  EXPECT_DOUBLE_EQ(scan[25].theta_rad, M_PI / 2);
  EXPECT_DOUBLE_EQ(scan[26].sag_mm, 1e-4 * std::sin(16));
  // Without theta_deg: one line at azimuth 0.
  WriteText(dir / "line.csv", "r_mm,sag_mm\n" + [] {
    std::string rows;
    for (int r = 17; r <= 37; ++r) rows += std::to_string(r) + ",0.0001\n";
    return rows;
  }());
  EXPECT_EQ(ReadProfileScan(dir / "line.csv", Shape(), Limits()).size(), 21u);
}

TEST(ProfileScanFile, RefusesBadScansNamingTheLine) {
  EXPECT_NE(ErrorOf("r_mm,height\n1,2\n").find("column 'sag_mm'"), std::string::npos);
  // Unsorted within a line (line 4: 20 after 21).
  std::string e = ErrorOf("r_mm,sag_mm\n19,0\n21,0\n20,0\n");
  EXPECT_NE(e.find("scan.csv: line 4: r_mm 20 after 21: expected increasing radii"),
            std::string::npos) << e;
  // Beyond the rim, and negative.
  e = ErrorOf("r_mm,sag_mm\n30,0\n41,0\n");
  EXPECT_NE(e.find("line 3: r_mm 41: expected a radius on the mirror, 0..40 mm"),
            std::string::npos) << e;
  EXPECT_NE(ErrorOf("r_mm,sag_mm\n-1,0\n").find("line 2: r_mm -1"), std::string::npos);
  // A sag in microns written as mm.
  e = ErrorOf("r_mm,sag_mm\n20,0\n21,3\n");
  EXPECT_NE(e.find("line 3: sag_mm 3: expected a departure from the conic of at most 0.5 mm"),
            std::string::npos) << e;
  // A gap: the 90 deg line has no point between 20 and 30 mm (the bound: 2 mm).
  std::string text = ScanText({0});
  text += "90,17,0\n90,18,0\n90,19,0\n90,20,0\n90,30,0\n90,31,0\n90,32,0\n90,33,0\n90,34,0\n"
          "90,35,0\n90,36,0\n90,37,0\n";
  e = ErrorOf(text);
  EXPECT_NE(e.find("line 27: the scan line at 90 deg has no point between r 20 and 30 mm: "
                   "expected gaps of at most 2 mm"),
            std::string::npos) << e;
  // A gap at the end of the profile's radii (the line stops at 30 mm).
  e = ErrorOf("r_mm,sag_mm\n17,0\n18,0\n19,0\n20,0\n21,0\n22,0\n23,0\n24,0\n25,0\n26,0\n27,0\n"
              "28,0\n29,0\n30,0\n");
  EXPECT_NE(e.find("no point between r 30 and 37 mm"), std::string::npos) << e;
  // Too few points inside the profile's radii.
  e = ErrorOf("r_mm,sag_mm\n1,0\n2,0\n20,0\n");
  EXPECT_NE(e.find("1 points inside the profile's radii 17..37 mm: expected at least 10"),
            std::string::npos) << e;
  // A theta that is no number.
  e = ErrorOf("r_mm,sag_mm,theta_deg\n20,0,east\n");
  EXPECT_NE(e.find("line 2: column 'theta_deg': expected a number (deg), got 'east'"),
            std::string::npos) << e;
}

}  // namespace
}  // namespace omni::io
