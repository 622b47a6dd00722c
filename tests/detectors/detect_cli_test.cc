// `omnistereo detect` on bad input: unreadable, wrong-size and grey images get one warning line
// each and the good images are still written; with no usable image nothing is written (exit 2).
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "model/io/detections_file.h"
#include "tests/cli_test_util.h"
#include "tests/temp_dir.h"

namespace omni {
namespace {

namespace fs = std::filesystem;

fs::path MakeDir(const std::string& name) {
  const fs::path dir = omni::testing::UniqueTempDir("omni_detect_cli_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void WriteSession(const fs::path& dir, const std::string& images) {
  std::ofstream(dir / "session.yaml")
      << "format: omnistereo-session/1\n"
      << "model: " << OMNISTEREO_SOURCE_DIR << "/sample_configs/big_rig_misaligned.yaml\n"
      << "images: " << images << "\n"
      << "targets:\n  - {type: chessboard, rows: 6, cols: 8, square: 40.0}\n";
}

TEST(DetectCliTest, BadImagesAreSkippedWithOneLineEach) {
  const fs::path dir = MakeDir("mixed");
  cv::imwrite((dir / "small.png").string(), cv::Mat(100, 100, CV_8UC3, cv::Scalar(90, 90, 90)));
  cv::imwrite((dir / "grey.png").string(), cv::Mat(960, 1280, CV_8U, cv::Scalar(128)));
  std::ofstream(dir / "broken.png") << "not a png";
  WriteSession(dir, "[missing.png, small.png, grey.png, broken.png]");
  std::string err, out;
  const int code = testing::RunOmnistereo(
      "detect --session=" + (dir / "session.yaml").string() + " --out=" + (dir / "det.yaml").string(),
      dir / "err.txt", &err, dir / "out.txt", &out);
  EXPECT_EQ(code, 0) << err;
  EXPECT_NE(err.find("missing.png: cannot read"), std::string::npos) << err;
  EXPECT_NE(err.find("broken.png: cannot read"), std::string::npos) << err;
  EXPECT_NE(err.find("small.png: the image is 100x100, the model expects 1280x960"), std::string::npos) << err;
  EXPECT_NE(err.find("grey.png: no target corners found"), std::string::npos) << err;
  EXPECT_NE(out.find("1 of 4 images used (3 skipped)"), std::string::npos) << out;
  const io::Detections det = io::ReadDetectionsFile((dir / "det.yaml").string());
  ASSERT_EQ(det.images.size(), 1u);
  EXPECT_EQ(det.images[0].file, "grey.png");
  EXPECT_EQ(det.images[0].width, 1280);
  EXPECT_TRUE(det.images[0].corners.empty());
  EXPECT_EQ(det.session, "session.yaml");
}

TEST(DetectCliTest, NoUsableImageWritesNothing) {
  const fs::path dir = MakeDir("none");
  cv::imwrite((dir / "small.png").string(), cv::Mat(10, 10, CV_8U, cv::Scalar(0)));
  WriteSession(dir, "[small.png, missing.png]");
  std::string err;
  const int code = testing::RunOmnistereo(
      "detect --session=" + (dir / "session.yaml").string() + " --out=" + (dir / "det.yaml").string(),
      dir / "err.txt", &err);
  EXPECT_EQ(code, 2);
  EXPECT_NE(err.find("none of the 2 images could be used; nothing written"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "det.yaml"));
}

}  // namespace
}  // namespace omni
