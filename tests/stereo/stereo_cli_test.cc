// `omnistereo triangulate`, `panorama` and `depth` through the real executable: the RMSE table
// from a fast-path truth file (noise-free pixels give the true corners), the CSV contract, and
// bad input (exit 2, one line, no output file).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <unistd.h>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/csv.h"
#include "io/model_file.h"
#include "model/central_mirror.h"
#include "tests/cli_test_util.h"

namespace omni {
namespace {

namespace fs = std::filesystem;
using testing::RunOmnistereo;

const std::string kSampleDir = std::string(OMNI_SOURCE_DIR) + "/sample_configs/";

class StereoCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("stereo_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

TEST_F(StereoCli, TriangulatesTruthPixelsAndPrintsTheRangeTable) {
  std::string err, out;
  ASSERT_EQ(RunOmnistereo("render --model=" + kSampleDir + "big_rig_misaligned.yaml --scene=" +
                              kSampleDir + "rmse_scene.yaml --no_render --out=" + Path("rmse"),
                          Path("err.txt"), &err),
            0)
      << err;
  // Noise-free truth pixels through the same model: every corner exact.
  ASSERT_EQ(RunOmnistereo("triangulate --model=" + kSampleDir + "big_rig_misaligned.yaml" +
                              " --truth=" + Path("rmse/truth.yaml") + " --out=" + Path("t.csv"),
                          Path("err.txt"), &err, Path("out.txt"), &out),
            0)
      << err;
  EXPECT_NE(out.find("range_m"), std::string::npos) << out;
  const std::vector<std::string> columns = {"x_mm", "y_mm", "z_mm", "cov_xx", "cov_zz", "gap_mm"};
  io::CsvReader csv(Path("t.csv"), columns);
  std::vector<double> row;
  int rows = 0;
  while (csv.ReadRow(&row)) {
    ++rows;
    EXPECT_GT(row[3], 0);            // covariance at sigma_px 1
    EXPECT_LT(row[5], 1e-6);         // the rays meet
  }
  EXPECT_EQ(rows, 480);  // 6 ranges x 4 boards x 20 corners, all seen in both rings
  // Six ranges, zero RMSE each.
  int zero_rows = 0;
  std::istringstream lines(out);
  std::string line;
  while (std::getline(lines, line)) {
    double range = 0, rmse = 1;
    if (std::sscanf(line.c_str(), "%lf %lf", &range, &rmse) == 2 && rmse < 1e-3) ++zero_rows;
  }
  EXPECT_EQ(zero_rows, 6) << out;
  // The paper's table beside it (bench/paper_triangulation_table.csv): each range its own row.
  ASSERT_EQ(RunOmnistereo("triangulate --model=" + kSampleDir + "big_rig_misaligned.yaml" +
                              " --truth=" + Path("rmse/truth.yaml") + " --out=" + Path("t.csv") +
                              " --reference_table=" + std::string(OMNI_SOURCE_DIR) +
                              "/bench/paper_triangulation_table.csv",
                          Path("err.txt"), &err, Path("out.txt"), &out),
            0)
      << err;
  const std::map<double, std::pair<double, double>> paper = {
      {0.25, {0.46, 0.31}}, {0.5, {1.20, 0.71}},    {1.0, {4.62, 2.55}},
      {2.0, {14.85, 9.06}}, {4.0, {57.67, 31.34}}, {8.0, {219.09, 129.92}}};
  int reference_rows = 0;
  std::istringstream with_reference(out);
  while (std::getline(with_reference, line)) {
    double range = 0, rmse = 0, sd = 0, ref_rmse = 0, ref_sd = 0;
    int points = 0;
    if (std::sscanf(line.c_str(), "%lf %lf %lf %d %lf %lf", &range, &rmse, &sd, &points,
                    &ref_rmse, &ref_sd) != 6) {
      continue;
    }
    const auto it = paper.lower_bound(0.9 * range);
    ASSERT_NE(it, paper.end()) << line;
    EXPECT_EQ(ref_rmse, it->second.first) << line;
    EXPECT_EQ(ref_sd, it->second.second) << line;
    ++reference_rows;
  }
  EXPECT_EQ(reference_rows, 6) << out;
}

// Without --sigma_px a calibrated model's measured corner noise per ring is the pixel sigma
// (residual RMS / sqrt 2 per axis; issue 38: the 1 px default gave sigmas ~10x the measured).
TEST_F(StereoCli, TriangulateDefaultsToTheModelsMeasuredNoise) {
  const std::string model = std::string(OMNI_SOURCE_DIR) + "/tests/model/data/calibrated_big_rig.yaml";
  std::string err, out;
  ASSERT_EQ(RunOmnistereo("render --model=" + model + " --scene=" + kSampleDir +
                              "rmse_scene.yaml --no_render --out=" + Path("noise"),
                          Path("err.txt"), &err),
            0)
      << err;
  ASSERT_EQ(RunOmnistereo("triangulate --model=" + model + " --truth=" + Path("noise/truth.yaml") +
                              " --out=" + Path("n.csv"),
                          Path("err.txt"), &err, Path("out.txt"), &out),
            0)
      << err;
  // 0.06834645964211683 / sqrt 2 and 0.08048952304286269 / sqrt 2 (the file's per_mirror_rms_px).
  EXPECT_NE(out.find("sigma_px 0.0483/0.0569, the model's measured corner noise"), std::string::npos)
      << out;
  ASSERT_EQ(RunOmnistereo("triangulate --model=" + model + " --truth=" + Path("noise/truth.yaml") +
                              " --sigma_px=1 --out=" + Path("n.csv"),
                          Path("err.txt"), &err, Path("out.txt"), &out),
            0)
      << err;
  EXPECT_NE(out.find("sigma_px 1/1)"), std::string::npos) << out;
}

// --frame mirror1: the points relative to mirror 1's body (its pose in the model file, applied
// here independently) and, with --truth, compared in the true rig's M1 (exact here: zero RMSE).
TEST_F(StereoCli, Mirror1FrameGivesThePointsInTheMirrorBody) {
  const std::string model = kSampleDir + "big_rig_misaligned.yaml";
  std::string err, out;
  ASSERT_EQ(RunOmnistereo("render --model=" + model + " --scene=" + kSampleDir +
                              "rmse_scene.yaml --no_render --out=" + Path("rmse"),
                          Path("err.txt"), &err),
            0)
      << err;
  for (const std::string frame : {"cam", "mirror1"}) {
    ASSERT_EQ(RunOmnistereo("triangulate --model=" + model + " --truth=" + Path("rmse/truth.yaml") +
                                " --frame=" + frame + " --out=" + Path(frame + ".csv"),
                            Path("err.txt"), &err, Path("out.txt"), &out),
              0)
        << err;
    int zero_rows = 0;
    std::istringstream lines(out);
    std::string line;
    while (std::getline(lines, line)) {
      double range = 0, rmse = 1;
      if (std::sscanf(line.c_str(), "%lf %lf", &range, &rmse) == 2 && rmse < 1e-3) ++zero_rows;
    }
    EXPECT_EQ(zero_rows, 6) << frame << "\n" << out;
  }
  const RigParams rig = io::ReadModelFile(model);
  const double rx = rig.mirror1_pose[kRx], ry = rig.mirror1_pose[kRy];
  const Eigen::Matrix3d cam_from_mirror1 =
      Eigen::AngleAxisd(std::hypot(rx, ry), Eigen::Vector3d(rx, ry, 0).normalized()).matrix();
  const Eigen::Vector3d mirror1_in_cam(rig.mirror1_pose[kTx], rig.mirror1_pose[kTy], rig.mirror1_pose[kTz]);
  io::CsvReader in_cam(Path("cam.csv"), {"x_mm", "y_mm", "z_mm"});
  io::CsvReader in_mirror1(Path("mirror1.csv"), {"x_mm", "y_mm", "z_mm"});
  std::vector<double> a, b;
  int rows = 0;
  double worst = 0;
  while (in_cam.ReadRow(&a) && in_mirror1.ReadRow(&b)) {
    const Eigen::Vector3d expected =
        cam_from_mirror1.transpose() * (Eigen::Vector3d(a[0], a[1], a[2]) - mirror1_in_cam);
    worst = std::max(worst, (expected - Eigen::Vector3d(b[0], b[1], b[2])).norm());
    ++rows;
  }
  EXPECT_EQ(rows, 480);
  EXPECT_LT(worst, 1e-6);
  // A frame the command does not know.
  EXPECT_EQ(RunOmnistereo("triangulate --model=" + model + " --truth=" + Path("rmse/truth.yaml") +
                              " --frame=world --out=" + Path("w.csv"),
                          Path("e"), &err),
            2);
  EXPECT_NE(err.find("--frame"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(Path("w.csv")));
}

TEST_F(StereoCli, BadInputFailsWithOneLineAndNoOutput) {
  std::string err;
  const std::string model = " --model=" + kSampleDir + "big_rig_misaligned.yaml";
  // No detections and no truth.
  EXPECT_EQ(RunOmnistereo("triangulate" + model + " --out=" + Path("t.csv"), Path("e"), &err), 2);
  EXPECT_NE(err.find("--detections"), std::string::npos) << err;
  // A truth file of the wrong format.
  { std::ofstream(Path("bad.yaml")) << "format: omnistereo-model/1\n"; }
  EXPECT_EQ(RunOmnistereo("triangulate" + model + " --truth=" + Path("bad.yaml") + " --out=" +
                              Path("t.csv"),
                          Path("e"), &err),
            2);
  EXPECT_NE(err.find("format"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(Path("t.csv")));
  // A reference table without its columns, or with a bad row: the file and line named, no output.
  ASSERT_EQ(RunOmnistereo("render" + model + " --scene=" + kSampleDir +
                              "rmse_scene.yaml --no_render --out=" + Path("noise_free"),
                          Path("e"), &err),
            0)
      << err;
  { std::ofstream(Path("ref.csv")) << "range_m,rmse_mm\n1,2\n"; }
  EXPECT_EQ(RunOmnistereo("triangulate" + model + " --truth=" + Path("noise_free/truth.yaml") +
                              " --reference_table=" + Path("ref.csv") + " --out=" + Path("t.csv"),
                          Path("e"), &err),
            2);
  EXPECT_NE(err.find("ref.csv: line 1: column 'sd_mm'"), std::string::npos) << err;
  { std::ofstream(Path("ref.csv")) << "range_m,rmse_mm,sd_mm\n1,2,3\n-1,2,3\n"; }
  EXPECT_EQ(RunOmnistereo("triangulate" + model + " --truth=" + Path("noise_free/truth.yaml") +
                              " --reference_table=" + Path("ref.csv") + " --out=" + Path("t.csv"),
                          Path("e"), &err),
            2);
  EXPECT_NE(err.find("ref.csv: line 3: expected range_m > 0"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(Path("t.csv")));
  // A bad method.
  EXPECT_EQ(RunOmnistereo("triangulate" + model + " --truth=" + Path("bad.yaml") +
                              " --method=best --out=" + Path("t.csv"),
                          Path("e"), &err),
            2);
  // depth / panorama: missing image, wrong image size, bad SGBM settings.
  EXPECT_EQ(RunOmnistereo("depth" + model + " --out=" + Path("d"), Path("e"), &err), 2);
  EXPECT_NE(err.find("--image"), std::string::npos) << err;
  cv::imwrite(Path("small.png"), cv::Mat(48, 64, CV_8UC3, cv::Scalar(90, 90, 90)));
  EXPECT_EQ(RunOmnistereo("panorama" + model + " --image=" + Path("small.png") + " --out=" +
                              Path("p"),
                          Path("e"), &err),
            2);
  EXPECT_NE(err.find("1280x960"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(Path("p/panorama1.png")));
  EXPECT_EQ(RunOmnistereo("depth" + model + " --image=" + Path("small.png") +
                              " --num_disparities=20 --out=" + Path("d"),
                          Path("e"), &err),
            2);
}

TEST_F(StereoCli, PanoramaAndDepthWriteTheirFiles) {
  // A flat grey image: valid input, panoramas of the right size, no matches (empty cloud).
  cv::imwrite(Path("grey.png"), cv::Mat(960, 1280, CV_8UC3, cv::Scalar(90, 90, 90)));
  std::string err, out;
  const std::string args = " --model=" + kSampleDir + "big_rig_ideal.yaml --image=" +
                           Path("grey.png") + " --panorama_width=360";
  ASSERT_EQ(RunOmnistereo("panorama" + args + " --out=" + Path("p"), Path("e"), &err), 0) << err;
  const cv::Mat p1 = cv::imread(Path("p/panorama1.png"));
  ASSERT_FALSE(p1.empty());
  EXPECT_EQ(p1.cols, 360);
  ASSERT_EQ(RunOmnistereo("depth" + args + " --out=" + Path("d"), Path("e"), &err), 0) << err;
  for (const char* f : {"panorama1.png", "panorama2.png", "disparity.png", "disparity16.png",
                        "cloud.ply"}) {
    EXPECT_TRUE(fs::exists(dir_ / "d" / f)) << f;
  }
}

// A single-mirror rig: `panorama` writes its one panorama; `depth` and `triangulate` need two
// rings and refuse it in one line naming the model file, exit 2, no output; `check` and `refine`
// read its rim, and on a model with no rim reference from calibration check cannot tell (exit 4)
// and says why, refine refuses in one line naming it (exit 2, nothing written).
TEST_F(StereoCli, SingleRigHasOnePanoramaAndNoStereo) {
  CentralMirror central;
  central.mirror = Conic<double>{20.0, -2.2};
  io::WriteModelFile(Path("single.yaml"),
                     MakeSingleRig(central.mirror, LensKind::kPerspective,
                                   central.CameraBelowVertexMm(), 30, 5,
                                   Pinhole<double>{800, 800, 640, 480, 0}, 1280, 960));
  cv::imwrite(Path("grey.png"), cv::Mat(960, 1280, CV_8UC3, cv::Scalar(90, 90, 90)));
  const std::string model = " --model=" + Path("single.yaml");
  const std::string image = " --image=" + Path("grey.png");
  std::string err, out;
  ASSERT_EQ(RunOmnistereo("panorama" + model + image + " --panorama_width=360 --out=" + Path("p"),
                          Path("e"), &err, Path("o"), &out),
            0)
      << err;
  EXPECT_EQ(cv::imread(Path("p/panorama1.png")).cols, 360);
  EXPECT_FALSE(fs::exists(Path("p/panorama2.png")));
  EXPECT_EQ(out.find("panorama2"), std::string::npos) << out;
  const std::string refused[] = {
      "depth" + model + image + " --out=" + Path("d"),
      "triangulate" + model + " --detections=" + Path("none.yaml") + " --out=" + Path("t.csv")};
  for (const std::string& command : refused) {
    EXPECT_EQ(RunOmnistereo(command, Path("e"), &err), 2) << command;
    EXPECT_NE(err.find(Path("single.yaml") + ": a single-mirror rig (rig: single) has one ring; "),
              std::string::npos)
        << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  }
  EXPECT_FALSE(fs::exists(Path("d/cloud.ply")) || fs::exists(Path("t.csv")) ||
               fs::exists(Path("r.yaml")));
  EXPECT_EQ(RunOmnistereo("check" + model + image, Path("e"), &err, Path("o"), &out), 4) << err;
  EXPECT_NE(out.find("CANNOT TELL"), std::string::npos) << out;
  EXPECT_NE(out.find("calibration.lip_reference"), std::string::npos) << out;
  EXPECT_EQ(RunOmnistereo("refine" + model + image + " --out=" + Path("r.yaml"), Path("e"), &err),
            2);
  EXPECT_NE(err.find("calibration.lip_reference"), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_FALSE(fs::exists(Path("r.yaml")));
}

// `depth --images`: one set-up for a glob of frames, DIR/<name>.ply per frame, the same cloud as
// `depth --image` of that frame (nothing carried from one frame to the next); bad frames and
// flags end in one line naming the file or flag, exit 2, nothing half-written.
TEST_F(StereoCli, DepthOfFramesWritesACloudPerFrame) {
  fs::create_directories(dir_ / "frames");
  for (int seed : {1, 2}) {  // blurred noise: SGBM finds matches
    cv::Mat image(960, 1280, CV_8UC3);
    cv::theRNG().state = seed;
    cv::randu(image, 0, 255);
    cv::GaussianBlur(image, image, cv::Size(0, 0), 2.0);
    cv::imwrite(Path("frames/f" + std::to_string(seed) + ".png"), image);
  }
  const std::string model = " --model=" + kSampleDir + "big_rig_ideal.yaml --panorama_width=360";
  std::string err, out;
  ASSERT_EQ(RunOmnistereo("depth" + model + " --images='" + Path("frames") + "/*.png' --out=" +
                              Path("d"),
                          Path("e"), &err, Path("o"), &out),
            0)
      << err;
  EXPECT_NE(out.find("2 frames"), std::string::npos) << out;
  EXPECT_NE(out.find("frames/s"), std::string::npos) << out;
  for (const std::string name : {"f1", "f2"}) {
    ASSERT_EQ(RunOmnistereo("depth" + model + " --image=" + Path("frames/" + name + ".png") +
                                " --out=" + Path("single_" + name),
                            Path("e"), &err),
              0)
        << err;
    const std::string cloud = testing::ReadText(dir_ / ("single_" + name) / "cloud.ply");
    EXPECT_GT(cloud.size(), 1000u) << name;  // some matches
    EXPECT_EQ(testing::ReadText(dir_ / "d" / (name + ".ply")), cloud) << name;
  }
  const std::string f1 = testing::ReadText(dir_ / "d" / "f1.ply");
  // The error: one line, the last (the frames before it print their progress lines).
  auto only_line = [](const std::string& e) {
    const size_t at = e.find("omnistereo depth: ");
    return at != std::string::npos && e.find('\n', at) == e.size() - 1 &&
           e.find("omnistereo depth: ", at + 1) == std::string::npos;
  };
  auto no_temporaries = [&](const std::string& folder) {
    for (const auto& entry : fs::directory_iterator(dir_ / folder)) {
      if (entry.path().filename().string().rfind(".tmp", 0) == 0) return false;
    }
    return true;
  };

  // A frame that is no image, between two good ones: skipped with a warning naming it; f1 and f2
  // written as without it.
  { std::ofstream(Path("frames/f1b.png")) << "not an image"; }
  EXPECT_EQ(RunOmnistereo("depth" + model + " --images='" + Path("frames") + "/*.png' --out=" +
                              Path("bad"),
                          Path("e"), &err, Path("o"), &out),
            0)
      << err;
  EXPECT_NE(err.find("warning: " + Path("frames/f1b.png") + ": expected a readable image; skipped"),
            std::string::npos)
      << err;
  EXPECT_NE(out.find("2 frames (1 skipped)"), std::string::npos) << out;
  EXPECT_EQ(testing::ReadText(dir_ / "bad" / "f1.ply"), f1);
  EXPECT_TRUE(fs::exists(dir_ / "bad" / "f2.ply"));
  EXPECT_FALSE(fs::exists(dir_ / "bad" / "f1b.ply"));
  EXPECT_TRUE(no_temporaries("bad"));

  // Frames of another size, or no image at all: none usable, one line naming the first, nothing
  // written.
  cv::imwrite(Path("frames/f3.png"), cv::Mat(48, 64, CV_8UC3, cv::Scalar(90, 90, 90)));
  EXPECT_EQ(RunOmnistereo("depth" + model + " --images=" + Path("frames/f3.png") + "," +
                              Path("frames/f1b.png") + " --out=" + Path("size"),
                          Path("e"), &err),
            2);
  EXPECT_NE(err.find("none of the 2 frames could be used (the first: " + Path("frames/f3.png") +
                     ": expected the model's image size 1280x960, got 64x48)"),
            std::string::npos)
      << err;
  EXPECT_TRUE(only_line(err)) << err;
  EXPECT_FALSE(fs::exists(dir_ / "size" / "f3.ply"));
  EXPECT_TRUE(no_temporaries("size"));
  fs::remove(Path("frames/f1b.png"));
  fs::remove(Path("frames/f3.png"));

  // Flags: a glob matching nothing, two frames of one name, --image with --images.
  EXPECT_EQ(RunOmnistereo("depth" + model + " --images='" + Path("none") + "/*.png' --out=" +
                              Path("x"),
                          Path("e"), &err),
            2);
  EXPECT_NE(err.find("--images: no file matches"), std::string::npos) << err;
  fs::create_directories(dir_ / "other");
  fs::copy_file(Path("frames/f1.png"), Path("other/f1.png"));
  EXPECT_EQ(RunOmnistereo("depth" + model + " --images=" + Path("frames/f1.png") + "," +
                              Path("other/f1.png") + " --out=" + Path("x"),
                          Path("e"), &err),
            2);
  EXPECT_NE(err.find("would both write f1.ply"), std::string::npos) << err;
  EXPECT_EQ(RunOmnistereo("depth" + model + " --image=" + Path("frames/f1.png") + " --images=" +
                              Path("frames/f2.png") + " --out=" + Path("x"),
                          Path("e"), &err),
            2);
  EXPECT_NE(err.find("--image, --images: expected one of them"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir_ / "x"));
}

}  // namespace
}  // namespace omni
