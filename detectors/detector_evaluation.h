// The detectors judged against a synthetic session's exact truth (bench/eval_detectors): per
// ring and per horizontal range of the corner from the axis, the corner error (mean, 99th
// percentile), the fraction of truly visible corners found and the wrong ids; the same per kind
// of target, for well-spaced corners, for resolved targets and for the corners guided detection
// found; and the lip-only intrinsics against the true rig. The truth is each image's true corners
// (model/truth.h, synthetic::ComputeTruth), matched by pixels alone (NearestTrueCorner).
// Beside the geometric count (every corner the model shows in a ring), a "readable" count leaves
// out chessboard corners whose squares the ring's blur flattens (Readability): what no detector
// can read is not in plain sight; the tables say how many it leaves out and how many of those
// were found anyway.
#pragma once

#include <array>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/detect_image.h"

#include "model/observations.h"
#include "model/rig_params.h"
#include "model/target.h"
#include "model/truth.h"

namespace omni::detectors {

// Which visible chessboard corners count as readable: the board's modulation there
// (board_modulation.h, from the true local square sides in raw pixels) at the ring's blur is at
// least min_modulation. Other kinds of target are all readable; blur 0: all readable.
// Why 10%: a board spans ~100-200 grey levels in the renders, so a tenth is 10-20 levels: the
// chessboard detector's X-junction test floor (ChessboardOptions::saddle_contrast_floor, 10),
// and a few times the webcam preset's noise over the few pixels of a 3-4 px square, where the
// acceptance asks 0.1 px. (10% and 15% count the same on the sessions measured: corners' values
// lie well above or far below; docs/experiments.md 2026-11-30.)
struct Readability {
  std::array<double, 2> blur_sigma_px = {0, 0};  // [0] ring 1, [1] ring 2; raw pixels
  double min_modulation = 0.10;
};

class DetectorEvaluation {
 public:
  explicit DetectorEvaluation(std::vector<TargetSpec> targets, Readability readability = {})
      : targets_(std::move(targets)), readability_(readability) {}

  // One image's detections (`guided`: per corner, found by guided detection) against its true
  // corners. Returns the lines worth a look, one each: wrong ids, right ids far off (> 0.5 px)
  // and the boards missed in part (with how many of their visible corners are readable, where
  // not all). *csv_rows (may be null) gets every matched corner and every
  // missed visible one (CsvHeader's columns).
  std::vector<std::string> AddImage(const std::string& name, const ImageObservations& detections,
                                    const std::vector<bool>& guided,
                                    const std::vector<TruthCorner>& truth,
                                    std::string* csv_rows = nullptr);

  static const char* CsvHeader();
  // The tables, newline-terminated.
  std::string Tables() const;

 private:
  struct Bin {
    std::vector<double> errors;
    int visible = 0, found = 0, wrong = 0;
    int readable = 0, readable_found = 0;  // Readability's subset of visible, found
  };
  // Per truth corner and ring (index 2 i + ring - 1): its board's modulation (1: not a
  // chessboard, no blur, or not visible).
  std::vector<double> Modulations(const std::vector<TruthCorner>& truth) const;

  std::vector<TargetSpec> targets_;
  Readability readability_;
  std::map<std::pair<int, int>, Bin> bins_;            // (mirror, range bin)
  std::map<std::pair<int, int>, Bin> by_kind_;         // (target type, mirror), all ranges
  std::map<std::pair<int, int>, Bin> guided_by_kind_;  // the same, guided corners only
  std::map<std::pair<int, int>, Bin> spaced_by_kind_;  // corners kSpacedPx from their target's others
  std::map<int, Bin> resolved_by_ring_;                // targets resolved (kResolvedPx), per ring
};

// The value at fraction p (0..1) of the sorted values (the nearest rank); 0 when empty.
double Percentile(std::vector<double> values, double p);

// The lip-only principal point against what the TRUE rig fixes. Lips are fixed to the mirror
// bodies, so with a nominal (coaxial) model a lip-only fit cannot tell a tilt of the camera
// against the bodies from a principal-point shift (lips/lip_intrinsics.h): the fit should put the
// principal point where the bodies put the lips' centres, not at the true one (reference points:
// LipReferencePointsOf). Fits: all labelled edges, mirror-1 edges only (direct, via_mirror1: one
// body), mirror-2 edges only (via_mirror2: mirror 2 and the reflex plane), and all edges from the
// nominal with the true lens distortion (what part of the focal-length error the distortion
// makes). Newline-terminated lines.
std::string LipIntrinsicsAgainstTruth(const RigParams& truth, const RigParams& nominal,
                                      const std::vector<LipEdgeObservation>& edges, int n_images);

// A session's detection as the evaluation runs it, beyond the corners DetectorEvaluation judges:
// per ring every image's measured view blur, each detection's wall and process CPU time (one
// thread), every labelled lip edge (for one pooled lip-only fit) and the images with lips.
struct DetectionRun {
  std::array<std::vector<double>, 2> view_blur;
  std::vector<double> times_ms, cpu_ms;
  std::vector<LipEdgeObservation> lips;
  int lip_images = 0;
};

// One image detected with `ctx` (DetectImage, timed) and judged against its true corners
// (DetectorEvaluation::AddImage, csv_rows as there); adds to *run. Returns AddImage's lines and
// "NAME: N corners in T ms".
std::vector<std::string> DetectAndEvaluate(const cv::Mat& raw, const std::string& name,
                                           const std::vector<TruthCorner>& truth,
                                           DetectorContext* ctx, DetectorEvaluation* evaluation,
                                           DetectionRun* run, std::string* csv_rows = nullptr);

// The run's report, newline-terminated: the context's build time (context_ms), each ring's views
// (size, f, median measured blur), the evaluation's tables, the time per image of `rig`'s size
// and, with lips, the lip-only intrinsics from `nominal` against `rig` (LipIntrinsicsAgainstTruth).
std::string DetectionRunReport(const DetectionRun& run, const DetectorContext& ctx,
                               const DetectorEvaluation& evaluation, const RigParams& rig,
                               const RigParams& nominal, double context_ms);

}  // namespace omni::detectors
