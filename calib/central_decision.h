// A single-mirror camera's non-central part kept only where the photos decide it.
//
// mirror1_pose is the mirror's tilt against the lens and, with a perspective lens, the camera's
// offset from the mirror's focus: the part that makes the camera non-central. A few photos of
// one board in one sector leave it in a valley with the principal point and the conic (Mei's
// 7-photo folds: the tilt's sigma 0.6 deg, a fit 0.02 px better on its own photos and 0.26 px
// worse on the held-out ones; a free perspective camera walked to 22 deg and diverged). The
// non-central fit is tested against the central assembly (the start's pose) by the Wald
// statistic of its determined pose coordinates with its own covariance (the considered
// parameters' share in it: the held tangential distortion trades with the tilt); it stands only
// where that is beyond chance at the 1% level and beyond Schwarz's k ln n (coordinates the
// covariance names undetermined carry no number and no evidence). With none determined the
// photos arbitrate (below): a public hyperbolic-mirror set's 9 photos left every pose
// coordinate undetermined and the fit walked the principal point 27 px from the rim's centre
// (sigma 14 px) in the valley; with fewer than 3 photos the fit stands. Where the same statistic with the pixel noise alone
// exceeds the threshold and the full one does not (the tilt in the camera-rotation valley the
// held tangential distortion opens), 3-fold cross-validation on the photos arbitrates: a true
// 0.7 deg tilt seen by 20 synthetic photos had chi^2 0.8 (73.6 from the noise alone), and held
// it predicted new photos at 0.72 px against the truth's 0.40. The cross-validation keeps the
// non-central fit only where its held-out squared error is lower by more than its standard
// error over the photos (the one-standard-error rule: a fold of 6 photos otherwise preferred a
// fit that predicted its held-out photos 0.47 px against the central 0.31). Otherwise the calibration holds
// the start's pose and says so, with the non-central fit's offset and sigma.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "calib/calibrate.h"

namespace omni::calib {

// Whether `options` ask for the test: a single rig, mirror1_pose estimated, noncentral: auto.
bool TestsNonCentral(const RigParams& start, const CalibrationOptions& options);

// The Wald test of `fit`'s refined mirror1_pose coordinates against `start`'s: fills chi2,
// dof, threshold, open and decided of `decision`.
void TestNonCentral(const RigParams& start, const CalibrationResult& fit,
                    NonCentralDecision* decision);

// Where the noise alone decides and the full covariance does not (NonCentralDecision), and where
// the covariance determines no pose coordinate at all while `photos` (>= 3) allow three folds.
bool NeedsCrossValidation(const NonCentralDecision& decision, size_t photos);

// The calibration (Calibrate without this decision) that the cross-validation runs.
using CalibrateFunction = std::function<CalibrationResult(
    const RigParams&, const std::vector<TargetSpec>&, const Observations&,
    const CalibrationOptions&)>;

// 3-fold cross-validation of the non-central against the central model on the detections'
// photos (image i in fold i % 3): fills cross_validated, cv_rms_*, decided.
void CrossValidateNonCentral(const RigParams& start, const std::vector<TargetSpec>& targets,
                             const Observations& detections, const CalibrationOptions& options,
                             const CalibrateFunction& calibrate, NonCentralDecision* decision);

// The decision in words, for the result's notes (the offset itself: single_mirror_summary.h).
std::string NonCentralNote(const NonCentralDecision& decision);

// `options` with mirror1_pose held (the central model).
CalibrationOptions CentralOptions(const CalibrationOptions& options);

}  // namespace omni::calib
