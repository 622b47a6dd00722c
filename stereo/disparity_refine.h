// Sub-pixel disparity of a dense match (dense_stereo.h's convention v2 = v1 - d): Gauss-Newton on
// the sum of squared differences between the window of Xi_1 around (u, v) and Xi_2 shifted up by
// d, with a brightness offset (the rings see the scene through different mirrors), Xi_2 sampled
// between rows by Catmull-Rom cubic interpolation (columns are whole pixels: matches share the
// column). Starts at d0 (SGBM's disparity); false if the window leaves the panoramas, the texture
// is flat, or the estimate leaves d0 +- 1 px (then SGBM's value stands). Columns wrap around
// (azimuth).
//
// Two ways to the same numbers:
//  - RefineDisparity (the first implementation, kept as the oracle): every iteration samples the
//    window, (2 hw + 1)(2 hh + 1) cubic interpolations.
//  - DisparityRefiner (what DenseStereo runs): a Catmull-Rom sample is a weighted sum of 4 taps
//    with weights w(t) (value) and w'(t) (slope) that depend only on the fraction t of the row,
//    so every sum of the normal equations is a quadratic form of the weights over window moments
//    of the 8-bit panoramas: sums of Xi_2 taps (S_j), of tap products (Q_jl, a product of two
//    rows L = l - j apart) and of Xi_1 times a tap (C_j). S, Q and the Xi_1 sum depend only on
//    (column, row): they are tabulated once per frame (window sums, CV_32S); C is summed per
//    integer row of the shifted window (SSE2 pmaddwd for the default 7 rows, on copies of the
//    panoramas whose rows have 8 bytes of slack, so that no 8-byte load leaves the image). All moments are integers, exact; the quadratic forms
//    differ from the oracle's sample-by-sample sums by rounding only. An iteration that stays in
//    the same integer row costs a few dozen flops.
#pragma once

#include <opencv2/core.hpp>

namespace omni::stereo {

// xi1, xi2: CV_32FC1 panoramas (or bands) of the same size; (u, v) a pixel of xi1.
bool RefineDisparity(const cv::Mat& xi1, const cv::Mat& xi2, int u, int v, double d0,
                     int half_width, int half_height, double* d);

class DisparityRefiner {
 public:
  // xi1_t, xi2_t: the TRANSPOSED 8-bit panoramas (or bands) of the same size (row = panorama
  // column u, so a column of the panorama is contiguous); builds the window sums (parallel).
  // Throws std::invalid_argument if the window holds more than 33025 samples (the int32 sums).
  DisparityRefiner(const cv::Mat& xi1_t, const cv::Mat& xi2_t, int half_width, int half_height);

  // RefineDisparity(xi1, xi2, u, v, d0, half_width, half_height, d) on the untransposed images.
  bool Refine(int u, int v, double d0, double* d) const;
  // Two refinements of column u at once (rows v[i], starts d0[i]): refined[i] as Refine returns,
  // d[i] set where true. Each Gauss-Newton step waits on the one before; two independent chains
  // side by side fill that wait.
  void RefinePair(int u, const int v[2], const double d0[2], double d[2], bool refined[2]) const;

 private:
  struct Chain;
  void Start(int u, int v, double d0, Chain* c) const;
  void Step(Chain* c) const;
  cv::Mat t1_, t2_;
  int half_width_, half_height_;
  cv::Mat sum1_, sum2_;  // window sums of xi1, xi2 at [u][v] (CV_32S; 0 where it leaves)
  cv::Mat lag_[4];       // window sums of xi2(v) xi2(v + L), window centred on row v
};

}  // namespace omni::stereo
