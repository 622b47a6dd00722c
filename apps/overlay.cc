#include "apps/overlay.h"

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <map>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "detectors/common/views.h"

namespace omni::apps {
namespace {

const cv::Scalar kRing1(0, 220, 0), kRing2(255, 0, 255), kLip(0, 255, 255), kBoundary(255, 255, 0);

// Text over a one-pixel dark outline, readable on bright squares and on the dark rim alike.
void Text(cv::Mat* out, const std::string& text, cv::Point at, double scale, const cv::Scalar& colour) {
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  const int thick = std::max(1, static_cast<int>(std::lround(scale * 1.5)));
  cv::putText(*out, text, at, font, scale, cv::Scalar(0, 0, 0), thick + 2, cv::LINE_AA);
  cv::putText(*out, text, at, font, scale, colour, thick, cv::LINE_AA);
}

void Legend(cv::Mat* out, double s) {
  const std::pair<cv::Scalar, const char*> rows[] = {
      {kRing1, "corner in ring 1 (mirror 1): x and id"},
      {kRing2, "corner in ring 2 (mirror 2): x and id"},
      {kLip, "lip edge point"},
      {kBoundary, "ring boundary (the model's)"}};
  const double scale = 0.45 * s;
  const int line = static_cast<int>(std::lround(18 * s)), pad = static_cast<int>(std::lround(6 * s));
  int width = 0;
  for (const auto& [colour, text] : rows) {
    int base = 0;
    width = std::max(width, cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &base).width);
  }
  const int mark = line;
  const cv::Rect box(0, 0, pad * 3 + mark + width, pad * 2 + line * 4);
  cv::Mat roi = (*out)(box & cv::Rect(0, 0, out->cols, out->rows));
  roi *= 0.3;  // darkened, the photo still faintly behind
  for (int k = 0; k < 4; ++k) {
    const cv::Point centre(pad + mark / 2, pad + line * k + line / 2);
    if (k < 2) {
      cv::drawMarker(*out, centre, rows[k].first, cv::MARKER_CROSS, mark * 2 / 3, 1);
    } else if (k == 2) {
      for (int d = -mark / 3; d <= mark / 3; d += 3) out->at<cv::Vec3b>(centre + cv::Point(d, 0)) =
          cv::Vec3b(0, 255, 255);
    } else {
      cv::line(*out, centre - cv::Point(mark / 3, 0), centre + cv::Point(mark / 3, 0), kBoundary, 1);
    }
    Text(out, rows[k].second, cv::Point(pad * 2 + mark, pad + line * k + line * 3 / 4), scale,
         rows[k].first);
  }
}

}  // namespace

std::vector<size_t> SpreadLabels(const std::vector<cv::Point2d>& anchors, double min_px) {
  std::vector<size_t> kept;
  for (size_t i = 0; i < anchors.size(); ++i) {
    bool free = true;
    for (size_t k : kept) {
      const cv::Point2d d = anchors[i] - anchors[k];
      if (d.x * d.x + d.y * d.y < min_px * min_px) {
        free = false;
        break;
      }
    }
    if (free) kept.push_back(i);
  }
  return kept;
}

cv::Mat DrawOverlay(const cv::Mat& image, const detectors::RingLayout& layout,
                    const ImageObservations& det, const std::vector<TargetSpec>& targets) {
  cv::Mat out;
  if (image.channels() == 1) {
    cv::cvtColor(detectors::ToGrey(image), out, cv::COLOR_GRAY2BGR);
  } else {
    image.convertTo(out, CV_8U, image.depth() == CV_16U ? 1.0 / 257.0 : 1.0);
    if (out.channels() == 4) cv::cvtColor(out, out, cv::COLOR_BGRA2BGR);
  }
  const double s = std::max(0.5, out.cols / 1280.0);
  for (const detectors::RingBoundary* b : {&layout.hole, &layout.reflex_edge, &layout.mirror1_cut,
                                           &layout.mirror1_rim, &layout.mirror2_rim}) {
    std::vector<cv::Point> curve;
    for (size_t k = 0; k < b->radius.size(); ++k) {
      const double phi = -M_PI + 2 * M_PI * k / b->radius.size();
      curve.emplace_back(cvRound(layout.centre.x() + b->radius[k] * std::cos(phi)),
                         cvRound(layout.centre.y() + b->radius[k] * std::sin(phi)));
    }
    if (!curve.empty()) cv::polylines(out, curve, true, kBoundary, 1, cv::LINE_AA);
  }
  const cv::Rect frame(0, 0, out.cols, out.rows);
  for (const auto& lip : det.lips) {
    for (const auto& p : lip.points) {
      const cv::Point q(cvRound(p.x()), cvRound(p.y()));
      if (frame.contains(q)) out.at<cv::Vec3b>(q) = cv::Vec3b(0, 255, 255);
    }
  }
  // Corners: crosses, then per board (target, ring) its name once, beside its corners.
  std::map<std::pair<int, int>, std::vector<const CornerObservation*>> boards;
  for (const auto& c : det.corners) {
    const cv::Scalar colour = c.mirror == Mirror::kOne ? kRing1 : kRing2;
    cv::drawMarker(out, cv::Point(cvRound(c.pixel.x()), cvRound(c.pixel.y())), colour,
                   cv::MARKER_CROSS, 5, 1);
    boards[{c.target, MirrorIndex(c.mirror)}].push_back(&c);
  }
  const double id_scale = 0.35 * s, name_scale = 0.5 * s;
  std::vector<cv::Point2d> anchors;
  std::vector<std::pair<std::string, cv::Scalar>> labels;
  std::vector<cv::Rect> names;  // where the boards' names went
  for (const auto& [key, corners] : boards) {
    const cv::Scalar colour = key.second == 1 ? kRing1 : kRing2;
    Eigen::Vector2d lo = corners[0]->pixel, hi = lo;
    for (const CornerObservation* c : corners) {
      lo = lo.cwiseMin(c->pixel);
      hi = hi.cwiseMax(c->pixel);
    }
    const std::string name =
        "T" + std::to_string(key.first) +
        (key.first >= 0 && key.first < static_cast<int>(targets.size())
             ? " " + TargetName(targets[key.first])
             : std::string());
    // Below the board, else above it, else right of it: where no other board's name is.
    int base = 0;
    const cv::Size size = cv::getTextSize(name, cv::FONT_HERSHEY_SIMPLEX, name_scale, 1, &base);
    const cv::Point below(cvRound(lo.x()), cvRound(hi.y() + 16 * s)),
        above(cvRound(lo.x()), cvRound(lo.y() - 8 * s)),
        right(cvRound(hi.x() + 8 * s), cvRound(0.5 * (lo.y() + hi.y())));
    cv::Point at = below;
    for (const cv::Point& candidate : {below, above, right}) {
      const cv::Rect box(candidate.x, candidate.y - size.height, size.width, size.height + base);
      if (std::none_of(names.begin(), names.end(), [&](const cv::Rect& r) { return (r & box).area() > 0; })) {
        at = candidate;
        break;
      }
    }
    names.emplace_back(at.x, at.y - size.height, size.width, size.height + base);
    Text(&out, name, at, name_scale, colour);
    for (const CornerObservation* c : corners) {
      anchors.emplace_back(c->pixel.x(), c->pixel.y());
      labels.emplace_back(std::to_string(c->id), colour);
    }
  }
  // An id's label needs about three digits' width around its corner to be read.
  for (size_t i : SpreadLabels(anchors, 24 * s)) {
    Text(&out, labels[i].first, cv::Point(cvRound(anchors[i].x + 3), cvRound(anchors[i].y - 3)),
         id_scale, labels[i].second);
  }
  Legend(&out, s);
  return out;
}

cv::Rect DrawColourBar(cv::Mat* image, int colormap, double max_value, const std::string& unit,
                       const std::string& title) {
  const double s = std::max(0.5, image->cols / 1280.0);
  const int width = static_cast<int>(std::lround(16 * s)), height = static_cast<int>(std::lround(200 * s));
  const int margin = static_cast<int>(std::lround(12 * s));
  const cv::Rect bar(image->cols - margin - width, margin + static_cast<int>(std::lround(24 * s)),
                     width, height);
  cv::Mat ramp(height, width, CV_8U);
  for (int v = 0; v < height; ++v) ramp.row(v).setTo(255 - 255 * v / std::max(1, height - 1));
  cv::Mat coloured;
  cv::applyColorMap(ramp, coloured, colormap);
  coloured.copyTo((*image)(bar));
  cv::rectangle(*image, bar, cv::Scalar(255, 255, 255), 1);
  char top[48];
  std::snprintf(top, sizeof top, "%.3g %s", max_value, unit.c_str());
  const double scale = 0.45 * s;
  const auto right_aligned = [&](const std::string& text, int y) {
    int base = 0;
    const int w = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &base).width;
    Text(image, text, cv::Point(bar.x - w - margin / 2, y), scale, cv::Scalar(255, 255, 255));
  };
  right_aligned(top, bar.y + static_cast<int>(std::lround(10 * s)));
  right_aligned("0 " + unit, bar.y + bar.height);
  right_aligned(title, bar.y - static_cast<int>(std::lround(8 * s)));
  return bar;
}

}  // namespace omni::apps
