// Guided detection across rings: a target identified in one ring gives its pose, the
// pose predicts its junctions in the other ring, and they are looked for there without
// decoding. For the inner ring's small tags (about 2 raw px per bit: too small to read) and
// chessboards that one ring's finders lose (cut by a ring's edge, near boards), whose corners
// are still sharp. Chessboards' and Kalibr grids' corners are X-junctions; plain tag36h11
// grids' are L-corners (one dark quadrant: the tag's), which the saddle test also finds.
//
// Per target found in ring s (chessboards: their corners; tag grids: their read tags' corners;
// at least min_seed_corners) and missing corners in ring d:
//  1. cam_from_target from ring s's corners (pose/initial_pose.h CentralPoseFromRing, the model's rays);
//     projected through ring d (RigModel::Project) and taken into the view of ring d that holds
//     most of them (RawToView): in a view the target is a homography of its plane, H0. Where
//     ring d already has corners of the target, H0 is fitted to them instead.
//  2. The model's prediction is 10-25 raw px off on an ideal model of a misaligned rig, more than
//     a near board's square: the target's lattice (its junctions) is matched to the view's
//     saddle points (saddle_points.h) by the translation that the most junctions agree on, scored
//     minus the junctions that the lattice extended by one row / column around the target would
//     also find (a lattice shifted by one row or column finds its extension on the board). The
//     best translation must beat every other by a margin, or the target is left alone (a board
//     cut on both sides of one direction cannot be told from its shift).
//     A junction matches only a saddle of its own polarity: X-junctions, which diagonal is dark,
//     against their parity, as ring s shows it (a one-square shift of a chessboard flips it;
//     Kalibr: a shift by a gap does); L-corners, which quadrant is dark (the tag's inside).
//  3. The best translations refined to homographies of their matched saddles (RANSAC, then
//     least squares on the tight matches: the prediction's scale and turn are off too) and
//     scored again; the best must beat every other alignment by the margin.
//  2b. Tag grids the saddle points cannot align (junctions under ~3 view px apart, or too
//     blurred to be saddles: the inner ring's 40-60 mm tags at 0.5-0.9 m, bits of ~1 raw px) are
//     aligned by their whole printed pattern (tag_pattern_fit.h AlignTargetPattern: correlation
//     over translations, scales and turns, then the pattern fitted to the raw pixels) and each
//     tag measured by its own pattern fit (FitTagPattern), a tag whole or not at all. Tried where
//     the saddles kept under pattern_when_found_below of the ring's missing corners; where the
//     ring already has the target, only for a small one; the better of the two is kept.
//  4. Each matched junction refined as the per-ring detector refines its kind: chessboards by
//     cornerSubPix in the raw image (corner_refine.h, windows kept on their squares, curvature
//     bias removed; where the blur exceeds 0.15 squares the border corners' windows kept 3 sigmas
//     off the margin and every corner fitted as the blurred board, board_junction_fit.h), Kalibr corners by cornerSubPix in the view mapped to raw, checked to be
//     whole X-junctions in the raw image and fitted as blurred junctions over the Kalibr
//     detector's window (FitBlurredJunction; a corner it cannot fit is left out; junctions
//     beyond the view's map, at the ring's edge through an ideal model, from a quadratic of their
//     neighbours' raw pixels: KalibrBeyondTheView), plain tags by their four edges in the raw
//     image (RefineTagCorners with the code of the tag's place; three of its corners matched,
//     the tag whole or not at all).
//  5. The grid check (tag_grid_check.h) on all the target's corners in ring d, the found ones and
//     the guided ones: a guided corner is kept only if checked and within its tolerance.
// Ids come from the target's lattice, fixed by ring s's ids and the alignment; a wrong
// alignment would give every corner a wrong id, so where any check is in doubt nothing is kept.
//
// Scale and failure modes, in short: the seed ring needs min_seed_corners (6) corners of the
// target; the prediction may be off by max_prediction_error_deg (1.18 degrees of the camera's
// view: 30 raw px at 1280x960, scaled into the view);
// saddles align only junctions at least ~3 view px apart (match_fraction 0.3 of their spacing >= 1
// px), smaller or more blurred tag grids go to the pattern alignment (gap under
// pattern_below_gap_px, 10 view px). It returns nothing for a target whose alignment is ambiguous
// (margin under min_margin / min_margin_fraction, the extension matched, polarity disagreeing in
// the seed ring), that one image holds twice, or that shares its rows x cols with another
// chessboard; fewer than min_kept (4) checked corners from the other ring alone are dropped.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/apriltag/tag_grid_check.h"
#include "detectors/common/views.h"
#include "model/observations.h"
#include "model/rig_model.h"
#include "model/target.h"

namespace omni::detectors {

struct GuidedOptions {
  bool enabled = true;
  int min_seed_corners = 6;          // corners of the target in the seeding ring
  // How far the model's prediction may be off: the translation search radius, in degrees of the
  // camera's view (CameraPixelsPerDegree; a tilt turns rays by an angle): 30 raw px at the big
  // rig's 1280x960, 22.5 at 960x720, 61 at 2592x1944.
  double max_prediction_error_deg = 1.1841;
  // Saddle points count from this contrast (grey levels; SaddlePoints): lower than the per-ring
  // detectors' 125, the lattice is the evidence here.
  double saddle_min_contrast = 50;
  // A lattice junction matches a saddle within this fraction of the distance to its nearest
  // other junction (view px).
  double match_fraction = 0.3;
  int min_matched = 6;
  // The best translation's score must exceed every other's by this many junctions and by this
  // fraction of its own score.
  int min_margin = 3;
  double min_margin_fraction = 0.2;
  // Junctions of the lattice's extension found (a lattice that goes on beyond the target: a
  // shifted alignment or a bigger board) above this fraction of the matched ones: refused.
  double max_extension_fraction = 0.1;
  // X-junctions: this fraction of ring s's corners must show one polarity (step 2).
  double min_polarity_agreement = 0.8;
  int alignments_refined = 6;  // best distinct translations refined to homographies
  // Tag grids the saddle points cannot align: their whole printed pattern (tag_pattern_fit.h
  // AlignTargetPattern), searched within this many view px where the ring's own corners give
  // the prediction (else within the pose's max_prediction_error_deg).
  bool pattern_alignment = true;
  double pattern_search_px = 4;
  // ... tried where the saddles' guided corners are fewer than this fraction of the ring's
  // missing corners of the target (the better of the two kept; 0.75 left hid1's and hid2's
  // partly found Kalibr grids at 96.7 / 97.3% in ring 2, 1.0: 100 / 100%).
  double pattern_when_found_below = 1.0;
  // ... and where the ring has min_seed_corners of the target already, only if the gap between
  // its tags is under this many view px (the inner ring's small tags; a large target's missing
  // corners are cut or unmeasurable, and its whole pattern costs 0.1 s).
  double pattern_below_gap_px = 10;
  int min_kept = 4;  // fewer guided corners of a target in a ring after the checks: none kept
  TagGridCheckOptions grid_check;

  // Empty if the options are usable, else "<field>: expected ...": a count under 1, an angle,
  // search or gap <= 0, a fraction outside its range.
  std::string Check() const;
};

// Guided corners (only ids not in `found` for their target and ring) from the targets `found`
// holds. `raw_grey`: the raw image as CV_8U grey; `views` rendered from it (RenderViews).
std::vector<CornerObservation> GuidedCorners(const cv::Mat& raw_grey,
                                                 const std::vector<RingView>& views,
                                                 const RigModel& model,
                                                 const std::vector<TargetSpec>& targets,
                                                 const std::vector<CornerObservation>& found,
                                                 const GuidedOptions& options = {});

}  // namespace omni::detectors
