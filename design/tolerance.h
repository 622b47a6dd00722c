// Assembly tolerances: (1) does a built (calibrated) rig meet them, given the calibration's
// uncertainty, and (2) what would parts machined and assembled to them do to the images, before
// anything is built (Monte Carlo over rigs drawn within the tolerances).
//
// Quantities checked, per mirror body (docs/design.md, Conventions misalignment parameters):
//   decentre  = |(tx, ty)|   mm      tilt = |(rx, ry)|   rad      axial = |tz|   mm
//   profile   = the peak-to-valley of the mirror's profile (model/mirror_profile.h) over its
//               radii, mm: how far the machined surface departs from the conic
// and for the reflex plane in mirror 1's body: tilt = |(rx, ry)| rad, offset = |dz| mm.
#pragma once

#include <array>
#include <cmath>
#include <functional>
#include <random>
#include <optional>
#include <string>
#include <vector>

#include "model/rig_params.h"

namespace omni::design {

// Limits (>= 0; a negative value means "not toleranced").
struct BodyTolerance {
  double decentre_mm = -1, tilt_rad = -1, axial_mm = -1;
  double profile_pv_mm = -1;  // machining: the profile's peak-to-valley
};
// The parts against each other (design/rig_body.h): mirror 2 and the camera against mirror 1's
// axis. -1: not toleranced.
struct RigBodyTolerance {
  double mirror2_decentre_mm = -1, mirror2_tilt_rad = -1, mirror2_spacing_mm = -1;
  double camera_decentre_mm = -1, camera_tilt_rad = -1;
  bool Any() const {
    return mirror2_decentre_mm >= 0 || mirror2_tilt_rad >= 0 || mirror2_spacing_mm >= 0 ||
           camera_decentre_mm >= 0 || camera_tilt_rad >= 0;
  }
};
struct ToleranceSpec {
  BodyTolerance mirror[2];  // each mirror against the camera (its pose in C)
  RigBodyTolerance rig_body;
  double reflex_tilt_rad = -1, reflex_dz_mm = -1;
  double confidence_sigmas = 2.0;  // a verdict must hold at value +- this many sigma
};

enum class Verdict { kPass, kFail, kUndecided };
const char* VerdictName(Verdict verdict);

struct ToleranceCheck {
  std::string name;             // e.g. mirror1.decentre
  std::string unit;             // mm | rad
  double value = 0;             // the magnitude measured
  std::optional<double> sigma;  // first-order sigma of the magnitude (calibrated models only)
  double limit = 0;
  Verdict verdict = Verdict::kUndecided;
  // The signed parameters the magnitude is made of (mirror1.tx, mirror1.ty for a decentre;
  // none for a profile): which way the part sits, so which way to move it.
  std::vector<std::string> parameters;
  std::vector<double> components;
  // The strongest correlation (calibrated models) of one of `parameters` with the principal
  // point (cx, cy), and the pair ("mirror1.ry ~ cx"): beyond kRotationValleyCorrelation the
  // value lies in the camera-rotation valley, where turning the camera against the bodies moves
  // it with the principal point, so the calibration cannot separate it from the camera's rotation.
  double valley_correlation = 0;
  std::string valley_pair;
  // The frame the quantity is measured in: "camera" (a mirror's pose in C, the reflex in M1 as
  // before) or "mirror1" (design/rig_body.h: the parts against mirror 1's axis).
  std::string frame = "camera";
  // The linearisation behind `sigma`: d value / d parameter over the covariance's named
  // parameters (sigma^2 = g' C g); what the photos that would decide it are predicted with.
  std::vector<std::string> gradient_names;
  std::vector<double> gradient;
  // One line on how the verdict was reached where the sigma alone does not say it (a held
  // profile: design/held_profile.h); else empty.
  std::string note;
};
constexpr double kRotationValleyCorrelation = 0.99;

// Checks a model against the spec. With a covariance (rig.calibration, parameter names like
// mirror1.tx, reflex.rx) a verdict is PASS only if value + k*sigma <= limit, FAIL only if
// value - k*sigma > limit, and UNDECIDED otherwise (more data would decide it). Without a
// covariance the verdict compares the value alone (and says so by an empty sigma).
std::vector<ToleranceCheck> CheckTolerances(const RigParams& rig, const ToleranceSpec& spec);

// For a FAIL (else empty; also empty in the camera-rotation valley, where no move of a part can be
// told from the camera's turn: RotationValleyNote says so): by how much the part is beyond its limit and the smallest move that
// brings it back, against the direction its signed components point in; C's axes: +x image
// right, +y image down, +z from the camera towards the mirrors. E.g. "(mirror1.tx, mirror1.ty)
// is (+0.311, -0.205) mm, |.| 0.373 beyond 0.300 by 0.073: move mirror1 by (-0.061, +0.040) mm
// in C's x, y (x image right, y image down), towards the axis".
std::string Correction(const ToleranceCheck& check);
// Where one of the check's parameters lies in the camera-rotation valley (|valley_correlation|
// over kRotationValleyCorrelation), one line saying so; else empty.
std::string RotationValleyNote(const ToleranceCheck& check);

// The image effect of the tolerances: `samples` rigs are drawn uniformly within the limits
// (decentre uniform in a disc, tilt uniform in a disc, axial and dz uniform in +-limit, random
// directions) around `nominal`; each projects a grid of points at horizontal range `range_mm`
// that the nominal rig sees in both rings. Shifts are pixel distances from the nominal pixels.
struct ImageEffect {
  int points = 0, samples = 0;
  double p50_px[2] = {0, 0}, p95_px[2] = {0, 0}, max_px[2] = {0, 0};  // [ring of mirror 1, 2]
  double lost_fraction = 0;  // points no longer valid in a drawn rig
};
// `progress` (may be empty) is called after each drawn rig with (done, samples). A profile limit
// draws each mirror's profile (random Legendre and astigmatism terms) scaled to a peak-to-valley
// uniform in [0, limit].
ImageEffect SimulateImageEffect(const RigParams& nominal, const ToleranceSpec& spec, int samples,
                                double range_mm, unsigned seed,
                                const std::function<void(int, int)>& progress = {});

// What machining accuracy a rig needs: `samples` random smooth profiles on both
// mirrors, each of peak-to-valley `pv_mm`, and what they do to points the nominal rig sees in
// both rings: the 95th percentile of the pixel shift at 1 m per ring, and of the relative range
// error at 2 m of a point triangulated with the nominal model from the machined rig's pixels.
// The effects are linear in the profile's size at these microns, so the peak-to-valley that
// keeps each within a budget follows: pv_mm * budget / effect.
struct ProfileSensitivity {
  double pv_mm = 0;
  int samples = 0;
  double p95_shift_px_1m[2] = {0, 0};
  double p95_range_error_2m = 0;  // relative (0.01 = 1%)
  double PvFor(double budget, double effect) const { return effect > 0 ? pv_mm * budget / effect : HUGE_VAL; }
};
ProfileSensitivity SimulateProfileSensitivity(const RigParams& nominal, double pv_mm, int samples,
                                              unsigned seed);

// A random smooth profile (Legendre P1..P4 and astigmatism terms) over `shape`'s radii with the
// given peak-to-valley.
std::array<double, kProfileTerms> RandomProfile(const ProfileShape& shape, double pv_mm,
                                                std::mt19937* rng);

}  // namespace omni::design
