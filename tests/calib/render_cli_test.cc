// `omnistereo render` end to end on a small frame: the fast path (--no_render) writes the same
// ground truth as a real render, the truth agrees with RigModel::Project, bad input fails cleanly.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <yaml-cpp/yaml.h>

#include "model/io/model_file.h"
#include "tests/cli_test_util.h"
#include "model/rig_model.h"

namespace omni {
namespace {

namespace fs = std::filesystem;

// ctest runs tests as parallel processes: every test gets its own folder.
std::string TestDir() {
  return fs::temp_directory_path() /
         (std::string("omni_render_cli_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
}

int RunCli(const std::string& args, std::string* err) {
  return testing::RunOmnistereo(args, TestDir() + ".err", err);
}

class RenderCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = TestDir();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // The misaligned big rig at a quarter of the resolution (fx 1450/4, 320x240).
    RigParams rig = MakeIdealRig(DesignParams{123.488, 241.803, 5.7319, 9.7443, 233.684, 37.0},
                                 7.0, Pinhole<double>{363.1, 362.8, 160.6, 119.2, 0}, 320, 240);
    rig.kind = ModelKind::kNoncentral;
    rig.mirror1_pose = {0.003, -0.005, 0.3, -0.2, 0.4};
    rig.mirror2_pose = {-0.004, 0.002, -0.25, 0.35, -0.3};
    rig.reflex = {0.004, -0.003, 0.15};
    rig.distortion = {-0.01, 0.0, 0.0002, 0.0, 0.0};
    io::WriteModelFile(dir_ + "/model.yaml", rig);
    std::ofstream(dir_ + "/scene.yaml")
        << "format: omnistereo-scene/1\n"
        << "render: {antialias: false, noise_sigma: 0}\n"
        << "targets: [{type: chessboard, rows: 4, cols: 5, square: 60.0}]\n"
        << "random: {images: 1, targets: [2, 2], range: [500, 900], seed: 3}\n";
  }
  std::string dir_;
};

TEST_F(RenderCli, FastPathEqualsRenderedTruthAndTruthEqualsProject) {
  std::string err;
  ASSERT_EQ(RunCli("render --model " + dir_ + "/model.yaml --scene " + dir_ +
                    "/scene.yaml --no_render --out " + dir_ + "/fast", &err), 0) << err;
  ASSERT_EQ(RunCli("render --model " + dir_ + "/model.yaml --scene " + dir_ + "/scene.yaml --out " +
                    dir_ + "/full", &err), 0) << err;
  EXPECT_EQ(testing::ReadText(dir_ + "/fast/truth.yaml"), testing::ReadText(dir_ + "/full/truth.yaml"));
  const cv::Mat img = cv::imread(dir_ + "/full/0001.png");
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 320);
  EXPECT_EQ(img.rows, 240);
  EXPECT_FALSE(fs::exists(dir_ + "/fast/0001.png"));

  const RigModel model(io::ReadModelFile(dir_ + "/full/model.yaml"));
  const YAML::Node truth = YAML::LoadFile(dir_ + "/full/truth.yaml");
  ASSERT_EQ(truth["format"].as<std::string>(), "omnistereo-truth/1");
  int seen[2] = {0, 0};
  for (const auto& c : truth["images"][0]["corners"]) {
    const Eigen::Vector3d p(c[3].as<double>(), c[4].as<double>(), c[5].as<double>());
    for (int m = 0; m < 2; ++m) {
      if (c[6 + 2 * m].IsNull()) continue;
      const auto px = model.Project(p, m == 0 ? Mirror::kOne : Mirror::kTwo);
      ASSERT_TRUE(px.has_value());
      EXPECT_NEAR(px->x(), c[6 + 2 * m].as<double>(), 1e-9);
      EXPECT_NEAR(px->y(), c[7 + 2 * m].as<double>(), 1e-9);
      ++seen[m];
    }
  }
  // Two 4x5 boards placed so that their outer corners are seen by both mirrors.
  EXPECT_GE(seen[0], 30);
  EXPECT_GE(seen[1], 30);
}

TEST_F(RenderCli, BadSceneFailsWithOneLineAndWritesNoTruth) {
  std::ofstream(dir_ + "/bad.yaml") << "format: omnistereo-scene/1\ntargets: [{type: chessboard, "
                                       "rows: 4, cols: 5, square: -1}]\nrandom: {images: 1}\n";
  std::string err;
  EXPECT_NE(RunCli("render --model " + dir_ + "/model.yaml --scene " + dir_ + "/bad.yaml --out " +
                    dir_ + "/bad", &err), 0);
  EXPECT_NE(err.find("bad.yaml"), std::string::npos) << err;
  EXPECT_NE(err.find("targets[0]"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir_ + "/bad/truth.yaml"));
  EXPECT_NE(RunCli("render --model " + dir_ + "/missing.yaml --scene " + dir_ + "/scene.yaml --out " +
                    dir_ + "/bad2", &err), 0);
  EXPECT_NE(err.find("missing.yaml"), std::string::npos) << err;
}

}  // namespace
}  // namespace omni
