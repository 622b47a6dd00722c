// The report's plots as scripts: bars read against 0 with the largest in view, targets by name,
// and the projection-uncertainty maps on one colour scale with its bar.
#include "report/figures.h"

#include <algorithm>
#include <cstdio>
#include <regex>
#include <string>

#include <gtest/gtest.h>

namespace omni::report {
namespace {

double YMax(const std::string& script) {
  std::smatch m;
  const std::regex range("set yrange \\[0:([0-9.eE+-]+)\\]");
  return std::regex_search(script, m, range) ? std::stod(m[1]) : -1;
}

TEST(Figures, BarsStartAtZeroHoldTheLargestAndNameTheTargets) {
  const std::vector<std::vector<double>> rows = {{0, 0.031, 0.052}, {1, 0.030, 0.118}};
  const std::string script =
      RmsBarsScript("target", {TargetName(ChessboardSpec(5, 6, 35)), "kalibr_aprilgrid 2x3 ids 50-55"}, rows);
  EXPECT_GE(YMax(script), 0.118) << script;
  EXPECT_LT(YMax(script), 0.2) << script;
  EXPECT_NE(script.find("\"chessboard 5x6\""), std::string::npos) << script;
  EXPECT_NE(script.find("\"kalibr_aprilgrid 2x3 ids 50-55\""), std::string::npos) << script;
  EXPECT_NE(script.find("xtic(stringcolumn(4))"), std::string::npos) << script;
  // All bars 0: still a range that starts at 0.
  EXPECT_GT(YMax(RmsBarsScript("image", {"0"}, {{0, 0, 0}})), 0);
  // Two names fit under their bars; the field session's five (up to 30 characters, ~180 px of
  // text under 160 px of bars each) are turned so that neighbours do not overlap.
  EXPECT_EQ(script.find("rotate"), std::string::npos) << script;
  std::vector<std::vector<double>> five;
  for (int i = 0; i < 5; ++i) five.push_back({double(i), 0.1, 0.1});
  const std::string turned = RmsBarsScript(
      "target", {"kalibr_aprilgrid 2x3 ids 70-75", "chessboard 5x7", "kalibr_aprilgrid 3x5 ids 80-94",
                 "chessboard 6x8", "chessboard 7x10"}, five);
  EXPECT_NE(turned.find("set xtics rotate by 25 right"), std::string::npos) << turned;
}

TEST(Figures, TargetNamesTellTheSessionsTargetsApart) {
  TargetSpec grid;
  grid.type = TargetType::kKalibrAprilGrid;
  grid.rows = 2;
  grid.cols = 3;
  grid.first_id = 50;
  EXPECT_EQ(TargetName(grid), "kalibr_aprilgrid 2x3 ids 50-55");
  EXPECT_EQ(TargetName(ChessboardSpec(5, 6, 35)), "chessboard 5x6");
}

TEST(Figures, UncertaintyMapsShareOneColourScaleWithABar) {
  calib::PointUncertainty p;
  p.point_in_cam = Eigen::Vector3d(1000, 0, 100);
  p.in_mirror1_px[0] = 0.05;
  p.in_mirror1_px[1] = 0.21;
  const std::vector<calib::PointUncertainty> near = {p};
  p.in_mirror1_px[0] = 0.11;
  p.in_mirror1_px[1] = 0.43;
  const std::vector<calib::PointUncertainty> far = {p};
  const double top = std::max(LargestUncertaintyPx(near), LargestUncertaintyPx(far));
  EXPECT_DOUBLE_EQ(top, 0.43);
  for (const auto* map : {&near, &far}) {
    const std::string script = UncertaintyMapScript(*map, 1000, top);
    EXPECT_NE(script.find("set cbrange [0:0.43]"), std::string::npos) << script;
    // The bar: hidden for ring 1, drawn for ring 2 (the same scale).
    const auto hidden = script.find("\nunset colorbox"), shown = script.find("\nset colorbox");
    ASSERT_NE(shown, std::string::npos) << script;
    EXPECT_LT(hidden, script.find("ring 1 (mirror 1)"));
    EXPECT_LT(shown, script.find("ring 2 (mirror 2)"));
    EXPECT_GT(shown, script.find("ring 1 (mirror 1)"));
  }
}

}  // namespace
}  // namespace omni::report
