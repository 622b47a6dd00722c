// Render bias of chessboard corners: are the X-junctions in POV-Ray renders where the model says?
// A controlled experiment (a timed run, not a test; synthetic/render_bias.h): a few chessboards
// rendered in small windows by POV-Ray and by the exact box-filtered oracle; cv::cornerSubPix
// started at the true corners with the detector's window (detectors/common/corner_refine.h
// RefineFromStarts; lines marked "+cc" add its curvature-bias correction, as the chessboard
// detector does); the mean radial and tangential offsets per ring then split the bias into
//   detector: cornerSubPix on the oracle image (exact pixels, no renderer involved);
//   renderer: POV-Ray image minus oracle (same refinement, same corners).
//
// Usage: render_bias MODEL OUT_DIR MODE CONFIG...
//   MODE: rig (4 boards at 700 and 1200 mm, both rings) or direct (draw_mirrors off, 2 tilted
//         boards in front of the pinhole: POV-Ray's camera and texture conventions alone).
//   CONFIG: oracle | noaa | aa3 | aa4 | aa5 | am1 | ss3 (3x focal and pixels, no AA, INTER_AREA
//           down by 3) | ss3aa (the same with the default AA) | raw:<povray AA flags>.
//   Environment: HALF (fixed cornerSubPix half-window instead of the detector's), SAMPLES (oracle
//   rays per pixel side, 8), RANGES ("700,1200") and PER (boards per range, 2) for rig mode.
//   Writes oracle.png, <config>.png and <config>_diff.png (128 + 4 (render - oracle), first window).
// Finding (docs in the session report): every POV-Ray setting agrees with the oracle to within
// 0.003 px radially; the oracle itself shows the +0.02 px outward bias, which the curvature model
// (synthetic/render_bias.h CurvatureModelText) reproduces per ring: it is cornerSubPix's
// straight-edge assumption, not the renderer. The experiment itself: synthetic/render_bias.h.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/common/corner_refine.h"
#include "io/model_file.h"
#include "synthetic/render_bias.h"

using namespace omni;

namespace {

// The detector's raw refinement started at the true corners (with `correct` also its
// curvature-bias correction), per ring; *errors per corner.
std::map<int, synthetic::RingBias> Measure(const synthetic::BiasSetup& s, const cv::Mat& image,
                                           int half_override, bool correct,
                                           std::vector<Eigen::Vector2d>* errors) {
  std::vector<detectors::CornerStart> starts;
  for (const synthetic::BiasCorner& c : s.corners) {
    starts.push_back(
        {c.board, c.id, c.truth, synthetic::DetectorHalfWindow(c.side, half_override)});
  }
  *errors = synthetic::ErrorsOf(s, detectors::RefineFromStarts(image, s.boards, starts, correct));
  return synthetic::BiasByRing(s, *errors);
}

// RANGES="700,1200" (rig mode's board ranges, mm).
std::vector<double> RangesFromEnvironment() {
  std::vector<double> ranges = {700, 1200};
  if (const char* e = std::getenv("RANGES")) {
    ranges.clear();
    for (std::string t(e); !t.empty();) {
      const auto k = t.find(',');
      ranges.push_back(std::atof(t.substr(0, k).c_str()));
      t = k == std::string::npos ? "" : t.substr(k + 1);
    }
  }
  return ranges;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: render_bias MODEL OUT_DIR rig|direct CONFIG...\n");
    return 2;
  }
  const std::string dir = argv[2];
  std::filesystem::create_directories(dir);
  const synthetic::BiasSetup s = synthetic::MakeBiasSetup(
      io::ReadModelFile(argv[1]), std::string(argv[3]) == "direct", RangesFromEnvironment(),
      std::getenv("PER") ? std::atoi(std::getenv("PER")) : 2);
  std::printf("%s", synthetic::WindowsLine(s).c_str());
  const int half = std::getenv("HALF") ? std::atoi(std::getenv("HALF")) : 0;
  const int samples = std::getenv("SAMPLES") ? std::atoi(std::getenv("SAMPLES")) : 8;

  auto t0 = std::chrono::steady_clock::now();
  cv::Mat oracle = synthetic::RenderOracle(s, samples, 0);
  const double oracle_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  cv::imwrite(dir + "/oracle.png", oracle);
  if (const char* b = std::getenv("ORACLE_BLUR")) {  // Gaussian sigma (px): a blurrier camera
    const cv::Mat sharp = oracle.clone();
    cv::GaussianBlur(sharp, oracle, cv::Size(0, 0), std::atof(b));
  }
  std::vector<Eigen::Vector2d> e_oracle, e;
  const auto print = [](const std::string& text) { std::printf("%s", text.c_str()); };
  print(synthetic::BiasLine("oracle", Measure(s, oracle, half, false, &e_oracle), oracle_s));
  print(synthetic::CurvatureModelText(s, e_oracle, half));
  print(synthetic::BiasLine("oracle+cc", Measure(s, oracle, half, true, &e), -1));
  for (int i = 4; i < argc; ++i) {
    const std::string config = argv[i];
    double seconds = 0;
    cv::Mat img;
    try {
      img = synthetic::RenderPovWindows(s, config, dir, &seconds);
    } catch (const std::exception& error) {
      std::fprintf(stderr, "%s\n", error.what());
      return dynamic_cast<const std::invalid_argument*>(&error) ? 2 : 1;
    }
    cv::imwrite(dir + "/" + config.substr(0, 8) + ".png", img);
    print(synthetic::BiasLine(config, Measure(s, img, half, false, &e), seconds));
    print(synthetic::BiasLine("  -oracle",
                              synthetic::BiasByRing(s, synthetic::Difference(e, e_oracle)), -1));
    print(synthetic::BiasLine(config + "+cc", Measure(s, img, half, true, &e), -1));
    cv::Mat diff;
    const std::string agreement = synthetic::PixelAgreementText(s, img, oracle, &diff);
    cv::imwrite(dir + "/" + config.substr(0, 8) + "_diff.png", diff);
    print(agreement);
  }
  return 0;
}
