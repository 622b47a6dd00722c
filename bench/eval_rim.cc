// The mirror rim finder (detectors/lips/mirror_rim.h) on a folder of real photos of a
// single-mirror camera: the circle from all photos together (their median) and from each alone,
// and how far each photo's circle lies from the common one (the rim is fixed: the spread is the
// finder's repeatability). A timed run, not a test:
//   eval_rim PHOTO...            (8- or 16-bit, grey or colour; one size)
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "detectors/lips/mirror_rim.h"
#include "io/image_file.h"

namespace {

cv::Mat Grey(const std::string& path) {
  cv::Mat img = omni::io::ReadImage(path);
  if (img.channels() == 1) return img;
  cv::Mat grey;
  cv::cvtColor(img, grey, img.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return grey;
}

void Print(const char* name, const omni::detectors::MirrorRim& rim, double ms) {
  std::printf("%-28s %s centre (%8.2f, %8.2f) radius %7.2f px  rms %.2f px  coverage %3.0f%%  "
              "contrast %5.1f  %6.1f ms%s%s\n",
              name, rim.found ? "found" : "NOT  ", rim.centre.x(), rim.centre.y(), rim.radius_px,
              rim.rms_px, 100 * rim.coverage, rim.contrast, ms, rim.found ? "" : "  ",
              rim.why.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: eval_rim PHOTO...\n");
    return 2;
  }
  try {
    std::vector<cv::Mat> photos;
    for (int i = 1; i < argc; ++i) photos.push_back(Grey(argv[i]));
    using Clock = std::chrono::steady_clock;
    auto t0 = Clock::now();
    const omni::detectors::MirrorRim all = omni::detectors::FindMirrorRim(photos);
    Print("all photos (median)", all,
          std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    double worst = 0;
    for (int i = 1; i < argc; ++i) {
      t0 = Clock::now();
      const omni::detectors::MirrorRim one = omni::detectors::FindMirrorRim({photos[i - 1]});
      const std::string name = std::string(argv[i]).substr(std::string(argv[i]).rfind('/') + 1);
      Print(name.c_str(), one, std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      if (one.found && all.found) {
        worst = std::max(worst, (one.centre - all.centre).norm() + std::abs(one.radius_px - all.radius_px));
      }
    }
    std::printf("largest single-photo departure from the common circle (centre + radius): %.2f px\n",
                worst);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "eval_rim: %s\n", e.what());
    return 2;
  }
  return 0;
}
