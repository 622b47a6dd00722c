#include "stereo/disparity_refine.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include <opencv2/core/utility.hpp>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace omni::stereo {
namespace {

// Catmull-Rom cubic through column samples p[-1..2] at t in [0, 1), and its derivative.
inline void CatmullRom(const float* p0, size_t step, double t, double* value, double* slope) {
  const double pm = p0[-static_cast<std::ptrdiff_t>(step)], a = p0[0], b = p0[step],
               pp = p0[2 * step];
  const double c1 = 0.5 * (b - pm), c2 = pm - 2.5 * a + 2 * b - 0.5 * pp,
               c3 = 0.5 * (pp - pm) + 1.5 * (a - b);
  *value = a + t * (c1 + t * (c2 + t * c3));
  *slope = c1 + t * (2 * c2 + t * 3 * c3);
}

// The same cubic as weights on the taps p[-1], p[0], p[1], p[2]: value = w . p, slope = w' . p.
inline void CatmullRomWeights(double t, double w[4], double w_slope[4]) {
  const double t2 = t * t, t3 = t2 * t;
  w[0] = -0.5 * t + t2 - 0.5 * t3;
  w[1] = 1 - 2.5 * t2 + 1.5 * t3;
  w[2] = 0.5 * t + 2 * t2 - 1.5 * t3;
  w[3] = -0.5 * t2 + 0.5 * t3;
  w_slope[0] = -0.5 + 2 * t - 1.5 * t2;
  w_slope[1] = -5 * t + 4.5 * t2;
  w_slope[2] = 0.5 + 4 * t - 4.5 * t2;
  w_slope[3] = -t + 1.5 * t2;
}

// C_j += sum_k a[k] b[k + j], k < n, j = 0..3 (a window of Xi_1 times the taps of Xi_2).
// N > 0: the window's length at compile time (unrolled, the taps stay in registers).
template <int N>
inline void CrossSums(const std::uint8_t* a, const std::uint8_t* b, int n, std::int32_t c[4]) {
  const int length = N > 0 ? N : n;
  for (int k = 0; k < length; ++k) {
    const std::int32_t ak = a[k];
    c[0] += ak * b[k];
    c[1] += ak * b[k + 1];
    c[2] += ak * b[k + 2];
    c[3] += ak * b[k + 3];
  }
}

// CrossSums<7> of the default 7-row window over the 2 hw + 1 columns of a step, with SSE2: per
// column, the 7 Xi_1 bytes and the 4 shifted runs of Xi_2 taps as 16-bit lanes, multiplied and
// summed in pairs (pmaddwd; 255 * 255 * 2 fits int32). Integer sums: the same as the scalar
// loop to the last bit. Each load takes 8 bytes, one past the window's last byte read by the
// scalar loop: the rows must have that slack (DisparityRefiner's padded copies).
#if defined(__SSE2__)
inline void CrossSums7Columns(const std::uint8_t* const* a, const std::uint8_t* const* b,
                              int columns, std::int32_t c[4]) {
  const __m128i zero = _mm_setzero_si128();
  const __m128i first7 = _mm_set_epi16(0, -1, -1, -1, -1, -1, -1, -1);  // lane 7: the slack
  __m128i acc[4] = {zero, zero, zero, zero};
  for (int k = 0; k < columns; ++k) {
    const __m128i a16 = _mm_and_si128(
        _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(a[k])), zero), first7);
    for (int j = 0; j < 4; ++j) {
      const __m128i b16 =
          _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(b[k] + j)), zero);
      acc[j] = _mm_add_epi32(acc[j], _mm_madd_epi16(a16, b16));
    }
  }
  for (int j = 0; j < 4; ++j) {
    alignas(16) std::int32_t lanes[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(lanes), acc[j]);
    c[j] += (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
  }
}
#endif

// A copy of an 8-bit image whose rows are followed by kRowSlack readable bytes (zeros).
constexpr int kRowSlack = 8;
constexpr int kSimdHalfWidth = 8;  // CrossSums7Columns' columns on the stack, up to 17
cv::Mat WithRowSlack(const cv::Mat& image) {
  cv::Mat padded(image.rows, image.cols + kRowSlack, CV_8UC1, cv::Scalar(0));
  cv::Mat inside = padded.colRange(0, image.cols);
  image.copyTo(inside);
  return inside;
}

}  // namespace

bool RefineDisparity(const cv::Mat& xi1, const cv::Mat& xi2, int u, int v, double d0,
                     int half_width, int half_height, double* d) {
  const int w = xi1.cols;
  const size_t step = xi2.step1();
  double disparity = d0;
  for (int iteration = 0; iteration < 4; ++iteration) {
    // Normal equations of r = I1 - I2(v' - d) - b in (delta d, b): dr/dd = I2'(v' - d), dr/db = -1.
    double h11 = 0, h12 = 0, h22 = 0, g1 = 0, g2 = 0;
    const double y = v - disparity;
    const int y0 = static_cast<int>(std::floor(y));
    const double t = y - y0;
    if (y0 - half_height - 1 < 0 || y0 + half_height + 2 >= xi2.rows ||
        v - half_height < 0 || v + half_height >= xi1.rows) {
      return false;
    }
    for (int du = -half_width; du <= half_width; ++du) {
      const int c = (u + du + w) % w;
      for (int dv = -half_height; dv <= half_height; ++dv) {
        double i2, slope;
        CatmullRom(xi2.ptr<float>(y0 + dv) + c, step, t, &i2, &slope);
        const double r = xi1.at<float>(v + dv, c) - i2;
        h11 += slope * slope;
        h12 -= slope;
        h22 += 1;
        g1 += slope * r;
        g2 -= r;
      }
    }
    const double det = h11 * h22 - h12 * h12;
    if (!(det > 1e-6 * h22 * h11) || h11 < 1e-3 * h22) return false;  // flat window
    // Gauss-Newton step (J^T J) x = -J^T r, J = (slope, -1); the offset b is re-solved from 0 at
    // every step (the problem is linear in it), only the disparity step is kept.
    const double delta = -(h22 * g1 - h12 * g2) / det;
    disparity += delta;
    if (std::abs(disparity - d0) > 1.0) return false;
    if (std::abs(delta) < 1e-3) break;
  }
  *d = disparity;
  return true;
}

DisparityRefiner::DisparityRefiner(const cv::Mat& xi1_t, const cv::Mat& xi2_t, int half_width,
                                   int half_height)
    : half_width_(half_width), half_height_(half_height) {
  if (xi1_t.type() != CV_8UC1 || xi2_t.type() != CV_8UC1 || xi1_t.size() != xi2_t.size()) {
    throw std::invalid_argument("DisparityRefiner: expected two 8-bit images of the same size");
  }
  t1_ = WithRowSlack(xi1_t);  // CrossSums7Columns reads a byte past a window's end
  t2_ = WithRowSlack(xi2_t);
  if (half_width < 0 || half_height < 0 ||
      (2 * half_width + 1) * (2 * half_height + 1) > 33025) {  // 33025 * 255^2 < 2^31
    throw std::invalid_argument("DisparityRefiner: window of at most 33025 samples expected");
  }
  const int columns = t1_.rows, rows = t1_.cols;  // of the panorama
  sum1_ = cv::Mat::zeros(columns, rows, CV_32S);
  sum2_ = cv::Mat::zeros(columns, rows, CV_32S);
  for (cv::Mat& lag : lag_) lag = cv::Mat::zeros(columns, rows, CV_32S);
  const int hw = half_width, hh = half_height;
  cv::Mat* const outputs[6] = {&sum1_, &sum2_, &lag_[0], &lag_[1], &lag_[2], &lag_[3]};
  cv::parallel_for_(cv::Range(0, columns), [&](const cv::Range& range) {
    // Column sums over u - hw .. u + hw (wrapped) of the six quantities, per row m, slid along u:
    // one column enters and one leaves per step.
    std::vector<std::int32_t> acc(6 * static_cast<size_t>(rows), 0);
    auto add_column = [&](int c, std::int32_t sign) {
      c = (c % columns + columns) % columns;
      const std::uint8_t* __restrict a = t1_.ptr<std::uint8_t>(c);
      const std::uint8_t* __restrict b = t2_.ptr<std::uint8_t>(c);
      std::int32_t* __restrict s1 = acc.data();
      std::int32_t* __restrict s2 = s1 + rows;
      for (int m = 0; m < rows; ++m) {
        s1[m] += sign * a[m];
        s2[m] += sign * b[m];
      }
      for (int lag = 0; lag < 4; ++lag) {
        std::int32_t* __restrict s = s1 + (2 + lag) * static_cast<size_t>(rows);
        const std::uint8_t* __restrict q = b + lag;
        for (int m = 0; m + lag < rows; ++m) s[m] += sign * (std::int32_t(b[m]) * q[m]);
      }
    };
    // Window sums over rows [m - hh, m + hh] (running sum) into row u of the tables.
    auto window = [&](int u) {
      for (int which = 0; which < 6; ++which) {
        const std::int32_t* sums = acc.data() + which * static_cast<size_t>(rows);
        std::int32_t* o = outputs[which]->ptr<std::int32_t>(u);
        const int last_row = rows - 1 - std::max(which - 2, 0);  // lag rows end earlier
        if (last_row - 2 * hh < 0) continue;
        std::int32_t running = 0;
        for (int k = 0; k <= 2 * hh; ++k) running += sums[k];
        o[hh] = running;
        for (int m = hh + 1; m + hh <= last_row; ++m) {
          running += sums[m + hh] - sums[m - hh - 1];
          o[m] = running;
        }
      }
    };
    for (int du = -hw; du <= hw; ++du) add_column(range.start + du, 1);
    window(range.start);
    for (int u = range.start + 1; u < range.end; ++u) {
      add_column(u + hw, 1);
      add_column(u - hw - 1, -1);
      window(u);
    }
  }, 4.0 * cv::getNumThreads());  // a few long stripes: the sliding pays off along each
}

// One refinement in progress: RefineDisparity's loop cut into steps, so that two can run side by
// side (RefinePair).
struct DisparityRefiner::Chain {
  enum State { kRunning, kDone, kFailed };
  int u = 0, v = 0, iteration = 0, moments_row = -1;
  double d0 = 0, disparity = 0, sum1 = 0;
  double S[4], Q[4][4], C[4];
  State state = kFailed;
};

void DisparityRefiner::Start(int u, int v, double d0, Chain* c) const {
  const int rows = t1_.cols, hh = half_height_;
  c->u = u, c->v = v, c->d0 = c->disparity = d0;
  c->iteration = 0;
  c->moments_row = -1;
  c->state = v - hh < 0 || v + hh >= rows ? Chain::kFailed : Chain::kRunning;
  if (c->state == Chain::kRunning) c->sum1 = sum1_.at<std::int32_t>(u, v);
}

// One Gauss-Newton step of RefineDisparity (see there) on the window moments.
inline void DisparityRefiner::Step(Chain* c) const {
  const int columns = t1_.rows, rows = t1_.cols, hh = half_height_, hw = half_width_;
  const int u = c->u, v = c->v;
  const double n = static_cast<double>((2 * hw + 1) * (2 * hh + 1));
  const double y = v - c->disparity;
  const int y0 = static_cast<int>(std::floor(y));
  const double t = y - y0;
  if (y0 - hh - 1 < 0 || y0 + hh + 2 >= rows) {
    c->state = Chain::kFailed;
    return;
  }
  if (y0 != c->moments_row) {
    // Tap j of the sample in row y0 + k is row y0 + k + j - 1: windows centred on y0 + j - 1.
    std::int32_t cross[4] = {0, 0, 0, 0};
    const bool wraps = u - hw < 0 || u + hw >= columns;
#if defined(__SSE2__)
    if (hh == 3 && hw <= kSimdHalfWidth) {  // the default 5 x 7 window
      const std::uint8_t* a[2 * kSimdHalfWidth + 1];
      const std::uint8_t* b[2 * kSimdHalfWidth + 1];
      for (int du = -hw; du <= hw; ++du) {
        const int col = wraps ? ((u + du) % columns + columns) % columns : u + du;
        a[du + hw] = t1_.ptr<std::uint8_t>(col) + v - hh;
        b[du + hw] = t2_.ptr<std::uint8_t>(col) + y0 - hh - 1;
      }
      CrossSums7Columns(a, b, 2 * hw + 1, cross);
    } else
#endif
    for (int du = -hw; du <= hw; ++du) {
      const int col = wraps ? ((u + du) % columns + columns) % columns : u + du;
      const std::uint8_t* a = t1_.ptr<std::uint8_t>(col) + v - hh;
      const std::uint8_t* b = t2_.ptr<std::uint8_t>(col) + y0 - hh - 1;
      if (hh == 3) CrossSums<7>(a, b, 7, cross);
      else CrossSums<0>(a, b, 2 * hh + 1, cross);
    }
    const std::int32_t* sum2 = sum2_.ptr<std::int32_t>(u);
    for (int j = 0; j < 4; ++j) {
      const int m = y0 + j - 1;
      c->C[j] = cross[j];
      c->S[j] = sum2[m];
      for (int l = j; l < 4; ++l) c->Q[j][l] = c->Q[l][j] = lag_[l - j].ptr<std::int32_t>(u)[m];
    }
    c->moments_row = y0;
  }
  double w[4], ws[4];
  CatmullRomWeights(t, w, ws);
  // Sums of RefineDisparity's normal equations, slope_k = ws . p_k, I2_k = w . p_k. Summed in
  // pairs: each step waits on the last, so the adds' latency is what it costs.
  auto dot = [](const double* x, const double* y) {
    return (x[0] * y[0] + x[1] * y[1]) + (x[2] * y[2] + x[3] * y[3]);
  };
  double q_ws[4], q_w[4];
  for (int j = 0; j < 4; ++j) q_ws[j] = dot(c->Q[j], ws), q_w[j] = dot(c->Q[j], w);
  const double ws_q_ws = dot(ws, q_ws), ws_q_w = dot(ws, q_w);
  const double ws_s = dot(ws, c->S), w_s = dot(w, c->S), ws_c = dot(ws, c->C);
  const double h11 = ws_q_ws, h12 = -ws_s, h22 = n;
  const double g1 = ws_c - ws_q_w, g2 = -(c->sum1 - w_s);
  const double det = h11 * h22 - h12 * h12;
  if (!(det > 1e-6 * h22 * h11) || h11 < 1e-3 * h22) {  // flat window
    c->state = Chain::kFailed;
    return;
  }
  const double delta = -(h22 * g1 - h12 * g2) / det;
  c->disparity += delta;
  if (std::abs(c->disparity - c->d0) > 1.0) c->state = Chain::kFailed;
  else if (std::abs(delta) < 1e-3 || ++c->iteration == 4) c->state = Chain::kDone;
}

bool DisparityRefiner::Refine(int u, int v, double d0, double* d) const {
  Chain c;
  Start(u, v, d0, &c);
  while (c.state == Chain::kRunning) Step(&c);
  if (c.state == Chain::kDone) *d = c.disparity;
  return c.state == Chain::kDone;
}

void DisparityRefiner::RefinePair(int u, const int v[2], const double d0[2], double d[2],
                                  bool refined[2]) const {
  Chain a, b;
  Start(u, v[0], d0[0], &a);
  Start(u, v[1], d0[1], &b);
  // The two chains' steps are independent: the CPU overlaps one's latency with the other's.
  while (a.state == Chain::kRunning && b.state == Chain::kRunning) {
    Step(&a);
    Step(&b);
  }
  while (a.state == Chain::kRunning) Step(&a);
  while (b.state == Chain::kRunning) Step(&b);
  refined[0] = a.state == Chain::kDone;
  refined[1] = b.state == Chain::kDone;
  if (refined[0]) d[0] = a.disparity;
  if (refined[1]) d[1] = b.disparity;
}

}  // namespace omni::stereo
