// Dense stereo on the two panoramas (the paper's "Stereo Matching on Panoramas" and "3D Sensing
// Results"): SGBM along the vertical epipolar lines, then every match triangulated by the
// common-perpendicular midpoint of the two rings' exact rays [midpoint_on_common_perpendicular]
// with a per-point sigma from [uncertainty_propagation].
//
// Disparity convention: both panoramas share columns (azimuth) and rows (elevation seen from
// each ring's viewpoint, panorama.h), so a match lies in the same column. F2 lies BELOW F1 on the
// cylinder axis, so a scene point appears at a higher elevation, i.e. a SMALLER row, in Xi_2:
//     v2 = v1 - d,  d >= 0   (pixels of the panoramas)
// which is [correspondence_from_vertical_block_match] with Delta m_12 = -d (our rows grow
// downwards, towards lower elevations). cv::StereoSGBM searches horizontally with
// left(x) <-> right(x - d), so it runs on the TRANSPOSED panoramas: left = Xi_1^T, right = Xi_2^T.
// Only the rows of Xi_1 in the common field of view (stereo ROI [common_FOV_limit_angles]) are
// matched; the crop starts num_disparities rows higher so that every reference row has its full
// disparity range.
//
// Triangulation: each match (u, v1) <-> (u, v2) maps through the LUTs to raw pixels (m1, m2)
// [panorama_pixel_mapping_function]. The exact rays of both rings and their derivatives w.r.t.
// the raw pixel are tabulated once per model at every panorama pixel of the band (central
// differences of RigModel::Unproject, step 1e-3 px); the ring-2 ray at the sub-pixel row v2 is
// interpolated linearly between rows (rays vary by ~1e-3 rad per row, so the interpolation error
// is ~1e-7 rad, far below the pixel noise). The midpoint's Jacobian w.r.t. the two rays comes from
// ceres::Jet through MidpointOnCommonPerpendicular; chained with the ray Jacobians it gives the
// 3x4 A and Sigma = sigma_px^2 A A^T; the point's sigma is sqrt(largest eigenvalue).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "model/rig_model.h"
#include "model/stereo/panorama.h"

namespace omni::stereo {

struct DepthOptions {
  // cv::StereoSGBM (on the transposed panoramas).
  int num_disparities = 64;   // multiple of 16
  int block_size = 5;         // odd
  int uniqueness_ratio = 10;
  int speckle_window = 100;
  int speckle_range = 2;      // in disparity units (1/16 px internally: x16)
  int disp12_max_diff = 1;
  bool three_way = true;      // cv::StereoSGBM::MODE_SGBM_3WAY (faster) or MODE_SGBM
  double sigma_px = 1.0;      // [pixel_covariance_matrix]
  double max_sigma_mm = 0;    // > 0: drop points with a larger sigma
  double min_disparity_px = 0.5;  // smaller disparities (points near infinity) are dropped
  // Re-estimate each match's sub-pixel disparity on the panoramas (see RefineDisparity) instead of
  // keeping SGBM's: SGBM's parabola fit locks to integers and rounds its 1/16 px offset towards
  // zero, measured +0.07 px (+0.8% range, nearer) on a synthetic box room.
  bool refine_subpixel = true;
  int refine_half_width = 2, refine_half_height = 3;  // window (2 hw + 1) x (2 hh + 1) panorama px
};

struct DensePoint {
  Eigen::Vector3f point_in_cam;  // mm
  float sigma_mm = 0;            // sqrt of the largest eigenvalue of the covariance
  std::uint8_t bgr[3] = {0, 0, 0};
  std::uint16_t u = 0, v = 0;    // reference panorama pixel (Xi_1)
  float disparity = 0;           // d of the convention above
};

struct DepthFrame {
  cv::Mat panorama[2];           // Xi_1, Xi_2 (the input's type)
  cv::Mat disparity;             // CV_32FC1 over Xi_1; NaN where no match
  int band_row_begin = 0, band_row_end = 0;  // rows of Xi_1 that were matched
  std::vector<DensePoint> points;
  double seconds_sgbm = 0, seconds_triangulation = 0, seconds_remap = 0;
};

// Sub-pixel disparity by Gauss-Newton on the sum of squared differences between the window of
// Xi_1 around (u, v) and Xi_2 shifted up by d (the convention above), with a brightness offset
// (the rings see the scene through different mirrors), Xi_2 sampled between rows by Catmull-Rom
// cubic interpolation (columns are whole pixels: matches share the column). Starts at d0 (SGBM's
// disparity); false if the window leaves the panoramas, the texture is flat, or the estimate
// leaves d0 +- 1 px (then SGBM's value stands). Panoramas: CV_32FC1 of the same size; columns
// wrap around (azimuth).
bool RefineDisparity(const cv::Mat& xi1, const cv::Mat& xi2, int u, int v, double d0,
                     int half_width, int half_height, double* d);

class DenseStereo {
 public:
  // Builds the LUTs and the ray tables (the expensive, once-per-model part; parallel).
  DenseStereo(const RigModel& model, const PanoramaOptions& panorama_options,
              const DepthOptions& depth_options);
  ~DenseStereo();

  // Raw 8-bit image (grey or BGR) of the model's size -> panoramas, disparity, points.
  DepthFrame Compute(const cv::Mat& image) const;
  // The panoramas and SGBM's disparity alone (CV_32FC1 over Xi_1, NaN where none; SGBM's 1/16 px
  // steps, not refined; no points): where a caller's own matcher starts (health/ring_matches.h).
  DepthFrame Disparity(const cv::Mat& image) const;

  const PanoramaLuts& luts() const { return luts_; }
  const DepthOptions& options() const { return options_; }

 private:
  struct RayTable;
  // Panoramas into *frame, the band's grey panoramas (rows from crop_begin_) and SGBM's CV_16S
  // disparity of the transposed band.
  void MatchBand(const cv::Mat& image, DepthFrame* frame, cv::Mat grey[2],
                 cv::Mat* disparity16) const;
  RigModel model_;
  PanoramaLuts luts_;
  DepthOptions options_;
  int band_begin_ = 0, band_end_ = 0;  // Xi_1 rows matched
  int crop_begin_ = 0;                 // first row given to SGBM
  std::unique_ptr<RayTable> rays_[2];
};

}  // namespace omni::stereo
