// Everything the detectors find in one omnidirectional image: chessboard corners, AprilTag grid
// corners (plain tag36h11 and Kalibr AprilGrid, detectors/apriltag/apriltag_detector.h) per ring, and the
// lip band edges (detectors/lips/lip_detector.h, colour images only), as detections-file records
// (io/detections_file.h).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/chessboard/chessboard_detector.h"
#include "detectors/common/ring_layout.h"
#include "detectors/common/views.h"
#include "detectors/guided_detection.h"
#include "detectors/lips/lip_detector.h"
#include "io/image_file.h"
#include "model/observations.h"
#include "model/rig_model.h"
#include "model/target.h"

namespace omni::detectors {

// What stays the same for every image of a session: the model, its ring layout and the views'
// maps (built once: MakeRingViews is the costly part), the targets to look for.
struct DetectorContext {
  DetectorContext(const RigParams& rig, std::vector<TargetSpec> targets, bool use_lips = true,
                  const ViewOptions& view_options = {});

  // Replaces the model, rebuilding the ring layout and the views' maps.
  void SetModel(const RigParams& rig);

  ViewOptions view_options;
  RigModel model;
  RingLayout layout;
  std::vector<RingView> views;  // each image is rendered into views[i].image (not thread-safe)
  std::vector<TargetSpec> targets;
  bool use_lips = true;
  // How the images encode light: DetectImage decodes them to linear first (io::LinearImage).
  io::ToneCurve tone = io::ToneCurve::kLinear;
  // Whether the CURRENT image's chroma was stored at half its luma's resolution (a JPEG:
  // io::HasHalvedChroma; DetectSession sets it per image): lip edges are then placed on the luma.
  bool chroma_halved = false;
  // The CURRENT image's own luma plane when chroma_halved (io::ReadStoredLuma; DetectSession
  // reads it per image), else empty: the lip edges are placed on it.
  cv::Mat luma;
  ChessboardOptions chessboard;
  GuidedOptions guided;  // corners of targets found in one ring looked for in the other
  // The lip detector's prediction for the model, made on the session's first colour image.
  LipPredictionCache lip_prediction;

 private:
  // A single-mirror model's chessboard options (the folded rig keeps the defaults): the grid
  // check allows the start model's smooth error (ChessboardOptions::smooth_grid_correction).
  void SetSingleMirrorOptions();
};

// Detects the context's targets in `image` (BGR or grey, 8 or 16 bit, the model's size, encoded
// as ctx->tone says). Throws
// io::InputError with a one-line reason when the image cannot be used (empty, wrong size);
// appends a line to *warnings for what was skipped (e.g. lips on a grey image). `file`, `width`
// and `height` of the result are for the caller to fill in. With `guided`: one flag per corner,
// true where guided detection across rings found it (guided_detection.h; those come last).
// With `repeated`: the targets of which the image showed more copies in a ring than the session
// lists sheets of the pattern (one copy per ring kept; each extra copy's target appended).
// The lip detector's input from a linear image (io::LinearImage, 16 bit): BGR, alpha dropped, the
// 16 bits kept (8-bit linear levels are too coarse for a dark band's Y': lip_detector.h).
cv::Mat LipInput(const cv::Mat& linear);

// The lip detector's options for `image` (as read) from its file's chroma layout: whether the
// chroma was halved (io::HasHalvedChroma) and the file's own luma plane (io::ReadStoredLuma).
LipDetectorOptions LipOptionsFor(const cv::Mat& image, bool chroma_halved, const cv::Mat& luma);

ImageObservations DetectImage(const cv::Mat& image, DetectorContext* ctx,
                                std::vector<std::string>* warnings = nullptr,
                                std::vector<bool>* guided = nullptr,
                                std::vector<int>* repeated = nullptr);

}  // namespace omni::detectors
