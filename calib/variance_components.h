// Per-group noise estimation for the calibration ("honest sigmas"): the corners of
// ring 1, the corners of ring 2 and the lip edge points have different noise (detector, blur of
// each ring, anti-aliased lip edges), so one posterior variance factor for all of them lets the
// most numerous group (the lips, ~10k points) set the scale of everyone's sigma. Each group g gets
// its own variance s_g^2 = SSR_g / r_g (variance component estimation, Foerstner's simplified
// form: r_g = the group's share of the redundancy), the solve is re-weighted with 1 / s_g^2 and
// the covariance is the inverse of the weighted normal matrix (variance factor ~1 by
// construction).
//
// Lip edge points are not independent: the same edge is detected in every image of the session
// (the rig does not move) and neighbouring points along an edge share its anti-aliasing bias, so
// 10k points know far less than 10k independent ones would. LipCorrelationFactor measures that
// from the residuals themselves (block averaging along each physical edge over all images): the
// factor tau by which the variance of a mean of L consecutive residuals exceeds s^2 / L, at the
// block length where it is largest. The lip group is weighted with s^2 * tau.
#pragma once

#include <string>
#include <vector>

namespace omni::calib {

struct VarianceComponent {
  std::string group;     // "corners ring 1" | "corners ring 2" | "lips"
  int count = 0;         // observations (corners) or edge points
  double ssr_px2 = 0;    // sum of squared residuals (px^2, unweighted)
  double redundancy = 0; // r_g: residual rows minus the group's share of the unknowns
  double sigma_px = 0;   // s_g = sqrt(SSR_g / r_g): per-axis noise of the group
  double correlation_factor = 1;  // tau (lips), 1 for corners
  double weight_sigma_px = 0;     // the sigma the group is weighted with: s_g sqrt(tau)
};

// One lip edge point's residual across its edge, with the edge it belongs to (the same physical
// edge in every image has one key) and its azimuth along it.
struct LipResidual {
  int edge_key = 0;
  double phi = 0;
  double across_px = 0;
};

// tau >= 1 by block averaging (see the file comment): residuals of each edge sorted by azimuth,
// non-overlapping blocks of L = 1, 2, 4, ... points (at least 16 blocks per edge), pooled over the
// edges; tau = max over L of L * var(block means) / var(points).
double LipCorrelationFactor(std::vector<LipResidual> residuals);

}  // namespace omni::calib
