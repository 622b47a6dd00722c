#include "detectors/lips/luma_edge.h"

#include <algorithm>
#include <cmath>

#include "io/image_file.h"

namespace omni::detectors {
namespace {

constexpr double kMin = -16, kMax = 64, kStep = 0.125;  // the tables' levels (8-bit linear)
constexpr double kMaxSigma2 = 16;
// Rec. 601 luma weights in BGR order, as JPEG computes Y' from the encoded channels.
const Eigen::Vector3d kLumaWeights(0.114, 0.587, 0.299);

// The sRGB encoding of a linear level, both on the 8-bit scale, clipped to the sensor's range.
double SrgbExact(double x) { return 255.0 * io::SrgbFromLinear(std::clamp(x, 0.0, 255.0) / 255.0); }

// The same, tabulated at 1/32 level (within 1e-3 of a level interpolated linearly): the tables
// below and every profile's expected Y' need it thousands of times per image.
double Srgb(double x) {
  constexpr double kFine = 32;
  static const std::vector<double> table = [] {
    std::vector<double> t(static_cast<size_t>(255 * kFine) + 2);
    for (size_t i = 0; i < t.size(); ++i) t[i] = SrgbExact(i / kFine);
    return t;
  }();
  if (x <= 0) return 0;
  if (x >= 255) return 255;
  const double f = x * kFine;
  const int i = static_cast<int>(f);
  return table[i] + (f - i) * (table[i + 1] - table[i]);
}

// The pixel's linear BGR colour in 8-bit levels.
Eigen::Vector3d PixelColour(const cv::Mat& bgr, int u, int v) {
  if (bgr.depth() == CV_8U) {
    const cv::Vec3b& p = bgr.at<cv::Vec3b>(v, u);
    return Eigen::Vector3d(p[0], p[1], p[2]);
  }
  const cv::Vec3w& p = bgr.at<cv::Vec3w>(v, u);
  return Eigen::Vector3d(p[0], p[1], p[2]) / 257.0;
}

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on the Legendre polynomial's roots).
struct GaussLegendre {
  static constexpr int kN = 20;
  double x[kN], w[kN];
  GaussLegendre() {
    for (int i = 0; i < kN; ++i) {
      double z = std::cos(M_PI * (i + 0.75) / (kN + 0.5)), dp = 1;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1, p1 = z;  // P_0, P_1, ... by the recurrence up to P_kN
        for (int k = 2; k <= kN; ++k) {
          const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = kN * (z * p1 - p0) / (z * z - 1);
        const double step = p1 / dp;
        z -= step;
        if (std::abs(step) < 1e-15) break;
      }
      x[i] = z;
      w[i] = 2 / ((1 - z * z) * dp * dp);
    }
  }
};

}  // namespace

NoisyLevels::NoisyLevels(double sigma2) : sigma2_(std::clamp(sigma2, 0.0, kMaxSigma2)) {
  if (sigma2_ <= 0) return;
  static const GaussLegendre rule;
  const double sigma = std::sqrt(sigma2_);
  const int n = static_cast<int>(std::lround((kMax - kMin) / kStep)) + 1;
  linear_.resize(n);
  encoded_.resize(n);
  encoded2_.resize(n);
  for (int i = 0; i < n; ++i) {
    const double x = kMin + i * kStep;
    // E[max(0, x + n)] in closed form; E[s(max(0, x + n))] over the part the clip leaves alone
    // (the clipped part encodes to 0), where the integrand is smooth: Gauss-Legendre.
    const double t = x / sigma;
    const double pdf = std::exp(-0.5 * t * t) / std::sqrt(2 * M_PI);
    linear_[i] = x * 0.5 * std::erfc(-t / std::sqrt(2.0)) + sigma * pdf;
    const double z0 = std::max(-6.0, -t), z1 = 6.0;
    double enc = 0, enc2 = 0;
    if (z0 < z1) {
      const double half = 0.5 * (z1 - z0), mid = 0.5 * (z1 + z0);
      for (int j = 0; j < GaussLegendre::kN; ++j) {
        const double z = mid + half * rule.x[j];
        const double w = rule.w[j] * half * std::exp(-0.5 * z * z) / std::sqrt(2 * M_PI);
        const double e = Srgb(x + sigma * z);
        enc += w * e;
        enc2 += w * e * e;
      }
    }
    encoded_[i] = enc;
    encoded2_[i] = enc2;
  }
}

double NoisyLevels::Table(const std::vector<double>& table, double x) const {
  const double f = (std::max(x, kMin) - kMin) / kStep;
  const int i = std::min(static_cast<int>(table.size()) - 2, static_cast<int>(f));
  return table[i] + (f - i) * (table[i + 1] - table[i]);
}

double NoisyLevels::Linear(double x) const {
  if (sigma2_ <= 0 || x >= kMax) return std::clamp(x, 0.0, 255.0);
  return Table(linear_, x);
}

double NoisyLevels::Encoded(double x) const {
  if (sigma2_ <= 0) return Srgb(x);
  if (x < kMax) return Table(encoded_, x);
  // Far from black: s(x) + s''(x) sigma^2 / 2 (s'' over +-1 level).
  const double s = Srgb(x);
  return s + 0.5 * sigma2_ * (Srgb(x + 1) - 2 * s + Srgb(x - 1));
}

double NoisyLevels::NoiseFree(double mean_linear) const {
  if (sigma2_ <= 0 || mean_linear >= linear_.back()) return mean_linear;
  if (mean_linear <= linear_.front()) return kMin;
  // Linear() is increasing: bisection on the table's index.
  int lo = 0, hi = static_cast<int>(linear_.size()) - 1;
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    (linear_[mid] <= mean_linear ? lo : hi) = mid;
  }
  const double f = (mean_linear - linear_[lo]) / std::max(1e-12, linear_[hi] - linear_[lo]);
  return kMin + (lo + f) * kStep;
}

double NoisyLevels::EncodedVariance(double x) const {
  if (sigma2_ <= 0) return 0;
  if (x >= kMax) {
    const double slope = 0.5 * (Srgb(x + 1) - Srgb(x - 1));
    return slope * slope * sigma2_;
  }
  const double e = Table(encoded_, x);
  return std::max(0.0, Table(encoded2_, x) - e * e);
}

double NoisyLevels::LumaVariance(const Eigen::Vector3d& bgr) const {
  double v = 0;
  for (int c = 0; c < 3; ++c) v += kLumaWeights[c] * kLumaWeights[c] * EncodedVariance(bgr[c]);
  return v;
}

double NoisyLevels::Luma(const Eigen::Vector3d& bgr) const {
  double y = 0;
  for (int c = 0; c < 3; ++c) y += kLumaWeights[c] * Encoded(bgr[c]);
  return y;
}

LumaProfile GatherLumaProfile(const cv::Mat& linear_bgr, const cv::Mat& luma,
                              const Eigen::Vector2d& centre, const Eigen::Vector2d& outward,
                              double rho, double band_sign, double tangential_px,
                              double side_from_px, double side_to_px) {
  LumaProfile p;
  const Eigen::Vector2d tangent(-outward.y(), outward.x());
  const Eigen::Vector2d at = centre + rho * outward;
  const double reach = LumaProfile::kReachPx;
  const int box = static_cast<int>(std::ceil(reach + tangential_px)) + 1;
  const int u0 = std::max(0, static_cast<int>(at.x()) - box);
  const int u1 = std::min(linear_bgr.cols - 1, static_cast<int>(at.x()) + box);
  const int v0 = std::max(0, static_cast<int>(at.y()) - box);
  const int v1 = std::min(linear_bgr.rows - 1, static_cast<int>(at.y()) + box);
  Eigen::Vector3d colour_sum[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  double luma_sum[2] = {0, 0}, luma_sum2[2] = {0, 0};
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      const Eigen::Vector2d q = Eigen::Vector2d(u, v) - centre;
      // Along the arc: rho tan(angle) for the angle's few degrees (within 0.01 px at +-6 px).
      const double radial = q.dot(outward);
      if (!(radial > 0) || std::abs(q.dot(tangent)) * rho > tangential_px * radial) continue;
      const double d = band_sign * (q.norm() - rho);
      if (std::abs(d) > reach) continue;
      const Eigen::Vector3d colour = PixelColour(linear_bgr, u, v);
      double y = 0;
      if (luma.empty()) {
        for (int c = 0; c < 3; ++c) y += kLumaWeights[c] * Srgb(colour[c]);
      } else {
        y = luma.at<uchar>(v, u);
      }
      p.d.push_back(d);
      p.luma.push_back(y);
      if (std::abs(d) >= side_from_px && std::abs(d) <= side_to_px) {
        const int side = d > 0;
        colour_sum[side] += colour;
        luma_sum[side] += y;
        luma_sum2[side] += y * y;
        ++p.side_count[side];
      }
    }
  }
  for (int s = 0; s < 2; ++s) {
    const int n = std::max(1, p.side_count[s]);
    p.side_colour[s] = colour_sum[s] / n;
    p.side_luma[s] = luma_sum[s] / n;
    p.side_spread[s] =
        std::sqrt(std::max(0.0, luma_sum2[s] / n - p.side_luma[s] * p.side_luma[s]));
  }
  return p;
}

double EstimateEncodingNoise(const std::vector<std::pair<Eigen::Vector3d, double>>& sides) {
  if (sides.empty()) return 0;
  // At most 300 sides, evenly: the noise is the camera's, one value per image.
  const size_t stride = std::max<size_t>(1, sides.size() / 300);
  auto cost = [&](double sigma) {
    const NoisyLevels noise(sigma * sigma);
    double sum = 0;
    for (size_t i = 0; i < sides.size(); i += stride) {
      Eigen::Vector3d x;
      for (int c = 0; c < 3; ++c) x[c] = noise.NoiseFree(sides[i].first[c]);
      const double r = sides[i].second - noise.Luma(x);
      sum += std::min(r * r, 9.0);  // a side that is not flat paint counts at most 3 levels
    }
    return sum;
  };
  // Golden-section search on sigma in [0, 4] levels.
  const double g = 0.5 * (std::sqrt(5.0) - 1);
  double a = 0, b = std::sqrt(kMaxSigma2);
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = cost(c), fd = cost(d);
  for (int it = 0; it < 14; ++it) {
    if (fc < fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - g * (b - a);
      fc = cost(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + g * (b - a);
      fd = cost(d);
    }
  }
  const double sigma = 0.5 * (a + b);
  return cost(0) <= std::min(fc, fd) ? 0 : sigma * sigma;
}

std::optional<double> LumaEdgeOffset(const LumaProfile& profile, const NoisyLevels& noise,
                                     double min_snr) {
  const double m0 = profile.side_luma[0], m1 = profile.side_luma[1];
  const double spread = std::max({profile.side_spread[0], profile.side_spread[1], 0.5});
  if (profile.side_count[0] < 3 || profile.side_count[1] < 3 ||
      std::abs(m1 - m0) < min_snr * spread) {
    return std::nullopt;
  }
  // The expected Y' across the edge, alpha = 0 (outside) .. 1 (band), from the sides' colours
  // with the noise taken out, scaled to 0..1.
  Eigen::Vector3d x0, x1;
  for (int c = 0; c < 3; ++c) {
    x0[c] = noise.NoiseFree(profile.side_colour[0][c]);
    x1[c] = noise.NoiseFree(profile.side_colour[1][c]);
  }
  constexpr int kAlpha = 64;
  double g[kAlpha + 1];
  double var[kAlpha + 1];
  for (int i = 0; i <= kAlpha; ++i) {
    const double alpha = static_cast<double>(i) / kAlpha;
    g[i] = noise.Luma((1 - alpha) * x0 + alpha * x1);
    // Y''s variance there; a floor of JPEG's rounding and quantisation (0.5 level).
    var[i] = noise.LumaVariance((1 - alpha) * x0 + alpha * x1) + 0.25;
  }
  const double g0 = g[0], g1 = g[kAlpha];
  if (!(std::abs(g1 - g0) > 0.5)) return std::nullopt;
  for (double& v : g) v = (v - g0) / (g1 - g0);
  for (int i = 0; i < kAlpha; ++i) {
    if (!(g[i + 1] > g[i])) return std::nullopt;  // not monotonic: Y' cannot tell the mix
  }
  // Start: each pixel's band share from its Y' (the table inverted, linear beyond its ends) and
  // the line alpha = 1/2 + k (d - delta) fitted to those within kHalfWidth of the edge, weighted
  // by the square of Y''s slope (alpha is noisier where Y' is flat in it).
  auto alpha_of = [&](double y) {
    const double t = (y - m0) / (m1 - m0);
    if (t <= 0) return t / (g[1] * kAlpha);
    if (t >= 1) return 1 + (t - 1) / ((1 - g[kAlpha - 1]) * kAlpha);
    const int i = static_cast<int>(std::upper_bound(g, g + kAlpha + 1, t) - g) - 1;
    return (i + (t - g[i]) / (g[i + 1] - g[i])) / kAlpha;
  };
  // G(alpha) and its slope, the table interpolated; flat beyond 0 and 1.
  auto g_of = [&](double a, double* slope) {
    const double f = std::clamp(a, 0.0, 1.0) * kAlpha;
    const int j = std::min(kAlpha - 1, static_cast<int>(f));
    *slope = (a <= 0 || a >= 1) ? 0 : (g[j + 1] - g[j]) * kAlpha;
    return g[j] + (f - j) * (g[j + 1] - g[j]);
  };
  constexpr double kHalfWidth = 1.25;
  const size_t n = profile.d.size();
  std::vector<double> alpha(n);
  for (size_t i = 0; i < n; ++i) alpha[i] = alpha_of(profile.luma[i]);
  double delta = 0, k = 0;
  for (int it = 0; it < 3; ++it) {
    double s1 = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    int used = 0;
    for (size_t i = 0; i < n; ++i) {
      const double x = profile.d[i] - delta;
      if (std::abs(x) > kHalfWidth) continue;
      double w = 1;
      if (k > 0) g_of(0.5 + k * x, &w);
      w = k > 0 ? std::max(w * w, 1e-6) : 1;
      const double y = alpha[i] - 0.5;
      s1 += w;
      sx += w * x;
      sy += w * y;
      sxx += w * x * x;
      sxy += w * x * y;
      ++used;
    }
    const double det = s1 * sxx - sx * sx;
    if (used < 6 || !(det > 0)) return std::nullopt;
    k = (s1 * sxy - sx * sy) / det;
    if (!(k > 0.1)) return std::nullopt;
    delta -= (sy - k * sx) / s1 / k;
    if (!(std::abs(delta) <= 1.0)) return std::nullopt;
  }
  // Then Gauss-Newton on the pixels' Y' themselves, E[Y'] = m0 + (m1 - m0) G(1/2 + k (d -
  // delta)), each weighted by 1 / Var[Y'] there: inverting a noisy Y' through the convex inverse
  // of G biases alpha upwards where G bends most (a blue band's Y' against black: 0.05 px).
  const double scale = m1 - m0;
  for (int it = 0; it < 6; ++it) {
    double jtj[3] = {0, 0, 0}, jtr[2] = {0, 0};
    int used = 0;
    for (size_t i = 0; i < n; ++i) {
      const double x = profile.d[i] - delta;
      if (std::abs(x) > kHalfWidth) continue;
      double slope;
      const double a = 0.5 + k * x;
      const double r = profile.luma[i] - (m0 + scale * g_of(a, &slope));
      const double w =
          1.0 / var[std::clamp(static_cast<int>(std::lround(a * kAlpha)), 0, kAlpha)];
      const double j_delta = -scale * slope * k, j_k = scale * slope * x;
      jtj[0] += w * j_delta * j_delta;
      jtj[1] += w * j_delta * j_k;
      jtj[2] += w * j_k * j_k;
      jtr[0] += w * j_delta * r;
      jtr[1] += w * j_k * r;
      ++used;
    }
    const double det = jtj[0] * jtj[2] - jtj[1] * jtj[1];
    if (used < 6 || !(det > 0)) return std::nullopt;
    const double step_delta = (jtj[2] * jtr[0] - jtj[1] * jtr[1]) / det;
    const double step_k = (jtj[0] * jtr[1] - jtj[1] * jtr[0]) / det;
    delta += std::clamp(step_delta, -0.3, 0.3);
    k = std::clamp(k + step_k, 0.1, 2.0);
    if (!(std::abs(delta) <= 1.0)) return std::nullopt;
    if (std::abs(step_delta) < 1e-4 && std::abs(step_k) < 1e-4) break;
  }
  return delta;
}

}  // namespace omni::detectors
