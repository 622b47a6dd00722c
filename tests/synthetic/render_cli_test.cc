// `omnistereo render` end to end on a small frame: the fast path (--no_render) writes the same
// ground truth as a real render, the truth agrees with RigModel::Project, bad input fails cleanly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <yaml-cpp/yaml.h>

#include "io/model_file.h"
#include "io/session_file.h"
#include "model/camera.h"
#include "model/rig_model.h"
#include "tests/cli_test_util.h"

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
        << "render: {antialias: true, noise_sigma: 0}\n"
        << "targets: [{type: chessboard, rows: 4, cols: 5, square: 60.0},\n"
        << "          {type: chessboard, rows: 4, cols: 5, square: 50.0}]\n"
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
  EXPECT_FALSE(fs::exists(dir_ + "/fast/session.yaml"));
  // The render is a session as it stands: its model, its images, the scene's targets.
  const io::Session session = io::ReadSessionFile(dir_ + "/full/session.yaml");
  EXPECT_EQ(fs::path(session.model_path), fs::path(dir_ + "/full/model.yaml"));
  ASSERT_EQ(session.images.size(), 1u);
  EXPECT_EQ(fs::path(session.images[0]), fs::path(dir_ + "/full/0001.png"));
  ASSERT_EQ(session.targets.size(), 2u);
  EXPECT_EQ(session.targets[0].type, TargetType::kChessboard);
  EXPECT_EQ(session.targets[0].rows, 4);
  EXPECT_EQ(session.targets[0].cols, 5);
  EXPECT_EQ(session.targets[0].square_mm, 60.0);

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

  // The blue lip's circles in C against POV-Ray: the outer rim of the lip seen straight by the
  // camera (pinhole + distortion of points on the truth's r_outer circle) is where the rendered
  // blue ends, at 36 azimuths (half-way crossing of the blue channel along the radius).
  const YAML::Node lip = truth["lips"][0];
  ASSERT_EQ(lip["mirror"].as<int>(), 1);
  ASSERT_EQ(lip["color"].as<std::string>(), "blue");
  auto vec = [](const YAML::Node& n) {
    return Eigen::Vector3d(n[0].as<double>(), n[1].as<double>(), n[2].as<double>());
  };
  const Eigen::Vector3d centre = vec(lip["centre"]), normal = vec(lip["normal"]);
  EXPECT_NEAR(normal.norm(), 1.0, 1e-12);
  const Eigen::Vector3d e1 = normal.cross(Eigen::Vector3d::UnitX()).normalized();
  const Eigen::Vector3d e2 = normal.cross(e1);
  const RigParams& rig = model.params();
  const Pinhole<double> cam{rig.camera[kFx], rig.camera[kFy], rig.camera[kCx], rig.camera[kCy], rig.camera[kSkew]};
  const RadTan<double> dist{rig.distortion[kDistK1], rig.distortion[kDistK2], rig.distortion[kDistP1],
                            rig.distortion[kDistP2], rig.distortion[kDistK3]};
  auto pixel_of = [&](const Eigen::Vector3d& p) {
    return cam.PixelFromNormalized(dist.Distort(Eigen::Vector2d(p.x() / p.z(), p.y() / p.z())));
  };
  auto blue_at = [&](const Eigen::Vector2d& px) {  // bilinear
    const int u = static_cast<int>(std::floor(px.x())), v = static_cast<int>(std::floor(px.y()));
    const double a = px.x() - u, b = px.y() - v;
    auto at = [&](int vv, int uu) { return img.at<cv::Vec3b>(vv, uu)[0] / 255.0; };
    return (1 - b) * ((1 - a) * at(v, u) + a * at(v, u + 1)) +
           b * ((1 - a) * at(v + 1, u) + a * at(v + 1, u + 1));
  };
  const double r_outer = lip["r_outer"].as<double>();
  double sum = 0, worst = 0;
  int n = 0;
  for (int k = 0; k < 36; ++k) {
    const double phi = k * M_PI / 18;
    const Eigen::Vector3d radial = std::cos(phi) * e1 + std::sin(phi) * e2;
    constexpr int kSamples = 41;
    std::vector<double> d(kSamples), blue(kSamples);
    bool inside_image = true;
    for (int i = 0; i < kSamples; ++i) {
      d[i] = -1.5 + 3.0 * i / (kSamples - 1);  // mm across the rim
      const Eigen::Vector2d px = pixel_of(centre + (r_outer + d[i]) * radial);
      inside_image = inside_image && px.x() >= 0 && px.y() >= 0 && px.x() < img.cols - 1 &&
                     px.y() < img.rows - 1;
      if (inside_image) blue[i] = blue_at(px);
    }
    if (!inside_image) continue;
    const double px_per_mm = (pixel_of(centre + (r_outer + 0.05) * radial) -
                              pixel_of(centre + (r_outer - 0.05) * radial)).norm() / 0.1;
    // Half-way between the lip's level 1.5 mm inside the rim (its paint lit by the room, not 1)
    // and the black beyond.
    const double half = 0.5 * blue[0];
    for (int i = 0; i + 1 < kSamples; ++i) {
      if (blue[i] >= half && blue[i + 1] < half) {
        const double crossing =
            d[i] + (blue[i] - half) / (blue[i] - blue[i + 1]) * (d[i + 1] - d[i]);
        sum += std::abs(crossing) * px_per_mm;
        worst = std::max(worst, std::abs(crossing) * px_per_mm);
        ++n;
        break;
      }
    }
  }
  std::printf("blue lip rim: %d azimuths, mean %.3f px, max %.3f px from the truth circle\n", n,
              sum / std::max(1, n), worst);
  EXPECT_GE(n, 30);
  EXPECT_LT(sum / std::max(1, n), 0.1);
  EXPECT_LT(worst, 0.3);
}

TEST_F(RenderCli, SceneImageSizeRendersTheSameRigAtThatResolution) {
  std::ofstream(dir_ + "/half.yaml") << testing::ReadText(dir_ + "/scene.yaml")
                                     << "image: {width: 160, height: 120}\n";
  std::string err;
  ASSERT_EQ(RunCli("render --model " + dir_ + "/model.yaml --scene " + dir_ +
                    "/scene.yaml --no_render --out " + dir_ + "/full", &err), 0) << err;
  ASSERT_EQ(RunCli("render --model " + dir_ + "/model.yaml --scene " + dir_ +
                    "/half.yaml --no_render --out " + dir_ + "/half", &err), 0) << err;
  EXPECT_EQ(io::ReadModelFile(dir_ + "/half/model.yaml").image_width, 160);
  const YAML::Node full = YAML::LoadFile(dir_ + "/full/truth.yaml")["images"][0]["corners"];
  const YAML::Node half = YAML::LoadFile(dir_ + "/half/truth.yaml")["images"][0]["corners"];
  ASSERT_EQ(full.size(), half.size());
  int compared = 0;
  for (size_t i = 0; i < full.size(); ++i) {
    for (int k = 6; k < 10; ++k) {
      if (full[i][k].IsNull() || half[i][k].IsNull()) continue;
      // Pixel centres at integers: (u + 0.5) scales with the image.
      EXPECT_NEAR(half[i][k].as<double>(), 0.5 * (full[i][k].as<double>() + 0.5) - 0.5, 1e-6);
      ++compared;
    }
  }
  EXPECT_GE(compared, 100);
  std::ofstream(dir_ + "/odd.yaml") << testing::ReadText(dir_ + "/scene.yaml")
                                    << "image: {width: 160, height: 100}\n";
  EXPECT_EQ(RunCli("render --model " + dir_ + "/model.yaml --scene " + dir_ + "/odd.yaml --out " +
                   dir_ + "/odd", &err), 2);
  EXPECT_NE(err.find("odd.yaml: image"), std::string::npos) << err;
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
  // Tag grids: ids beyond tag36h11's 587 codes, a gap below one tag bit, an unknown kind.
  const std::pair<std::string, std::string> bad_targets[] = {
      {"{type: kalibr_aprilgrid, rows: 2, cols: 3, tag_size: 45, spacing: 0.3, first_id: 585}", "first_id"},
      {"{type: apriltag_grid, family: tag36h11, rows: 2, cols: 3, tag_size: 45, spacing: 0.05}", "spacing"},
      {"{type: apriltag_grid, family: tag25h9, rows: 2, cols: 3, tag_size: 45, spacing: 0.3}", "family"},
      {"{type: aprilgrid, rows: 2, cols: 3}", "targets[0].type"}};
  for (const auto& [target, key] : bad_targets) {
    std::ofstream(dir_ + "/bad_tags.yaml") << "format: omnistereo-scene/1\ntargets: [" << target
                                           << "]\nrandom: {images: 1}\n";
    EXPECT_EQ(RunCli("render --model " + dir_ + "/model.yaml --scene " + dir_ + "/bad_tags.yaml --out " +
                     dir_ + "/bad3", &err), 2) << target;
    EXPECT_NE(err.find("bad_tags.yaml: targets[0]"), std::string::npos) << err;
    EXPECT_NE(err.find(key), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_FALSE(fs::exists(dir_ + "/bad3/truth.yaml"));
  }
  // Found by scripts/fuzz.sh: a flag that is not true or false (was yaml-cpp's "bad conversion").
  // A section that is not a map, and a list entry that is not a list (yaml-cpp's "operator[]
  // call on a scalar" before).
  for (const char* flags : {"render: {antialias: tr\xff\xffue}", "room: {enabled: [yes]}",
                            "render: antialias", "markers: [{center: 3}]"}) {
    std::ofstream(dir_ + "/bad_flag.yaml") << "format: omnistereo-scene/1\n" << flags
                                           << "\ntargets: [{type: chessboard, rows: 4, cols: 5, "
                                              "square: 60}]\nrandom: {images: 1}\n";
    EXPECT_EQ(RunCli("render --model " + dir_ + "/model.yaml --scene " + dir_ + "/bad_flag.yaml --out " +
                     dir_ + "/bad4", &err), 2) << flags;
    EXPECT_NE(err.find("bad_flag.yaml: "), std::string::npos) << err;
    EXPECT_EQ(err.find("yaml-cpp"), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  }
  // Found by scripts/fuzz.sh (UBSan): a whole number beyond the integer it goes into (was a
  // double-to-int cast out of range, undefined behaviour); a negative or fractional seed.
  const std::pair<std::string, std::string> bad_numbers[] = {
      {"image: {width: 960444444444444444444444444444, height: 720}", "image.width"},
      {"render: {noise_seed: -1}", "render.noise_seed"},
      {"render: {noise_seed: 1.5}", "render.noise_seed"},
      // (a timeout: 25601 random images placed in the parser)
      {"random: {images: 25601}", "random.images"}};
  for (const auto& [line, key] : bad_numbers) {
    std::ofstream(dir_ + "/bad_number.yaml") << "format: omnistereo-scene/1\n" << line
                                             << "\ntargets: [{type: chessboard, rows: 4, cols: 5, "
                                                "square: 60}]\n"
                                             << (line.find("random:") == std::string::npos
                                                     ? "random: {images: 1}\n" : "");
    EXPECT_EQ(RunCli("render --model " + dir_ + "/model.yaml --scene " + dir_ +
                     "/bad_number.yaml --out " + dir_ + "/bad5", &err), 2) << line;
    EXPECT_NE(err.find("bad_number.yaml: " + key + ": expected a whole number"), std::string::npos)
        << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_FALSE(fs::exists(dir_ + "/bad5/truth.yaml"));
  }
  // A target is in one place per image: two per image need two definitions.
  std::ofstream(dir_ + "/twice.yaml") << "format: omnistereo-scene/1\ntargets: [{type: chessboard, "
                                         "rows: 4, cols: 5, square: 60}]\nrandom: {images: 1, targets: [2, 2]}\n";
  EXPECT_EQ(RunCli("render --model " + dir_ + "/model.yaml --scene " + dir_ + "/twice.yaml --out " +
                   dir_ + "/twice", &err), 2);
  EXPECT_NE(err.find("twice.yaml: random: expected at most 1 targets per image"), std::string::npos) << err;
  EXPECT_NE(RunCli("render --model " + dir_ + "/missing.yaml --scene " + dir_ + "/scene.yaml --out " +
                    dir_ + "/bad2", &err), 0);
  EXPECT_NE(err.find("missing.yaml"), std::string::npos) << err;
}

}  // namespace
}  // namespace omni
