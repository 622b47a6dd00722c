// A colour edge placed on the luma Y' of a chroma-subsampled image (JPEG 4:2:0 or 4:2:2, what
// cameras write). Such a file keeps Y' (Rec. 601 weights on the sRGB-encoded channels) at full
// resolution and the chroma at half, so the decoded colours near a colour edge are not the linear
// mix of its two sides (saturated bands read 0.15-0.23 px off per side), while each pixel's Y' is
// right. Y' is not linear in the light, though: across a blurred edge where alpha is the band's
// linear share, Y'(alpha) = sum_c w_c s(x_c(alpha)) with s the sRGB curve. Three things then bias
// a crossing found on Y' (docs/experiments.md, 2026-11-26):
//  - interpolating Y' between pixels (concave in alpha): here the pixels themselves are fitted
//    with alpha(d) a line across the edge. A symmetric blur makes alpha(d) antisymmetric about
//    the edge, so the line's 1/2 crossing is the edge whatever the blur. The fit is on Y' itself
//    (Gauss-Newton, from a line through the pixels' alpha read off their Y'): alpha read off a
//    noisy Y' is biased where the curve bends;
//  - the side colours measured elsewhere than the side Y': the blur's tail is a large share of
//    Y' on the dark side of an edge (red against black: 30% of the contrast 1.5 px out), so the
//    alpha mapping is built from the mean colours of the very pixels whose mean Y' anchors it;
//  - the sensor's noise before the camera's sRGB encoding: E[s(x + n)] is not s(x), most at dark
//    levels (a navy band's red and green: 4-6 linear levels of 255), so Y' between two dark sides
//    is not where the noise-free curve puts it. The expected Y' under Gaussian noise (clipped at
//    black) is used, its variance estimated per image from the bands' sides.
#pragma once

#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace omni::detectors {

// Expected levels under a camera's noise before its sRGB encoding: Gaussian of variance sigma2
// (8-bit linear levels squared) on a linear level x (8-bit scale), clipped to [0, 255]. Tabulated
// where the noise matters (x below 64 levels); above, a second-order expansion.
class NoisyLevels {
 public:
  explicit NoisyLevels(double sigma2 = 0);
  double sigma2() const { return sigma2_; }
  double Linear(double x) const;   // E[clip(x + n)]
  double Encoded(double x) const;  // E[s(clip(x + n))], s the sRGB curve on the 8-bit scale
  // The noise-free level x whose Linear(x) is `mean_linear` (a mean colour's channel).
  double NoiseFree(double mean_linear) const;
  // E[Y'] of a noise-free linear BGR colour (8-bit levels).
  double Luma(const Eigen::Vector3d& bgr) const;
  double EncodedVariance(double x) const;  // Var[s(clip(x + n))]
  double LumaVariance(const Eigen::Vector3d& bgr) const;  // Var[Y'], channels independent

 private:
  double Table(const std::vector<double>& table, double x) const;
  double sigma2_ = 0;
  std::vector<double> linear_, encoded_, encoded2_;  // at x = kMin + i * kStep
};

// The pixels across one edge point: those within +-tangential_px along the arc about `centre`
// through the point and within kReachPx across it.
struct LumaProfile {
  static constexpr double kReachPx = 3.5;
  std::vector<double> d;                // across the edge, px from the point, + into the band
  std::vector<double> luma;             // Y' (8-bit)
  // Each side's pixels 1.5-3 px from the point (0: outside, 1: band): mean linear BGR colour
  // (8-bit levels), mean Y' and its spread, pixel count.
  Eigen::Vector3d side_colour[2];
  double side_luma[2] = {0, 0};
  double side_spread[2] = {0, 0};
  int side_count[2] = {0, 0};
};

// `linear_bgr`: 8- or 16-bit linear BGR; `luma`: the file's own Y' plane (8-bit, same size) or
// empty (Y' then from the linear colours). `outward`: unit direction of increasing radius at the
// point, `rho` the point's radius about `centre`, `band_sign` +1 if the band lies outward.
LumaProfile GatherLumaProfile(const cv::Mat& linear_bgr, const cv::Mat& luma,
                              const Eigen::Vector2d& centre, const Eigen::Vector2d& outward,
                              double rho, double band_sign, double tangential_px,
                              double side_from_px = 1.5, double side_to_px = 3.0);

// The noise variance (8-bit linear levels squared, 0..16) whose expected Y' best explains the
// given sides' mean Y' from their mean colours (pairs of mean linear BGR, mean Y'; the bands'
// sides: flat paint, no texture).
double EstimateEncodingNoise(const std::vector<std::pair<Eigen::Vector3d, double>>& sides);

// The edge's offset along d from the profile's point (px): where alpha = 1/2 on the line alpha(d)
// whose expected Y' best fits the pixels within 1.25 px of the edge (each weighted by its Y'
// variance under `noise`). nullopt if the sides' Y' contrast is not min_snr times their per-pixel
// spread (at least half a level: JPEG's rounding), Y' does not rise monotonically from the
// outside's colour to the band's, or the fit fails or leaves the point more than 1 px away.
std::optional<double> LumaEdgeOffset(const LumaProfile& profile, const NoisyLevels& noise,
                                     double min_snr);

}  // namespace omni::detectors
