// The in-field health check: does a stored calibration still describe the rig, and if
// not, which group moved? From images of whatever scene the rig sees, no target needed.
//
// Evidence per image (health/evidence.h, collected by apps/health_cli.cc): ring-to-ring matches of
// natural features (ring_matches.h) and the lip edges detected under the stored model. Each
// match gives the signed gap of its two rays in ring-2 pixels (consistency.h EpipolarGap), each
// lip point its signed distance across its edge. A rig that moved shows as a pattern of these
// over the azimuth; noise and the scene's own texture do not. So the statistic is built on bins:
//   matches: 24 azimuth bins x 2 elevation halves; lips: 24 azimuth bins per edge (path, circle);
//   per bin a robust mean (3-sigma clipped about the median) and its standard error from the
//   scatter pooled over the bin's kind (residuals.h), widened by a floor (what stays correlated
//   inside a bin: the lips' texture-dependent bias along an arc, docs/experiments.md; the
//   tracker's bias); bins with fewer than min_bin_count are dropped. Where the stored model
//   carries the calibration photos' lip bins (lip_reference.h), a lip bin is measured from
//   their mean and its error is the photos' scatter: the check then tests whether the lips
//   moved since calibration, not whether the edge detector is unbiased.
// Under the stored model the bin means are zero up to their errors and the model's own
// uncertainty: r ~ N(0, C), C = diag(se^2) + J Sigma J^T, with Sigma the stored covariance over
// the drift coordinates that are rig parameters and J the bins' derivatives by the drift
// coordinates (drift.h; forward differences at a subsample of each bin's points). chi^2 = r^T
// C^-1 r has the chi-square distribution with one degree of freedom per bin.
// Verdict: CANNOT TELL when the matches are too few or cover too little of the azimuth (a
// textureless scene: the lips alone cannot tell a knocked rig from the lips' own bias); OK when
// chi^2's p-value is at least `significance`; otherwise DRIFTED, and each group's coordinates
// are fitted to r by generalised least squares (pseudo-inverse: degenerate directions inside a
// group cost nothing); the group with the lowest chi^2 + rank ln(bins) (Schwarz's Bayesian
// criterion: the camera's ten coordinates must earn their freedom) is named, with the fitted
// amounts, and a second group within 4 of it is named as one the data cannot tell apart.
// A single mirror (one ring, RigParams::Single) has no second view to match: its evidence is the
// rim's edge (detectors/lips/rim_edge.h), measured from the calibration photos' (lip_reference.h);
// where the edge of the mirror's image is not its rim (model/single_rim.h), at the mirror circle
// the edge is (lip_reference.h AsObserved). The verdict tests the rim's move, its scale, shift
// and tilt (harmonics 0-2 of the azimuth fitted to the bins): chi^2 with 5 dof against the fit's
// covariance (widened where the bins scatter about it by more than their errors) plus what the
// scene moves the edge by in k photos and in the n calibration photos' mean (sigma_s^2 (1/k +
// 1/n) per coefficient; sigma_s from the calibration photos, calibration.lip_reference.rim_scene_px).
// DRIFTED names the camera or mirror 1, which the rim cannot tell apart. No reference or too few
// bins: CANNOT TELL, saying which.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "health/ring_matches.h"
#include "model/observations.h"
#include "model/rig_params.h"

namespace omni::health {

struct ImageEvidence {
  std::string file;
  std::vector<RingMatch> matches;
  std::vector<LipEdgeObservation> lips;  // detected under the stored model, labelled
};

struct CheckOptions {
  int azimuth_bins = 24;
  int min_bin_count = 6;
  double match_floor_px = 0.02;  // per match bin, added in quadrature to its standard error
  double lip_floor_px = 0.08;    // per lip bin
  // A single mirror's rim: what one photo's scene moves the rim's edge by as a whole (each of its
  // shift, scale and tilt coefficients, px), the prior the calibration photos' own scatter is
  // pooled with (kPooledScatterPhotos photos' worth; lip_reference.h RimSceneSigma): a dark
  // sleeve along a side of the rim against the holder's dark moved the edge of Mei's held-out
  // photos by 0.6-0.8 px with the rig untouched.
  double rim_scene_prior_px = 0.4;
  int jacobian_samples = 6;      // per bin
  int max_lip_points_per_edge = 360;  // per image (a subsample spread along the edge)
  double significance = 1e-3;    // p-value below which the rig has drifted
  int min_matches = 150;         // fewer: CANNOT TELL
  // With too few matches, lips farther than this fraction of f (rms; 1.5 px at 1280x960's f,
  // a calibrated rig's are 0.2-0.5 px) say the model does not fit the photos at all.
  double lip_misfit_per_f = 0.001;
  double min_match_coverage = 0.5;  // share of azimuth bins with a usable match bin
  // A single mirror's rim: bins needed beyond its harmonics' five (RimHarmonicsTest, check.cc).
  int min_rim_bins_beyond_harmonics = 5;
};

// A single mirror's rim bins are tested for its move's harmonics of the azimuth (0, 1, 2: scale,
// shift, tilt) against their scatter about them.
constexpr int kRimHarmonics = 5;

enum class Verdict { kOk, kDrifted, kCannotTell };
const char* VerdictName(Verdict verdict);  // "OK", "DRIFTED", "CANNOT TELL"

struct GroupFit {
  std::string group;
  double chi2 = 0;
  int dof = 0, rank = 0;
  double p_value = 0;
  std::vector<std::string> names;  // its coordinates
  Eigen::VectorXd amounts, sigma;  // internal units (px, rad, mm); sigma 0 where degenerate
  int bins = 0;  // the bins it was fitted to
  // Schwarz's Bayesian criterion, chi^2 + rank ln(bins) (see CheckRig).
  double Score() const { return chi2 + rank * std::log(static_cast<double>(std::max(bins, 1))); }
};

// The residual bins (for tests, plots and the refinement's covariance).
struct ResidualBin {
  std::string kind;  // "matches" or the lip edge ("via_mirror2 r_outer")
  double azimuth_deg = 0;
  int count = 0;
  double mean = 0, standard_error = 0;
  bool referenced = false;  // measured from the calibration photos' mean (lip_reference.h)
  int reference_photos = 0;  // the calibration photos that mean is over
};

struct CheckResult {
  Verdict verdict = Verdict::kCannotTell;
  std::string reason;  // one sentence: why this verdict
  bool model_misfit = false;  // CANNOT TELL because the model does not fit the photos at all
  int n_images = 0, n_matches = 0, n_lip_points = 0;
  int match_bins = 0, lip_bins = 0, covered_azimuth_bins = 0;
  int referenced_lip_bins = 0;  // of lip_bins, those measured from the calibration photos'
  double gap_rms_px = 0, lip_rms_px = 0;  // of the (clipped) samples
  double chi2 = 0, p_value = 1;
  int dof = 0;
  // A single mirror (one ring): chi2 and dof are its rim's move against its uncertainty and 5
  // (RimHarmonicsTest, check.cc); the move's coefficients (px: scale, shift x, y, tilt's cos 2,
  // sin 2 of the azimuth) and the bins' scatter about them against their errors (per dof).
  Eigen::VectorXd rim_move;
  double rim_scatter_factor = 0;
  bool model_covariance = false;  // the stored model's covariance entered C
  std::vector<GroupFit> groups;   // best explanation first (GroupFit::Score; when DRIFTED)
  std::string named_group;        // DRIFTED: the group named ("" otherwise)
  std::string runner_up;          // a group that explains it nearly as well, if any
  std::vector<ResidualBin> bins;
  // The bins' Jacobian by DriftCoordinates() and C (rows: bins).
  Eigen::MatrixXd jacobian, bin_covariance;
  Eigen::VectorXd residual;
};

CheckResult CheckRig(const RigParams& stored, const std::vector<ImageEvidence>& images,
                     const CheckOptions& options = {});

// A single mirror's rim bin's row of the harmonics (1, cos, sin of the azimuth and of twice it).
Eigen::Matrix<double, kRimHarmonics, 1> RimHarmonicsRow(double azimuth_deg);
// The variance (px^2) the scene behind the rim adds to each harmonic's coefficient of a check of
// result.n_images photos against the reference's mean: rim_scene_px^2 (1/k + 1/n).
double RimSceneVariance(const RigParams& stored, const CheckResult& result);

// Upper tail of the chi-square distribution with `dof` degrees of freedom: P(X >= x).
double ChiSquareSurvival(double x, int dof);


}  // namespace omni::health
