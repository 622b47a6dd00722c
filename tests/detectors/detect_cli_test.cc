// `omnistereo detect` on bad input: unreadable and grey images get one warning line each and the
// good images are still written; with no usable image nothing is written (exit 2). Images of an
// unsupported layout, of another size than the model's, or colour images in a session that names
// a Bayer pattern stop the session with one line naming the file: nothing written (exit 2).
// Images as cameras write them (8/16-bit PNG and TIFF, JPEG, grey or colour, raw Bayer frames
// with the session's `bayer:` key) are read.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "io/detections_file.h"
#include "io/model_file.h"
#include "synthetic/image_effects.h"
#include "tests/cli_test_util.h"
#include "tests/render_window.h"
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

void WriteSession(const fs::path& dir, const std::string& images, const std::string& extra = "") {
  std::ofstream(dir / "session.yaml")
      << "format: omnistereo-session/1\n"
      << "model: " << OMNISTEREO_SOURCE_DIR << "/sample_configs/big_rig_misaligned.yaml\n"
      << "images: " << images << "\n"
      << "targets:\n  - {type: chessboard, rows: 6, cols: 8, square: 40.0}\n"
      << extra;
}

// Runs detect on dir/session.yaml into dir/det.yaml; returns the exit code.
int Detect(const fs::path& dir, std::string* err, std::string* out = nullptr) {
  return testing::RunOmnistereo(
      "detect --session=" + (dir / "session.yaml").string() + " --out=" + (dir / "det.yaml").string(),
      dir / "err.txt", err, dir / "out.txt", out);
}

int Lines(const std::string& text) { return static_cast<int>(std::count(text.begin(), text.end(), '\n')); }

TEST(DetectCliTest, BadImagesAreSkippedWithOneLineEach) {
  const fs::path dir = MakeDir("mixed");
  cv::imwrite((dir / "grey.png").string(), cv::Mat(960, 1280, CV_8U, cv::Scalar(128)));
  std::ofstream(dir / "broken.png") << "not a png";
  WriteSession(dir, "[missing.png, grey.png, broken.png]");
  std::string err, out;
  const int code = Detect(dir, &err, &out);
  EXPECT_EQ(code, 0) << err;
  EXPECT_NE(err.find("missing.png: cannot read"), std::string::npos) << err;
  EXPECT_NE(err.find("broken.png: cannot read"), std::string::npos) << err;
  EXPECT_NE(err.find("grey.png: no target corners found"), std::string::npos) << err;
  EXPECT_NE(out.find("1 of 3 images used (2 skipped)"), std::string::npos) << out;
  // The session per target (issue 38): a target found in no photo is named.
  EXPECT_NE(out.find("target 0 (chessboard 6x8): in 0 of 1 photos, 0 corners in ring 1, 0 in ring 2: "
                     "never found"), std::string::npos) << out;
  const Observations det = io::ReadDetectionsFile((dir / "det.yaml").string());
  ASSERT_EQ(det.images.size(), 1u);
  EXPECT_EQ(det.images[0].file, "grey.png");
  EXPECT_EQ(det.images[0].width, 1280);
  EXPECT_TRUE(det.images[0].corners.empty());
  EXPECT_EQ(det.session, "session.yaml");
}

// Files cut short in copying: a PNG whose decoder fails (libpng would print its own "libpng
// error" line) and a JPEG with no end-of-image marker (libjpeg would decode it with its missing
// part grey and say so only on stderr): each is skipped with our one line and nothing else.
TEST(DetectCliTest, FilesCutShortAreSkippedWithOurLineOnly) {
  const fs::path dir = MakeDir("cut_short");
  cv::Mat noise(960, 1280, CV_8UC3);
  cv::randu(noise, 0, 255);
  std::vector<uchar> png, jpeg;
  cv::imencode(".png", noise, png);
  cv::imencode(".jpg", noise, jpeg);
  std::ofstream(dir / "cut.png", std::ios::binary)
      .write(reinterpret_cast<const char*>(png.data()), static_cast<long>(png.size() / 2));
  std::ofstream(dir / "cut.jpg", std::ios::binary)
      .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<long>(jpeg.size() / 2));
  cv::imwrite((dir / "grey.png").string(), cv::Mat(960, 1280, CV_8U, cv::Scalar(128)));
  WriteSession(dir, "[cut.png, cut.jpg, grey.png]", "lips: false\n");
  std::string err, out;
  EXPECT_EQ(Detect(dir, &err, &out), 0) << err;
  EXPECT_NE(err.find("cut.png: cannot read the image"), std::string::npos) << err;
  EXPECT_NE(err.find("cut.jpg: cannot read the image: expected a whole JPEG file"),
            std::string::npos) << err;
  EXPECT_EQ(err.find("libpng"), std::string::npos) << err;
  EXPECT_EQ(err.find("JPEG"), err.find("JPEG file")) << err;  // no libjpeg "Corrupt JPEG data"
  // The two files, grey.png's "no target corners found" and its progress line.
  EXPECT_EQ(Lines(err), 4) << err;
  EXPECT_NE(out.find("1 of 3 images used (2 skipped)"), std::string::npos) << out;
}

// A misspelt flag is named, with the command's flag it is closest to.
TEST(DetectCliTest, MisspeltFlagIsNamed) {
  const fs::path dir = MakeDir("flag");
  std::string err;
  const int code = testing::RunOmnistereo("detect --sesion " + (dir / "session.yaml").string() +
                                              " --out=" + (dir / "det.yaml").string(),
                                          dir / "err.txt", &err, dir / "out.txt", nullptr);
  EXPECT_EQ(code, 2);
  EXPECT_EQ(err, "omnistereo detect: unknown flag --sesion; did you mean --session?\n");
  EXPECT_FALSE(fs::exists(dir / "det.yaml"));
}

TEST(DetectCliTest, NoUsableImageWritesNothing) {
  const fs::path dir = MakeDir("none");
  std::ofstream(dir / "broken.png") << "not a png";
  WriteSession(dir, "[broken.png, missing.png]");
  std::string err, out;
  const int code = Detect(dir, &err, &out);
  EXPECT_EQ(code, 2);
  // Each file named once, then the session's line; no lip guide line for images never read.
  EXPECT_NE(err.find("broken.png: cannot read the image"), std::string::npos) << err;
  EXPECT_EQ(out.find("detection guided"), std::string::npos) << out;
  EXPECT_EQ(out.find("no colour image"), std::string::npos) << out;
  EXPECT_NE(err.find("session.yaml: none of the 2 images could be read"), std::string::npos) << err;
  EXPECT_NE(err.find("the first: " + (dir / "broken.png").string() + ": cannot read the image"),
            std::string::npos)
      << err;
  EXPECT_FALSE(fs::exists(dir / "det.yaml"));
}

// Each case: one line on stderr naming the file and what was expected, exit 2, no detections file.
TEST(DetectCliTest, UnusableImagesStopTheSessionWithOneLine) {
  struct Case {
    std::string name, image, extra, expect;
  };
  const std::vector<Case> cases = {
      {"size", "small.png", "", "small.png: expected a 1280x960 image"},
      {"float", "float.tiff", "", "float.tiff: expected an 8- or 16-bit grey, colour or colour+alpha image, got a 32-bit float image"},
      {"bayer_on_colour", "colour.png", "bayer: RGGB\n",
       "colour.png: the session names Bayer pattern RGGB, so expected a raw one-channel 8- or 16-bit frame, got a 8-bit image with 3 channels"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const fs::path dir = MakeDir("unusable_" + c.name);
    cv::imwrite((dir / "small.png").string(), cv::Mat(720, 960, CV_8UC3, cv::Scalar(90, 90, 90)));
    cv::imwrite((dir / "float.tiff").string(), cv::Mat(960, 1280, CV_32F, cv::Scalar(0.5)));
    cv::imwrite((dir / "colour.png").string(), cv::Mat(960, 1280, CV_8UC3, cv::Scalar(90, 90, 90)));
    WriteSession(dir, "[" + c.image + "]", c.extra);
    std::string err;
    EXPECT_EQ(Detect(dir, &err), 2) << err;
    EXPECT_NE(err.find(c.expect), std::string::npos) << err;
    EXPECT_EQ(Lines(err), 1) << err;
    EXPECT_FALSE(fs::exists(dir / "det.yaml"));
  }
}

// --model replaces the session's model (a second pass with the calibrated one): a photo of the
// session's model's size is refused against a --model of another size, with the size it expected.
TEST(DetectCliTest, TheModelFlagReplacesTheSessionsModel) {
  const fs::path dir = MakeDir("model_flag");
  cv::imwrite((dir / "colour.png").string(), cv::Mat(960, 1280, CV_8UC3, cv::Scalar(90, 90, 90)));
  WriteSession(dir, "[colour.png]");
  std::ifstream in(std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/big_rig_misaligned.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string size = "image: {width: 1280, height: 960}";
  ASSERT_NE(text.find(size), std::string::npos);
  text.replace(text.find(size), size.size(), "image: {width: 960, height: 720}");
  std::ofstream(dir / "other.yaml") << text;
  std::string err;
  EXPECT_EQ(Detect(dir, &err), 0) << err;  // the session's own model: the photo's size
  fs::remove(dir / "det.yaml");
  EXPECT_EQ(testing::RunOmnistereo("detect --session=" + (dir / "session.yaml").string() +
                                       " --model=" + (dir / "other.yaml").string() +
                                       " --out=" + (dir / "det.yaml").string(),
                                   dir / "err.txt", &err),
            2);
  EXPECT_NE(err.find("colour.png: expected a 960x720 image"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "det.yaml"));
}

// What cameras write is read: 16-bit PNG and TIFF, JPEG, grey and colour, and a raw Bayer frame
// demosaiced with the session's pattern.
TEST(DetectCliTest, ImagesAsCamerasWriteThemAreRead) {
  const fs::path dir = MakeDir("formats");
  cv::imwrite((dir / "grey16.png").string(), cv::Mat(960, 1280, CV_16U, cv::Scalar(30000)));
  cv::imwrite((dir / "colour16.tiff").string(), cv::Mat(960, 1280, CV_16UC3, cv::Scalar(9000, 20000, 30000)));
  cv::imwrite((dir / "colour.jpg").string(), cv::Mat(960, 1280, CV_8UC3, cv::Scalar(20, 90, 200)));
  WriteSession(dir, "[grey16.png, colour16.tiff, colour.jpg]");
  std::string err, out;
  EXPECT_EQ(Detect(dir, &err, &out), 0) << err;
  EXPECT_NE(out.find("3 of 3 images used (0 skipped)"), std::string::npos) << out;

  const fs::path raw = MakeDir("raw");
  cv::imwrite((raw / "raw16.png").string(), cv::Mat(960, 1280, CV_16U, cv::Scalar(30000)));
  WriteSession(raw, "[raw16.png]", "bayer: GRBG\n");
  EXPECT_EQ(Detect(raw, &err, &out), 0) << err;
  EXPECT_NE(out.find("1 of 1 images used (0 skipped)"), std::string::npos) << out;
}

// A lips-only session (targets: []) on a render of the misaligned rig's lips (the strips
// through the principal point, 16-bit linear, through the rig's lens): the lip edges are written,
// no image is warned about missing target corners, and the intrinsics the lips give are printed
// against the model's. The oracle is the rig as rendered: with it as the model the lips' f lies
// within 0.1% of its own (lip_detector_test: +0.001%) and the principal point where the mirror
// bodies put the lips' centres, within 1 px of LipReferencePointsOf's points (here only printed:
// each body gives its own).
TEST(DetectCliTest, LipsOnlySessionPrintsTheLipsIntrinsics) {
  const fs::path dir = MakeDir("lips_only");
  const std::string model = std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/big_rig_misaligned.yaml";
  const RigParams rig = io::ReadModelFile(model);
  const cv::Mat pinhole = testing::RenderLipStrips(rig, "detect_cli", 16);
  ASSERT_FALSE(pinhole.empty());
  const cv::Mat strips = synthetic::ApplyDistortion(pinhole, rig);  // the rig's own lens
  cv::imwrite((dir / "lips.png").string(), strips);
  std::ofstream(dir / "session.yaml") << "format: omnistereo-session/1\n"
                                      << "model: " << model << "\n"
                                      << "images: [lips.png]\ntone: linear\ntargets: []\n";
  std::string err, out;
  ASSERT_EQ(Detect(dir, &err, &out), 0) << err;
  EXPECT_EQ(err.find("no target corners"), std::string::npos) << err;
  EXPECT_NE(out.find("1 of 1 images used (0 skipped), 0 corners"), std::string::npos) << out;
  const Observations det = io::ReadDetectionsFile((dir / "det.yaml").string());
  ASSERT_EQ(det.images.size(), 1u);
  EXPECT_GE(det.images[0].lips.size(), 3u);
  const auto at = out.find("lips only: f ");
  ASSERT_NE(at, std::string::npos) << out;
  const double f = std::stod(out.substr(at + 13));
  const double f_model = 0.5 * (rig.camera[kFx] + rig.camera[kFy]);
  EXPECT_NEAR(f / f_model, 1.0, 0.001) << out;
  std::printf("%s", out.c_str());

  // Nothing to detect: one line, nothing written.
  std::ofstream(dir / "session.yaml", std::ios::app) << "lips: false\n";
  fs::remove(dir / "det.yaml");
  EXPECT_EQ(Detect(dir, &err), 2);
  EXPECT_NE(err.find("nothing to detect"), std::string::npos) << err;
  EXPECT_EQ(Lines(err), 1) << err;
  EXPECT_FALSE(fs::exists(dir / "det.yaml"));
}

}  // namespace
}  // namespace omni
