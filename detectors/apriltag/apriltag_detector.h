// AprilTag grid detection in both rings: the plain tag36h11 grid (`apriltag_grid`, libapriltag)
// and Kalibr's AprilGrid (`kalibr_aprilgrid`, our own quad finder and decoder, kalibr_detector.h,
// since its black corner squares defeat libapriltag 3's quad finder and aruco's contours).
//
// Tags are found in the un-mirrored perspective views of each ring (views.h: built from 3D rays,
// so tags read as printed and decode without flipping), their corners mapped to the raw image.
// Plain tags are refined THERE by our own step (RefineTagCorners): each of the tag's 4 edges is
// fitted (a quadratic across its chord, its curvature the one the view's map gives a straight
// view edge; the offset and slope from the halfway crossings of profiles across the black border,
// then from a blurred-step model of the edge's pixels), and the corners are where consecutive
// edges meet. This removes the ~0.1 px scatter of libapriltag's corners (its edge refinement
// samples whole view pixels) and the views' resampling blur.
//
// Corner ids: 4 * tag_id + k (model/target.h: k counter-clockwise from the tag's bottom-left seen
// from the printed side). libapriltag's p[0..3] already run that way in a view (checked by the tag
// texture test); the Kalibr decoder returns k directly.
// An id is right or absent: only exact codes (hamming 0), only ids that lie on a target of the
// detector's layout, Kalibr tags consistent with their neighbours in the view, and only tags whose
// four refined raw corners form a convex quadrilateral close to the mapped one, and only corners
// that fit their target's homography with the target's other corners in the ring (tag_grid_check.h).
//
// Scale and failure modes, in short: tags are read in the views (libapriltag, its quads found at half
// resolution in the inner ring; Kalibr quads at least 10 view px a side, kalibr_detector.h); in
// views with a measured blur, plain codes up to plain_max_hamming (2) bits off are taken only where
// the tag's blurred pattern reads as that code. Raw refinement needs a border of at least 1.3 raw
// px (min_border_px) and may move a corner at most 1.5 raw px: a plain tag it cannot refine keeps
// its mapped corners; a Kalibr tag loses its corners that are not whole X-junctions (at least 2
// must remain). Tags the views cut (at a ring's edge) and codes no target holds (UnclaimedTags)
// give no corners here; guided detection (guided_detection.h) measures the former from the other
// ring, and the grid check drops corners off their target's homography.
#pragma once

#include <set>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/apriltag/kalibr_detector.h"
#include "detectors/apriltag/tag_grid_check.h"
#include "detectors/common/saddle_points.h"
#include "detectors/common/views.h"
#include "model/observations.h"
#include "model/rig_model.h"
#include "model/target.h"

namespace omni::detectors {

struct TagDetectorOptions {
  // libapriltag. 1.5 would save 19 ms per calibration_scene_tags image with the same tags found,
  // but the plain corners move (detector_eval_scene ring 1 mean 0.106 -> 0.112 px): kept at 1.
  float quad_decimate = 1.0f;
  // In the inner ring's views, which are upsampled ~1.75x to the outer ring's resolution
  // (views.h), the quad finder loses nothing at 2 and costs half (libapriltag 60 -> 34 ms per
  // hid1 image; the same tags found on hid1, hid2, realistic_scene, clean and harsh, their
  // corners measured in the raw image as before).
  float inner_ring_quad_decimate = 2.0f;
  // In blurred views, libapriltag's readings up to this many bits off are re-read by their
  // blurred pattern (ReadTagBlurred) and kept only if that gives the same code.
  int plain_max_hamming = 2;
  // In views blurred >= blurred_view_sigma, plain tags are also looked for by their outlines
  // (DetectPlainTagsBlurred, kalibr_detector.h).
  bool plain_outline_finder = true;
  // Each view is searched only in its middle 360/views-per-ring degrees plus this much each side
  // (views overlap): tags up to this wide (at 1 m, 0.17 rad = 170 mm) are whole in some crop.
  double view_overlap_deg = 10.0;
  double max_refine_shift_px = 1.5;  // refined corner farther from the mapped one: tag unrefined
  // Shorter tag edges in the raw image: tag unrefined (a pixel-grid limit, 0.6 px per bit of a
  // tag36h11 tag: the same at any image size).
  double min_edge_px = 5.0;
  double max_edge_rms_px = 0.25;  // of the edge points about their fitted curve
  double edge_corner_margin_px = 2.0;  // edge points are measured this far from both corners
  // Plain tags: refine in the raw image (RefineTagCorners: the 4 edges fitted, corners where they
  // meet). Off: libapriltag's corners in the views mapped to raw (detector_eval_scene mean error
  // ring 1 / 2: 0.099 / 0.073 px off, 0.042 / 0.054 px on).
  bool refine_in_raw = true;
  // Plain tags in blurred views (>= blurred_view_sigma: the inner ring of a camera image): the
  // whole tag's pattern fitted to its pixels (tag_pattern_fit.h) first, the edge fit
  // (RefineTagCorners) where that fails. hid1 session, ring 2, realistic camera: sd per axis
  // 0.15 -> 0.03 px, recall 89.9 -> 95.9%. Not in sharp views: there the edge fit is as precise
  // (ring 1: 0.029 against 0.021 px) and OpenCV's edge-aware demosaic (its undershoot clipped at
  // black) moves the pattern fit's corners 0.02 px towards the tag's centre, the edge fit's not.
  bool fit_tag_pattern = true;
  bool curvature_from_view = true;  // edge curvature from the view's map (else fitted: noisier)
  bool fit_edge_pixels = true;      // the blurred-step fit after the crossings' fit
  double edge_fit_reach_in = 0.7;   // pixels used inside the edge: this fraction of the border
  bool edge_bits = true;            // RefineTagCorners: the data bits behind the border modelled
  // With them, in views blurred more than blurred_view_sigma (view px: the inner ring of a
  // defocused camera image, 2.1-2.4 against 1.0-1.4 on sharp renders) the fit reaches this far
  // in (of the border), towards the bit behind it: realistic ring 2 mean 0.133 -> 0.106 px;
  // farther (1.0) is no better there and worse on sharp views (the bits' own edges).
  double edge_fit_reach_in_blurred = 0.85;
  double blurred_view_sigma = 1.6;
  // Narrower black borders (raw px, across an edge) leave too few pixels between the outside and
  // the data bits: the tag keeps its mapped corners (tag_grid_tests 70 mm ring 2: 1.3 px).
  double min_border_px = 1.3;
  // Kalibr AprilGrid: tags found in the views (kalibr_detector.h), their X-junction corners
  // refined by cornerSubPix in the view, mapped to raw, checked to be whole X-junctions there,
  // and (if on) refined again by cornerSubPix in the raw image. Off: on the misaligned-rig renders
  // (kalibr_tests) the mapped corners measured mean 0.058 / 0.072 px, max 0.14 / 0.18 px (mirror
  // 1 / 2) vs truth, the raw refinement 0.072 / 0.061 px, max 0.18 / 0.21 px: no better.
  KalibrDetectorOptions kalibr;
  bool kalibr_refine_in_raw = false;
  // Kalibr corners fitted in the raw image by a blurred X-junction model (corner_refine.h
  // FitBlurredJunction) over this fraction of the tag side (half-width): the 2-bit border, where
  // all four quadrants are still uniform (near_scene ring 2 mean, clean / realistic: 0.15 of the
  // side 0.075 / 0.090 px, 0.2: 0.032 / 0.049, 0.25: 0.035 / 0.082, the blurred data bits in).
  bool kalibr_fit_junction = true;
  double kalibr_junction_window = 0.2;
  // Kalibr tags whose gap (a corner square's side) is under this many raw px: the whole tag's
  // pattern fitted instead (tag_pattern_fit.h; its junctions are too small for the junction
  // window, and the corner squares carry the geometry); the junctions where it refuses.
  double kalibr_pattern_below_gap_px = 4.5;
  // A Kalibr tag keeps the corners that are whole X-junctions in the raw image (the others are cut
  // by the ring's rim) if at least this many are.
  int kalibr_min_whole_corners = 2;
  bool kalibr_saddle_gate = true;  // false: the quad finder runs on the whole crop
  SaddleOptions kalibr_saddles;  // where the Kalibr quad finder runs (saddle-point clusters)
  // Added around each cluster's box, degrees of the view (16 view px at the big rig's 1280x960,
  // 12 at 960x720, 32 at 2592x1944): background for the quad finder past the outer tags.
  double kalibr_region_pad_deg = 3.13;
  // Grid check (tag_grid_check.h) of each target's corners per ring after refinement: a corner
  // off the target's homography by more than grid_check.max_residual_px raw px is dropped.
  bool grid_check = true;
  // Tags of a target predicted in a view from its tags read there (GrowTagGrids), taken if their
  // blurred pattern fits the code their place gives to this residual (of the contrast).
  bool grow_grids = true;
  double grow_max_residual = 0.15;
  TagGridCheckOptions grid_check_options;
  // A Kalibr corner the grid check drops is refined again in its view from the grid's prediction
  // with smaller windows (these fractions of the first one), nearest the prediction first, and
  // kept if it then lies within kalibr_retry_max_residual_px raw px of the prediction.
  std::vector<double> kalibr_retry_windows = {0.7, 0.5, 0.35};
  double kalibr_retry_max_residual_px = 0.2;

  // Empty if the options are usable, else "<field>: expected ..." (kalibr.<field> for the
  // Kalibr finder's): a decimation under 1, an overlap, pad or reach < 0, a shift, length,
  // tolerance or window <= 0, a retry window outside (0, 1).
  std::string Check() const;
};

// One detected tag corner with its diagnostics.
struct TagCornerDetection {
  CornerObservation observation;
  int tag_id = 0;
  Eigen::Vector2d mapped = Eigen::Vector2d::Zero();  // the view detector's corner mapped to raw
  int view = 0;                     // index of the view its tag was found in
  Eigen::Vector2d in_view = Eigen::Vector2d::Zero();  // the corner in that view
  double side_in_view = 0;          // the tag's mean side in that view (pixels)
  double grid_residual_px = -1;     // from the grid check (-1: not checked)
};

// Tag-grid corners in a raw image. `views` come from MakeRingViews for `model`; their `image` is
// used if RenderViews filled it for this raw image, otherwise the views are resampled here.
// Target index = index in `targets`; chessboard targets are skipped.
// Tag ids read in an image that no target of the session holds (per layout): a `first_id`,
// rows x cols or layout that is not the printed one.
struct UnclaimedTags {
  std::set<int> plain, kalibr;
};

std::vector<CornerObservation> DetectTagGrids(const cv::Mat& raw_bgr,
                                                  const std::vector<RingView>& views,
                                                  const RigModel& model,
                                                  const std::vector<TargetSpec>& targets,
                                                  UnclaimedTags* unclaimed = nullptr);

std::vector<TagCornerDetection> DetectTagCorners(const cv::Mat& raw_bgr,
                                                 const std::vector<RingView>& views,
                                                 const RigModel& model,
                                                 const std::vector<TargetSpec>& targets,
                                                 const TagDetectorOptions& options = {},
                                                 UnclaimedTags* unclaimed = nullptr);

// Refines a plain tag's four corners (raw pixels, approximate, in k order round the tag) in a grey
// CV_32F raw image: each edge's sub-pixel points (where profiles across it cross halfway between
// the black border and the white outside) fitted by a quadratic, the corners where consecutive
// edges meet. border_fraction: the black border's width / the tag side; spacing: the gap to the
// neighbouring tags / the tag side (the outside is measured within half of it). False (refined
// unset) if an edge cannot be measured or a corner moves more than max_refine_shift_px.
// With tag_id >= 0 (and options.edge_bits) the blurred-step fit models the border as the bar it
// is: the data bits behind it (from the code) bring the level back up one border width in.
bool RefineTagCorners(const cv::Mat& grey, const Eigen::Vector2d (&corners)[4],
                      const double (&curvature)[4], double border_fraction, double spacing,
                      const TagDetectorOptions& options, Eigen::Vector2d (&refined)[4],
                      int tag_id = -1);

}  // namespace omni::detectors
