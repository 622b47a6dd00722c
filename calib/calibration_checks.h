// What a calibration is checked by after its solve, apart from its table (ResultTable): the
// corner noise against a synthetic session's truth, the observations it left out, and whether a
// model's detections are the ones it was calibrated from (`report` solves again from the model).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "calib/calibrate.h"
#include "model/observations.h"
#include "model/rig_params.h"
#include "model/target.h"
#include "model/truth.h"

namespace omni::calib {

// The acceptance check "reprojection RMS within 20% of the corner noise" on a synthetic session:
// the detector's true error (detected - true pixel, 2-D RMS) over exactly the corners the solve
// kept, per ring, to set beside the solve's reprojection RMS (per_mirror_rms_px). A ratio well
// under 1 means the fit absorbs part of the detector's error (coherent over boards), well over 1
// a model that cannot fit. Images are matched to the truth's by file name (the detections may
// name them by path); a target placed several times in one image: the nearest true corner.
struct CornerNoise {
  double true_rms_px[2] = {0, 0};  // per ring; 0 where count is 0
  int count[2] = {0, 0};           // kept corners matched to a true one, per ring
  int unmatched = 0;               // kept corners with no true counterpart
};
CornerNoise CornerNoiseAgainstTruth(const CalibrationResult& result,
                                    const Observations& detections, const Truth& truth);
// The check as `calibrate --truth PATH` prints it: per ring the reprojection RMS beside the true
// error and their ratio, and the kept corners without a true one. Newline-terminated.
std::string CornerNoiseText(const CalibrationResult& result, const CornerNoise& noise,
                            const std::string& truth_path);

// With the true rig of a synthetic session (`calibrate --truth_model`): what the calibration is
// worth for measuring, as the projection difference from the true rig of points at 1 m over the
// stereo band, held in mirror 1's body (what `triangulate --frame mirror1` measures) and in the
// camera frame; each group's share of it (ShareOfProjectionError), and the parameter error
// against the covariance. Newline-terminated.
std::string TruthShareText(const CalibrationResult& result, const RigParams& truth);

// Against the true rig in one line (bench_calibrate): the worst misalignment (a pose or reflex
// parameter) as |value - truth| / sigma with its name, and the projection difference at 1 m in
// mirror 1's body and in C per ring. Newline-terminated.
std::string TruthLine(const CalibrationResult& result, const RigParams& truth);

// "name value sigma" per refined parameter (internal units, 17 digits), to compare two builds'
// answers.
std::string ValuesText(const CalibrationResult& result);

// Every observation the solve left out, one line each with why ("left out: image I (FILE) target
// T corner C ring R at (u, v): reason (residual px)"), then, when there were any, one line per
// target (named) of how many in how many photos: a target with most of the outliers is worth a
// look (its print, its size, its flatness). Newline-terminated; empty when none was left out.
std::string LeftOutText(const CalibrationResult& result, const Observations& detections,
                        const std::vector<TargetSpec>& targets);

// Whether detections can be those a model was calibrated from: the model's dataset (image count,
// targets) against theirs. Empty when they agree, else "its calibration: dataset: has ...; these
// have ..." for the caller's message.
std::string DatasetMismatch(const CalibrationInfo& info, const Observations& detections,
                            const std::vector<TargetSpec>& targets);

// Solved again from the calibrated model on the same detections, the solve starts at its optimum
// and stays there; a parameter that moves by more than one of its sigmas means other data: "NAME
// moved X sigma when solved again" for the first such, else empty.
std::string MovedWhenSolvedAgain(const CalibrationInfo& info, const CalibrationResult& result);

}  // namespace omni::calib
