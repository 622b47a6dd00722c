#include "print/target_sheet.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <utility>

#include <Eigen/Core>

#include "io/file_util.h"
#include "io/session_file.h"
#include "model/input_error.h"
#include "synthetic/tag_texture.h"

namespace omni::print {
namespace {

const std::vector<Paper>& Papers() {
  static const std::vector<Paper> papers = {{"A4", 210, 297},   {"A3", 297, 420},
                                            {"A2", 420, 594},   {"A1", 594, 841},
                                            {"A0", 841, 1189},  {"letter", 215.9, 279.4}};
  return papers;
}

std::string Mm(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", std::round(v * 10) / 10);
  return buf;
}

// The target in words, for the sheet's margin.
std::string Describe(const TargetSpec& t) {
  if (t.type == TargetType::kChessboard) {
    return "chessboard " + std::to_string(t.rows) + " x " + std::to_string(t.cols) +
           " inner corners, square " + Mm(t.square_mm) + " mm";
  }
  const int last = t.first_id + t.rows * t.cols - 1;
  return std::string(TargetTypeName(t.type)) + " " + std::to_string(t.rows) + " x " +
         std::to_string(t.cols) + " tags (tag36h11, ids " + std::to_string(t.first_id) + "-" +
         std::to_string(last) + "), tag " + Mm(t.tag_size_mm) + " mm, spacing " +
         io::FormatDouble(t.spacing);
}

// The texture's black pixels as rectangles: runs along each row, runs of the same columns in
// consecutive rows merged.
std::vector<RectMm> BlackRectangles(const cv::Mat& image, double mm_per_pixel, double x0,
                                    double y0) {
  std::vector<RectMm> done;
  std::map<std::pair<int, int>, RectMm> open;  // (first column, end column) -> rectangle
  for (int r = 0; r <= image.rows; ++r) {
    std::map<std::pair<int, int>, RectMm> next;
    for (int c = 0; r < image.rows && c < image.cols;) {
      if (image.at<uint8_t>(r, c) != 0) {
        ++c;
        continue;
      }
      int end = c;
      while (end < image.cols && image.at<uint8_t>(r, end) == 0) ++end;
      const auto key = std::make_pair(c, end);
      auto it = open.find(key);
      if (it != open.end()) {
        it->second.height += mm_per_pixel;
        next.emplace(key, it->second);
        open.erase(it);
      } else {
        next.emplace(key, RectMm{x0 + c * mm_per_pixel, y0 + r * mm_per_pixel,
                                 (end - c) * mm_per_pixel, mm_per_pixel});
      }
      c = end;
    }
    for (const auto& [key, rect] : open) done.push_back(rect);
    open = std::move(next);
  }
  return done;
}

}  // namespace

bool PaperByName(const std::string& name, Paper* paper) {
  for (const Paper& p : Papers()) {
    if (p.name == name) {
      *paper = p;
      return true;
    }
  }
  return false;
}

std::string PaperNames() {
  std::string names;
  for (const Paper& p : Papers()) names += (names.empty() ? "" : ", ") + p.name;
  return names;
}

TargetPage LayoutTargetPage(const TargetSpec& target, const Paper& paper) {
  synthetic::TagTexture texture;
  try {
    texture = synthetic::SheetTexture(target);
  } catch (const std::invalid_argument& e) {
    std::string why = e.what();
    throw InputError("target: " + why.substr(why.find(':') + 2));
  }
  // The black cells on the sheet (mm from the sheet's corner); the paper's white around them is
  // the quiet zone, at least the page margin.
  std::vector<RectMm> cells = BlackRectangles(texture.image, texture.mm_per_pixel, 0, 0);
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const RectMm& r : cells) {
    x0 = std::min(x0, r.x);
    y0 = std::min(y0, r.y);
    x1 = std::max(x1, r.x + r.width);
    y1 = std::max(y1, r.y + r.height);
  }
  const double w = x1 - x0, h = y1 - y0;
  auto fits = [&](double pw, double ph) {
    return w <= pw - 2 * kMarginMm + 1e-9 && h <= ph - kMarginMm - kFooterMm + 1e-9;
  };
  TargetPage page;
  if (fits(paper.width_mm, paper.height_mm)) {
    page.width_mm = paper.width_mm;
    page.height_mm = paper.height_mm;
  } else if (fits(paper.height_mm, paper.width_mm)) {
    page.width_mm = paper.height_mm;
    page.height_mm = paper.width_mm;
  } else {
    // The smallest paper that holds it, either way up.
    const Paper* fitting = nullptr;
    for (const Paper& p : Papers()) {
      if ((fits(p.width_mm, p.height_mm) || fits(p.height_mm, p.width_mm)) &&
          (!fitting || p.width_mm * p.height_mm < fitting->width_mm * fitting->height_mm)) {
        fitting = &p;
      }
    }
    throw InputError("target: the pattern is " + Mm(w) + " x " + Mm(h) + " mm; " + paper.name +
                     " (" + Mm(paper.width_mm) + " x " + Mm(paper.height_mm) + " mm) holds at most " +
                     Mm(paper.width_mm - 2 * kMarginMm) + " x " +
                     Mm(paper.height_mm - kMarginMm - kFooterMm) + " mm either way up: " +
                     (fitting ? "--paper " + fitting->name + " holds it"
                              : "no paper of " + PaperNames() + " holds it") +
                     ", or a smaller --size or fewer rows/cols");
  }
  const double area_h = page.height_mm - kMarginMm - kFooterMm;
  page.pattern = {(page.width_mm - w) / 2, kMarginMm + (area_h - h) / 2, w, h};
  const Eigen::Vector4d bounds = SheetBounds(target);
  page.sheet = {page.pattern.x - x0, page.pattern.y - y0, bounds[2] - bounds[0],
                bounds[3] - bounds[1]};
  for (RectMm r : cells) {
    r.x += page.sheet.x;
    r.y += page.sheet.y;
    page.black.push_back(r);
  }
  // Footer: three lines of text, then the bar with a tick every 10 mm.
  const double footer = page.height_mm - kFooterMm;
  page.text_x_mm = kMarginMm;
  page.text_y_mm = footer + 4;
  page.text_size_mm = 2.8;
  page.text = {"omnistereo target: " + Describe(target),
               "session entry:  " + io::TargetEntryText(target),
               "Print at 100% (no 'fit to page'), glue flat on a rigid board; the bar is 100 mm:"};
  const double bar_y = page.height_mm - 6;
  page.scale_bar.push_back({kMarginMm, bar_y, 100, 1.2});
  for (int k = 0; k <= 10; ++k) page.scale_bar.push_back({kMarginMm + 10 * k - 0.15, bar_y - 2.5, 0.3, 2.5});
  page.scale_bar.back().x -= 0.15;   // the end ticks stay inside the 100 mm
  page.scale_bar[1].x += 0.15;
  return page;
}

}  // namespace omni::print
