#include "calib/lip_edge_bias.h"

#include <algorithm>
#include <cmath>

namespace omni::calib {

namespace {
// Below this many correlation lengths along the edge the formula is not trusted.
constexpr double kMinStretches = 4;
}  // namespace

AlongEdgePattern CommonPartOfAlongEdgePattern(const std::vector<double>& azimuth_rad,
                                              const std::vector<double>& across_px) {
  const int n_bins = static_cast<int>(std::lround(360.0 / kAlongEdgeBinDeg));
  std::vector<double> sum(n_bins, 0.0);
  std::vector<int> count(n_bins, 0);
  for (size_t i = 0; i < azimuth_rad.size(); ++i) {
    const double turns = azimuth_rad[i] / (2 * M_PI);
    const int b = static_cast<int>(std::floor((turns - std::floor(turns)) * n_bins)) % n_bins;
    sum[b] += across_px[i];
    ++count[b];
  }
  std::vector<double> bin(n_bins, 0.0);
  int filled = 0;
  double c0 = 0;
  for (int b = 0; b < n_bins; ++b) {
    if (!count[b]) continue;
    bin[b] = sum[b] / count[b];
    c0 += bin[b] * bin[b];
    ++filled;
  }
  AlongEdgePattern pattern;
  if (filled == 0) return pattern;
  c0 /= filled;
  pattern.rms_px = std::sqrt(c0);
  pattern.coverage_deg = filled * kAlongEdgeBinDeg;
  double length_bins = 1.0;  // integrated correlation length, in bins
  if (filled >= 2 && c0 > 0) {
    for (int lag = 1; lag < n_bins / 2; ++lag) {
      double c = 0;
      int pairs = 0;
      for (int b = 0; b < n_bins; ++b) {
        const int other = (b + lag) % n_bins;
        if (!count[b] || !count[other]) continue;
        c += bin[b] * bin[other];
        ++pairs;
      }
      if (pairs < 10) break;
      const double rho = c / pairs / c0;
      if (rho <= 0) break;
      length_bins += 2 * rho;
    }
  }
  // A pattern longer than a quarter of the edge: too few independent stretches to tell its
  // constant part from what shows (random patterns' means then run to 5-10 of the formula's
  // sigmas), so it is taken as large as what shows (the rms).
  if (kMinStretches * length_bins > filled) length_bins = filled;
  pattern.correlation_deg = length_bins * kAlongEdgeBinDeg;
  pattern.common_sigma_px = std::sqrt(c0 * length_bins / filled);
  return pattern;
}

}  // namespace omni::calib
