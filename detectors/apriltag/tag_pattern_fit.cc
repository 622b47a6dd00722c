#include "detectors/apriltag/tag_pattern_fit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "detectors/apriltag/kalibr_detector.h"

namespace omni::detectors {
namespace {

// Plane -> view homography (3x3, h22 = 1) taking the four points `from` to `to`.
Eigen::Matrix3d HomographyFrom(const Eigen::Vector2d (&from)[4], const Eigen::Vector2d (&to)[4]) {
  Eigen::Matrix<double, 8, 8> a;
  Eigen::Matrix<double, 8, 1> b;
  for (int i = 0; i < 4; ++i) {
    const double x = from[i].x(), y = from[i].y(), u = to[i].x(), v = to[i].y();
    a.row(2 * i) << x, y, 1, 0, 0, 0, -u * x, -u * y;
    a.row(2 * i + 1) << 0, 0, 0, x, y, 1, -v * x, -v * y;
    b(2 * i) = u;
    b(2 * i + 1) = v;
  }
  const Eigen::Matrix<double, 8, 1> h = a.fullPivLu().solve(b);
  Eigen::Matrix3d m;
  m << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1;
  return m;
}

Eigen::Vector2d Apply(const Eigen::Matrix3d& h, const Eigen::Vector2d& p) {
  const Eigen::Vector3d q = h * p.homogeneous();
  return q.head<2>() / q.z();
}

// The view's map inverted near the tag, roughly: view pixel = quadratic in the raw pixel, fitted
// to the map's own samples (ViewToRaw) over the fitted region (0.05-0.25 view px off: the start
// of ViewOfRaw, and the blur's Jacobian). Raw coordinates are taken about `origin` and scaled by
// 1/16 for the fit's conditioning.
struct RawToViewMap {
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  Eigen::Matrix<double, 6, 2> c = Eigen::Matrix<double, 6, 2>::Zero();

  static Eigen::Matrix<double, 6, 1> Basis(const Eigen::Vector2d& d) {
    Eigen::Matrix<double, 6, 1> f;
    f << 1, d.x(), d.y(), d.x() * d.x(), d.x() * d.y(), d.y() * d.y();
    return f;
  }
  Eigen::Vector2d operator()(const Eigen::Vector2d& raw) const {
    return c.transpose() * Basis((raw - origin) / 16.0);
  }
  Eigen::Matrix2d Jacobian(const Eigen::Vector2d& raw) const {  // d view / d raw
    const Eigen::Vector2d d = (raw - origin) / 16.0;
    Eigen::Matrix<double, 6, 2> df;
    df << 0, 0, 1, 0, 0, 1, 2 * d.x(), 0, d.y(), d.x(), 0, 2 * d.y();
    return (c.transpose() * df) / 16.0;
  }
};

// A tag grid's printed pattern in bits (x right, y down from tag (0, 0)'s top-left outer corner;
// tags a pitch apart): 1 white, 0 black. Plain tag36h11: 8 bits with a 1-bit border, white gaps;
// Kalibr: 10 bits with a 2-bit border and a black square at every gap crossing
// (synthetic/tag_texture.cc prints the same). White beyond the grid (the sheet's margin).
class TargetPattern {
 public:
  explicit TargetPattern(const TargetSpec& target)
      : kalibr_(target.type == TargetType::kKalibrAprilGrid),
        bits_(kalibr_ ? 10 : 8),
        rows_(target.rows),
        cols_(target.cols),
        pitch_bits_((1 + target.spacing) * bits_) {
    const TagLayout layout = kalibr_ ? KalibrTagLayout() : PlainTagLayout();
    cells_.resize(static_cast<size_t>(rows_) * cols_ * bits_ * bits_);
    for (int r = 0; r < rows_; ++r) {
      for (int c = 0; c < cols_; ++c) {
        const int id = TagIdAt(target, r, c);
        float* cells = &cells_[(static_cast<size_t>(r) * cols_ + c) * bits_ * bits_];
        for (int y = 0; y < bits_; ++y) {
          for (int x = 0; x < bits_; ++x) cells[y * bits_ + x] = static_cast<float>(TagCellValue(id, layout, x, y));
        }
      }
    }
  }
  float At(double x, double y) const {
    const int c = static_cast<int>(std::floor(x / pitch_bits_)), r = static_cast<int>(std::floor(y / pitch_bits_));
    const double lx = x - c * pitch_bits_, ly = y - r * pitch_bits_;
    if (lx >= bits_ && ly >= bits_) {  // a gap crossing
      return kalibr_ && r >= -1 && c >= -1 && r < rows_ && c < cols_ ? 0 : 1;
    }
    if (r < 0 || c < 0 || r >= rows_ || c >= cols_ || lx >= bits_ || ly >= bits_) return 1;
    return cells_[(static_cast<size_t>(r) * cols_ + c) * bits_ * bits_ + static_cast<int>(ly) * bits_ +
                  static_cast<int>(lx)];
  }
  int bits() const { return bits_; }
  double pitch_bits() const { return pitch_bits_; }
  double gap_bits() const { return pitch_bits_ - bits_; }
  // The outer corners of all tags: (0, 0) - extent().
  Eigen::Vector2d extent() const {
    return Eigen::Vector2d((cols_ - 1) * pitch_bits_ + bits_, (rows_ - 1) * pitch_bits_ + bits_);
  }
  // The interval [a, b] (bits, shorter than a bit) split where the pattern may change along one
  // axis (a cell's edge: whole bits from a tag's origin, the tags' origins a pitch apart; a gap's
  // far edge is the next origin): up to two parts as (middle, share of b - a).
  int Split(double a, double b, double (&middle)[2], double (&share)[2]) const {
    const double mid = 0.5 * (a + b);
    const int d0 = static_cast<int>(std::floor(mid / pitch_bits_));
    for (int d = d0 - 1; d <= d0 + 1; ++d) {
      const double edge = d * pitch_bits_ + std::clamp(std::round(mid - d * pitch_bits_), 0.0, double(bits_));
      if (edge > a && edge < b) {
        middle[0] = 0.5 * (a + edge), share[0] = (edge - a) / (b - a);
        middle[1] = 0.5 * (edge + b), share[1] = (b - edge) / (b - a);
        return 2;
      }
    }
    middle[0] = mid, share[0] = 1;
    return 1;
  }

 private:
  bool kalibr_;
  int bits_, rows_, cols_;
  double pitch_bits_;
  std::vector<float> cells_;
};

// A normalised 1D Gaussian kernel of variance `var` (samples^2), cut at 3.5 sigma.
std::vector<float> GaussianTaps(double var) {
  const int half = static_cast<int>(std::ceil(3.5 * std::sqrt(std::max(var, 0.0))));
  std::vector<float> taps(2 * half + 1);
  double sum = 0;
  for (int k = -half; k <= half; ++k) sum += taps[k + half] = var > 0 ? std::exp(-0.5 * k * k / var) : (k == 0);
  for (float& t : taps) t = static_cast<float>(t / sum);
  return taps;
}

// `sharp` (CV_32F) blurred by a Gaussian of covariance [a b; b c] (samples^2), replicating its
// border, in two 1D passes instead of one 2D kernel (5x faster at the fit's 2.5+ samples per
// sigma; the 2D filter had been 60% of the pattern fit's time): along x with the conditional
// variance a - b^2/c, then along the slanted line (b/c, 1) with variance c in y. A point (e + (b/c) t, t),
// e ~ N(0, a - b^2/c), t ~ N(0, c), has exactly that covariance. The slanted pass interpolates
// linearly along x, which widens the blur along x by at most 1/4 sample^2 (the fit's blur is
// its own parameter) and moves nothing.
cv::Mat AnisotropicGaussianBlur(const cv::Mat& sharp, const Eigen::Matrix2d& cov) {
  const double a = cov(0, 0), b = cov(0, 1), c = std::max(cov(1, 1), 1e-9);
  const std::vector<float> tx = GaussianTaps(a - b * b / c);
  const std::vector<float> ty = GaussianTaps(c);
  cv::Mat along_x;
  cv::sepFilter2D(sharp, along_x, CV_32F, cv::Mat(tx), cv::Mat(std::vector<float>{1.0f}), cv::Point(-1, -1), 0,
                  cv::BORDER_REPLICATE);
  const double slope = b / c;
  const int rows = sharp.rows, cols = sharp.cols, half = static_cast<int>(ty.size() / 2);
  cv::Mat out(rows, cols, CV_32F, cv::Scalar(0));
  for (int k = -half; k <= half; ++k) {
    const double shift = slope * k;
    const int whole = static_cast<int>(std::floor(shift));
    const float f = static_cast<float>(shift - whole), w = ty[k + half];
    const float w0 = w * (1 - f), w1 = w * f;
    // x + whole and x + whole + 1 both inside the row for x in [begin, end).
    const int begin = std::clamp(-whole, 0, cols), end = std::clamp(cols - 1 - whole, begin, cols);
    for (int y = 0; y < rows; ++y) {
      const float* in = along_x.ptr<float>(std::clamp(y + k, 0, rows - 1));
      float* o = out.ptr<float>(y);
      // The border replicated at both ends; the inside without clamps (vectorised).
      const auto clamped = [&](int x) {
        o[x] += w0 * in[std::clamp(x + whole, 0, cols - 1)] + w1 * in[std::clamp(x + whole + 1, 0, cols - 1)];
      };
      for (int x = 0; x < begin; ++x) clamped(x);
      const float* in0 = in + whole;
      for (int x = begin; x < end; ++x) o[x] += w0 * in0[x] + w1 * in0[x + 1];
      for (int x = end; x < cols; ++x) clamped(x);
    }
  }
  return out;
}

// The pattern blurred by a Gaussian of covariance `cov` (bits^2), sampled every 1/spb bit over
// [lo, hi] (bits, per axis) with sample i's centre at lo + (i + 0.5) / spb; looked up bilinearly.
struct BlurredPattern {
  Eigen::Vector2d lo = Eigen::Vector2d::Zero();
  int spb = 8;
  cv::Mat image;  // CV_32F

  // The pattern's area per sample, unblurred (Sharp), then blurred: a fit blurs one rendering at
  // two widths.
  static cv::Mat Sharp(const TargetPattern& pattern, const Eigen::Vector2d& lo_bits, const Eigen::Vector2d& hi_bits,
                       int spb) {
    const int nx = static_cast<int>(std::ceil((hi_bits.x() - lo_bits.x()) * spb));
    const int ny = static_cast<int>(std::ceil((hi_bits.y() - lo_bits.y()) * spb));
    cv::Mat sharp(ny, nx, CV_32F);
    std::vector<std::array<double, 4>> x_parts(nx);  // middles and shares along x, once per column
    std::vector<int> x_count(nx);
    for (int i = 0; i < nx; ++i) {
      double xm[2] = {0, 0}, xw[2] = {0, 0};
      x_count[i] = pattern.Split(lo_bits.x() + double(i) / spb, lo_bits.x() + double(i + 1) / spb, xm, xw);
      x_parts[i] = {xm[0], xw[0], xm[1], xw[1]};
    }
    for (int j = 0; j < ny; ++j) {
      float* row = sharp.ptr<float>(j);
      double ym[2], yw[2];
      const int nyp = pattern.Split(lo_bits.y() + double(j) / spb, lo_bits.y() + double(j + 1) / spb, ym, yw);
      for (int i = 0; i < nx; ++i) {
        // The sample's area: exact where a cell's edge crosses it (the gaps need not be a whole
        // number of samples: spacing 0.3 is 2.4 bits).
        const auto& xp = x_parts[i];
        double value = 0;
        for (int v = 0; v < nyp; ++v) {
          for (int u = 0; u < x_count[i]; ++u) value += xp[2 * u + 1] * yw[v] * pattern.At(xp[2 * u], ym[v]);
        }
        row[i] = static_cast<float>(value);
      }
    }
    return sharp;
  }

  BlurredPattern(const cv::Mat& sharp, const Eigen::Vector2d& lo_bits, int samples_per_bit,
                 const Eigen::Matrix2d& cov)
      : lo(lo_bits), spb(samples_per_bit), image(AnisotropicGaussianBlur(sharp, cov * spb * spb)) {}

  // The value at `bits`, and its gradient (per bit) where `gradient` is given.
  double At(const Eigen::Vector2d& bits, Eigen::Vector2d* gradient = nullptr) const {
    // A trial step's degenerate homography: NaN, which the fit's step test refuses.
    if (!bits.allFinite()) {
      if (gradient) gradient->setZero();
      return std::numeric_limits<double>::quiet_NaN();
    }
    const double u_free = (bits.x() - lo.x()) * spb - 0.5, v_free = (bits.y() - lo.y()) * spb - 0.5;
    const double u = std::clamp(u_free, 0.0, image.cols - 1.001);
    const double v = std::clamp(v_free, 0.0, image.rows - 1.001);
    const int i = static_cast<int>(u), j = static_cast<int>(v);
    const double a = u - i, b = v - j;
    const float* r0 = image.ptr<float>(j);
    const float* r1 = image.ptr<float>(j + 1);
    const double top = (1 - a) * r0[i] + a * r0[i + 1], bottom = (1 - a) * r1[i] + a * r1[i + 1];
    if (gradient) {
      const double du = (1 - b) * (r0[i + 1] - r0[i]) + b * (r1[i + 1] - r1[i]);
      *gradient = Eigen::Vector2d(u == u_free ? du * spb : 0, v == v_free ? (bottom - top) * spb : 0);
    }
    return (1 - b) * top + b * bottom;
  }
};

// The view pixel that the view's map (ViewToRaw, bilinear between its exact projections) takes
// to `raw`: Newton from the local quadratic's guess (which is 0.05-0.25 view px off over a tag).
std::optional<Eigen::Vector2d> ViewOfRaw(const RingView& view, const RawToViewMap& guess,
                                         const Eigen::Vector2d& raw) {
  Eigen::Vector2d q = guess(raw);
  for (int it = 0; it < 6; ++it) {
    const auto at = view.ViewToRaw(q);
    const auto dx = view.ViewToRaw(q + Eigen::Vector2d(0.25, 0));
    const auto dy = view.ViewToRaw(q + Eigen::Vector2d(0, 0.25));
    if (!at || !dx || !dy) return std::nullopt;
    Eigen::Matrix2d j;
    j.col(0) = (*dx - *at) / 0.25;
    j.col(1) = (*dy - *at) / 0.25;
    const Eigen::Vector2d step = j.inverse() * (raw - *at);
    if (!step.allFinite()) return std::nullopt;
    q += step;
    if (step.norm() < 1e-5) return q;
  }
  return q;
}

// The pattern's region [lo, hi] (bits) fitted to the raw pixels it covers, through the
// plane -> view homography of the control points `plane` (bits) seen near `corners_in_view`.
struct RegionFit {
  Eigen::Vector2d view_corners[4];  // the control points' fitted view pixels
  double sigma_px = 0, misfit = 0, contrast = 0;
  int pixels = 0;
};

// The view's map over a region, inverted roughly: raw -> view as a local quadratic fitted to
// the map's exact points on a 9 x 9 grid over the region (and half a bit round it) as
// `view_from_plane0` puts it, and the raw box those points span.
struct RegionMap {
  RawToViewMap map;
  Eigen::Vector2d raw_lo, raw_hi;
};

// nullopt where fewer than 30 of the grid's points lie on the ring's map.
std::optional<RegionMap> MapOverRegion(const RingView& view, const Eigen::Matrix3d& view_from_plane0,
                                       const Eigen::Vector2d& region_lo, const Eigen::Vector2d& region_hi) {
  std::vector<Eigen::Vector2d> raw_samples, view_samples;
  Eigen::Vector2d raw_lo(1e9, 1e9), raw_hi(-1e9, -1e9);
  constexpr int kGrid = 8;
  const Eigen::Vector2d span = region_hi - region_lo + Eigen::Vector2d(1, 1);
  for (int j = 0; j <= kGrid; ++j) {
    for (int i = 0; i <= kGrid; ++i) {
      const Eigen::Vector2d bits(region_lo.x() - 0.5 + span.x() * i / kGrid, region_lo.y() - 0.5 + span.y() * j / kGrid);
      const Eigen::Vector2d at_view = Apply(view_from_plane0, bits);
      const auto raw = view.ViewToRaw(at_view);
      if (!raw) continue;  // beyond the ring's map (a tag at its rim): those pixels are left out
      raw_samples.push_back(*raw);
      view_samples.push_back(at_view);
      raw_lo = raw_lo.cwiseMin(*raw);
      raw_hi = raw_hi.cwiseMax(*raw);
    }
  }
  if (raw_samples.size() < 30) return std::nullopt;
  RegionMap out;
  out.raw_lo = raw_lo;
  out.raw_hi = raw_hi;
  out.map.origin = 0.5 * (raw_lo + raw_hi);
  Eigen::MatrixXd a(raw_samples.size(), 6), b(raw_samples.size(), 2);
  for (size_t k = 0; k < raw_samples.size(); ++k) {
    a.row(k) = RawToViewMap::Basis((raw_samples[k] - out.map.origin) / 16.0).transpose();
    b.row(k) = view_samples[k].transpose();
  }
  out.map.c = a.colPivHouseholderQr().solve(b);
  return out;
}

// A raw pixel of the fitted region: the view pixel the view's map takes it to, and its value.
struct PatternPixel {
  Eigen::Vector2d view;
  double value;
};

// The raw pixels (centres at integer coordinates) of the region's raw box whose plane point
// (through `plane_from_view0`) lies in the region; in a large region every stride-th pixel each
// way, at most about options.max_pixels (the geometry is over-determined anyway). nullopt where
// the box leaves the image or fewer than 40 pixels remain.
std::optional<std::vector<PatternPixel>> RegionPixels(const cv::Mat& grey, const RingView& view,
                                                      const RegionMap& region_map,
                                                      const Eigen::Matrix3d& plane_from_view0,
                                                      const Eigen::Vector2d& region_lo,
                                                      const Eigen::Vector2d& region_hi,
                                                      const TagPatternFitOptions& options) {
  std::vector<PatternPixel> pixels;
  const Eigen::Vector2d& raw_lo = region_map.raw_lo;
  const Eigen::Vector2d& raw_hi = region_map.raw_hi;
  const int x0 = static_cast<int>(std::floor(raw_lo.x())), x1 = static_cast<int>(std::ceil(raw_hi.x()));
  const int y0 = static_cast<int>(std::floor(raw_lo.y())), y1 = static_cast<int>(std::ceil(raw_hi.y()));
  if (x0 < 0 || y0 < 0 || x1 >= grey.cols || y1 >= grey.rows) return std::nullopt;
  const int stride = options.max_pixels > 0
                         ? std::max(1, static_cast<int>(std::ceil(std::sqrt(double(x1 - x0 + 1) * (y1 - y0 + 1) /
                                                                        options.max_pixels))))
                         : 1;
  for (int y = y0; y <= y1; y += stride) {
    for (int x = x0; x <= x1; x += stride) {
      const auto at_view = ViewOfRaw(view, region_map.map, Eigen::Vector2d(x, y));
      if (!at_view) continue;
      const Eigen::Vector2d bits = Apply(plane_from_view0, *at_view);
      if ((bits - region_lo).minCoeff() < 0 || (region_hi - bits).minCoeff() < 0) continue;
      pixels.push_back({*at_view, grey.at<float>(y, x)});
    }
  }
  if (static_cast<int>(pixels.size()) < 40) return std::nullopt;
  return pixels;
}

// The blur step between the fit's two renders (raw px): the blur is interpolated between them.
constexpr double kSigmaStep = 0.2;

// The pattern rendered for one round of the fit: blurred at `sigma` and at sigma + kSigmaStep.
struct PatternRenders {
  BlurredPattern at_sigma, at_wider;
};

// The renders for the control points now at `corners_now` (view px): the raw pixel's blur
// (Gaussian sigma plus the pixel's box) taken into bits through d raw / d plane at the
// region's centre (`centre_bits`), sampled at least 2.5 samples per blur width (bilinear
// look-ups stay smooth), from whole samples off the top-left control point (a tag's origin:
// its cells' edges fall between samples) over the region and 3.5 blur widths + 1 bit round it.
// nullopt where the centre is off the view's map or the map there is degenerate.
std::optional<PatternRenders> RenderAtBlur(const RingView& view, const RawToViewMap& map,
                                           const TargetPattern& pattern, const Eigen::Vector2d (&plane)[4],
                                           const Eigen::Vector2d (&corners_now)[4],
                                           const Eigen::Vector2d& centre_bits, const Eigen::Vector2d& region_lo,
                                           const Eigen::Vector2d& region_hi, double sigma,
                                           const TagPatternFitOptions& options) {
  const Eigen::Matrix3d view_from_plane = HomographyFrom(plane, corners_now);
  Eigen::Matrix2d view_from_plane_j;
  for (int a = 0; a < 2; ++a) {
    Eigen::Vector2d d = Eigen::Vector2d::Zero();
    d(a) = 0.01;
    view_from_plane_j.col(a) = (Apply(view_from_plane, centre_bits + d) - Apply(view_from_plane, centre_bits - d)) / 0.02;
  }
  const Eigen::Vector2d centre_view = Apply(view_from_plane, centre_bits);
  const auto centre_raw = view.ViewToRaw(centre_view);
  if (!centre_raw) return std::nullopt;
  const Eigen::Matrix2d raw_from_plane = map.Jacobian(*centre_raw).inverse() * view_from_plane_j;
  if (!raw_from_plane.allFinite() || std::abs(raw_from_plane.determinant()) < 1e-6) return std::nullopt;
  const Eigen::Matrix2d plane_from_raw = raw_from_plane.inverse();
  const auto cov_bits = [&](double s) {
    return Eigen::Matrix2d(plane_from_raw * ((s * s + 1.0 / 12) * Eigen::Matrix2d::Identity()) *
                           plane_from_raw.transpose());
  };
  const double bits_per_px = std::sqrt(std::abs(plane_from_raw.determinant()));
  const int spb = std::clamp(static_cast<int>(std::ceil(2.5 / (bits_per_px * std::sqrt(sigma * sigma + 1.0 / 12)))),
                             options.samples_per_bit / 2, 4 * options.samples_per_bit);
  const double max_sigma_bits =
      std::sqrt(cov_bits(sigma + kSigmaStep).selfadjointView<Eigen::Upper>().eigenvalues().maxCoeff());
  const double margin = 3.5 * max_sigma_bits + 1;
  const Eigen::Vector2d lo = plane[3] + ((region_lo - plane[3]).array() - margin).cwiseProduct(Eigen::Array2d::Constant(spb)).floor().matrix() / spb;
  const Eigen::Vector2d hi = region_hi.array() + margin;
  const cv::Mat sharp = BlurredPattern::Sharp(pattern, lo, hi, spb);
  return PatternRenders{BlurredPattern(sharp, lo, spb, cov_bits(sigma)),
                        BlurredPattern(sharp, lo, spb, cov_bits(sigma + kSigmaStep))};
}

// The fit's parameters: the 4 view corners' offsets (8), black, contrast, tau (the blur between
// the two renders, linearly) and two tone terms.
using Vector13 = Eigen::Matrix<double, 13, 1>;

// The region's pixels as the renders model them, for parameters q: each pixel's plane point
// through the homography of the moved corners, the pattern there (blurred between the two
// renders by tau), through the levels and the tone terms.
struct PatternModel {
  const Eigen::Vector2d (&view_corners)[4];
  const Eigen::Vector2d (&plane)[4];
  const std::vector<PatternPixel>& pixels;
  const PatternRenders& renders;

  // Residuals (model - pixel) and, where asked, the pattern at sigma and the renders' difference.
  void Evaluate(const Vector13& q, Eigen::VectorXd* r, Eigen::VectorXd* b_sigma, Eigen::VectorXd* b_diff) const {
    const int n = static_cast<int>(pixels.size());
    Eigen::Vector2d c[4];
    for (int k = 0; k < 4; ++k) c[k] = view_corners[k] + q.segment<2>(2 * k);
    const Eigen::Matrix3d plane_from_view = HomographyFrom(c, plane);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d bits = Apply(plane_from_view, pixels[i].view);
      const double b0 = renders.at_sigma.At(bits), b1 = renders.at_wider.At(bits);
      if (b_sigma) (*b_sigma)(i) = b0;
      if (b_diff) (*b_diff)(i) = b1 - b0;
      const double b = b0 + q(10) * (b1 - b0);
      (*r)(i) = q(8) + q(9) * b + q(11) * b * (1 - b) + q(12) * b * (1 - b) * (1 - 2 * b) - pixels[i].value;
    }
  }

  // The residuals' Jacobian at p (b0, bd: Evaluate's pattern values there). The corners' columns
  // by the chain rule: the pattern's gradient at each pixel's plane point times how that point
  // moves with each corner (the homography redone per corner).
  Eigen::MatrixXd Jacobian(const Vector13& p, const Eigen::VectorXd& b0, const Eigen::VectorXd& bd,
                           bool tone_terms) const {
    const int n = static_cast<int>(pixels.size());
    Eigen::MatrixXd jacobian(n, 13);
    {
      constexpr double kStep = 0.01;  // view px
      Eigen::Vector2d c[4];
      for (int k = 0; k < 4; ++k) c[k] = view_corners[k] + p.segment<2>(2 * k);
      const Eigen::Matrix3d plane_from_view = HomographyFrom(c, plane);
      Eigen::Matrix3d moved[8];
      for (int k = 0; k < 8; ++k) {
        Eigen::Vector2d ck[4];
        std::copy(c, c + 4, ck);
        ck[k / 2](k % 2) += kStep;
        moved[k] = HomographyFrom(ck, plane);
      }
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector2d bits = Apply(plane_from_view, pixels[i].view);
        Eigen::Vector2d g0, g1;
        const double v0 = renders.at_sigma.At(bits, &g0), v1 = renders.at_wider.At(bits, &g1);
        const double b = v0 + p(10) * (v1 - v0);
        const double dtone = p(9) + p(11) * (1 - 2 * b) + p(12) * (1 - 6 * b + 6 * b * b);
        const Eigen::Vector2d g = dtone * (g0 + p(10) * (g1 - g0));
        for (int k = 0; k < 8; ++k) jacobian(i, k) = g.dot(Apply(moved[k], pixels[i].view) - bits) / kStep;
      }
    }
    const Eigen::ArrayXd b = (b0 + p(10) * bd).array();
    jacobian.col(8).setOnes();
    jacobian.col(9) = b.matrix();
    const Eigen::ArrayXd dtone = p(9) + p(11) * (1 - 2 * b) + p(12) * (1 - 6 * b + 6 * b * b);
    jacobian.col(10) = (dtone * bd.array()).matrix();
    jacobian.col(11) = (b * (1 - b)).matrix();
    jacobian.col(12) = (b * (1 - b) * (1 - 2 * b)).matrix();
    if (!tone_terms) jacobian.rightCols<2>().setZero();
    return jacobian;
  }
};

// Levenberg-Marquardt on the model's parameters from *p (tau clamped to [-2, 3]) until no step
// improves or the corners move under 1e-4 view px; *cost the final sum of squared residuals.
// False where a step is not finite.
bool FitPatternModel(const PatternModel& model, const TagPatternFitOptions& options, Vector13* p, double* cost) {
  const int n = static_cast<int>(model.pixels.size());
  Eigen::VectorXd r(n), b0(n), bd(n), r_try(n);
  model.Evaluate(*p, &r, &b0, &bd);
  *cost = r.squaredNorm();
  double lambda = 1e-3;
  for (int it = 0; it < options.max_iterations; ++it) {
    const Eigen::MatrixXd jacobian = model.Jacobian(*p, b0, bd, options.tone_terms);
    const Eigen::Matrix<double, 13, 13> h = jacobian.transpose() * jacobian;
    const Vector13 g = jacobian.transpose() * r;
    bool improved = false;
    Vector13 step = Vector13::Zero();
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      Eigen::Matrix<double, 13, 13> damped = h;
      damped.diagonal() += lambda * h.diagonal();
      if (!options.tone_terms) damped.diagonal().tail<2>().setOnes();
      step = damped.ldlt().solve(-g);
      if (!step.allFinite()) return false;
      Vector13 q = *p + step;
      q(10) = std::clamp(q(10), -2.0, 3.0);
      model.Evaluate(q, &r_try, nullptr, nullptr);
      if (r_try.squaredNorm() < *cost) {
        *p = q;
        model.Evaluate(*p, &r, &b0, &bd);
        *cost = r.squaredNorm();
        lambda = std::max(1e-6, lambda / 4);
        improved = true;
      } else {
        lambda *= 8;
      }
    }
    if (!improved || step.head<8>().cwiseAbs().maxCoeff() < 1e-4) break;
  }
  return true;
}

std::optional<RegionFit> FitPatternRegion(const cv::Mat& grey, const RingView& view, const TargetPattern& pattern,
                                          const Eigen::Vector2d (&plane)[4], const Eigen::Vector2d& region_lo,
                                          const Eigen::Vector2d& region_hi,
                                          const Eigen::Vector2d (&corners_in_view)[4],
                                          const TagPatternFitOptions& options) {
  Eigen::Vector2d view_corners[4];
  std::copy(corners_in_view, corners_in_view + 4, view_corners);
  const Eigen::Vector2d centre_bits = 0.25 * (plane[0] + plane[1] + plane[2] + plane[3]);

  // The view's map sampled over the fitted region (where it has one) and inverted roughly.
  const Eigen::Matrix3d view_from_plane0 = HomographyFrom(plane, view_corners);
  const std::optional<RegionMap> region_map = MapOverRegion(view, view_from_plane0, region_lo, region_hi);
  if (!region_map) return std::nullopt;
  const std::optional<std::vector<PatternPixel>> pixels =
      RegionPixels(grey, view, *region_map, view_from_plane0.inverse(), region_lo, region_hi, options);
  if (!pixels) return std::nullopt;
  const int n = static_cast<int>(pixels->size());
  // Levels from the pixels' spread; the blur from a camera's typical defocus, then fitted.
  std::vector<double> values;
  for (const PatternPixel& p : *pixels) values.push_back(p.value);
  std::sort(values.begin(), values.end());
  const double black = values[n / 20], white = values[n - 1 - n / 20];
  double sigma = 0.8;

  Vector13 p = Vector13::Zero();
  p(8) = black;
  p(9) = white - black;
  double misfit = 0;
  for (int round = 0; round < options.max_rounds; ++round) {
    Eigen::Vector2d corners_now[4];
    for (int k = 0; k < 4; ++k) corners_now[k] = view_corners[k] + p.segment<2>(2 * k);
    const std::optional<PatternRenders> renders = RenderAtBlur(view, region_map->map, pattern, plane, corners_now,
                                                               centre_bits, region_lo, region_hi, sigma, options);
    if (!renders) return std::nullopt;
    p(10) = 0;
    const PatternModel model{view_corners, plane, *pixels, *renders};
    double cost = 0;
    if (!FitPatternModel(model, options, &p, &cost)) return std::nullopt;
    misfit = std::sqrt(cost / n) / std::max(1e-9, p(9));
    const double new_sigma = std::clamp(sigma + p(10) * kSigmaStep, 0.1, 3.0);
    const bool settled = std::abs(new_sigma - sigma) < 0.02;
    sigma = new_sigma;
    if (settled) break;
  }
  if (!(p(9) >= options.min_contrast) || !(misfit <= options.max_misfit)) return std::nullopt;
  RegionFit fit;
  fit.sigma_px = sigma;
  fit.misfit = misfit;
  fit.contrast = p(9);
  fit.pixels = n;
  for (int k = 0; k < 4; ++k) fit.view_corners[k] = view_corners[k] + p.segment<2>(2 * k);
  return fit;
}

// A correlation's result: the best translation (view px, sub-pixel) and the best half a pitch or
// more from it (to a view pixel), with their scores.
struct Peak {
  double best = -2, second = -2;
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  Eigen::Vector2d second_shift = Eigen::Vector2d::Zero();  // to a view pixel
};

// The template for a correlation: the pattern over the region [lo, hi] (bits) as `h_inverse`
// (view -> bits) puts it in the view box at (tx0, ty0), 2 x 2 samples per view pixel, pixels
// outside the region masked.
void PatternTemplate(const TargetPattern& pattern, const Eigen::Matrix3d& h_inverse, const Eigen::Vector2d& lo,
                     const Eigen::Vector2d& hi, int tx0, int ty0, cv::Mat* templ, cv::Mat* mask) {
  for (int y = 0; y < templ->rows; ++y) {
    for (int x = 0; x < templ->cols; ++x) {
      double sum = 0;
      for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
          const Eigen::Vector2d b = Apply(h_inverse, Eigen::Vector2d(tx0 + x + (i - 0.5) / 2, ty0 + y + (j - 0.5) / 2));
          sum += pattern.At(b.x(), b.y());
        }
      }
      templ->at<float>(y, x) = static_cast<float>(sum / 4);
      const Eigen::Vector2d b = Apply(h_inverse, Eigen::Vector2d(tx0 + x, ty0 + y));
      mask->at<float>(y, x) = (b - lo).minCoeff() >= 0 && (hi - b).minCoeff() >= 0 ? 1.0f : 0.0f;
    }
  }
}

// The peaks of a correlation score over `search` (at 1 / f of the resolution), as translations
// of the template box at (tx0, ty0): the best, refined by a parabola per axis, and the best at
// least half a pitch (`pitch_view`, view px) from it.
Peak PeakOf(const cv::Mat& score, const cv::Rect& search, int tx0, int ty0, int f, double pitch_view) {
  Peak peak;
  cv::Point at;
  for (int y = 0; y < score.rows; ++y) {
    for (int x = 0; x < score.cols; ++x) {
      const float s = score.at<float>(y, x);
      if (std::isfinite(s) && s > peak.best) peak.best = s, at = cv::Point(x, y);
    }
  }
  for (int y = 0; y < score.rows; ++y) {
    for (int x = 0; x < score.cols; ++x) {
      const float s = score.at<float>(y, x);
      if (std::isfinite(s) && f * std::hypot(x - at.x, y - at.y) >= 0.5 * pitch_view && s > peak.second) {
        peak.second = s;
        peak.second_shift = Eigen::Vector2d(search.x + f * x - tx0, search.y + f * y - ty0);
      }
    }
  }
  // Sub-pixel: a parabola per axis.
  const auto vertex = [&](int dx, int dy) {
    if (at.x - dx < 0 || at.y - dy < 0 || at.x + dx >= score.cols || at.y + dy >= score.rows) return 0.0;
    const double a = score.at<float>(at.y - dy, at.x - dx), b = score.at<float>(at.y, at.x),
                 c = score.at<float>(at.y + dy, at.x + dx);
    const double d = a - 2 * b + c;
    return d < 0 ? std::clamp(0.5 * (a - c) / d, -0.5, 0.5) : 0.0;
  };
  peak.shift = Eigen::Vector2d(search.x + at.x + vertex(1, 0) - tx0, search.y + at.y + vertex(0, 1) - ty0);
  return peak;
}

// The whole target's pattern correlated with a view: what every correlation of one alignment
// shares (the region [lo, hi] in bits, the view's blur, the search radius and the pitch in view
// px).
struct PatternCorrelation {
  const RingView& view;
  const TargetPattern& pattern;
  Eigen::Vector2d lo, hi;
  double blur = 1, radius_view_px = 0, pitch_view = 0;

  // One correlation: the template is the pattern over the region as `h` (bits -> view) puts it
  // in the view, blurred as the view is, pixels outside the region masked; every translation
  // within the radius (clipped to the view), at 1 / f of the resolution where f > 1 (the score
  // only). nullopt where the target leaves the view's map or the template or search is too
  // small or large.
  std::optional<Peak> operator()(const Eigen::Matrix3d& h, int f) const {
    const Eigen::Matrix3d h_inverse = h.inverse();
    Eigen::Vector2d v_lo(1e9, 1e9), v_hi(-1e9, -1e9);
    for (const Eigen::Vector2d& c : {lo, hi, Eigen::Vector2d(lo.x(), hi.y()), Eigen::Vector2d(hi.x(), lo.y())}) {
      const Eigen::Vector2d at = Apply(h, c);
      if (!at.allFinite() || !view.ViewToRaw(at)) return std::nullopt;  // the whole target in the view's map
      v_lo = v_lo.cwiseMin(at);
      v_hi = v_hi.cwiseMax(at);
    }
    const int pad = 2;
    const int tx0 = static_cast<int>(std::floor(v_lo.x())) - pad, ty0 = static_cast<int>(std::floor(v_lo.y())) - pad;
    const int tw = static_cast<int>(std::ceil(v_hi.x())) + pad + 1 - tx0;
    const int th = static_cast<int>(std::ceil(v_hi.y())) + pad + 1 - ty0;
    if (tw < 8 || th < 8 || tw > 400 || th > 400) return std::nullopt;
    cv::Mat templ(th, tw, CV_32F), mask(th, tw, CV_32F);
    PatternTemplate(pattern, h_inverse, lo, hi, tx0, ty0, &templ, &mask);
    cv::GaussianBlur(templ, templ, cv::Size(0, 0), std::max(0.3, blur));
    const int r = static_cast<int>(std::ceil(radius_view_px));
    const cv::Rect search =
        cv::Rect(tx0 - r, ty0 - r, tw + 2 * r, th + 2 * r) & cv::Rect(0, 0, view.image.cols, view.image.rows);
    if (search.width < tw + 2 || search.height < th + 2) return std::nullopt;
    cv::Mat image, score;
    view.image(search).convertTo(image, CV_32F, 1.0 / 255);
    if (f > 1) {  // at 1 / f of the resolution: the score only
      cv::resize(image, image, cv::Size(), 1.0 / f, 1.0 / f, cv::INTER_AREA);
      cv::resize(templ, templ, cv::Size(), 1.0 / f, 1.0 / f, cv::INTER_AREA);
      cv::resize(mask, mask, cv::Size(), 1.0 / f, 1.0 / f, cv::INTER_AREA);
      cv::threshold(mask, mask, 0.99, 1.0, cv::THRESH_BINARY);
      if (image.cols < templ.cols || image.rows < templ.rows) return std::nullopt;
    }
    cv::matchTemplate(image, templ, score, cv::TM_CCOEFF_NORMED, mask);
    return PeakOf(score, search, tx0, ty0, f, pitch_view);
  }
};

// The prediction's scale and turn are off too (a few percent, a few degrees): each of a few
// similarities of `view_from_bits` about the target's centre is correlated, the best kept
// (*view_from_bits_found: its homography). Scales first, then turns at the best scale; at half
// the resolution where the target is large enough (the similarity is chosen there), then the
// chosen one at full resolution.
std::optional<Peak> BestSimilarity(const PatternCorrelation& correlate, const Eigen::Matrix3d& view_from_bits,
                                   const Eigen::Vector2d& extent, const TargetAlignOptions& options,
                                   Eigen::Matrix3d* view_from_bits_found) {
  const Eigen::Vector2d centre_view = Apply(view_from_bits, 0.5 * extent);
  std::optional<Peak> found;
  *view_from_bits_found = view_from_bits;
  const Eigen::Vector2d corner_view = Apply(view_from_bits, Eigen::Vector2d::Zero());
  const int coarse = (Apply(view_from_bits, extent) - corner_view).norm() > 48 ? 2 : 1;
  const auto try_similarity = [&](double scale, double turn_deg) {
    const double t = turn_deg * M_PI / 180;
    Eigen::Matrix3d similarity = Eigen::Matrix3d::Identity();
    similarity.topLeftCorner<2, 2>() << scale * std::cos(t), -scale * std::sin(t), scale * std::sin(t),
        scale * std::cos(t);
    similarity.topRightCorner<2, 1>() = centre_view - similarity.topLeftCorner<2, 2>() * centre_view;
    const Eigen::Matrix3d h = similarity * view_from_bits;
    const auto peak = correlate(h, coarse);
    if (peak && (!found || peak->best > found->best)) {
      found = peak;
      *view_from_bits_found = h;
      return true;
    }
    return false;
  };
  const std::vector<double> scales =
      options.search_similarity ? std::vector<double>{1.0, 0.96, 1.04, 0.92, 1.08} : std::vector<double>{1.0};
  const std::vector<double> turns = options.search_similarity ? std::vector<double>{-4.0, 4.0} : std::vector<double>{};
  double best_scale = 1;
  for (const double scale : scales) {
    if (try_similarity(scale, 0)) best_scale = scale;
  }
  for (const double turn_deg : turns) try_similarity(best_scale, turn_deg);
  if (found && coarse > 1) found = correlate(*view_from_bits_found, 1);
  return found;
}

// The whole pattern (control points `plane`: its outer tag corners, bits) fitted to the raw
// pixels from `view_from_bits` moved by `from` (view px), as an alignment for the tags' own
// fits (the blur's first estimate and a coarser render do); nullopt where the fit fails or a
// corner moves more than max_shift_pitches pitches.
std::optional<RegionFit> FitWholePattern(const cv::Mat& grey, const PatternCorrelation& c,
                                         const Eigen::Vector2d (&plane)[4], const Eigen::Matrix3d& view_from_bits,
                                         const Eigen::Vector2d& from, const TargetAlignOptions& options) {
  TagPatternFitOptions fit_options;
  fit_options.max_misfit = options.max_misfit;
  fit_options.max_pixels = options.max_fit_pixels;
  fit_options.max_rounds = 2;
  fit_options.max_iterations = 12;
  fit_options.samples_per_bit = 4;
  Eigen::Vector2d at[4];
  for (int k = 0; k < 4; ++k) at[k] = Apply(view_from_bits, plane[k]) + from;
  auto fit = FitPatternRegion(grey, c.view, c.pattern, plane, c.lo, c.hi, at, fit_options);
  for (int k = 0; k < 4 && fit; ++k) {
    if (!((fit->view_corners[k] - at[k]).norm() <= options.max_shift_pitches * c.pitch_view)) fit.reset();
  }
  return fit;
}

}  // namespace

std::optional<TagPatternFit> FitTagPattern(const cv::Mat& grey, const RingView& view,
                                           const TargetSpec& target, int tag_id,
                                           const Eigen::Vector2d (&corners_in_view)[4],
                                           const TagPatternFitOptions& options) {
  int row = 0, col = 0;
  if (target.type == TargetType::kChessboard || !TagCell(target, tag_id, &row, &col)) return std::nullopt;
  const TargetPattern pattern(target);
  const double b = pattern.bits();
  const Eigen::Vector2d origin(col * pattern.pitch_bits(), row * pattern.pitch_bits());
  // The tag's corners in bits (CornerInTarget's k order: bottom-left, bottom-right, top-right,
  // top-left; y down).
  const Eigen::Vector2d plane[4] = {origin + Eigen::Vector2d(0, b), origin + Eigen::Vector2d(b, b),
                                    origin + Eigen::Vector2d(b, 0), origin};
  const double reach = options.reach_into_gap * pattern.gap_bits();
  const auto region = FitPatternRegion(grey, view, pattern, plane, origin.array() - reach,
                                       origin.array() + b + reach, corners_in_view, options);
  if (!region) return std::nullopt;
  TagPatternFit fit;
  fit.sigma_px = region->sigma_px;
  fit.misfit = region->misfit;
  fit.pixels = region->pixels;
  for (int k = 0; k < 4; ++k) {
    const auto start = view.ViewToRaw(corners_in_view[k]);
    const auto raw = view.ViewToRaw(region->view_corners[k]);
    if (!start || !raw) return std::nullopt;
    fit.corners[k] = *raw;
    if (!fit.corners[k].allFinite() || (fit.corners[k] - *start).norm() > options.max_shift_px) {
      return std::nullopt;
    }
  }
  return fit;
}

std::optional<TargetAlignment> AlignTargetPattern(const cv::Mat& grey, const RingView& view,
                                                  const TargetSpec& target,
                                                  const Eigen::Matrix3d& view_from_plane_mm,
                                                  double radius_view_px, const TargetAlignOptions& options) {
  if (target.type == TargetType::kChessboard || view.image.empty()) return std::nullopt;
  const TargetPattern pattern(target);
  const double mm_per_bit = target.tag_size_mm / pattern.bits();
  Eigen::Matrix3d plane_mm_from_bits = Eigen::Matrix3d::Identity();
  plane_mm_from_bits(0, 0) = plane_mm_from_bits(1, 1) = mm_per_bit;
  const Eigen::Matrix3d view_from_bits = view_from_plane_mm * plane_mm_from_bits;
  const Eigen::Vector2d extent = pattern.extent();
  const double reach = 0.75 * pattern.gap_bits();
  const Eigen::Vector2d lo = Eigen::Vector2d::Constant(-reach), hi = extent.array() + reach;

  // The pitch in the view (px, mean of both axes).
  const Eigen::Vector2d origin_view = Apply(view_from_bits, Eigen::Vector2d::Zero());
  const double pitch_view =
      0.5 * ((Apply(view_from_bits, Eigen::Vector2d(pattern.pitch_bits(), 0)) - origin_view).norm() +
             (Apply(view_from_bits, Eigen::Vector2d(0, pattern.pitch_bits())) - origin_view).norm());
  const double blur = view.blur_sigma ? *view.blur_sigma : 1.0;
  const PatternCorrelation correlate{view, pattern, lo, hi, blur, radius_view_px, pitch_view};

  Eigen::Matrix3d view_from_bits_found;
  const std::optional<Peak> found = BestSimilarity(correlate, view_from_bits, extent, options, &view_from_bits_found);
  if (!found || !(found->best >= options.min_score) || found->best - found->second < options.min_margin_to_fit) {
    return std::nullopt;
  }
  const double best = found->best, second = found->second;
  const Eigen::Vector2d shift = found->shift;

  // The whole pattern fitted to the raw pixels, its outer tag corners free.
  const Eigen::Vector2d plane[4] = {{0, extent.y()}, {extent.x(), extent.y()}, {extent.x(), 0}, {0, 0}};
  const auto fit = FitWholePattern(grey, correlate, plane, view_from_bits_found, shift, options);
  if (!fit) return std::nullopt;
  // A close runner-up (an elongated grid shifted by a pitch along its length still overlaps
  // most of itself): the pattern fitted there too must fit clearly worse, or land where the
  // best did.
  if (found->best - found->second < options.min_margin) {
    const auto other = FitWholePattern(grey, correlate, plane, view_from_bits_found, found->second_shift, options);
    const bool same = other && (other->view_corners[3] - fit->view_corners[3]).norm() < 0.25 * pitch_view;
    if (other && !same && !(other->misfit >= options.min_misfit_ratio * fit->misfit)) return std::nullopt;
  }
  TargetAlignment out;
  out.view_from_plane = HomographyFrom(plane, fit->view_corners) * plane_mm_from_bits.inverse();
  out.score = best;
  out.second = second;
  out.misfit = fit->misfit;
  return out;
}

}  // namespace omni::detectors
