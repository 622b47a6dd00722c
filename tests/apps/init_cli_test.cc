// Runs the real `omnistereo init --design single_mirror` on drawn photos of a single-mirror
// camera whose rim is known exactly (tests/detectors/drawn_rim.h): the session and start model
// written, the model read back imaging its rim at the drawn radius (the scale's independent
// check), the session's estimate and priors; bad input ends with exit code 2, one stderr line
// naming the flag or the photos, and nothing written.
#include <algorithm>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "io/model_file.h"
#include "io/session_file.h"
#include "model/lip.h"
#include "model/rig_model.h"
#include "tests/cli_test_util.h"
#include "tests/detectors/drawn_rim.h"

namespace omni {
namespace {

namespace fs = std::filesystem;

class InitCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    photos_ = new fs::path(fs::temp_directory_path() /
                           ("omni_init_cli_photos_" + std::to_string(::getpid())));
    fs::remove_all(*photos_);
    fs::create_directories(*photos_ / "rim");
    fs::create_directories(*photos_ / "noise");
    for (int seed = 1; seed <= 3; ++seed) {
      cv::imwrite((*photos_ / "rim" / ("photo_" + std::to_string(seed) + ".pgm")).string(),
                  detectors::testing::Photo(detectors::testing::Drawn(), seed));
      cv::Mat noise(600, 800, CV_8U);
      cv::randu(noise, 0, 255);
      cv::imwrite((*photos_ / "noise" / ("photo_" + std::to_string(seed) + ".pgm")).string(), noise);
    }
  }
  static void TearDownTestSuite() {
    fs::remove_all(*photos_);
    delete photos_;
  }
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("omni_init_cli_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // `init --design single_mirror` on the drawn photos (or the noise) with the extra flags.
  int Run(const std::string& flags, std::string* err, std::string* out = nullptr,
          const std::string& photos = "rim") {
    const std::string args = "init --design single_mirror --images '" +
                             (*photos_ / photos / "*.pgm").string() +
                             "' --targets '[{type: chessboard, rows: 6, cols: 8, square: 42}]' "
                             "--out '" + (dir_ / "session.yaml").string() + "' " + flags;
    return testing::RunOmnistereo(args, dir_ / "stderr.txt", err, dir_ / "stdout.txt", out);
  }
  void ExpectRejected(const std::string& flags, const std::string& named,
                      const std::string& photos = "rim") {
    std::string err;
    EXPECT_EQ(Run(flags, &err, nullptr, photos), 2) << flags;
    EXPECT_EQ(err.rfind("omnistereo init: " + named, 0), 0u) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    for (const auto& entry : fs::directory_iterator(dir_)) {  // nothing written
      const std::string name = entry.path().filename().string();
      EXPECT_TRUE(name == "stderr.txt" || name == "stdout.txt") << flags << ": " << name;
    }
  }
  // The written model's rim (the direct view of its rim circle) about the principal point: the
  // worst distance from the drawn radius over the azimuths.
  double WorstRimError() const {
    const RigModel model(io::ReadModelFile((dir_ / "start_model.yaml").string()));
    const detectors::testing::Drawn d;
    double worst = 0;
    for (int i = 0; i < 36; ++i) {
      const auto pixel = ProjectLipPoint(model, LipPath::kDirect, LipCircle::kOuter, i * M_PI / 18);
      if (!pixel) return 1e9;
      worst = std::max(worst, std::abs((*pixel - Eigen::Vector2d(d.cx, d.cy)).norm() - d.r));
    }
    return worst;
  }

  static fs::path* photos_;
  fs::path dir_;
};

fs::path* InitCli::photos_ = nullptr;

TEST_F(InitCli, TelecentricParaboloidFromItsRim) {
  const detectors::testing::Drawn d;
  std::string err, out;
  // A 40 mm rim; the lens's magnification as the drawn radius over 20 mm, 2% off.
  const std::string flags = "--mirror_diameter 40 --mirror parabolic --lens telecentric "
                            "--magnification " + std::to_string(1.02 * d.r / 20);
  ASSERT_EQ(Run(flags, &err, &out), 0) << err;
  EXPECT_NE(out.find("mirror rim: centre (402."), std::string::npos) << out;
  EXPECT_NE(out.find("start: paraboloid R 20.000 mm, K -1.0000"), std::string::npos) << out;
  EXPECT_NE(out.find("diameter checked:"), std::string::npos) << out;
  EXPECT_NE(out.find("next: omnistereo detect --session"), std::string::npos) << out;
  EXPECT_NE(out.find("omnistereo calibrate --session"), std::string::npos) << out;
  EXPECT_LT(WorstRimError(), 1.0);
  const RigParams rig = io::ReadModelFile((dir_ / "start_model.yaml").string());
  EXPECT_TRUE(rig.Single());
  EXPECT_EQ(rig.lens, LensKind::kTelecentric);
  EXPECT_EQ(rig.kind, ModelKind::kIdeal);
  const io::Session session = io::ReadSessionFile((dir_ / "session.yaml").string());
  EXPECT_TRUE(session.use_lips);  // the rim measured in the photos (detectors/lips/rim_edge.h)
  EXPECT_EQ(session.estimate, (std::vector<std::string>{"camera", "distortion", "mirror1_shape",
                                                        "mirror1_pose"}));
  ASSERT_EQ(session.priors.count("mirror1_shape"), 1u);
  EXPECT_EQ(session.priors.at("mirror1_shape").sigma_k, 0.01);
  EXPECT_EQ(session.images.size(), 3u);
  const std::string text = testing::ReadText(dir_ / "session.yaml");
  EXPECT_NE(text.find("# priors: K held near -1"), std::string::npos) << text;
}

// --out into a folder that does not exist yet: made, the session and its model written there.
TEST_F(InitCli, OutIntoANewFolder) {
  std::string err, out;
  const fs::path session = dir_ / "new" / "work" / "session.yaml";
  ASSERT_EQ(Run("--mirror_diameter 50 --camera_distance 80 --out '" + session.string() + "'",
                &err, &out),
            0)
      << err;
  EXPECT_TRUE(fs::exists(session));
  EXPECT_TRUE(fs::exists(dir_ / "new" / "work" / "start_model.yaml"));
  EXPECT_EQ(io::ReadSessionFile(session.string()).images.size(), 3u);
}

TEST_F(InitCli, PerspectiveUnknownMirrorFromItsRim) {
  std::string err, out;
  ASSERT_EQ(Run("--mirror_diameter 50 --camera_distance 80", &err, &out), 0) << err;
  EXPECT_NE(out.find("unknown mirror: started as the central hyperboloid"), std::string::npos)
      << out;
  EXPECT_NE(out.find("diameter not checked"), std::string::npos) << out;
  EXPECT_LT(WorstRimError(), 1.0);
  const io::Session session = io::ReadSessionFile((dir_ / "session.yaml").string());
  EXPECT_TRUE(session.priors.empty());
}

TEST_F(InitCli, PerspectiveFromAUnifiedFit) {
  std::string err, out;
  ASSERT_EQ(Run("--mirror_diameter 50 --mirror hyperbolic --unified 0.9,300", &err, &out), 0) << err;
  EXPECT_NE(out.find("from the unified fit xi 0.9, gamma 300 px"), std::string::npos) << out;
  EXPECT_LT(WorstRimError(), 1.0);
}

TEST_F(InitCli, BadInputIsNamedAndNothingWritten) {
  const detectors::testing::Drawn d;
  // The rim's px per mm 10% off the magnification.
  ExpectRejected("--mirror_diameter 44 --mirror parabolic --lens telecentric --magnification " +
                     std::to_string(d.r / 20),
                 "--mirror_diameter: ");
  // The focal length and the distance disagree with the diameter by 2x (a radius given).
  ExpectRejected("--mirror_diameter 25 --mirror hyperbolic --focal_px 600 --camera_distance 100",
                 "--mirror_diameter: ");
  ExpectRejected("--mirror_diameter 40 --mirror hyperbolic --lens telecentric", "--lens: ");
  ExpectRejected("--mirror_diameter 40 --mirror spherical", "--camera_distance: ");
  ExpectRejected("--mirror parabolic --mirror_diameter=-40", "--mirror_diameter: ");
  ExpectRejected("--mirror_diameter 40 --mirror conic", "--mirror: ");
  ExpectRejected("--mirror_diameter 40 --lens fisheye", "--lens: ");
  ExpectRejected("--mirror_diameter 40 --unified 0.9", "--unified: ");
  ExpectRejected("--mirror_diameter 40 --unified 0.9,0", "--unified: ");
  ExpectRejected("--mirror_diameter 40", "--images: no mirror rim found in the 3 photos: ", "noise");
  // Telecentric with the folded design.
  std::string err;
  const std::string folded = "init --design big_rig --lens telecentric --images '" +
                             (*photos_ / "rim" / "*.pgm").string() +
                             "' --targets '[{type: chessboard, rows: 6, cols: 8, square: 42}]' "
                             "--out '" + (dir_ / "session.yaml").string() + "'";
  EXPECT_EQ(testing::RunOmnistereo(folded, dir_ / "stderr.txt", &err), 2);
  EXPECT_EQ(err.rfind("omnistereo init: --lens: telecentric needs --design single_mirror", 0), 0u)
      << err;
  EXPECT_FALSE(fs::exists(dir_ / "session.yaml"));
}

}  // namespace
}  // namespace omni
