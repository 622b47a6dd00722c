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
// Sub-pixel disparity: disparity_refine.h. Triangulation: each match (u, v1) <-> (u, v2) maps
// through the LUTs to raw pixels (m1, m2) [panorama_pixel_mapping_function]; the exact rays of
// both rings and their derivatives w.r.t. the raw pixel are tabulated once per model at every
// panorama pixel of the band (dense_triangulation.h: RayTable), and each match is the midpoint of
// the common perpendicular with sigma = sqrt(largest eigenvalue of sigma_px^2 A A^T).
// Per frame, Compute costs remap + SGBM + refinement and triangulation of every match; the
// latter two run on the tables (no ray tracing) and in parallel over columns (cv::parallel_for_).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "model/rig_model.h"
#include "stereo/dense_triangulation.h"
#include "stereo/disparity_refine.h"  // RefineDisparity
#include "stereo/panorama.h"

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
  // The first implementation's per-point paths (RefineDisparity, TriangulateMatchReference)
  // instead of the tabulated ones: the same points and sigmas to rounding, several times slower;
  // the oracle of the fast path (tests/stereo/dense_fast_path_test.cc).
  bool reference_path = false;
  // false: remap only the panorama rows that matching and colours read (the stereo band and
  // num_disparities rows above it), DepthFrame::panorama black elsewhere; the points are the
  // same. For a loop that keeps only the clouds (`depth --images`): ~60% less remap at 2592.
  bool full_panoramas = true;

  // Empty if the options are consistent, else "<field>: expected <what>" (`depth` prefixes
  // "--": its flags have the fields' names).
  std::string Check() const;
};

struct DensePoint {
  Eigen::Vector3f point_in_cam;  // mm
  float sigma_mm = 0;            // sqrt of the largest eigenvalue of the covariance
  std::uint8_t bgr[3] = {0, 0, 0};
  std::uint16_t u = 0, v = 0;    // reference panorama pixel (Xi_1)
  float disparity = 0;           // d of the convention above
};

struct DepthFrame {
  cv::Mat panorama[2];           // Xi_1, Xi_2 (the input's type; see full_panoramas)
  cv::Mat disparity;             // CV_32FC1 over Xi_1; NaN where no match
  int band_row_begin = 0, band_row_end = 0;  // rows of Xi_1 that were matched
  std::vector<DensePoint> points;
  double seconds_sgbm = 0, seconds_triangulation = 0, seconds_remap = 0;
};

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
  // Panoramas into *frame, the band's grey panoramas (rows from crop_begin_), transposed
  // (what SGBM matched) and SGBM's CV_16S disparity of the transposed band.
  void MatchBand(const cv::Mat& image, DepthFrame* frame, cv::Mat grey[2],
                 cv::Mat transposed[2], cv::Mat* disparity16) const;
  RigModel model_;
  PanoramaLuts luts_;
  DepthOptions options_;
  int band_begin_ = 0, band_end_ = 0;  // Xi_1 rows matched
  int crop_begin_ = 0;                 // first row given to SGBM
  std::unique_ptr<RayTable> rays_[2];
};

}  // namespace omni::stereo
