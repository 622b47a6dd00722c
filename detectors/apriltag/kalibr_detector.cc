#include "detectors/apriltag/kalibr_detector.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <tuple>
#include <unordered_map>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/common/corner_window.h"
#include "detectors/common/option_check.h"

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
}

namespace omni::detectors {

std::string KalibrDetectorOptions::Check() const {
  if (upsample < 1) return OptionError("upsample", "an enlargement of at least 1", upsample);
  if (threshold_window_px < 1) return OptionError("threshold_window_px", "at least 1 px", threshold_window_px);
  if (separation_px < 0) return OptionError("separation_px", "an erosion >= 0 px", separation_px);
  if (separation_passes < 1) return OptionError("separation_passes", "at least 1", separation_passes);
  if (!(min_side_px > 0)) return OptionError("min_side_px", "a side > 0 view px", min_side_px);
  if (!(min_bit_margin >= 0 && min_bit_margin < 0.5)) {
    return OptionError("min_bit_margin", "a fraction in [0, 0.5)", min_bit_margin);
  }
  if (!(max_neighbour_error > 0)) {
    return OptionError("max_neighbour_error", "a fraction > 0 of the side", max_neighbour_error);
  }
  if (!(blur_sigma >= 0)) return OptionError("blur_sigma", "a blur >= 0 view px (0: sharp)", blur_sigma);
  return "";
}
namespace {

// A Kalibr tag is 10 bits across: 2 black border bits each side around tag36h11's 6 x 6 data
// bits; libapriltag's bit_x/bit_y count from its own 1-bit border, hence the +1.
constexpr int kBits = 10;
constexpr int kBorderShift = 1;

// tag36h11's codes (index by exact code) and bit positions, read once.
struct Family {
  std::vector<uint32_t> bit_x, bit_y;
  uint32_t nbits = 0;
  std::unordered_map<uint64_t, int> id_of_code;
  std::vector<uint64_t> codes;
};

const Family& Tag36h11() {
  static const Family family = [] {
    Family f;
    std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> lib(tag36h11_create(),
                                                                        tag36h11_destroy);
    f.nbits = lib->nbits;
    f.bit_x.assign(lib->bit_x, lib->bit_x + lib->nbits);
    f.bit_y.assign(lib->bit_y, lib->bit_y + lib->nbits);
    for (uint32_t i = 0; i < lib->ncodes; ++i) f.id_of_code[lib->codes[i]] = static_cast<int>(i);
    f.codes.assign(lib->codes, lib->codes + lib->ncodes);
    return f;
  }();
  return family;
}

double Bilinear(const cv::Mat& grey, double u, double v) {
  if (!(u >= 0 && v >= 0 && u < grey.cols - 1 && v < grey.rows - 1)) return -1;
  const int x = static_cast<int>(u), y = static_cast<int>(v);
  const double a = u - x, b = v - y;
  const uchar* r0 = grey.ptr<uchar>(y);
  const uchar* r1 = grey.ptr<uchar>(y + 1);
  return (1 - b) * ((1 - a) * r0[x] + a * r0[x + 1]) + b * ((1 - a) * r1[x] + a * r1[x + 1]);
}

// Mean grey of the middle of one bit cell (cx, cy in bits from the tag's top-left outer corner,
// may be outside the tag), through the homography tag bits -> view pixels. -1 outside the view.
double CellValue(const cv::Mat& grey, const cv::Matx33d& H, double cx, double cy) {
  double sum = 0;
  for (double a : {-0.2, 0.0, 0.2}) {
    for (double b : {-0.2, 0.0, 0.2}) {
      const cv::Vec3d p = H * cv::Vec3d(cx + 0.5 + a, cy + 0.5 + b, 1.0);
      const double value = Bilinear(grey, p[0] / p[2], p[1] / p[2]);
      if (value < 0) return -1;
      sum += value;
    }
  }
  return sum / 9;
}

// A quad's cells (CellValue) sampled once, with the homography of rotation 0 (tag corners
// TL, TR, BR, BL as printed -> quad[0..3]). Reading the quad in rotation r only permutes them: a
// quarter turn of the tag square takes cell (x, y) to (kBits - 1 - y, x) and CellValue's 3 x 3
// samples onto themselves, so the border test is the same in every rotation and is done once.
struct QuadCells {
  double cell[kBits][kBits];  // [y][x]; the data cells (2..kBits-3 each way) only
  double threshold = 0, contrast = 0;
};

// Samples the quad's cells and tests its border. Black: the 2-bit border. White: the middle of
// the gap (3 bits wide) along each side, clear of the corner squares. False if the border is not
// black against white gaps by options.min_contrast, or any border cell is outside the view.
bool SampleQuadCells(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
                     const KalibrDetectorOptions& options, QuadCells* cells) {
  const cv::Point2f tag[4] = {{0, 0}, {kBits, 0}, {kBits, kBits}, {0, kBits}};
  const cv::Matx33d H(cv::getPerspectiveTransform(tag, quad.data()));
  double black = 0, black_max = 0, white = 0;
  int n_black = 0, n_white = 0;
  for (int y = 0; y < kBits; ++y) {
    for (int x = 0; x < kBits; ++x) {
      if (x >= 2 && x < kBits - 2 && y >= 2 && y < kBits - 2) continue;
      const double v = CellValue(grey, H, x, y);
      if (v < 0) return false;
      black += v;
      black_max = std::max(black_max, v);
      ++n_black;
    }
  }
  for (int i = 1; i < kBits - 1; ++i) {
    for (const auto& [cx, cy] : {std::pair<double, double>{i, -1.5}, {i, kBits + 0.5},
                                 {-1.5, i}, {kBits + 0.5, i}}) {
      const double v = CellValue(grey, H, cx, cy);
      if (v < 0) continue;
      white += v;
      ++n_white;
    }
  }
  if (n_white < kBits) return false;
  black /= n_black;
  white /= n_white;
  cells->contrast = white - black;
  if (cells->contrast < options.min_contrast) return false;
  cells->threshold = 0.5 * (black + white);
  if (black_max > cells->threshold) return false;
  for (int y = 2; y < kBits - 2; ++y) {
    for (int x = 2; x < kBits - 2; ++x) cells->cell[y][x] = CellValue(grey, H, x, y);
  }
  return true;
}

// The tag read from the cells with tag corner j at quad[(r + j) % 4]: its id, or -1.
int ReadRotation(const QuadCells& cells, int r, const KalibrDetectorOptions& options) {
  const Family& family = Tag36h11();
  uint64_t code = 0;
  for (uint32_t i = 0; i < family.nbits; ++i) {
    int x = family.bit_x[i] + kBorderShift, y = family.bit_y[i] + kBorderShift;
    for (int k = 0; k < r; ++k) std::tie(x, y) = std::make_pair(kBits - 1 - y, x);
    const double v = cells.cell[y][x];
    if (v < 0 || std::abs(v - cells.threshold) < options.min_bit_margin * cells.contrast) {
      return -1;
    }
    code = (code << 1) | (v > cells.threshold ? 1u : 0u);
  }
  const auto it = family.id_of_code.find(code);
  return it == family.id_of_code.end() ? -1 : it->second;
}

// Reads a quad (view pixels, TL, TR, BR, BL as printed up to a rotation) in all four rotations:
// the tag id and its homography tag bits -> view pixels, or -1 if no rotation or more than one
// reads (two readings of one quad: neither is trusted).
int DecodeQuad(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
               const KalibrDetectorOptions& options, cv::Matx33d* H) {
  QuadCells cells;
  if (!SampleQuadCells(grey, quad, options, &cells)) return -1;
  int id = -1, rotation = 0;
  for (int r = 0; r < 4; ++r) {
    const int id_r = ReadRotation(cells, r, options);
    if (id_r < 0) continue;
    if (id >= 0) return -1;
    id = id_r;
    rotation = r;
  }
  if (id >= 0) {
    const cv::Point2f tag[4] = {{0, 0}, {kBits, 0}, {kBits, kBits}, {0, kBits}};
    cv::Point2f image[4];
    for (int j = 0; j < 4; ++j) image[j] = quad[(rotation + j) % 4];
    *H = cv::Matx33d(cv::getPerspectiveTransform(tag, image));
  }
  return id;
}

// True if the quad's 6 x 6 data cells are all within min_contrast grey levels of each other:
// a solid square (Kalibr's corner squares) or an empty frame, not a tag, however its corners are
// placed (tag36h11 codes have 10 to 25 of their 36 bits light). -1 cells (outside the view) count as
// not uniform.
bool DataAreaIsUniform(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
                       int min_contrast) {
  const cv::Point2f tag[4] = {{0, 0}, {kBits, 0}, {kBits, kBits}, {0, kBits}};
  const cv::Matx33d H(cv::getPerspectiveTransform(tag, quad.data()));
  double lo = 1e9, hi = -1e9;
  for (int y = 2; y < kBits - 2; ++y) {
    for (int x = 2; x < kBits - 2; ++x) {
      const double v = CellValue(grey, H, x, y);
      if (v < 0) return false;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  return hi - lo < min_contrast;
}

// True if `p` lies inside one of `tags` (their corners in the view).
bool InsideAnyTag(const std::vector<KalibrViewTag>& tags, const cv::Point2f& p) {
  for (const KalibrViewTag& t : tags) {
    std::vector<cv::Point2f> polygon;
    for (const Eigen::Vector2d& c : t.corners) {
      polygon.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()));
    }
    if (cv::pointPolygonTest(polygon, p, false) > 0) return true;
  }
  return false;
}

// The quad's corners refined as X-junctions (RefineSaddleCorner) with the window the decoded
// tags' corners get (0.15 side: the 2-bit border around the corner), each allowed to move up to
// 0.2 side (well short of the corner square's far corners, 0.42 side away). False if any fails
// or is not a Kalibr X-junction (IsKalibrXJunction: dark tag and corner square, light gaps) as
// every tag corner is; quads of other things (plain tags' L-corners, blobs) stop here, unread.
bool RefineQuadCorners(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
                       int min_contrast, std::array<cv::Point2f, 4>* refined) {
  double side = 0;
  for (int k = 0; k < 4; ++k) side += 0.25 * cv::norm(quad[k] - quad[(k + 1) % 4]);
  const int half = TagCornerHalfWindow(side);
  for (int k = 0; k < 4; ++k) {
    Eigen::Vector2d corner;
    if (!RefineSaddleCorner(grey, Eigen::Vector2d(quad[k].x, quad[k].y), half, 0.2 * side,
                            &corner)) {
      return false;
    }
    (*refined)[k] = cv::Point2f(static_cast<float>(corner.x()), static_cast<float>(corner.y()));
  }
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d at((*refined)[k].x, (*refined)[k].y);
    const cv::Point2f next = (*refined)[(k + 1) % 4], previous = (*refined)[(k + 3) % 4];
    const Eigen::Vector2d to_next = (Eigen::Vector2d(next.x, next.y) - at).normalized();
    const Eigen::Vector2d to_previous = (Eigen::Vector2d(previous.x, previous.y) - at).normalized();
    if (!IsKalibrXJunction(grey, at, to_next, to_previous, XJunctionProbe(side),
                           min_contrast)) {
      return false;
    }
  }
  return true;
}

// The intersection of two lines given as (vx, vy, x0, y0) from cv::fitLine.
bool Intersect(const cv::Vec4f& a, const cv::Vec4f& b, cv::Point2f* p) {
  const double det = a[0] * b[1] - a[1] * b[0];
  if (std::abs(det) < 1e-6) return false;
  const double t = ((b[2] - a[2]) * b[1] - (b[3] - a[3]) * b[0]) / det;
  *p = cv::Point2f(static_cast<float>(a[2] + t * a[0]), static_cast<float>(a[3] + t * a[1]));
  return true;
}

// The four corners of a quadrilateral contour: lines fitted to the middle of each side of its
// polygon approximation, intersected. Ordered with positive shoelace area in image coordinates
// (clockwise on screen, as the printed tag's TL, TR, BR, BL).
bool FitQuad(const std::vector<cv::Point>& contour, double min_side,
             std::array<cv::Point2f, 4>* quad) {
  const double perimeter = cv::arcLength(contour, true);
  if (perimeter < 4 * min_side) return false;
  std::vector<cv::Point> poly;
  cv::approxPolyDP(contour, poly, 0.06 * perimeter, true);
  if (poly.size() != 4 || !cv::isContourConvex(poly)) return false;
  // Index of each polygon vertex on the contour.
  std::array<int, 4> at{};
  for (int j = 0; j < 4; ++j) {
    at[j] = static_cast<int>(std::find(contour.begin(), contour.end(), poly[j]) - contour.begin());
  }
  const int n = static_cast<int>(contour.size());
  std::array<cv::Vec4f, 4> lines;
  for (int j = 0; j < 4; ++j) {
    const int a = at[j], b = at[(j + 1) % 4];
    const int len = ((b - a) % n + n) % n;
    if (len < 4) return false;
    std::vector<cv::Point2f> side;
    for (int i = len / 5; i <= len - len / 5; ++i) side.emplace_back(contour[(a + i) % n]);
    cv::fitLine(side, lines[j], cv::DIST_L2, 0, 0.01, 0.01);
  }
  for (int j = 0; j < 4; ++j) {
    if (!Intersect(lines[(j + 3) % 4], lines[j], &(*quad)[j])) return false;
  }
  double area = 0;
  for (int j = 0; j < 4; ++j) {
    const cv::Point2f& p = (*quad)[j];
    const cv::Point2f& q = (*quad)[(j + 1) % 4];
    area += p.x * q.y - q.x * p.y;
  }
  if (area < 0) std::reverse(quad->begin(), quad->end());
  return true;
}


// The blurred pattern of a tag seen through one orientation of its quad: the sampled value of
// every cell of the tag and of the ring of cells just outside it, and what those samples would be
// for data bits b (0 black, 1 white) at the view's blur: base + W b, in units of the contrast
// above black.
struct BlurredPattern {
  std::vector<double> v;   // sampled grey values, cells (x, y) = -1..bits, row-major
  Eigen::MatrixXd W;       // samples x data bits
  Eigen::VectorXd base;    // samples: the border's, the outside's and corner squares' share
  std::vector<int> data_sample;  // sample index of each data bit (family bit order)
};

double Phi(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

bool SampleBlurredPattern(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
                          const TagLayout& layout, double blur_sigma, BlurredPattern* p) {
  const int n = layout.bits;
  const cv::Point2f tag[4] = {{0, 0}, {static_cast<float>(n), 0},
                              {static_cast<float>(n), static_cast<float>(n)},
                              {0, static_cast<float>(n)}};
  const cv::Matx33d H(cv::getPerspectiveTransform(tag, quad.data()));
  const auto at = [&](double x, double y) {
    const cv::Vec3d q = H * cv::Vec3d(x, y, 1.0);
    return cv::Point2d(q[0] / q[2], q[1] / q[2]);
  };
  const double c = 0.5 * n;
  const double dx = cv::norm(at(c + 0.5, c) - at(c - 0.5, c));
  const double dy = cv::norm(at(c, c + 0.5) - at(c, c - 0.5));
  if (!(dx > 0.5 && dy > 0.5)) return false;
  // Each cell is sampled at 3 x 3 points +-0.2 bit about its middle (CellValue): adds that
  // spread to the blur along each axis.
  const double blur = blur_sigma > 0 ? blur_sigma : 0.8;
  const double sx = std::sqrt(blur * blur + (2.0 / 3.0) * 0.04 * dx * dx) / dx;  // in bits
  const double sy = std::sqrt(blur * blur + (2.0 / 3.0) * 0.04 * dy * dy) / dy;
  constexpr int R = 3;
  double wx[2 * R + 1], wy[2 * R + 1];
  for (int k = -R; k <= R; ++k) {
    wx[k + R] = Phi((k + 0.5) / sx) - Phi((k - 0.5) / sx);
    wy[k + R] = Phi((k + 0.5) / sy) - Phi((k - 0.5) / sy);
  }
  const Family& family = Tag36h11();
  const int shift = layout.border - 1;
  // Level of every cell from -1 - R to n + R with the data bits black (-1: a data bit).
  const int span = n + 2 + 2 * R, lo = -1 - R;
  std::vector<double> level(span * span, 1.0);
  for (int y = lo; y < lo + span; ++y) {
    for (int x = lo; x < lo + span; ++x) {
      double& l = level[(y - lo) * span + (x - lo)];
      const bool in_x = x >= 0 && x < n, in_y = y >= 0 && y < n;
      if (in_x && in_y) {
        l = 0;
      } else if (layout.corner_squares && !in_x && !in_y && x >= -3 && x < n + 3 && y >= -3 &&
                 y < n + 3) {
        l = 0;
      }
    }
  }
  const int m = (n + 2) * (n + 2);
  p->v.assign(m, 0);
  p->base = Eigen::VectorXd::Zero(m);
  p->W = Eigen::MatrixXd::Zero(m, family.nbits);
  p->data_sample.assign(family.nbits, 0);
  for (int y = -1; y <= n; ++y) {
    for (int x = -1; x <= n; ++x) {
      const int i = (y + 1) * (n + 2) + (x + 1);
      const double value = CellValue(grey, H, x, y);
      if (value < 0) return false;
      p->v[i] = value;
      double b = 0;
      for (int l = -R; l <= R; ++l) {
        for (int k = -R; k <= R; ++k) {
          b += wx[k + R] * wy[l + R] * level[(y + l - lo) * span + (x + k - lo)];
        }
      }
      p->base(i) = b;
    }
  }
  for (uint32_t t = 0; t < family.nbits; ++t) {
    const int bx = static_cast<int>(family.bit_x[t]) + shift, by = static_cast<int>(family.bit_y[t]) + shift;
    p->data_sample[t] = (by + 1) * (n + 2) + (bx + 1);
    for (int y = std::max(-1, by - R); y <= std::min(n, by + R); ++y) {
      for (int x = std::max(-1, bx - R); x <= std::min(n, bx + R); ++x) {
        p->W((y + 1) * (n + 2) + (x + 1), t) = wx[bx - x + R] * wy[by - y + R];
      }
    }
  }
  return true;
}

// Least-squares levels v = a + c (base + W b) for the code's bits b: rms misfit / c (1e9 if c
// is not positive).
double CodeMisfit(const BlurredPattern& p, uint64_t code, double* contrast) {
  const Family& family = Tag36h11();
  Eigen::VectorXd b(family.nbits);
  for (uint32_t t = 0; t < family.nbits; ++t) b(t) = (code >> (family.nbits - 1 - t)) & 1u;
  const Eigen::VectorXd model = p.base + p.W * b;
  const int m = static_cast<int>(p.v.size());
  double sm = 0, sv = 0, smm = 0, smv = 0;
  for (int i = 0; i < m; ++i) {
    sm += model(i);
    sv += p.v[i];
    smm += model(i) * model(i);
    smv += model(i) * p.v[i];
  }
  const double var_m = smm - sm * sm / m;
  if (var_m <= 1e-9) return 1e9;
  const double c = (smv - sm * sv / m) / var_m;
  const double a = (sv - c * sm) / m;
  if (contrast) *contrast = c;
  if (!(c > 0)) return 1e9;
  double sse = 0;
  for (int i = 0; i < m; ++i) sse += std::pow(p.v[i] - a - c * model(i), 2);
  return std::sqrt(sse / m) / c;
}

// The data bits as hard decisions: the levels from the cells that hold no data bit (data bits
// taken as 0.5), then the bits deblurred by regularised least squares and thresholded at 0.5.
uint64_t HardCode(const BlurredPattern& p) {
  const Family& family = Tag36h11();
  const int m = static_cast<int>(p.v.size());
  const Eigen::VectorXd half = p.base + p.W * Eigen::VectorXd::Constant(family.nbits, 0.5);
  std::vector<bool> is_data(m, false);
  for (const int i : p.data_sample) is_data[i] = true;
  double sm = 0, sv = 0, smm = 0, smv = 0;
  int k = 0;
  for (int i = 0; i < m; ++i) {
    if (is_data[i]) continue;
    sm += half(i);
    sv += p.v[i];
    smm += half(i) * half(i);
    smv += half(i) * p.v[i];
    ++k;
  }
  const double var_m = smm - sm * sm / k;
  double c = var_m > 1e-9 ? (smv - sm * sv / k) / var_m : 0;
  if (!(c > 1)) c = 1;
  const double a = (sv - c * sm) / k;
  Eigen::VectorXd y(m);
  for (int i = 0; i < m; ++i) y(i) = (p.v[i] - a) / c - p.base(i);
  constexpr double kLambda = 0.03;
  const Eigen::MatrixXd A = p.W.transpose() * p.W +
                            kLambda * Eigen::MatrixXd::Identity(family.nbits, family.nbits);
  const Eigen::VectorXd rhs =
      p.W.transpose() * y + kLambda * Eigen::VectorXd::Constant(family.nbits, 0.5);
  const Eigen::VectorXd x = A.ldlt().solve(rhs);
  uint64_t code = 0;
  for (uint32_t t = 0; t < family.nbits; ++t) code = (code << 1) | (x(t) > 0.5 ? 1u : 0u);
  return code;
}

}  // namespace

TagLayout KalibrTagLayout() { return TagLayout{10, 2, true}; }

int TagCellValue(int tag_id, const TagLayout& layout, int x, int y) {
  const int n = layout.bits;
  if (x < 0 || y < 0 || x >= n || y >= n) return 1;
  const Family& family = Tag36h11();
  if (tag_id < 0 || tag_id >= static_cast<int>(family.codes.size())) return 0;
  const int shift = layout.border - 1;
  for (uint32_t t = 0; t < family.nbits; ++t) {
    if (static_cast<int>(family.bit_x[t]) + shift == x && static_cast<int>(family.bit_y[t]) + shift == y) {
      return static_cast<int>((family.codes[tag_id] >> (family.nbits - 1 - t)) & 1u);
    }
  }
  return 0;  // the border
}
TagLayout PlainTagLayout() { return TagLayout{8, 1, false}; }

BlurredReading ReadTagBlurred(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
                              const TagLayout& layout, double blur_sigma,
                              const BlurredReadOptions& options) {
  BlurredReading out;
  const Family& family = Tag36h11();
  // The codes nearest each rotation's hard decisions (at most a few bits off for a readable
  // tag; tag36h11 codes are 11 apart), then their blurred patterns compared with the samples.
  struct Candidate {
    int rotation, id, hamming;
  };
  std::vector<Candidate> candidates;
  BlurredPattern patterns[4];
  bool valid[4] = {false, false, false, false};
  for (int r = 0; r < 4; ++r) {
    std::array<cv::Point2f, 4> q;
    for (int j = 0; j < 4; ++j) q[j] = quad[(r + j) % 4];
    valid[r] = SampleBlurredPattern(grey, q, layout, blur_sigma, &patterns[r]);
    if (!valid[r]) continue;
    const uint64_t word = HardCode(patterns[r]);
    for (std::size_t id = 0; id < family.codes.size(); ++id) {
      const int h = __builtin_popcountll(word ^ family.codes[id]);
      candidates.push_back({r, static_cast<int>(id), h});
    }
  }
  if (candidates.empty()) return out;
  const std::size_t keep = std::min<std::size_t>(6, candidates.size());
  std::partial_sort(candidates.begin(), candidates.begin() + keep, candidates.end(),
                    [](const Candidate& a, const Candidate& b) { return a.hamming < b.hamming; });
  candidates.resize(keep);
  for (const Candidate& c : candidates) {
    double contrast = 0;
    const double e = CodeMisfit(patterns[c.rotation], family.codes[c.id], &contrast);
    if (e < out.residual) {
      out.second = out.residual;
      out.residual = e;
      out.tag_id = c.id;
      out.rotation = c.rotation;
      out.contrast = contrast;
    } else if (e < out.second) {
      out.second = e;
    }
  }
  // The runner-up is the best of the other 5 nearest codes (any rotation): a code farther from
  // the hard decisions fits the samples worse still.
  if (!(out.residual <= options.max_residual && out.second - out.residual >= options.min_margin &&
        out.second >= options.min_ratio * out.residual && out.contrast >= options.min_contrast)) {
    out.tag_id = -1;
  }
  return out;
}

double TagCodeResidual(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
                       const TagLayout& layout, double blur_sigma, int tag_id, double* contrast) {
  const Family& family = Tag36h11();
  if (tag_id < 0 || tag_id >= static_cast<int>(family.codes.size())) return 1e9;
  BlurredPattern p;
  if (!SampleBlurredPattern(grey, quad, layout, blur_sigma, &p)) return 1e9;
  return CodeMisfit(p, family.codes[tag_id], contrast);
}

void DropTagsInconsistentWithNeighbours(const TargetSpec& target, double max_neighbour_error,
                                        std::vector<KalibrViewTag>* tags) {
  if (tags->size() < 2) return;
  std::vector<cv::Point2f> plane, view;
  for (const KalibrViewTag& t : *tags) {
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d p = CornerInTarget(target, 4 * t.tag_id + k);
      plane.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
      view.emplace_back(static_cast<float>(t.corners[k].x()), static_cast<float>(t.corners[k].y()));
    }
  }
  double side = 0;
  for (const KalibrViewTag& t : *tags) side += (t.corners[1] - t.corners[0]).norm() / tags->size();
  const double tolerance = max_neighbour_error * side;
  const cv::Mat H = cv::findHomography(plane, view, cv::RANSAC, tolerance);
  if (H.empty()) {
    tags->clear();
    return;
  }
  std::vector<cv::Point2f> predicted;
  cv::perspectiveTransform(plane, predicted, H);
  std::vector<KalibrViewTag> kept;
  for (std::size_t i = 0; i < tags->size(); ++i) {
    bool ok = true;
    for (int k = 0; k < 4; ++k) ok = ok && cv::norm(predicted[4 * i + k] - view[4 * i + k]) <= tolerance;
    if (ok) kept.push_back((*tags)[i]);
  }
  *tags = kept;
}

bool IsKalibrXJunction(const cv::Mat& grey, const Eigen::Vector2d& corner,
                       const Eigen::Vector2d& to_next, const Eigen::Vector2d& to_previous, double r,
                       int min_contrast) {
  const Eigen::Vector2d in = r * (to_next + to_previous).normalized();
  const Eigen::Vector2d across = r * (to_next - to_previous).normalized();
  const double dark[2] = {Bilinear(grey, corner.x() + in.x(), corner.y() + in.y()),
                          Bilinear(grey, corner.x() - in.x(), corner.y() - in.y())};
  const double light[2] = {Bilinear(grey, corner.x() + across.x(), corner.y() + across.y()),
                           Bilinear(grey, corner.x() - across.x(), corner.y() - across.y())};
  if (std::min({dark[0], dark[1], light[0], light[1]}) < 0) return false;  // outside the image
  return std::min(light[0], light[1]) - std::max(dark[0], dark[1]) >= min_contrast;
}

bool RefineSaddleCorner(const cv::Mat& grey, const Eigen::Vector2d& corner, int half_window_px,
                        double max_shift_px, Eigen::Vector2d* refined) {
  const int h = std::max(2, half_window_px);
  if (!(corner.x() >= h + 1 && corner.y() >= h + 1 && corner.x() < grey.cols - h - 2 &&
        corner.y() < grey.rows - h - 2)) {
    return false;
  }
  std::vector<cv::Point2f> points{cv::Point2f(static_cast<float>(corner.x()),
                                              static_cast<float>(corner.y()))};
  cv::cornerSubPix(grey, points, cv::Size(h, h), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.001));
  *refined = Eigen::Vector2d(points[0].x, points[0].y);
  return refined->allFinite() && (*refined - corner).norm() <= max_shift_px;
}

// Erodes a black mask by `passes` steps of a 3x3 cross (an erosion by n steps equals n erosions
// by one step, so a mask separated by n + 1 is the one separated by n, eroded once more).
void SeparateTags(int passes, cv::Mat* black) {
  if (passes <= 0) return;
  cv::erode(*black, *black, cv::getStructuringElement(cv::MORPH_CROSS, cv::Size(3, 3)),
            cv::Point(-1, -1), passes);
}

cv::Mat KalibrTagMask(const cv::Mat& view_grey, const KalibrDetectorOptions& options) {
  const int up = std::max(1, options.upsample);
  cv::Mat big;
  cv::resize(view_grey, big, cv::Size(), up, up, cv::INTER_LINEAR);
  // Threshold halfway between the local darkest and brightest values; flat areas are white.
  // The window must reach across the blurred edges (2.5 sigma each side) to see both levels.
  int window_px = options.threshold_window_px;
  if (options.blur_sigma > 0) {
    window_px = std::max(window_px, 2 * static_cast<int>(std::ceil(2.5 * options.blur_sigma * up)) + 1);
  }
  const cv::Mat window = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(window_px, window_px));
  cv::Mat lo, hi;
  cv::erode(big, lo, window);
  cv::dilate(big, hi, window);
  cv::Mat black(big.size(), CV_8U);
  for (int y = 0; y < big.rows; ++y) {
    const uchar *g = big.ptr<uchar>(y), *l = lo.ptr<uchar>(y), *u = hi.ptr<uchar>(y);
    uchar* b = black.ptr<uchar>(y);
    for (int x = 0; x < big.cols; ++x) {
      b[x] = (u[x] - l[x] >= options.min_contrast && 2 * g[x] < l[x] + u[x]) ? 255 : 0;
    }
  }
  // Break the tags' corner contacts with Kalibr's corner squares.
  SeparateTags(options.separation_px, &black);
  return black;
}

std::vector<KalibrViewTag> DetectPlainTagsBlurred(const cv::Mat& view_grey, double blur_sigma,
                                                  const BlurredReadOptions& options) {
  std::vector<KalibrViewTag> out;
  KalibrDetectorOptions mask_options;
  mask_options.upsample = 1;
  mask_options.separation_px = 0;
  mask_options.blur_sigma = blur_sigma;
  const cv::Mat black = KalibrTagMask(view_grey, mask_options);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(black, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  std::vector<int> seen;
  for (const auto& contour : contours) {
    std::array<cv::Point2f, 4> quad;
    if (!FitQuad(contour, mask_options.min_side_px, &quad)) continue;
    const BlurredReading reading =
        ReadTagBlurred(view_grey, quad, PlainTagLayout(), blur_sigma, options);
    if (reading.tag_id < 0 || std::count(seen.begin(), seen.end(), reading.tag_id)) continue;
    seen.push_back(reading.tag_id);
    KalibrViewTag tag;
    tag.tag_id = reading.tag_id;
    // Printed TL, TR, BR, BL = k 3, 2, 1, 0.
    for (int j = 0; j < 4; ++j) {
      const cv::Point2f& p = quad[(reading.rotation + j) % 4];
      tag.corners[3 - j] = Eigen::Vector2d(p.x, p.y);
    }
    out.push_back(tag);
  }
  return out;
}

std::vector<KalibrViewTag> DetectKalibrTagsInView(const cv::Mat& view_grey,
                                                  const KalibrDetectorOptions& options) {
  std::vector<KalibrViewTag> out;
  const int up = std::max(1, options.upsample);
  std::vector<int> seen;
  // Blur decides how wide the tag-to-corner-square necks are: more erosion passes for blurrier
  // (inner-ring) views; a tag found in an earlier pass is not read again.
  // The thresholded mask is made once (resizing and the local extremes were ~60% of this
  // function); each pass erodes the previous pass's mask by one more step.
  cv::Mat black = KalibrTagMask(view_grey, options);
  for (int pass = 0; pass < std::max(1, options.separation_passes); ++pass) {
  if (pass > 0) SeparateTags(1, &black);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(black, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
  for (const auto& contour : contours) {
    std::array<cv::Point2f, 4> quad;
    if (!FitQuad(contour, options.min_side_px * up, &quad)) continue;
    // Enlarged pixel -> view pixel (pixel centres at integers in both).
    for (cv::Point2f& p : quad) p = (p + cv::Point2f(0.5f, 0.5f)) / up - cv::Point2f(0.5f, 0.5f);
    cv::Matx33d H;
    int id = DecodeQuad(view_grey, quad, options, &H);
    // A quad that does not read may still be a tag whose contour missed its corners: where a
    // neck to a corner square survived the erosion it pulls that corner out and tilts both sides
    // through it, and the thresholded border band's inner outline is a quad inside the tag; the
    // border or bit cells are then sampled off their middles. The tag's corners are X-junctions:
    // refined as saddles they are the tag's corners whatever the contour did, and the tag is read
    // once more from them. Not for quads inside a tag already read here (the same tag again), nor
    // for solid squares (Kalibr's corner squares), which no corner placement turns into a tag.
    if (id < 0 && options.refine_quad_before_decode &&
        !InsideAnyTag(out, 0.25f * (quad[0] + quad[1] + quad[2] + quad[3])) &&
        !DataAreaIsUniform(view_grey, quad, options.min_contrast)) {
      std::array<cv::Point2f, 4> refined;
      if (RefineQuadCorners(view_grey, quad, options.min_contrast, &refined)) {
        id = DecodeQuad(view_grey, refined, options, &H);
        if (id >= 0) quad = refined;
        // Blurred views (the inner ring of a defocused, demosaiced camera image): bits of one
        // bit width keep ~40% of the contrast and fail the per-bit margin; the tag is read by
        // its whole blurred pattern instead (ReadTagBlurred), from the refined X-junctions.
        if (id < 0 && options.read_blurred && options.blur_sigma > 0) {
          const BlurredReading reading =
              ReadTagBlurred(view_grey, refined, KalibrTagLayout(), options.blur_sigma,
                             options.blurred);
          if (reading.tag_id >= 0) {
            id = reading.tag_id;
            for (int j = 0; j < 4; ++j) quad[j] = refined[(reading.rotation + j) % 4];
            const cv::Point2f tag[4] = {{0, 0}, {kBits, 0}, {kBits, kBits}, {0, kBits}};
            H = cv::Matx33d(cv::getPerspectiveTransform(tag, quad.data()));
          }
        }
      }
    }
    if (id < 0 || std::count(seen.begin(), seen.end(), id)) continue;
    seen.push_back(id);
    KalibrViewTag tag;
    tag.tag_id = id;
    // k: 0 bottom-left, 1 bottom-right, 2 top-right, 3 top-left (in tag bits: y down).
    const double corner_bits[4][2] = {{0, kBits}, {kBits, kBits}, {kBits, 0}, {0, 0}};
    double side = 0;
    for (int k = 0; k < 4; ++k) {
      const cv::Vec3d p = H * cv::Vec3d(corner_bits[k][0], corner_bits[k][1], 1.0);
      tag.corners[k] = Eigen::Vector2d(p[0] / p[2], p[1] / p[2]);
      side += 0.25 * cv::norm(quad[k] - quad[(k + 1) % 4]);
    }
    bool ok = true;
    if (options.refine_in_view) {
      // The clean X-junction reaches 2 bits (the border) around the corner.
      const int half = TagCornerHalfWindow(side);
      for (int k = 0; k < 4 && ok; ++k) {
        ok = RefineSaddleCorner(view_grey, tag.corners[k], half, 0.1 * side, &tag.corners[k]);
      }
    }
    if (ok) out.push_back(tag);
  }
  }
  return out;
}

}  // namespace omni::detectors
