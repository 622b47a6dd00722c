// Lip detection: sub-pixel edge points of the painted lip bands (mirror 1's lip and mirror 2's,
// each of the paint its model file names: model/lip.h) labelled with the 3D circle and optical
// path each edge is the image of, cleaned by a robust ellipse fit per edge.
//
// A coloured band is the union of several images of the same annulus (model/lip.h): mirror 1's
// band is the lip seen directly plus mirror 1's reflection of its underside, mirror 2's band
// mirror 2's reflection of its lip (plus the lip in the reflex disc where the disc's rim does not
// hide it, which on the designed rigs it always does). The model (the ideal one is enough)
// predicts, for every azimuth, the image of each (circle, path) pair; a band edge is kept at that
// azimuth only if it is unambiguous: the outermost (innermost) covered radius of the band is the
// image of a lip circle along one path, the lip is seen on its band side along the same path
// over at least `min_band_px`, and no other (circle, path) image of the band lies within
// `min_margin_px`. Edges clipped by an occluder (the reflex disc's rim) are dropped.
//
// Edge points, on a LINEAR image (camera images decoded from sRGB first, as DetectImage does):
// along radial profiles from the principal point, within +-search_px of the prediction (so the
// model may be misaligned by that much), where the colour turns from the outside's into the
// band's. The band is told by its likeness to the paint's hue (any brightness: the room lights
// it), the point is placed where the two colours mix half and half (FindEdge in the .cc). No
// absolute level is assumed: a point is kept if its colour contrast stands min_snr times above
// the band's noise and is at least min_relative of its neighbours' along the edge (a dark navy
// band gives 20 levels, a bright red one 80 on the same image).
//
// JPEG (4:2:0 or 4:2:2, what cameras write) keeps the sRGB luma Y' at full resolution but the
// chroma at half: a colour edge's mix is then not the linear half-and-half one (saturated blue /
// red bands read 0.15-0.23 px wider or narrower a side). With `chroma_halved` each point is then
// placed on Y' (detectors/lips/luma_edge.h: the pixels' band share from their Y', under the sensor
// noise estimated from the image), wherever Y' stands luma_min_snr times above its noise (else on
// the colour, as without). Give the file's own Y' plane as `luma` (io::ReadStoredLuma) and the
// linear image in 16 bit: 8-bit linear levels are too coarse for a dark band's Y'.
//
// Scale and failure modes, in short: the model may be misaligned by search_px (by default
// kLipSearchPerFocal of the focal length: 20 px at f 1452 px); a band must be at least 2.5 px wide
// along the edge's own path (4.5 px measured) and 1.5 px clear of any other image of the band.
// An edge gives nothing where it is ambiguous at every azimuth, clipped by the reflex disc, its
// contrast is under min_snr times its noise (or 2 grey levels), or fewer than 30 points fit its
// ellipse within 0.5 px.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "model/lip.h"
#include "model/observations.h"
#include "model/rig_model.h"

namespace omni::detectors {

constexpr double kLipSearchPerFocal = 0.014;  // 20 px at the big rig's f 1452 px (1280x960)

struct LipDetectorOptions {
  int profiles = 720;            // radial profiles per full circle
  // Half-width of the search window around the prediction (px); 0: kLipSearchPerFocal times
  // the model's focal length, at least 20 px. The ideal design's prediction is off by the rig's
  // tilts (rays turned by a few tenths of a degree: pixels in proportion to f) and its focal
  // length's error (f from the image size): 10-20 px at 1280x960, twice that at 2592x1944.
  double search_px = 0;
  double min_margin_px = 1.5;    // to the nearest other (circle, path) image of the same band
  double min_band_px = 2.5;      // visible band width along the edge's own path (prior model)
  double min_measured_band_px = 4.5;  // the band's colour found this far past the edge point
  double tangential_px = 3;      // profile samples average the colour over +-this along the edge
  double min_snr = 6;            // colour contrast over the band side's noise
  double min_relative = 0.4;     // contrast and paint likeness over their neighbours' median
  double min_contrast = 2;       // levels (0..255): below this a linear 8-bit edge is quantisation
  double ransac_inlier_px = 0.5; // ellipse fit: Sampson distance of an inlier
  int ransac_iterations = 300;  // at most: fewer once 5 inliers were surely drawn
  int min_points = 30;           // fewer inliers: the edge is dropped
  bool chroma_halved = false;    // the image's chroma had half the luma's resolution (JPEG)
  cv::Mat luma;                  // with chroma_halved: the file's Y' plane (8-bit) if known
  double luma_min_snr = 4;       // luma contrast over its noise to place a point on the luma
  double luma_tangential_px = 6; // the luma placement's pixels span +-this along the edge (a
                                 // dark band's Y' is noisy: +-3 px left 0.12 px per point)

  // Empty if the options are usable, else "<field>: expected ...": fewer than 8 profiles or 5
  // points, a search or width < 0, a ratio, tolerance or iteration count <= 0.
  std::string Check() const;
};

// An ellipse as the conic a u^2 + b uv + c v^2 + d u + e v + f = 0 (unit norm) with its centre,
// semi-axes and the angle of the first axis (rad).
struct Ellipse {
  Eigen::Matrix<double, 6, 1> conic = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double semi_major = 0, semi_minor = 0, angle = 0;
  // Sampson (first-order geometric) distance of a pixel to the ellipse.
  double Distance(const Eigen::Vector2d& p) const;
};

// One detected lip edge: the points that survived the ellipse fit, their labels and the fit.
struct LipEdgeFit {
  LipEdgeObservation edge;  // mirror, edge, circle, path (always set), points (inliers)
  Ellipse ellipse;
  double rms_px = 0;   // of the inliers to the ellipse
  int n_profiles = 0;  // profiles where the edge was labelled unambiguous and searched
  int n_found = 0;     // edge points found and kept before the ellipse fit
  // Medians over the inliers, in 8-bit linear levels: the band's paint likeness, its colour
  // contrast to the outside and the band side's noise (what the paint, light and camera give).
  double band = 0, contrast = 0, noise = 0;
};

// The labelled edges a model predicts (lip_detector.cc): made once per model, they cost tens of
// thousands of projections.
class LipPrediction;

// The last prediction made, and what for, kept for the next image: one per session (the
// DetectorContext the session loop owns holds it), so that sessions in one process never share
// one. Not thread-safe.
struct LipPredictionCache {
  std::shared_ptr<const LipPrediction> prediction;
  int profiles = 0;  // the options it was made with (LipDetectorOptions)
  double min_margin_px = 0, min_band_px = 0;
};

// The edges the model labels unambiguous, detected in a linear BGR image (8 or 16 bit, the
// model's size). Grey or wrongly sized images give no edges. The model's prediction is taken
// from `cache` when it holds this model's (and kept there), made anew without one.
std::vector<LipEdgeFit> DetectLipEdges(const cv::Mat& raw_bgr, const RigModel& model,
                                       const LipDetectorOptions& options = {},
                                       LipPredictionCache* cache = nullptr);

// The detections-file view of DetectLipEdges.
std::vector<LipEdgeObservation> DetectLips(const cv::Mat& raw_bgr, const RigModel& model,
                                    const LipDetectorOptions& options = {},
                                    LipPredictionCache* cache = nullptr);

// Robust ellipse fit (RANSAC on 5-point conics, then least squares on the inliers); false if
// fewer than min_points inliers. *inliers receives their indices.
bool FitEllipseRobust(const std::vector<Eigen::Vector2d>& points, const LipDetectorOptions& options,
                      Ellipse* ellipse, std::vector<int>* inliers);

}  // namespace omni::detectors
