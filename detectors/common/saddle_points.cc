#include "detectors/common/saddle_points.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "detectors/common/option_check.h"

namespace omni::detectors {

// Saddle points of the view: local maxima of Ixy^2 - Ixx Iyy (positive where the Hessian is
// indefinite, i.e. at X-junctions) above the strength of a saddle of `min_contrast` grey levels.
std::string SaddleOptions::Check() const {
  if (!(sigma > 0)) return OptionError("sigma", "a smoothing > 0 view px", sigma);
  if (!(min_contrast > 0)) return OptionError("min_contrast", "grey levels > 0", min_contrast);
  if (!(balance > 0)) return OptionError("balance", "a ratio > 0", balance);
  if (!(relative_contrast >= 0)) return OptionError("relative_contrast", "a fraction >= 0", relative_contrast);
  if (!(min_contrast_floor > 0)) return OptionError("min_contrast_floor", "grey levels > 0", min_contrast_floor);
  if (!(merge_sigmas >= 0)) return OptionError("merge_sigmas", "a distance >= 0 blurred sigmas", merge_sigmas);
  if (min_saddles < 1) return OptionError("min_saddles", "at least 1", min_saddles);
  return "";
}

namespace {

// Of saddle points nearer each other than `radius` with the same sign of Ixy, the strongest:
// the response of a junction whose edges cross obliquely peaks twice, either side of its centre
// along the acute angle's bisector (Mei's photos: ~4 view px apart at 1.4 px of blur), which
// halved the regions' spacing and with it the X-junction test's circle. The twin peaks share
// their junction's Ixy sign; a chessboard's neighbouring junctions have opposite signs (its
// squares alternate), so small squares' junctions closer than `radius` stay apart (the webcam
// preset's ring 1 at 1.2 MP: 6 view px squares under 3 blurred sigmas of 2.1 px lost half
// their junctions to their neighbours).
std::vector<cv::Point2f> KeepStrongest(const std::vector<cv::Point2f>& points,
                                       const std::vector<float>& strengths,
                                       const std::vector<bool>& positive_ixy, double radius) {
  std::vector<int> order(points.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return strengths[a] > strengths[b]; });
  std::vector<cv::Point2f> kept;
  const double r2 = radius * radius;
  std::vector<int> kept_index;
  for (int i : order) {
    bool near = false;
    for (int k : kept_index) {
      const cv::Point2f d = points[k] - points[i];
      if (d.dot(d) < r2 && positive_ixy[k] == positive_ixy[i]) {
        near = true;
        break;
      }
    }
    if (!near) {
      kept_index.push_back(i);
      kept.push_back(points[i]);
    }
  }
  std::sort(kept.begin(), kept.end(), [](const cv::Point2f& a, const cv::Point2f& b) {
    return a.y != b.y ? a.y < b.y : a.x < b.x;
  });
  return kept;
}

// Whether the grey levels on a circle of `radius` about (x, y) alternate dark, light, dark,
// light with opposite sectors alike (two straight edges crossing there) and span at least
// `min_contrast`. Outside the image: false.
bool ClearXJunction(const cv::Mat& grey, int x, int y, double radius, double min_contrast) {
  constexpr int kSamples = 24;
  std::array<float, kSamples> v;
  for (int k = 0; k < kSamples; ++k) {
    const double a = 2 * M_PI * k / kSamples;
    const int px = static_cast<int>(std::lround(x + radius * std::cos(a)));
    const int py = static_cast<int>(std::lround(y + radius * std::sin(a)));
    if (px < 0 || py < 0 || px >= grey.cols || py >= grey.rows) return false;
    v[k] = grey.at<uchar>(py, px);
  }
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  if (*hi - *lo < min_contrast) return false;
  const float mid = 0.5f * (*lo + *hi);
  int changes = 0, asymmetric = 0;
  for (int k = 0; k < kSamples; ++k) changes += (v[k] > mid) != (v[(k + 1) % kSamples] > mid);
  for (int k = 0; k < kSamples / 2; ++k) asymmetric += (v[k] > mid) != (v[k + kSamples / 2] > mid);
  return changes == 4 && asymmetric <= 3;
}

}  // namespace

std::vector<cv::Point2f> SaddlePoints(const RingView& view, const SaddleOptions& options) {
  if (const std::string error = options.Check(); !error.empty()) throw std::invalid_argument(error);
  const double blur = view.blur_sigma.value_or(-1);
  RingView::SaddleCache& cache = view.saddle_cache;
  if (cache.image_data != nullptr && cache.image_data == view.image.data &&
      cache.image_size == view.image.size() &&
      cache.sigma == options.sigma && cache.min_contrast == options.min_contrast &&
      cache.balance == options.balance && cache.blur == blur &&
      cache.relative_contrast == options.relative_contrast &&
      cache.min_contrast_floor == options.min_contrast_floor && cache.merge_sigmas == options.merge_sigmas) {
    return cache.points;
  }
  cache = {};
  cv::Mat f, ixx, iyy, ixy;
  view.image.convertTo(f, CV_32F);
  cv::GaussianBlur(f, f, cv::Size(0, 0), options.sigma);
  cv::Sobel(f, ixx, CV_32F, 2, 0, 3);
  cv::Sobel(f, iyy, CV_32F, 0, 2, 3);
  cv::Sobel(f, ixy, CV_32F, 1, 1, 3);
  // -det(H), kept only where the saddle is balanced (|trace| small against sqrt(-det)): an
  // X-junction's Hessian is [[a, b], [b, -a]]; blobs and edges of texture are not. Not next to
  // the view's invalid area (its edge is a strong false feature). One pass, no temporaries: this
  // runs on every view several times per image.
  // (A view cut to a crop keeps its whole view's mask: made afresh then.)
  const cv::Mat valid_inner = view.valid_for_saddles.size() == view.map_x.size()
                                  ? view.valid_for_saddles
                                  : SaddleValidMask(view.map_x);
  const float balance2 = static_cast<float>(options.balance * options.balance);
  cv::Mat response(f.size(), CV_32F);
  for (int y = 0; y < f.rows; ++y) {
    const float* xx = ixx.ptr<float>(y);
    const float* yy = iyy.ptr<float>(y);
    const float* xy = ixy.ptr<float>(y);
    const uchar* valid = valid_inner.ptr<uchar>(y);
    float* r = response.ptr<float>(y);
    for (int x = 0; x < f.cols; ++x) {
      const float det = xy[x] * xy[x] - xx[x] * yy[x];
      const float trace = xx[x] + yy[x];
      r[x] = valid[x] && !(trace * trace > balance2 * det) ? det : 0.0f;
    }
  }
  // An ideal saddle of contrast C blurred by sigma has Ixy = C / (pi sigma^2); the 3x3 Sobel
  // second derivatives carry a gain of 4 each. The view's own blur adds in quadrature (at least
  // 0.7 px: the sharpest a render's anti-aliasing and the view's resampling leave).
  const double blur2 = view.blur_sigma ? *view.blur_sigma * *view.blur_sigma : 0.5;
  const double s2 = options.sigma * options.sigma + std::max(0.5, blur2);
  // The response of a junction of contrast c: (4 c / (pi s2))^2.
  const auto response_of = [&](double contrast) {
    const double ixy = 4.0 * contrast / (M_PI * s2);
    return static_cast<float>(ixy * ixy);
  };
  const bool relative = options.relative_contrast > 0;
  const float threshold =
      response_of(relative ? std::min(options.min_contrast, options.min_contrast_floor) : options.min_contrast);
  // The junction's own contrast: the range of grey levels within 2 blurred sigmas of it.
  const int reach = static_cast<int>(std::ceil(2 * std::sqrt(s2)));
  const auto local_range = [&](int x, int y) {
    int lo = 255, hi = 0;
    for (int yy = std::max(0, y - reach); yy <= std::min(view.image.rows - 1, y + reach); ++yy) {
      const uchar* g = view.image.ptr<uchar>(yy);
      for (int xx = std::max(0, x - reach); xx <= std::min(view.image.cols - 1, x + reach); ++xx) {
        lo = std::min(lo, static_cast<int>(g[xx]));
        hi = std::max(hi, static_cast<int>(g[xx]));
      }
    }
    return hi - lo;
  };
  // Local maxima over 5x5 (clipped at the view's border), tested only where the response passes
  // the threshold: a 5x5 dilation of the whole response was a seventh of this function.
  std::vector<cv::Point2f> points;
  std::vector<float> strengths;
  std::vector<bool> positive_ixy;
  for (int y = 0; y < response.rows; ++y) {
    const float* r = response.ptr<float>(y);
    for (int x = 0; x < response.cols; ++x) {
      if (!(r[x] > threshold)) continue;
      bool peak = true;
      for (int yy = std::max(0, y - 2); peak && yy <= std::min(response.rows - 1, y + 2); ++yy) {
        const float* n = response.ptr<float>(yy);
        for (int xx = std::max(0, x - 2); xx <= std::min(response.cols - 1, x + 2); ++xx) {
          if (n[xx] > r[x]) {
            peak = false;
            break;
          }
        }
      }
      if (!peak) continue;
      // A saddle under min_contrast counts only as a clear X-junction of its own contrast, read
      // on a circle 3 blurred sigmas out (clear of the blur): the relative test alone took
      // texture and noise (a 5 MP JPEG's blurred inner ring: ~2000 saddles per view; at 2
      // sigmas Mei's photo 10 lost its board).
      if (relative && r[x] <= response_of(options.min_contrast) &&
          (r[x] <= response_of(options.relative_contrast * local_range(x, y)) ||
           !ClearXJunction(view.image, x, y, 3 * std::sqrt(s2), options.min_contrast_floor))) {
        continue;
      }
      points.emplace_back(x, y);
      strengths.push_back(r[x]);
      positive_ixy.push_back(ixy.at<float>(y, x) > 0);
    }
  }
  if (options.merge_sigmas > 0) {
    points = KeepStrongest(points, strengths, positive_ixy, options.merge_sigmas * std::sqrt(s2));
  }
  if (!view.image.empty()) {
    cache = {view.image.data, view.image.size(), options.sigma, options.min_contrast,
             options.balance, blur, options.relative_contrast, options.min_contrast_floor, options.merge_sigmas, points};
  }
  return points;
}

namespace {
int Find(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

}  // namespace

// Groups saddle points into candidate board regions: a point links to another closer than 1.25
// times the smaller of their 4th-nearest-neighbour distances (a grid corner's 4th neighbour is at
// most 2 squares away; neighbouring boards are at least 3 squares apart with their margins).
std::vector<Region> Regions(const std::vector<cv::Point2f>& points, const cv::Size& size,
                            const SaddleOptions& options, double view_f) {
  const int n = static_cast<int>(points.size());
  // Buckets of kCell pixels; neighbours are searched within kReach buckets: ~9.4 degrees of the
  // view (48 px at the 293 px/rad of a 1280x960 image's views, never less), so that a near
  // board's squares link at any resolution (at 5 MP a 35 mm square at 0.4 m is ~60 view px).
  constexpr int kReach = 3;
  const int kCell = std::max(16, static_cast<int>(std::lround(0.164 * view_f / kReach)));
  const int bw = size.width / kCell + 1, bh = size.height / kCell + 1;
  std::vector<std::vector<int>> buckets(bw * bh);
  for (int i = 0; i < n; ++i) {
    buckets[static_cast<int>(points[i].y) / kCell * bw + static_cast<int>(points[i].x) / kCell].push_back(i);
  }
  auto for_neighbours = [&](int i, auto&& fn) {
    const int bx = static_cast<int>(points[i].x) / kCell, by = static_cast<int>(points[i].y) / kCell;
    for (int y = std::max(0, by - kReach); y <= std::min(bh - 1, by + kReach); ++y) {
      for (int x = std::max(0, bx - kReach); x <= std::min(bw - 1, bx + kReach); ++x) {
        for (int j : buckets[y * bw + x]) {
          if (j != i) fn(j, std::hypot(points[i].x - points[j].x, points[i].y - points[j].y));
        }
      }
    }
  };
  std::vector<double> nn4(n), nn1(n);
  for (int i = 0; i < n; ++i) {
    std::array<double, 4> b;
    b.fill(kCell * kReach);
    for_neighbours(i, [&](int, double d) {
      if (d < b[3]) {
        b[3] = d;
        std::sort(b.begin(), b.end());
      }
    });
    nn4[i] = b[3];
    nn1[i] = b[0];
  }
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  for (int i = 0; i < n; ++i) {
    for_neighbours(i, [&](int j, double d) {
      if (d <= 1.25 * std::min(nn4[i], nn4[j])) parent[Find(parent, i)] = Find(parent, j);
    });
  }
  std::vector<std::vector<int>> members(n);
  for (int i = 0; i < n; ++i) members[Find(parent, i)].push_back(i);
  std::vector<Region> regions;
  for (const auto& m : members) {
    if (static_cast<int>(m.size()) < options.min_saddles) continue;
    std::vector<double> spacing;
    float x0 = 1e9f, y0 = 1e9f, x1 = -1e9f, y1 = -1e9f;
    for (int i : m) {
      spacing.push_back(nn1[i]);
      x0 = std::min(x0, points[i].x);
      y0 = std::min(y0, points[i].y);
      x1 = std::max(x1, points[i].x);
      y1 = std::max(y1, points[i].y);
    }
    std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
    Region r;
    r.saddles = static_cast<int>(m.size());
    for (int i : m) r.points.push_back(points[i]);
    r.spacing = spacing[spacing.size() / 2];
    // The outer squares and a quiet zone lie about 1.5 squares beyond the inner corners; the
    // corner finder needs some background beyond them too.
    const int margin = static_cast<int>(std::ceil(2.5 * r.spacing + 8));
    r.full = cv::Rect(cv::Point(static_cast<int>(x0) - margin, static_cast<int>(y0) - margin),
                      cv::Point(static_cast<int>(x1) + margin + 1, static_cast<int>(y1) + margin + 1));
    r.rect = r.full & cv::Rect(0, 0, size.width, size.height);
    regions.push_back(r);
  }
  return regions;
}

}  // namespace omni::detectors
