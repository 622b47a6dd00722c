// Virtual perspective views of each ring: the raw omnidirectional image resampled into ordinary
// pinhole images in which targets look like targets (straight lines, no radial squeeze).
//
// A view of ring m is a virtual pinhole camera at mirror m's (approximate) single viewpoint (its
// primary focus, [m1]/[m2]) looking out at azimuth `azimuth` and elevation `elevation`, with +z_C
// as "up" in the view (view x right, y down, as OpenCV). Each view pixel is a 3D ray; the point at
// `distance_mm` along it is projected by RigModel via mirror m to the raw pixel it is seen at. On
// a non-central rig the choice of distance bends the view slightly; the views only serve to FIND
// targets (corners are mapped back to the raw image and refined there), so this does not matter.
// Because views are built from 3D rays they are never mirrored: a board reads the same way in
// both rings (the inner ring's double reflection and the outer ring's single one are undone).
//
// Enough sectors with overlap are made that every target in a ring's field of view fits whole
// in some view: with `sectors` views of `horizontal_fov_deg` each, anything narrower than
// horizontal_fov - 360/sectors degrees does. Vertically a view covers the ring's field plus
// margins up to max_vertical_fov_deg (the margins cut first); a field taller than that is
// covered whole (a wide single mirror).
//
// Pixel scales: a view pixel is not a raw pixel. By default a view has the outer ring's
// tangential resolution at its middle radius, so the inner ring's views are upsampled (~1.7-3
// times) and every view's blur is measured (RingView::blur_sigma, ViewBlurSigma) for the
// detectors to scale their thresholds. Failure modes: a target wider than the overlap above fits
// no view whole; a model far from the rig (10-20 px: lip_guide.h) shifts and bends the views,
// which only serve to find targets; where the ring is not seen the maps hold -1 and the view is
// invalid there.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "model/rig_model.h"

namespace omni::detectors {

struct ViewOptions {
  int sectors = 8;                  // views per ring, evenly spaced in azimuth
  double horizontal_fov_deg = 90;   // per view
  double max_vertical_fov_deg = 80; // cap on the elevation range a view covers with its margins
                                    // (a field taller than this is covered whole, up to 150)
  double elevation_margin_deg = 4;  // added above and below each ring's elevation range
  // View resolution in pixels per radian; 0: the outer ring's tangential resolution at its
  // middle radius (so the inner ring is upsampled and boards look alike in both rings).
  double pixels_per_rad = 0;
  double distance_mm = 1000;        // where view rays are taken to meet the world
  int grid_step = 4;                // exact projections every grid_step view pixels (bilinear between)

  // Empty if the options are usable, else "<field>: expected ...": no sector, a field of view
  // outside (0, 180) degrees, a negative margin or resolution, a distance or grid step <= 0.
  std::string Check() const;
};

struct RingView {
  Mirror mirror = Mirror::kOne;
  double azimuth = 0, elevation = 0;  // of the optical axis (rad)
  // Views of this ring (ViewOptions::sectors): the azimuth between neighbours is 2 pi / sectors.
  int sectors = 0;
  Eigen::Vector3d viewpoint_in_cam = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cam_from_view = Eigen::Matrix3d::Identity();  // columns: right, down, forward
  double f = 0, cx = 0, cy = 0;  // pinhole of the view (pixels)
  double distance_mm = 1000;
  int width = 0, height = 0;
  cv::Mat map_x, map_y;  // CV_32F: raw pixel of each view pixel, -1 where ring `mirror` is not seen
  cv::Mat map_fixed, map_interp;  // the same maps in cv::convertMaps' fast form (for remap)
  cv::Mat image;                  // the last RenderViews result: CV_8U grey
  // Where the ring is seen, shrunk so that a window centred there stays inside it: 13 x 13 for
  // the blur measure, 3 steps of 3 x 3 for saddle points. Made with the maps (empty: computed
  // when needed).
  cv::Mat valid_for_blur, valid_for_saddles;
  // The blur of the ring's views' sharpest edges (ViewBlurSigma; one value per ring: the median
  // over its views that show enough edges), view pixels; nullopt where none does.
  std::optional<double> blur_sigma;
  // The X-junctions last found in `image` (SaddlePoints, saddle_points.h) and what they were
  // found with: chessboards and Kalibr grids search the same ones. RenderViews clears it.
  struct SaddleCache {
    const uchar* image_data = nullptr;  // nullptr: empty
    cv::Size image_size;
    double sigma = 0, min_contrast = 0, balance = 0, blur = 0;
    double relative_contrast = 0, min_contrast_floor = 0, merge_sigmas = 0;
    std::vector<cv::Point2f> points;
  };
  mutable SaddleCache saddle_cache;

  // Unit ray direction in C of a view pixel (from viewpoint_in_cam).
  Eigen::Vector3d RayInCam(const Eigen::Vector2d& view_pixel) const;
  // View pixel of a direction in C (nullopt behind the view).
  std::optional<Eigen::Vector2d> ViewPixelOfDirection(const Eigen::Vector3d& dir_in_cam) const;
  // Raw pixel of a view pixel by bilinear lookup of the map; nullopt where any of the four
  // neighbouring map entries is invalid or the pixel is outside the view.
  std::optional<Eigen::Vector2d> ViewToRaw(const Eigen::Vector2d& view_pixel) const;
  // The blur (sigma) of the sharpest edges in raw pixels near a view pixel: blur_sigma times
  // the raw pixels per view pixel there (the square root of the map's Jacobian determinant);
  // 0 where the ring has no blur measure or the map is invalid there.
  double RawBlurAt(const Eigen::Vector2d& view_pixel) const;
  // Raw pixel of a view pixel by projecting exactly through the model.
  std::optional<Eigen::Vector2d> ViewToRawExact(const RigModel& model,
                                                const Eigen::Vector2d& view_pixel) const;
  // View pixel of a raw pixel seen via this view's mirror: the model's back-projected ray,
  // taken at distance_mm from the viewpoint. nullopt if the pixel is not in this ring or the view.
  std::optional<Eigen::Vector2d> RawToView(const RigModel& model,
                                           const Eigen::Vector2d& raw_pixel) const;
};

// The views of both rings (mirror 1's first), maps computed. Costly (tens of thousands of model
// projections): build once per model and reuse for every image.
std::vector<RingView> MakeRingViews(const RigModel& model, const ViewOptions& options = {});

// Resamples the raw image (grey or BGR, the model's size) into every view's `image` (grey) and
// measures each ring's blur_sigma.
void RenderViews(const cv::Mat& raw, std::vector<RingView>* views);

// The Gaussian blur (sigma, view pixels) of the sharpest edges the view shows: the camera's and
// the view's resampling blur together (every edge in the world is at best that sharp). From
// the 98th percentile of |gradient| / local contrast (13 x 13 max - min >= 60 grey levels): a
// blurred step of sigma s gives sqrt(s^2 + 0.5) there (the pixel's box and the 3x3 Sobel add
// 0.5; calibrated on box-filtered blurred checkerboards, exact to 5% for s = 0.5-2 px).
// nullopt where fewer than 200 pixels have such contrast.
std::optional<double> ViewBlurSigma(const cv::Mat& view_image, const cv::Mat& map_x);
// The same with the mask of pixels to measure given (BlurValidMask of the view's map).
std::optional<double> BlurWhereValid(const cv::Mat& view_image, const cv::Mat& valid);

// RingView::valid_for_blur and valid_for_saddles from a view's map_x (CV_8U, 255 = usable).
cv::Mat BlurValidMask(const cv::Mat& map_x);
cv::Mat SaddleValidMask(const cv::Mat& map_x);

// Grey CV_8U copy of a raw image (BGR, BGRA or grey; 8 or 16 bit).
cv::Mat ToGrey(const cv::Mat& raw);

}  // namespace omni::detectors
