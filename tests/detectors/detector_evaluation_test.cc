// detectors/detector_evaluation.h and detect_session.h's lines on hand-made detections and truths
// whose counts and errors are known.
#include "detectors/detector_evaluation.h"

#include <gtest/gtest.h>

#include "detectors/detect_session.h"
#include "io/model_file.h"

namespace omni::detectors {
namespace {

CornerObservation Corner(int target, int id, Mirror mirror, double u, double v) {
  CornerObservation c;
  c.target = target;
  c.id = id;
  c.mirror = mirror;
  c.pixel = Eigen::Vector2d(u, v);
  return c;
}

TargetSpec Board(int rows, int cols) {
  TargetSpec t;
  t.type = TargetType::kChessboard;
  t.rows = rows;
  t.cols = cols;
  return t;
}

TEST(DetectorEvaluation, FoundWrongOffAndMissedCornersCounted) {
  // Four true corners of target 0 in ring 1 at 0.75 m from the axis, 10 px apart.
  std::vector<TruthCorner> truth(4);
  for (int i = 0; i < 4; ++i) {
    truth[i].target = 0;
    truth[i].id = i;
    truth[i].point_in_cam = Eigen::Vector3d(750, 0, 100);
    truth[i].pixel[0] = Eigen::Vector2d(100 + 10 * i, 50);
  }
  ImageObservations det;
  det.corners = {Corner(0, 0, Mirror::kOne, 100.1, 50),   // 0.1 px
                 Corner(0, 1, Mirror::kOne, 110, 50.6),   // right id, 0.6 px off
                 Corner(0, 3, Mirror::kOne, 120, 50)};    // id 2's place: wrong
  DetectorEvaluation evaluation({Board(2, 2)});
  std::string csv;
  const std::vector<std::string> lines =
      evaluation.AddImage("0001", det, {false, false, true}, truth, &csv);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0].rfind("0001: off: target 0 id 1 mirror 1", 0), 0u) << lines[0];
  EXPECT_EQ(lines[1].rfind("0001: wrong (guided): target 0 id 3 mirror 1", 0), 0u) << lines[1];
  EXPECT_EQ(lines[2], "0001: missed: target 0 ring 1 at 0.75 m: 2 of 4 visible corners found");
  // Two matched rows and two missed ones.
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4);
  const std::string tables = evaluation.Tables();
  // Ring 1 at 0.5-1 m: 4 visible, 2 found (50%), mean (0.1 + 0.6) / 2, one wrong.
  EXPECT_NE(tables.find("1      0.5-1 m           4        2    50.0%   0.3500   0.6000      1"),
            std::string::npos) << tables;
  EXPECT_NE(tables.find("1      chessboard        4        2    50.0%   0.3500   0.6000"),
            std::string::npos) << tables;
  // The guided corner was the wrong one.
  EXPECT_NE(tables.find("1      chessboard        0   0.0000   0.0000      1"), std::string::npos)
      << tables;
}

TEST(DetectorEvaluation, Percentile) {
  EXPECT_EQ(Percentile({}, 0.5), 0);
  EXPECT_EQ(Percentile({3, 1, 2}, 0.5), 2);
  EXPECT_EQ(Percentile({3, 1, 2}, 1.0), 3);
  EXPECT_EQ(Percentile({4, 1, 3, 2}, 0.5), 3);  // rank 1.5 rounds up
}

TEST(DetectSessionLines, ImageLineAndTargetSummary) {
  ImageReport r;
  r.index = 1;
  r.total = 3;
  r.file = "b.png";
  r.corners[0] = 2;
  r.corners[1] = 1;
  r.ms = 12.4;
  ImageObservations det;
  det.corners = {Corner(0, 0, Mirror::kOne, 0, 0), Corner(0, 1, Mirror::kOne, 0, 0),
                 Corner(1, 0, Mirror::kTwo, 0, 0)};
  det.lips.resize(5);
  EXPECT_EQ(ImageLine(r, det, false), "[2/3] b.png: 2 corners in ring 1, 1 in ring 2 (12 ms)");
  EXPECT_EQ(ImageLine(r, det, true),
            "[2/3] b.png: 2 corners in ring 1, 1 in ring 2, 5 lip edges (12 ms); target 0 2 / 0, "
            "target 1 0 / 1");
  Observations detections;
  detections.images = {det, ImageObservations()};
  EXPECT_EQ(TargetSummary({Board(2, 2), Board(3, 4), Board(5, 5)}, detections),
            "  target 0 (" + TargetName(Board(2, 2)) + "): in 1 of 2 photos, 2 corners in ring 1, 0 in ring 2\n"
            "  target 1 (" + TargetName(Board(3, 4)) + "): in 1 of 2 photos, 0 corners in ring 1, 1 in ring 2\n"
            "  target 2 (" + TargetName(Board(5, 5)) + "): in 0 of 2 photos, 0 corners in ring 1, 0 in ring 2: "
            "never found (check its rows/cols, size and first_id)\n");
}

// The run's report: each ring's views with the median of its measured blurs, the evaluation's
// tables, the time per image (mean and max); no lip line without lips.
TEST(DetectionRunReport, StatesViewsBlurAndTimes) {
  const RigParams rig = io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) +
                                          "/sample_configs/big_rig_misaligned.yaml");
  const DetectorContext ctx(rig, {Board(2, 2)});
  DetectionRun run;
  run.view_blur = {std::vector<double>{0.4, 0.5, 0.9}, std::vector<double>{1.2}};
  run.times_ms = {10, 30};
  run.cpu_ms = {8, 12};
  const DetectorEvaluation evaluation({Board(2, 2)});
  const std::string report = DetectionRunReport(run, ctx, evaluation, rig, rig, 42);
  EXPECT_EQ(report.rfind("views and layout built once in 42 ms\n", 0), 0u) << report;
  EXPECT_NE(report.find("measured blur sigma median 0.50 view px\n"), std::string::npos) << report;
  EXPECT_NE(report.find("measured blur sigma median 1.20 view px\n"), std::string::npos) << report;
  EXPECT_NE(report.find(evaluation.Tables()), std::string::npos);
  EXPECT_NE(report.find("image on one core: mean 20.0 ms, max 30.0 ms (2 images)\n"),
            std::string::npos) << report;
  EXPECT_NE(report.find("mean 10.0 ms, max 12.0 ms\n"), std::string::npos) << report;
  EXPECT_EQ(report.find("lip"), std::string::npos) << report;
}

}  // namespace
}  // namespace omni::detectors
