#include "detectors/chessboard/chessboard_trace.h"

#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <map>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace omni::detectors::trace {
namespace {

const char* Setting() { return std::getenv("OMNI_CHESSBOARD_TRACE"); }

int image_count = -1;
// The views drawn so far for the current image (written again as junctions are added).
std::map<int, cv::Mat> drawn;

std::string ViewPath(int view_index) {
  return std::string(Setting()) + "/view_" + std::to_string(image_count) + "_" +
         std::to_string(view_index) + ".png";
}

bool Folder() {
  const char* s = Setting();
  return s && *s && std::string(s) != "1";
}

}  // namespace

bool On() { return Setting() != nullptr; }

void Line(const char* format, ...) {
  if (!On()) return;
  std::fprintf(stderr, "chessboard: ");
  va_list args;
  va_start(args, format);
  std::vfprintf(stderr, format, args);
  va_end(args);
  std::fprintf(stderr, "\n");
}

void NextImage() {
  ++image_count;
  drawn.clear();
}

void View(int view_index, const cv::Mat& image, const std::vector<cv::Point2f>& saddles,
          const std::vector<cv::Rect>& regions) {
  if (!Folder()) return;
  cv::imwrite(ViewPath(view_index).replace(ViewPath(view_index).size() - 4, 4, "_clean.png"), image);
  cv::Mat out;
  cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
  for (const auto& p : saddles) cv::circle(out, p, 2, cv::Scalar(0, 0, 255), 1);
  for (const auto& r : regions) cv::rectangle(out, r, cv::Scalar(255, 128, 0), 1);
  drawn[view_index] = out;
  cv::imwrite(ViewPath(view_index), out);
}

void Junctions(int view_index, const std::vector<cv::Point2f>& junctions) {
  if (!Folder() || !drawn.count(view_index)) return;
  for (const auto& p : junctions) cv::circle(drawn[view_index], p, 4, cv::Scalar(0, 255, 0), 1);
  cv::imwrite(ViewPath(view_index), drawn[view_index]);
}

void Grid(int view_index, const std::vector<cv::Point2f>& points, const std::vector<cv::Point>& coords) {
  if (!Folder() || !drawn.count(view_index)) return;
  for (size_t i = 0; i < points.size() && i < coords.size(); ++i) {
    cv::putText(drawn[view_index], std::to_string(coords[i].x) + "," + std::to_string(coords[i].y),
                points[i] + cv::Point2f(2, -2), cv::FONT_HERSHEY_PLAIN, 0.6, cv::Scalar(255, 255, 0));
  }
  cv::imwrite(ViewPath(view_index), drawn[view_index]);
}

}  // namespace omni::detectors::trace
