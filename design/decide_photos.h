// The photos that would decide an UNDECIDED tolerance check: candidate photos of a chessboard
// (at several ranges, heights in the stereo band and azimuths) are simulated through the
// calibrated model, their corners' information added to the calibration's (the inverse of its
// noise-alone covariance, each new board's pose eliminated by its Schur complement, each ring's
// corners weighted by that ring's residual RMS), and photos are chosen greedily, each the one
// that lowers the check's sigma most, until its value and limit lie k sigma apart or max_photos
// are taken. The considered parameters' share of the covariance (held coordinates, the
// detectors' biases) is carried through: it shrinks only where the photos pin what those
// columns move (decide_photos.cc, Knowledge); a held profile (calibration.held_profiles) moves
// the new photos' corners too, so each photo's information is taken with its terms free under
// what is known of them (their prior narrowed by the data). First order; a model without a noise covariance
// (older files) takes its whole covariance as the data's information, which is optimistic where
// the considered share dominates (reflex.tilt on the demo: predicted 0.014, reached 0.020 deg).
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "design/tolerance.h"
#include "model/rig_params.h"

namespace omni::design {

struct CandidatePhoto {
  double range_mm = 0, height_mm = 0, azimuth_rad = 0;  // the board's centre in C (z: the axis)
  const char* height_name = "";                          // low | middle | high in the band
  // A chessboard's inner corners: rows + cols odd, so a half turn does not map the pattern onto
  // itself and a detector tells the corner ids apart (a 6x8 one it cannot; sample_configs' scenes
  // follow it). A tag grid (tag_grid): rows x cols tags, 4 corners each.
  int rows = 5, cols = 8;
  double square_mm = 0;                                   // or the tag's side; CandidateBoard
  bool tag_grid = false;                                  // a Kalibr AprilGrid (spacing 0.3)
  int corners[2] = {0, 0};                                // seen via mirror 1, mirror 2
};

struct DecidingPhotos {
  std::string check;
  double sigma_now = 0, sigma_needed = 0, sigma_after = 0;
  std::vector<CandidatePhoto> photos;  // in the order chosen
  bool decides = false;                // sigma_after <= sigma_needed
  // The check lies in the camera-rotation valley: no photo is proposed (the data cannot tell the
  // value from the camera's turn against the bodies, and the part of its sigma that the held
  // tangential distortion carries does not shrink with photos).
  bool in_valley = false;
  // The part of sigma_after that is the considered parameters' share (the lips' and corners'
  // detector biases, held coordinates): photos do not average it, and along a valley the photos
  // close it can even grow (mirror1.tz / mirror2.tz on the demo with a 1 um scan: the lips' bias
  // across the edge, 0.03 px, leaves 0.037 / 0.040 mm after 8 wide boards).
  double considered_after = 0;
  // One line: "6 photos: a 5x8 board of 16 mm squares at 0.4 m, low in the band (its centre
  // 72 mm up the axis from the camera), azimuths 0, 45 x2, ... deg; sigma 0.372 -> 0.081 mm
  // (0.085 decides)".
  std::string Describe(const std::string& unit, double scale) const;
};

// A candidate board: a chessboard's inner corners or a tag grid's tags, squares (tags) scaled
// with the range, up to a range (its width stays one a user can put up against a wall).
struct CandidateBoard {
  int rows = 5, cols = 8;
  double square_mm_per_m = 40;
  double max_range_mm = HUGE_VAL;
  bool tag_grid = false;
};

struct DecidingPhotosOptions {
  std::vector<double> ranges_mm = {400, 700, 1000, 1600, 2500};
  int azimuths = 8;
  int max_photos = 12;
  // The 5x8 chessboard at every range, and a wide tag grid (4x10 tags of 120 mm at 1 m: 1.5 x
  // 0.6 m) up to 1 m: its corners span ~75 deg of azimuth in both rings, which is what pins the
  // camera's focal length against the mirrors' axial positions, and a tag grid is found where the
  // rings cut it (a chessboard that wide is not: its ids need the whole board). docs/experiments.md,
  // 2026-11-29 "both mirrors' axial sigmas": 8 such photos took the demo's noise-alone sigma of
  // mirror1.tz 0.065 -> 0.030 mm where 8 of the 5x8 at 0.4 m took it to 0.066.
  std::vector<CandidateBoard> boards = {{5, 8, 40, HUGE_VAL, false}, {4, 10, 120, 1000, true}};
};

// For every UNDECIDED check with a sigma (a calibrated model): the photos that would decide it
// (none for a check in the camera-rotation valley: in_valley).
std::vector<DecidingPhotos> PhotosThatDecide(const RigParams& rig,
                                             const std::vector<ToleranceCheck>& checks,
                                             double confidence_sigmas,
                                             const DecidingPhotosOptions& options = {});

// The check's sigma once the given photos are added to the calibration's data (the same first-order
// model as PhotosThatDecide's, photos skipped that show fewer than 6 corners); nullopt without a
// calibration with a covariance or a check without a gradient.
std::optional<double> SigmaAfterPhotos(const RigParams& rig, const ToleranceCheck& check,
                                       const std::vector<CandidatePhoto>& photos);

}  // namespace omni::design
