// Small helpers the lips' detectors share (lip_detector.cc, post_finder.cc, mirror_rim.cc,
// rim_edge.cc): a bilinear grey level and a median.
#pragma once

#include <algorithm>
#include <vector>

#include <opencv2/core.hpp>

namespace omni::detectors {

// Bilinear grey level of a CV_32F image at (x, y); false outside the image.
inline bool SampleBilinear(const cv::Mat& img, double x, double y, double* value) {
  if (!(x >= 0 && y >= 0 && x <= img.cols - 1 && y <= img.rows - 1)) return false;
  const int x0 = std::min(static_cast<int>(x), img.cols - 2);
  const int y0 = std::min(static_cast<int>(y), img.rows - 2);
  const double fx = x - x0, fy = y - y0;
  const float* r0 = img.ptr<float>(y0);
  const float* r1 = img.ptr<float>(y0 + 1);
  *value = (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) +
           fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
  return true;
}

// The upper median (the element at size / 2 once sorted); 0 for none.
inline double MedianOf(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace omni::detectors
