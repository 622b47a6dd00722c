// Detection's guide corrected by the lips. Every detector is guided by the model: it places the
// rings' edges and views, labels the lip edges, and predicts one ring's targets from the other's.
// A design (or any model not yet calibrated) puts all of these 10-20 px off on a built rig: lens
// distortion and the mirrors' tilts. The lips are found even so (a search of +-1.4% of f, and
// with f scaled by a few percent where that finds none: lip_detector.h), so a few
// images' lip edges first correct the model's focal length and principal point (the lip-only fit,
// lip_intrinsics.h, as `init` does), and the session is detected with that model.
//
// The correction only guides detection: the session's model, the starting point of calibrate and
// the reference of the lip check, is unchanged. A model that already agrees with the lips (a
// calibrated one, or `init`'s) is left as it is.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "detectors/detect_image.h"

namespace omni::detectors {

struct LipGuide {
  bool applied = false;  // ctx's model was replaced by the corrected one
  int images = 0;        // colour images of the model's size the lips were looked for in
  int points = 0;        // lip edge points of the fit
  double rms_px = 0;     // the fit's point-to-circle residual
  double f_before = 0, f_after = 0;
  Eigen::Vector2d pp_before = Eigen::Vector2d::Zero(), pp_after = Eigen::Vector2d::Zero();
  // The reflex tilt (rx, ry, rad), fitted where the via_mirror2 edge was found.
  Eigen::Vector2d reflex_before = Eigen::Vector2d::Zero(), reflex_after = Eigen::Vector2d::Zero();
  double f_scanned = 1;  // the scale of the model's f the lips were found with (f_scan)
  // The model has the mount's posts (the lip points beside them were left out): a high rms is
  // then not for want of them (detect_session.h GuideLine).
  bool mount_in_model = false;
  // Mirror 2's axial offset (mm) before and after: the inner ring's scale (lip_intrinsics.h).
  double mirror2_tz_before = 0, mirror2_tz_after = 0;
  std::string why_not;   // when not applied: one line for the user
};

// Under the minimum changes the model already agrees with the lips; over the maximum the fit is
// not trusted (a wrong paint, another rig). The fit's 1-sigma over 3 images is ~0.01% in f and
// ~0.05 px in the principal point; from the true model, one image, the realistic camera: f
// -0.01%, the principal point 0.14 px, the inner ring (2 f times the reflex tilt's change) 0.5
// px. A guide 1 px off changes nothing in detection (its searches span several px).
struct LipGuideOptions {
  double min_f_change = 1e-3, min_pp_move_px = 0.5, min_inner_move_px = 1.0;
  // The rings' move (principal point and the inner ring's by the reflex tilt) is bounded as a
  // fraction of f: 60 px at 1280x960's f 1452 px, 120 px at 2592x1944.
  double max_f_change = 0.12, max_move_per_f = 0.04, max_rms_px = 3.0;
  // Where the model's lips are not found (or their fit does not hold), f scaled by these is
  // tried (GuideByLips): a start up to ~10% off.
  std::vector<double> f_scan = {0.96, 1.04, 0.92, 1.08};

  // Empty if the options are usable, else "<field>: expected ...": a change, move or rms <= 0,
  // an f scale outside (0.5, 2).
  std::string Check() const;
};

// One image for the guide: as read, and its file's chroma layout (LipOptionsFor).
struct GuideImage {
  cv::Mat image;
  bool chroma_halved = false;  // io::HasHalvedChroma
  cv::Mat luma;                // io::ReadStoredLuma when chroma_halved
};

// Which of a session's n images the guide reads: up to 3, spread over the session.
std::vector<size_t> LipGuideImages(size_t n);

// Detects the lips in `images` (encoded as ctx->tone says; the lip edges placed as DetectImage
// places them; grey images and images not of the model's size are passed over) with ctx->model, fits f and the principal point, and where
// they (and the reflex tilt) move the model's by more than the options' minimum (and less than
// the maximum), replaces ctx's model with the corrected one (views and ring layout rebuilt).
LipGuide GuideByLips(const std::vector<GuideImage>& images, DetectorContext* ctx,
                     const LipGuideOptions& options = {});

// GuideByLips on a session's LipGuideImages(count), image i as read(i) gives it (the benches'
// sessions, read their own way).
LipGuide GuideByLipsOf(size_t count, const std::function<GuideImage(size_t i)>& read,
                       DetectorContext* ctx, const LipGuideOptions& options = {});

// One line for the user saying what the guide did.
std::string Describe(const LipGuide& guide);

}  // namespace omni::detectors
