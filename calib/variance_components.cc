#include "calib/variance_components.h"

#include <algorithm>
#include <map>

namespace omni::calib {

double LipCorrelationFactor(std::vector<LipResidual> residuals) {
  std::map<int, std::vector<LipResidual>> edges;
  for (const auto& r : residuals) edges[r.edge_key].push_back(r);
  // Centre each edge (its mean is one of the things that repeats, so it stays in the blocks'
  // variance: only the overall mean of all points is removed).
  double sum = 0, sum2 = 0;
  int n = 0;
  for (auto& [key, e] : edges) {
    std::sort(e.begin(), e.end(),
              [](const LipResidual& a, const LipResidual& b) { return a.phi < b.phi; });
    for (const auto& r : e) {
      sum += r.across_px;
      sum2 += r.across_px * r.across_px;
      ++n;
    }
  }
  if (n < 32) return 1.0;
  const double mean = sum / n;
  const double var1 = sum2 / n - mean * mean;
  if (!(var1 > 0)) return 1.0;
  double tau = 1.0;
  for (int block = 2;; block *= 2) {
    double ss = 0;
    int n_blocks = 0;
    for (const auto& [key, e] : edges) {
      const int m = static_cast<int>(e.size()) / block;
      if (m < 16) continue;
      for (int b = 0; b < m; ++b) {
        double s = 0;
        for (int k = 0; k < block; ++k) s += e[b * block + k].across_px;
        const double d = s / block - mean;
        ss += d * d;
        ++n_blocks;
      }
    }
    if (n_blocks < 16) break;
    tau = std::max(tau, block * (ss / n_blocks) / var1);
  }
  return tau;
}

}  // namespace omni::calib
