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


// The rule in a real Ceres solve: every lip edge carries a known common offset across it and a
// known pattern along it, the same in every image (as a detector's bias), on the small clean
// session. Short patterns (orders 20-40, 0.12 px rms, correlated over ~3 deg, as the renders'
// lips) get the floor, 2.7x below their rms (the old rule's sigma); the last edge's long pattern (orders
// 3-5, 0.3 px rms, as the webcam's crescent edge) is seen and sized above the floor, and its
// 0.15 px offset (3 floors) is covered. Each edge's assigned sigma covers its true offset
// (within 2 sigma), and every misalignment ends within 3 sigma of the truth.
TEST(CalibLipEdgeBias, AssignedSigmaCoversAKnownCommonOffsetInASolve) {
  testing::SyntheticSession session;
  const RigParams truth = testing::SmallCleanSessionWithoutTangential(&session);
  Observations detections = testing::NoisyDetections(session, 0.05, 7);
  testing::AddLipDetections(truth, 0.1, 11, &detections, 720);
  const Eigen::Vector2d centre(truth.camera[kCx], truth.camera[kCy]);
  // Per edge (in the images' order): its common offset (outward, px) and pattern. The long
  // pattern's edge is 0.15 px off: 3 times the floor, covered only if the pattern is seen.
  std::vector<double> offsets;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> phase(0, 2 * M_PI);
  struct Pattern {
    std::vector<int> orders;
    std::vector<double> phases;
    double amplitude;  // per order: rms of the sum = amplitude * sqrt(orders / 2)
  };
  std::vector<Pattern> patterns;
  std::vector<std::string> names;
  int long_edge = -1;
  for (size_t e = 0; e < detections.images[0].lips.size(); ++e) {
    const LipEdgeObservation& edge = detections.images[0].lips[e];
    const Lip& lip = LipOf(truth, *edge.path);
    char name[64];
    std::snprintf(name, sizeof(name), "lip %s r %g across", LipPathName(*edge.path),
                  *edge.circle == LipCircle::kInner ? lip.r_inner : lip.r_outer);
    names.push_back(name);
    Pattern p;
    // The last edge gets the long pattern.
    const bool is_long = e + 1 == detections.images[0].lips.size();
    if (is_long) long_edge = static_cast<int>(e);
    offsets.push_back(is_long ? 0.15 : (e % 2 ? -0.025 : 0.025));
    for (int k = is_long ? 3 : 20; k <= (is_long ? 5 : 40); ++k) {
      p.orders.push_back(k);
      p.phases.push_back(phase(rng));
    }
    p.amplitude = (is_long ? 0.3 : 0.12) / std::sqrt(p.orders.size() / 2.0);
    patterns.push_back(p);
  }
  ASSERT_GE(long_edge, 0);
  for (auto& image : detections.images) {
    ASSERT_EQ(image.lips.size(), patterns.size());
    for (size_t e = 0; e < image.lips.size(); ++e) {
      for (auto& point : image.lips[e].points) {
        const Eigen::Vector2d outward = (point - centre).normalized();
        const double phi = std::atan2(outward.y(), outward.x());
        double across = offsets[e];
        for (size_t k = 0; k < patterns[e].orders.size(); ++k) {
          across += patterns[e].amplitude * std::cos(patterns[e].orders[k] * phi + patterns[e].phases[k]);
        }
        point += across * outward;
      }
    }
  }
  CalibrationOptions options;
  options.solver.threads = 2;
  options.profile = "off";  // exact quadrics by construction; not this test's subject
  const CalibrationResult r = Calibrate(truth, session.targets, detections, options);
  const auto& u = r.uncertainty;
  ASSERT_EQ(u.lip_edge_patterns.size(), patterns.size());
  for (size_t e = 0; e < patterns.size(); ++e) {
    int column = -1, edge_column = 0;  // the edge's across column; its place among the edges
    for (size_t c = 0; c < u.considered_column_names.size() && column < 0; ++c) {
      if (u.considered_column_names[c] == names[e]) {
        column = static_cast<int>(c);
      } else if (u.considered_column_names[c].find(" across") != std::string::npos) {
        ++edge_column;
      }
    }
    ASSERT_GE(column, 0) << names[e];
    const double sigma = u.considered_column_sigma(column);
    const AlongEdgePattern& p = u.lip_edge_patterns[edge_column];
    std::printf("%-28s true offset %+.3f px, assigned sigma %.4f (%.2f sigma); residual pattern "
                "rms %.3f px (the old rule's sigma) over %.0f deg, correlated over %.1f deg\n",
                names[e].c_str(), offsets[e], sigma, std::abs(offsets[e]) / sigma, p.rms_px,
                p.coverage_deg, p.correlation_deg);
    EXPECT_LE(std::abs(offsets[e]), 2 * sigma) << names[e];
    if (static_cast<int>(e) == long_edge) {
      EXPECT_GT(sigma, options.lip_edge_offset_floor_px) << names[e] << ": the long pattern unseen";
      EXPECT_GT(p.correlation_deg, 10) << names[e];
    } else {
      EXPECT_DOUBLE_EQ(sigma, options.lip_edge_offset_floor_px) << names[e];
      EXPECT_GT(p.rms_px, 2 * sigma) << names[e];
    }
  }
  for (size_t i = 0; i < r.estimate.names.size(); ++i) {
    const std::string& name = r.estimate.names[i];
    if (name.rfind("mirror", 0) != 0 && name.rfind("reflex", 0) != 0) continue;
    const double z = (r.estimate.values(i) - testing::TruthValue(truth, name)) / u.sigma(i);
    std::printf("%-12s (estimate - truth) / sigma %+.2f (sigma %.4g, noise alone %.4g)\n",
                name.c_str(), z, u.sigma(i), u.noise_sigma(i));
    EXPECT_LT(std::abs(z), 3.0) << name;
  }
}

}  // namespace
}  // namespace omni::calib
