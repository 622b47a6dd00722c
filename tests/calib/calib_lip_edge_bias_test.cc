// A lip edge's constant detector bias across the edge (calib/lip_edge_bias.h, carried by
// calib/solve_covariance.cc LipEdgeColumns): from the residual pattern along the edge, its
// constant part's sigma. Oracles: the spread of the true constant parts of many random patterns
// (their means, which a solve absorbs and the rule never sees); a real Ceres solve whose lip edges
// carry a known common bias and a known pattern along them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "calib/calibrate.h"
#include "calib/lip_edge_bias.h"
#include "model/lip.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

// A stationary random pattern round the circle at 0.25 deg steps: white noise smoothed by a
// Gaussian of `width_deg` (circularly), scaled to unit RMS in expectation.
std::vector<double> SmoothPattern(double width_deg, std::mt19937* rng) {
  const int n = 1440;
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<double> white(n), kernel, out(n, 0.0);
  for (double& w : white) w = unit(*rng);
  const int half = static_cast<int>(std::ceil(4 * width_deg / 0.25));
  double norm = 0;
  for (int k = -half; k <= half; ++k) {
    kernel.push_back(std::exp(-0.5 * std::pow(k * 0.25 / width_deg, 2)));
    norm += kernel.back() * kernel.back();
  }
  for (double& k : kernel) k /= std::sqrt(norm);
  for (int i = 0; i < n; ++i) {
    for (int k = -half; k <= half; ++k) out[i] += kernel[k + half] * white[((i + k) % n + n) % n];
  }
  return out;
}

// Many random patterns (correlated over a few degrees, as the renders' lips; over tens, as the
// webcam's crescent edge), whole edges and half edges, plus each point's own noise: the rule sees
// each pattern less its mean (the solve absorbs the mean) and must predict the spread of the
// means. The predicted sigma's RMS against the means' RMS within 20%; for patterns correlated over
// a few degrees no mean beyond 4 sigma (a pattern correlated over tens of degrees on a half edge
// is at times nearly constant over it, its mean then runs to 5-11 sigmas: the limit of telling a
// constant part from a pattern as long as the edge: 8 and 28 of 300 beyond 3 sigma).
TEST(LipEdgeBias, ConstantPartMatchesTheSpreadOfRandomPatternsMeans) {
  std::mt19937 rng(49);
  std::normal_distribution<double> point_noise(0.0, 0.5);  // 0.05 px per normal point at 0.1 px
  for (double width_deg : {1.0, 4.0, 15.0}) {
    for (double cover_deg : {360.0, 180.0}) {
      double ss_mean = 0, ss_sigma = 0, max_z = 0;
      int beyond_3 = 0;
      const int trials = 300;
      for (int t = 0; t < trials; ++t) {
        const std::vector<double> pattern = SmoothPattern(width_deg, &rng);
        std::vector<double> azimuth, across;
        for (int i = 0; i < static_cast<int>(pattern.size()); ++i) {
          if (i * 0.25 >= cover_deg) break;
          azimuth.push_back((i + 0.5) * 0.25 * M_PI / 180);
          across.push_back(pattern[i] + point_noise(rng));
        }
        double mean = 0;
        for (double a : across) mean += a;
        mean /= across.size();
        for (double& a : across) a -= mean;
        const AlongEdgePattern p = CommonPartOfAlongEdgePattern(azimuth, across);
        ss_mean += mean * mean;
        ss_sigma += p.common_sigma_px * p.common_sigma_px;
        max_z = std::max(max_z, std::abs(mean) / p.common_sigma_px);
        beyond_3 += std::abs(mean) > 3 * p.common_sigma_px;
      }
      const double ratio = std::sqrt(ss_sigma / ss_mean);
      std::printf("pattern correlated over %4.1f deg (sd), edge %3.0f deg: rms of the means %.4f, "
                  "of the predicted sigmas %.4f (ratio %.2f), largest |mean| / sigma %.2f, %d of %d "
                  "beyond 3\n",
                  width_deg, cover_deg, std::sqrt(ss_mean / trials),
                  std::sqrt(ss_sigma / trials), ratio, max_z, beyond_3, trials);
      EXPECT_NEAR(ratio, 1.0, 0.2) << width_deg << " deg, " << cover_deg << " deg";
      if (width_deg > 10) continue;
      EXPECT_LT(max_z, 4.0) << width_deg << " deg, " << cover_deg << " deg";
      EXPECT_LE(beyond_3, 0.02 * trials) << width_deg << " deg, " << cover_deg << " deg";
    }
  }
}

}  // namespace
}  // namespace omni::calib
