// `omnistereo tolerance` on the calibrated test model (tests/data/calibrated_big_rig.yaml, with
// its covariance) against limits it fails: a FAIL line says by how much and which way to move
// the part; a value in the camera-rotation valley (|correlation| with cx or cy over 0.99) is
// said to be inseparable from the camera's rotation.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/cli_test_util.h"
#include "tests/temp_dir.h"

namespace omni {
namespace {

namespace fs = std::filesystem;

// The lines printed under the table row of `quantity` (indented by four spaces).
std::string LinesAfterRow(const std::string& out, const std::string& quantity) {
  const auto row = out.find("  " + quantity + " ");
  if (row == std::string::npos) return "";
  const size_t first = out.find('\n', row) + 1;
  size_t stop = first;
  while (stop < out.size() && out.compare(stop, 4, "    ") == 0) stop = out.find('\n', stop) + 1;
  return out.substr(first, stop - first);
}

TEST(ToleranceCli, FailSaysWhichWayAndTheValleyIsNamed) {
  const fs::path dir = testing::UniqueTempDir("omni_tolerance_cli");
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "tol.yaml") << "format: omnistereo-tolerances/1\n"
                                     "mirror1: {decentre: 0.1, tilt_deg: 0.01, axial: 5}\n"
                                     "mirror2: {decentre: 0.3}\n"
                                     "simulate: {samples: 0}\n";
  std::string err, out;
  const int code = testing::RunOmnistereo(
      "tolerance --model=" + std::string(OMNI_SOURCE_DIR) +
          "/tests/data/calibrated_big_rig.yaml --config=" + (dir / "tol.yaml").string(),
      dir / "err.txt", &err, dir / "out.txt", &out);
  ASSERT_EQ(code, 0) << err << out;
  // mirror1 sits at (+0.311, -0.205) mm: 0.373 mm, 0.273 beyond 0.1; moving it back along its
  // own direction by 0.273 mm is (-0.228, +0.150) mm.
  const std::string decentre = LinesAfterRow(out, "mirror1.decentre");
  EXPECT_NE(decentre.find("(mirror1.tx, mirror1.ty) is (+0.311, -0.205) mm, |.| 0.373 beyond "
                          "0.100 by 0.273: move mirror1 by (-0.228, +0.150) mm"),
            std::string::npos)
      << out;
  // Its tilt's rx is correlated +0.9997 with cy (ry -0.9996 with cx): the valley line, and no
  // move advised (turning mirror 1 cannot be told from turning the camera).
  const std::string tilt = LinesAfterRow(out, "mirror1.tilt");
  EXPECT_EQ(tilt.find("turn mirror1 back by"), std::string::npos) << out;
  EXPECT_NE(tilt.find("mirror1.rx ~ cy correlation +0.999"), std::string::npos) << out;
  EXPECT_NE(tilt.find("not separable from the camera's rotation"), std::string::npos) << out;
  // A PASS gets no correction.
  EXPECT_EQ(LinesAfterRow(out, "mirror1.axial").find("move"), std::string::npos) << out;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace omni
