#include "detectors/chessboard/junction_grid.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include <opencv2/imgproc.hpp>

namespace omni::detectors {
namespace {

// Bilinear grey level at p; nullopt outside the image.
std::optional<float> Sample(const cv::Mat& grey, const cv::Point2f& p) {
  if (!(p.x >= 0 && p.y >= 0 && p.x <= grey.cols - 2 && p.y <= grey.rows - 2)) return std::nullopt;
  const int x0 = static_cast<int>(p.x), y0 = static_cast<int>(p.y);
  const float fx = p.x - x0, fy = p.y - y0;
  return (1 - fy) * ((1 - fx) * grey.at<uchar>(y0, x0) + fx * grey.at<uchar>(y0, x0 + 1)) +
         fy * ((1 - fx) * grey.at<uchar>(y0 + 1, x0) + fx * grey.at<uchar>(y0 + 1, x0 + 1));
}

GridExtent GrowGrid(const cv::Mat& grey, const std::vector<cv::Point2f>& p, double spacing, int seed,
                    double min_contrast) {
  const auto edge = [&](int i, int j) { return IsEdgeStep(grey, p[i], p[j], min_contrast); };
  const int n = static_cast<int>(p.size());
  const auto nearest = [&](const cv::Point2f& at, double within, const std::vector<int>& taken) {
    int best = -1;
    double best_d = within;
    for (int i = 0; i < n; ++i) {
      const double d = cv::norm(p[i] - at);
      if (d < best_d && taken[i] < 0) {
        best_d = d;
        best = i;
      }
    }
    return best;
  };
  // The seed's two grid steps: its nearest neighbour along an edge and the nearest one along
  // an edge across it, which on a board seen obliquely (held flat below a single mirror: Mei's
  // photos, squares 2-3 times longer one way than the other in the view) lies several times
  // farther than the first.
  int a = -1;
  double best_a = 2.5 * spacing;
  for (int i = 0; i < n; ++i) {
    const double len = cv::norm(p[i] - p[seed]);
    if (i != seed && len < best_a && edge(seed, i)) {
      best_a = len;
      a = i;
    }
  }
  if (a < 0) return {};
  const cv::Point2f step_a = p[a] - p[seed];
  int b = -1;
  double best_b = std::max(1.6 * spacing, 3.5 * cv::norm(step_a));
  for (int i = 0; i < n; ++i) {
    if (i == seed || i == a) continue;
    const cv::Point2f d = p[i] - p[seed];
    const double len = cv::norm(d);
    const double cosine = std::abs(d.dot(step_a)) / (len * cv::norm(step_a) + 1e-9);
    if (cosine < 0.85 && len < best_b && edge(seed, i)) {
      best_b = len;
      b = i;
    }
  }
  if (b < 0) return {};
  // Breadth-first growth: grid coordinates and the two local steps of each assigned point.
  std::vector<int> order(n, -1);
  std::vector<cv::Point> coord(n);
  std::vector<std::array<cv::Point2f, 2>> steps(n);
  std::vector<int> queue{seed};
  order[seed] = 0;
  steps[seed] = {step_a, p[b] - p[seed]};
  int min_a = 0, max_a = 0, min_b = 0, max_b = 0;
  for (size_t q = 0; q < queue.size(); ++q) {
    const int i = queue[q];
    for (int dir = 0; dir < 4; ++dir) {
      const int axis = dir / 2;
      const float sign = dir % 2 ? -1.f : 1.f;
      const cv::Point2f step = sign * steps[i][axis];
      const int j = nearest(p[i] + step, 0.3 * cv::norm(step), order);
      if (j < 0 || !edge(i, j)) continue;
      order[j] = static_cast<int>(queue.size());
      queue.push_back(j);
      coord[j] = coord[i] + (axis == 0 ? cv::Point(dir % 2 ? -1 : 1, 0) : cv::Point(0, dir % 2 ? -1 : 1));
      steps[j] = steps[i];
      steps[j][axis] = sign * (p[j] - p[i]);
      min_a = std::min(min_a, coord[j].x);
      max_a = std::max(max_a, coord[j].x);
      min_b = std::min(min_b, coord[j].y);
      max_b = std::max(max_b, coord[j].y);
    }
  }
  GridExtent out;
  out.a = max_a - min_a + 1;
  out.b = max_b - min_b + 1;
  out.count = static_cast<int>(queue.size());
  for (int i : queue) {
    out.points.push_back(p[i]);
    out.coords.push_back(coord[i] - cv::Point(min_a, min_b));
  }
  out.box = cv::boundingRect(out.points);
  return out;
}


}  // namespace

bool IsEdgeStep(const cv::Mat& grey, const cv::Point2f& p, const cv::Point2f& q, double min_contrast) {
  const cv::Point2f d = q - p;
  const float len = std::hypot(d.x, d.y);
  if (!(len > 0)) return false;
  const cv::Point2f middle = 0.5f * (p + q);
  const cv::Point2f side = std::max(1.5f, 0.2f * len) / len * cv::Point2f(-d.y, d.x);
  const auto m = Sample(grey, middle), l = Sample(grey, middle + side), r = Sample(grey, middle - side);
  if (!m || !l || !r) return false;
  const float contrast = std::abs(*l - *r);
  // The middle of an edge lies between its two sides (at their mean, blurred evenly).
  return contrast >= min_contrast && std::abs(*m - 0.5f * (*l + *r)) <= 0.35f * contrast;
}

// The grid grown from the junction nearest the region's centroid; where that seed's steps are
// wrong (a stray junction beside the board, or a neighbour the saddle test missed), growth stops
// after a few points, so the next-nearest seeds are tried too (at most 5) and the largest grid
// wins. realistic camera, RMSE scene through the ideal rig: a ring-2 board's 22 junctions grew to
// 5 from the centroid's seed, which ruled out every pattern search (see SearchRegion).
GridExtent MeasureGrid(const cv::Mat& grey, const std::vector<cv::Point2f>& p, double spacing,
                       double min_contrast) {
  const int n = static_cast<int>(p.size());
  if (n < 4) return {};
  cv::Point2f centroid(0, 0);
  for (const auto& q : p) centroid += q * (1.0f / n);
  std::vector<int> seeds(n);
  for (int i = 0; i < n; ++i) seeds[i] = i;
  std::sort(seeds.begin(), seeds.end(), [&](int a, int b) {
    return cv::norm(p[a] - centroid) < cv::norm(p[b] - centroid);
  });
  GridExtent best;
  for (int k = 0; k < std::min(n, 5); ++k) {
    GridExtent grid = GrowGrid(grey, p, spacing, seeds[k], min_contrast);
    if (grid.count > best.count) best = std::move(grid);
    if (2 * best.count > n) break;  // the seed's grid holds most junctions: the usual case
  }
  return best;
}

bool GridNearPattern(const GridExtent& grid, int rows, int cols, int tolerance) {
  return (std::abs(rows - grid.a) <= tolerance && std::abs(cols - grid.b) <= tolerance) ||
         (std::abs(rows - grid.b) <= tolerance && std::abs(cols - grid.a) <= tolerance);
}

bool GridFitsInPattern(const GridExtent& grid, int rows, int cols, int extra) {
  return (grid.a <= rows + extra && grid.b <= cols + extra) || (grid.b <= rows + extra && grid.a <= cols + extra);
}

int PatternDistance(const GridExtent& grid, int rows, int cols) {
  return std::min(std::abs(rows - grid.a) + std::abs(cols - grid.b), std::abs(rows - grid.b) + std::abs(cols - grid.a));
}

}  // namespace omni::detectors
