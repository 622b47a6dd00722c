#include "detectors/common/corner_refine.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <opencv2/imgproc.hpp>

#include "detectors/common/junction_lm.h"

namespace omni::detectors {
namespace {

// Both RefineCornerInRaw and the bias model use exactly these settings.
const cv::TermCriteria kCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 1e-4);

// Signed offset of `d` (relative to the corner) from the parabola s t + s^2 / 2 k, positive on
// the side of the normal perp(t); near the corner it is the distance to the line.
double Side(const LocalLine& line, const Eigen::Vector2d& d) {
  const Eigen::Vector2d n(-line.tangent.y(), line.tangent.x());
  const double a = line.tangent.dot(d);
  return n.dot(d) - 0.5 * n.dot(line.curvature) * a * a;
}

// A predicted offset larger than this means the lines were taken from wrong neighbours (the
// bias itself is a few hundredths of a pixel): the corner is left uncorrected.
constexpr double kMaxBiasPx = 0.2;

}  // namespace

bool RefineCornerInRaw(const cv::Mat& grey, int half, Eigen::Vector2d* pixel) {
  if (pixel->x() < half + 2 || pixel->y() < half + 2 || pixel->x() > grey.cols - half - 3 ||
      pixel->y() > grey.rows - half - 3) {
    return false;
  }
  std::vector<cv::Point2f> p{cv::Point2f(static_cast<float>(pixel->x()), static_cast<float>(pixel->y()))};
  cv::cornerSubPix(grey, p, cv::Size(half, half), cv::Size(-1, -1), kCriteria);
  *pixel = Eigen::Vector2d(p[0].x, p[0].y);
  return true;
}

Eigen::Vector2d PredictedRefineBias(const Eigen::Vector2d& corner, const LocalLine& row,
                                    const LocalLine& col, int half) {
  // The patch holds the window, cornerSubPix's one-pixel gradient border and room to move.
  const int r = half + 5, size = 2 * r + 1;
  const int x0 = static_cast<int>(std::lround(corner.x())) - r;
  const int y0 = static_cast<int>(std::lround(corner.y())) - r;
  constexpr int kSamples = 8;  // per pixel side, where an edge crosses the pixel
  cv::Mat patch(size, size, CV_32F);
  for (int v = 0; v < size; ++v) {
    for (int u = 0; u < size; ++u) {
      // Pixel (x, y) covers [x - 0.5, x + 0.5] x [y - 0.5, y + 0.5] (docs/design.md, Conventions).
      const Eigen::Vector2d centre = Eigen::Vector2d(x0 + u, y0 + v) - corner;
      const double f1 = Side(row, centre), f2 = Side(col, centre);
      float value;
      if (std::min(std::abs(f1), std::abs(f2)) > 0.8) {  // beyond the half diagonal: one colour
        value = f1 * f2 > 0 ? 255.f : 0.f;
      } else {
        int bright = 0;
        for (int a = 0; a < kSamples; ++a) {
          for (int b = 0; b < kSamples; ++b) {
            const Eigen::Vector2d d =
                centre + Eigen::Vector2d((a + 0.5) / kSamples - 0.5, (b + 0.5) / kSamples - 0.5);
            bright += Side(row, d) * Side(col, d) > 0;
          }
        }
        value = 255.f * bright / (kSamples * kSamples);
      }
      patch.at<float>(v, u) = value;
    }
  }
  std::vector<cv::Point2f> p{cv::Point2f(static_cast<float>(corner.x() - x0), static_cast<float>(corner.y() - y0))};
  const cv::Point2f start = p[0];
  cv::cornerSubPix(patch, p, cv::Size(half, half), cv::Size(-1, -1), kCriteria);
  return Eigen::Vector2d(p[0].x - start.x, p[0].y - start.y);
}

std::optional<LocalLine> LineThroughCorner(const std::vector<std::optional<Eigen::Vector2d>>& corners,
                                           int rows, int cols, int id, bool along_row) {
  const int r = id / cols, c = id % cols;
  const int dr = along_row ? 0 : 1, dc = along_row ? 1 : 0;
  const auto get = [&](int k) -> std::optional<Eigen::Vector2d> {
    const int rr = r + k * dr, cc = c + k * dc;
    if (rr < 0 || cc < 0 || rr >= rows || cc >= cols) return std::nullopt;
    return corners[rr * cols + cc];
  };
  if (!get(0)) return std::nullopt;
  // q(u) = B + u d1 + u^2 / 2 d2 through A, B, C at u = -1, 0, 1; the corner at u0 = -centre.
  // Perspective makes u non-uniform along the curve (d2 along the tangent); only the normal
  // part of d2 bends it. Centred triple first: the curvature there is second-order accurate.
  for (int centre : {0, 1, -1}) {
    const auto a = get(centre - 1), b = get(centre), c3 = get(centre + 1);
    if (!a || !b || !c3) continue;
    const Eigen::Vector2d d1 = (*c3 - *a) / 2, d2 = *c3 - 2 * *b + *a;
    const Eigen::Vector2d tangent = d1 - centre * d2;
    if (tangent.norm() < 1e-6) continue;
    LocalLine line;
    line.tangent = tangent.normalized();
    line.curvature = (d2 - d2.dot(line.tangent) * line.tangent) / tangent.squaredNorm();
    return line;
  }
  for (int k : {1, -1}) {
    if (const auto q = get(k); q && (*q - *get(0)).norm() > 1e-6) {
      LocalLine line;
      line.tangent = (*q - *get(0)).normalized();
      return line;
    }
  }
  return std::nullopt;
}

// Calls visit(id, corner, row line, column line) for every measured corner whose row and column
// lines (through its neighbours in `measured`) are known.
template <typename Visit>
void ForEachCornerWithLines(const std::vector<std::optional<Eigen::Vector2d>>& measured, int rows,
                            int cols, Visit visit) {
  for (int id = 0; id < rows * cols; ++id) {
    if (!measured[id]) continue;
    const auto row = LineThroughCorner(measured, rows, cols, id, true);
    const auto col = LineThroughCorner(measured, rows, cols, id, false);
    if (row && col) visit(id, *measured[id], *row, *col);
  }
}

void RemoveCurvatureBias(int rows, int cols, const std::vector<int>& halves,
                         std::vector<std::optional<Eigen::Vector2d>>* corners) {
  const std::vector<std::optional<Eigen::Vector2d>> measured = *corners;
  ForEachCornerWithLines(measured, rows, cols, [&](int id, const Eigen::Vector2d& corner,
                                                   const LocalLine& row, const LocalLine& col) {
    const Eigen::Vector2d bias = PredictedRefineBias(corner, row, col, halves[id]);
    if (bias.norm() <= kMaxBiasPx) (*corners)[id] = corner - bias;
  });
}

int CleanHalfWindow(const cv::Mat& grey, const Eigen::Vector2d& corner, const LocalLine& row,
                    const LocalLine& col, double side, int half, double blur_px, double min_foreign_slope) {
  // The pixels cornerSubPix may read from: the window, its gradient border, interpolation; two
  // more for the slopes read here.
  const int reach = half + 2;
  const int u0 = static_cast<int>(std::lround(corner.x())), v0 = static_cast<int>(std::lround(corner.y()));
  if (u0 - reach < 2 || v0 - reach < 2 || u0 + reach + 2 >= grey.cols || v0 + reach + 2 >= grey.rows) {
    return half;  // RefineCornerInRaw refuses it
  }
  const auto at = [&](int u, int v) -> float {
    return grey.depth() == CV_8U ? grey.at<uchar>(v, u) : grey.at<float>(v, u);
  };
  const auto gradient = [&](int u, int v) {
    return 0.5f * std::hypot(at(u + 1, v) - at(u - 1, v), at(u, v + 1) - at(u, v - 1));
  };
  // Px either side of a line: its blur, the box filter. Two blurred edges' product at b from
  // both is erf(b / (sqrt2 s))^2 of the contrast: within 35% of the level (with room for noise)
  // from b = 1.3 s; a fixed 1.5 px took a 5-megapixel webcam's 2.6 px blur for foreign edges.
  const double kEdgeBand = std::max(1.5, 1.3 * blur_px);
  const auto off_the_lines = [&](int u, int v) {
    const Eigen::Vector2d d = Eigen::Vector2d(u, v) - corner;
    return std::min(std::abs(Side(row, d)), std::abs(Side(col, d))) >= kEdgeBand;
  };
  // The steepest slope at a pixel or next to it, off the board's own edges: a step's partial
  // pixels (the box filter) count as on the step.
  const auto slope_near = [&](int u, int v) {
    float out = 0;
    for (int dv = -1; dv <= 1; ++dv) {
      for (int du = -1; du <= 1; ++du) {
        if (off_the_lines(u + du, v + dv)) out = std::max(out, gradient(u + du, v + dv));
      }
    }
    return out;
  };
  struct Sample {
    double chebyshev;
    bool bright_quadrant;
    float value, gradient;
  };
  std::vector<Sample> samples;
  std::vector<float> levels[2], edge_gradients;
  for (int v = v0 - reach; v <= v0 + reach; ++v) {
    for (int u = u0 - reach; u <= u0 + reach; ++u) {
      const Eigen::Vector2d d = Eigen::Vector2d(u, v) - corner;
      const double f1 = Side(row, d), f2 = Side(col, d);
      const double near = std::min(std::abs(f1), std::abs(f2)), far = std::max(std::abs(f1), std::abs(f2));
      if (far > side - kEdgeBand) continue;
      if (near < kEdgeBand && far >= kEdgeBand) edge_gradients.push_back(gradient(u, v));
      if (near < kEdgeBand) continue;
      const float value = at(u, v);
      samples.push_back({d.cwiseAbs().maxCoeff(), f1 * f2 > 0, value, slope_near(u, v)});
      levels[f1 * f2 > 0].push_back(value);
    }
  }
  if (levels[0].empty() || levels[1].empty()) return half;  // squares too small to judge
  const auto median = [](std::vector<float> x) {
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    return x[x.size() / 2];
  };
  // Which pair of quadrants is bright is read from the image (the model's sign is arbitrary).
  const float level[2] = {median(levels[0]), median(levels[1])};
  const float contrast = std::abs(level[1] - level[0]);
  if (contrast < 20) return half;  // no board to judge against
  // A foreign edge is a step: off its quadrant's level AND at least min_foreign_slope times as
  // steep as the board's own edges in the window (their 90th-percentile gradient: the edges'
  // peak). Shading within a square (a glossy sheet's sheen, strong in linear light: Mei's photo
  // 10, the bright squares of one junction at 61-125 levels against dark ones at 6) moves the
  // level at a gentler slope, and dropped 17 of that board's 48 corners (31 of Mei's 36
  // missing) when the level alone decided.
  float steep = 0;
  if (!edge_gradients.empty()) {
    auto p90 = edge_gradients.begin() + (9 * edge_gradients.size()) / 10;
    std::nth_element(edge_gradients.begin(), p90, edge_gradients.end());
    steep = static_cast<float>(min_foreign_slope) * *p90;
  }
  double nearest_foreign = 1e9;
  for (const Sample& s : samples) {
    if (std::abs(s.value - level[s.bright_quadrant]) > 0.35f * contrast && s.gradient >= steep) {
      nearest_foreign = std::min(nearest_foreign, s.chebyshev);
    }
  }
  // A window of half h reads up to h + 1 px (gradient) plus the interpolation's pixel.
  return std::min(half, static_cast<int>(std::ceil(nearest_foreign)) - 3);
}

namespace {

// A pixel of a junction's window: its centre and its value.
struct JunctionPixel {
  Eigen::Vector2d x;
  double value;
};

// The blurred junction's parameters: corner (2), the lines' tangent angles (2), a, b, s.
using Vec7 = Eigen::Matrix<double, 7, 1>;
using Mat7 = Eigen::Matrix<double, 7, 7>;

// The model a + b erf(d_row / s) erf(d_col / s) of the window's pixels, d the signed distance
// from each line with the line's curvature along its normal perp(t) held (the neighbours'
// estimate, good to a few percent of the few-hundredths-of-a-pixel effect).
struct JunctionModel {
  const std::vector<JunctionPixel>& pixels;
  double k[2];  // the row's and the column's curvature along their normals

  // The sum of squared residuals at q; with jtj and jtr, J^T J (lower triangle) and J^T r are
  // accumulated too.
  double Evaluate(const Vec7& q, Mat7* jtj, Vec7* jtr) const {
    const double kErfScale = std::sqrt(0.5), kGaussScale = std::sqrt(2 / M_PI);
    const double s = q[6];
    double e[2], g[2], dd_dth[2], dd_ds[2];
    Eigen::Vector2d dd_dp[2];
    double sum = 0;
    Eigen::Vector2d tangents[2], normals[2];
    for (int i = 0; i < 2; ++i) {
      tangents[i] = Eigen::Vector2d(std::cos(q[2 + i]), std::sin(q[2 + i]));
      normals[i] = Eigen::Vector2d(-tangents[i].y(), tangents[i].x());
    }
    for (const JunctionPixel& p : pixels) {
      const Eigen::Vector2d r = p.x - q.head<2>();
      for (int i = 0; i < 2; ++i) {
        const Eigen::Vector2d& t = tangents[i];
        const Eigen::Vector2d& n = normals[i];
        const double along = t.dot(r);
        const double d = n.dot(r) - 0.5 * k[i] * (along * along + s * s);
        e[i] = std::erf(kErfScale * d / s);
        if (!jtj) continue;
        g[i] = kGaussScale / s * std::exp(-0.5 * d * d / (s * s));
        dd_dp[i] = -n + k[i] * along * t;
        dd_dth[i] = -along - k[i] * along * n.dot(r);
        dd_ds[i] = -d / s - k[i] * s;
      }
      const double res = q[4] + q[5] * e[0] * e[1] - p.value;
      sum += res * res;
      if (!jtj) continue;
      Vec7 j;
      j.head<2>() = q[5] * (g[0] * e[1] * dd_dp[0] + e[0] * g[1] * dd_dp[1]);
      j[2] = q[5] * g[0] * e[1] * dd_dth[0];
      j[3] = q[5] * e[0] * g[1] * dd_dth[1];
      j[4] = 1;
      j[5] = e[0] * e[1];
      j[6] = q[5] * (g[0] * dd_ds[0] * e[1] + e[0] * g[1] * dd_ds[1]);
      jtj->selfadjointView<Eigen::Lower>().rankUpdate(j);
      *jtr += j * res;
    }
    return sum;
  }
};

// The window's pixels: those within `half` (Chebyshev) of `start`; nullopt where the window
// (plus a pixel) leaves the image.
std::optional<std::vector<JunctionPixel>> JunctionWindow(const cv::Mat& grey, const Eigen::Vector2d& start,
                                                         double half) {
  const int reach = static_cast<int>(std::floor(half));
  const int u0 = static_cast<int>(std::lround(start.x())), v0 = static_cast<int>(std::lround(start.y()));
  if (u0 - reach - 1 < 0 || v0 - reach - 1 < 0 || u0 + reach + 1 >= grey.cols ||
      v0 + reach + 1 >= grey.rows) {
    return std::nullopt;
  }
  std::vector<JunctionPixel> pixels;
  for (int v = v0 - reach - 1; v <= v0 + reach + 1; ++v) {
    for (int u = u0 - reach - 1; u <= u0 + reach + 1; ++u) {
      if (std::abs(u - start.x()) > half || std::abs(v - start.y()) > half) continue;
      pixels.push_back({Eigen::Vector2d(u, v),
                        grey.depth() == CV_8U ? grey.at<uchar>(v, u) : grey.at<float>(v, u)});
    }
  }
  return pixels;
}

// The levels a and b, linear given the shape: least squares of a + b S over the pixels, S the
// straight lines' product at the start (q's corner ignored: `start`) and blur sigma0.
void InitialLevels(const std::vector<JunctionPixel>& pixels, const Eigen::Vector2d& start, double sigma0, Vec7* q) {
  const double kErfScale = std::sqrt(0.5);
  Eigen::Matrix2d a = Eigen::Matrix2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  for (const JunctionPixel& p : pixels) {
    const Eigen::Vector2d r = p.x - start;
    double shape = 1;
    for (int i = 0; i < 2; ++i) {
      const Eigen::Vector2d t(std::cos((*q)[2 + i]), std::sin((*q)[2 + i])), n(-t.y(), t.x());
      shape *= std::erf(kErfScale * n.dot(r) / sigma0);
    }
    const Eigen::Vector2d f(1, shape);
    a += f * f.transpose();
    b += f * p.value;
  }
  const Eigen::Vector2d levels = a.ldlt().solve(b);
  (*q)[4] = levels[0];
  (*q)[5] = levels[1];
}

}  // namespace

std::optional<JunctionFit> FitBlurredJunction(const cv::Mat& grey, const Eigen::Vector2d& start,
                                              const LocalLine& row, const LocalLine& col,
                                              double half, double sigma0) {
  CV_Assert(grey.depth() == CV_8U || grey.depth() == CV_32F);
  const std::optional<std::vector<JunctionPixel>> pixels = JunctionWindow(grey, start, half);
  if (!pixels) return std::nullopt;
  if (pixels->size() < 16) return std::nullopt;
  const auto normal_curvature = [](const LocalLine& l) {
    return l.curvature.dot(Eigen::Vector2d(-l.tangent.y(), l.tangent.x()));
  };
  const JunctionModel model{*pixels, {normal_curvature(row), normal_curvature(col)}};
  Vec7 q;
  q << start.x(), start.y(), std::atan2(row.tangent.y(), row.tangent.x()),
      std::atan2(col.tangent.y(), col.tangent.x()), 0, 0, sigma0;
  InitialLevels(*pixels, start, sigma0, &q);
  // Levenberg-Marquardt; the blur is held between 0.3 px and half the window (a blur, not the
  // window's width).
  const double cost = JunctionLevenbergMarquardt(
      half, model.Evaluate(q, nullptr, nullptr),
      [&](const Vec7& at, Mat7* jtj, Vec7* jtr) {
        jtj->setZero();
        jtr->setZero();
        model.Evaluate(at, jtj, jtr);
        *jtj = jtj->selfadjointView<Eigen::Lower>();
      },
      [&](const Vec7& at) { return model.Evaluate(at, nullptr, nullptr); }, &q);
  return JunctionFitOf(q, cost, pixels->size(), start, half);
}

int FitBoardJunctions(const cv::Mat& grey, int rows, int cols, const std::vector<double>& sides,
                      const std::vector<int>& halves, double window_squares,
                      std::vector<std::optional<Eigen::Vector2d>>* corners) {
  const std::vector<std::optional<Eigen::Vector2d>> measured = *corners;
  std::vector<bool> fitted(measured.size(), false);
  // Twice: the lines (above all their curvature, a second difference of three corners) come
  // from the neighbours, which the first pass makes several times more accurate.
  for (int pass = 0; pass < 2; ++pass) {
    const std::vector<std::optional<Eigen::Vector2d>> lines_from = *corners;
    ForEachCornerWithLines(lines_from, rows, cols, [&](int id, const Eigen::Vector2d& corner,
                                                       const LocalLine& row, const LocalLine& col) {
      const double half = std::min(window_squares * sides[id], static_cast<double>(halves[id]));
      const Eigen::Vector2d& start = *measured[id];
      if (const auto fit = FitBlurredJunction(grey, corner, row, col, half);
          fit && (fit->corner - start).norm() <= std::max(0.5, 0.15 * sides[id])) {
        (*corners)[id] = fit->corner;
        fitted[id] = true;
        return;
      }
      fitted[id] = false;
      const Eigen::Vector2d bias = PredictedRefineBias(start, row, col, halves[id]);
      (*corners)[id] = bias.norm() <= kMaxBiasPx ? start - bias : start;
    });
  }
  return static_cast<int>(std::count(fitted.begin(), fitted.end(), true));
}

int KeepWindowsOnTheirSquares(const cv::Mat& grey, int rows, int cols, const std::vector<double>& sides,
                              int min_half, std::vector<int>* halves,
                              std::vector<std::optional<Eigen::Vector2d>>* corners, double blur_px,
                              double min_foreign_slope) {
  int dropped = 0;
  // Twice: a corner refined again moves the lines its neighbours are judged with.
  for (int pass = 0; pass < 2; ++pass) {
    const std::vector<std::optional<Eigen::Vector2d>> measured = *corners;
    ForEachCornerWithLines(measured, rows, cols, [&](int id, const Eigen::Vector2d& corner,
                                                     const LocalLine& row, const LocalLine& col) {
      int& half = (*halves)[id];
      const int clean = CleanHalfWindow(grey, corner, row, col, sides[id], half, blur_px, min_foreign_slope);
      if (clean >= half) return;
      Eigen::Vector2d pixel = corner;
      if (clean < std::min(min_half, half) || !RefineCornerInRaw(grey, clean, &pixel) ||
          (pixel - corner).norm() > clean) {
        (*corners)[id].reset();
        ++dropped;
        return;
      }
      half = clean;
      (*corners)[id] = pixel;
    });
  }
  return dropped;
}

std::vector<std::optional<Eigen::Vector2d>> RefineFromStarts(
    const cv::Mat& grey, const std::vector<std::pair<int, int>>& board_sizes,
    const std::vector<CornerStart>& corners, bool correct) {
  // Refined corners per board, row-major by id as the detector holds them.
  std::vector<std::vector<std::optional<Eigen::Vector2d>>> grids(board_sizes.size());
  std::vector<std::vector<int>> halves(board_sizes.size());
  for (size_t b = 0; b < board_sizes.size(); ++b) {
    grids[b].resize(board_sizes[b].first * board_sizes[b].second);
    halves[b].resize(board_sizes[b].first * board_sizes[b].second, 1);
  }
  for (const CornerStart& c : corners) {
    Eigen::Vector2d p = c.start;
    const int half = c.half;
    if (p.x() < half + 3 || p.y() < half + 3 || p.x() > grey.cols - half - 4 ||
        p.y() > grey.rows - half - 4) {
      continue;
    }
    if (!RefineCornerInRaw(grey, half, &p)) continue;
    grids[c.board][c.id] = p;
    halves[c.board][c.id] = half;
  }
  if (correct) {
    for (size_t b = 0; b < board_sizes.size(); ++b) {
      RemoveCurvatureBias(board_sizes[b].first, board_sizes[b].second, halves[b], &grids[b]);
    }
  }
  std::vector<std::optional<Eigen::Vector2d>> refined;
  refined.reserve(corners.size());
  for (const CornerStart& c : corners) refined.push_back(grids[c.board][c.id]);
  return refined;
}

}  // namespace omni::detectors
