// The render-bias experiment (bench/render_bias): are the X-junctions in POV-Ray renders where
// the model says? A few chessboards through the rig (or seen directly by the pinhole), rendered in
// small windows by POV-Ray and by an independent oracle, the exact box-filtered pixel (S x S
// sub-pixel rays through RigModel::Unproject, intersected with the boards, averaged); the
// refinement from the true corners is the detector's (detectors/common/corner_refine.h), run by
// the bench; this file sets the boards up, renders them and states the offsets per ring.
// Lens distortion is set to zero: the renders are compared before image_effects.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "model/rig_params.h"
#include "synthetic/scene.h"

namespace omni::synthetic {

struct BiasWindow {
  int placement = 0, ring = 0;  // ring 0: the direct view
  cv::Rect box;
};

struct BiasCorner {
  int placement = 0, ring = 0, id = 0;
  int board = 0;  // index into BiasSetup::boards: one per (placement, ring)
  Eigen::Vector2d truth;
  double side = 0;  // local square side in pixels
};

struct BiasSetup {
  RigParams rig;  // distortion zero
  Scene scene;
  SceneImage image;
  bool direct = false;
  std::vector<BiasCorner> corners;  // those with a neighbour (a local square side)
  std::vector<BiasWindow> windows;  // per (placement, ring): its corners' boxes, in the frame
  std::vector<std::pair<int, int>> boards;  // (rows, cols) per board
};

// direct: two tilted 5x6 boards ~600 mm in front of the pinhole (draw_mirrors off: POV-Ray's
// camera and texture conventions alone); else 4x5 boards in both rings at ranges_mm, per_range
// boards per range (synthetic::AddRingImage).
BiasSetup MakeBiasSetup(const RigParams& rig, bool direct, const std::vector<double>& ranges_mm,
                        int per_range);

// The detector's raw-refinement half window for a corner's square side (clamp(round(0.4 side),
// 1, 6)), or half_override when > 0.
int DetectorHalfWindow(double side, int half_override);

// The oracle image (8-bit grey, black outside the windows), `samples` rays per pixel side; parity
// chooses the checker's colour.
cv::Mat RenderOracle(const BiasSetup& s, int samples, int parity);

// POV-Ray's render of the windows under `config` (noaa | aa3 | aa4 | aa5 | am1 | ss3 | ss3aa |
// raw:<flags>; bench/render_bias.cc), its files in dir, *seconds its wall time. Throws
// std::invalid_argument "unknown config C" or std::runtime_error "povray failed for PNG".
cv::Mat RenderPovWindows(const BiasSetup& s, const std::string& config, const std::string& dir,
                         double* seconds);

// Per ring the mean radial (away from the principal point) and tangential offset, the mean (du,
// dv) and the RMS of the corners' errors (NaN: not measured).
struct RingBias {
  int n = 0;
  double radial = 0, tangential = 0, rms = 0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
};
std::map<int, RingBias> BiasByRing(const BiasSetup& s, const std::vector<Eigen::Vector2d>& errors);
// Refined - true per corner, NaN where not refined or more than 0.5 px off (a lost corner, not a
// bias, as the detector evaluation counts it).
std::vector<Eigen::Vector2d> ErrorsOf(const BiasSetup& s,
                                      const std::vector<std::optional<Eigen::Vector2d>>& refined);
// a - b per corner, NaN where either is.
std::vector<Eigen::Vector2d> Difference(const std::vector<Eigen::Vector2d>& a,
                                        const std::vector<Eigen::Vector2d>& b);
// "NAME  ring R: n .. radial .. tang .. (du .. dv ..) rms .." (and "(T s)" when seconds >= 0).
std::string BiasLine(const std::string& name, const std::map<int, RingBias>& stats,
                     double seconds);
// The windows: "N corners in W windows: [pP rR WxH] ...".
std::string WindowsLine(const BiasSetup& s);

// The mechanism: cv::cornerSubPix puts the corner where the tangent lines of the edge pixels in
// its window meet. The image of a straight board line through the mirrors is curved (curvature
// vector k towards its centre of curvature); the tangent at arc length s from the corner passes
// k s^2 / 2 beside it on the convex side, so the estimate moves by about -a h^2 k per edge line
// (h: the window's half size, a: the window's weighted mean of s^2 / (2 h^2)). Model per corner:
// m = -h^2 (k_row + k_col), from RigModel::Project of board points +-0.3 squares along the row
// and the column; fitted e = a m over all corners of the image. Per ring: measured and predicted
// radial offset and their per-corner correlation. Empty for the direct view.
std::string CurvatureModelText(const BiasSetup& s, const std::vector<Eigen::Vector2d>& errors,
                               int half_override);

// A render's pixels against the oracle's (either checker parity) in the windows: the mean
// difference where the oracle is black, white and edge, and the mean |difference|. *diff: 128 + 4
// (render - oracle) over the first window.
std::string PixelAgreementText(const BiasSetup& s, const cv::Mat& render, const cv::Mat& oracle,
                               cv::Mat* diff);

}  // namespace omni::synthetic
