#include "exports/central_report.h"

#include <cmath>
#include <cstdio>

namespace omni::exports {

cv::Mat BothResidualMaps(const std::vector<CentralRing>& rings, cv::Mat* seen, double* max_px) {
  // The maps are NaN off their ring (OpenCV's comparisons do not single NaN out: by hand).
  cv::Mat both(rings[0].residual_map.size(), CV_32F, cv::Scalar(0));
  *seen = cv::Mat(both.size(), CV_8U, cv::Scalar(0));
  for (const auto& ring : rings) {
    for (int v = 0; v < both.rows; ++v) {
      for (int u = 0; u < both.cols; ++u) {
        const float e = ring.residual_map.at<float>(v, u);
        if (std::isnan(e)) continue;
        both.at<float>(v, u) = e;
        seen->at<uchar>(v, u) = 255;
      }
    }
  }
  double lo = 0;
  *max_px = 0;
  cv::minMaxIdx(both, &lo, max_px, nullptr, nullptr, *seen);
  return both;
}

std::string ResidualLines(const std::vector<CentralRing>& rings) {
  std::string out;
  for (const auto& ring : rings) {
    const int m = ring.mirror == Mirror::kOne ? 1 : 2;
    for (const auto& r : ring.residuals) {
      char line[256];
      std::snprintf(line, sizeof line, "  ring %d at %.2f m: RMS %.4f px, max %.4f px over %d pixels%s\n",
                    m, r.distance_mm / 1000, r.rms_px, r.max_px, r.pixels,
                    r.not_projected ? " (some not projectable)" : "");
      out += line;
    }
  }
  return out;
}

}  // namespace omni::exports
