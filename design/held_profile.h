// The tolerance check of a mirror profile the calibration held (not refined): its peak-to-valley
// is the held coefficients', and what bounds the true one is what is known of the terms (a scan's
// fit: rig.measured_profile; the session's data: calibration.held_profiles' data_information) or
// only assumed (the machining tolerance the calibration considered it with). A verdict rests on
// the known part alone: the assumed tolerance is what a machinist promised, and checking a limit
// against it restates the promise (a mirror machined 2.5 tolerance-sigmas off would pass).
#pragma once

#include <array>
#include <string>

#include <Eigen/Core>

#include "design/tolerance.h"
#include "model/rig_params.h"

namespace omni::design {

using ProfileMatrix = Eigen::Matrix<double, kProfileTerms, kProfileTerms>;

// Bounds at probability p of the peak-to-valley over `shape`'s radii and azimuths of the profile
// `coeffs` + dc, dc ~ N(0, information^-1) (mm, 1/mm^2): above, its p quantile over `draws` Monte
// Carlo draws (a maximum over the surface: not Gaussian, never below 0); below, the held
// profile's peak-to-valley minus z_p sigma of the sag difference between its own extremes (a
// lower bound whatever the profile, and <= 0 at the exact conic: no draw's spread calls an
// exact mirror beyond a small limit).
// `bounded` false when the information leaves a direction of the terms with a sigma beyond
// the profile's bound on the sag (kUnboundedSigmaMm): nothing is said of it there.
struct PvInterval {
  bool bounded = false;
  double lower = 0, upper = 0;  // mm
};
constexpr double kUnboundedSigmaMm = 0.1;
PvInterval PeakToValleyInterval(const ProfileShape& shape,
                                const std::array<double, kProfileTerms>& coeffs,
                                const ProfileMatrix& information, double p, int draws = 20000,
                                unsigned seed = 1);

// What is known of mirror m's (0 or 1) held profile: the information the scan's fit and the data
// give its terms (`measured`, naming `measured_from`), and with the assumed machining tolerance
// added (`assumed`, of `tolerance_mm` per term). `recorded` false: the model says nothing of it
// (profile: off, or a model from before held profiles were recorded) and no scan is given.
struct HeldProfileKnowledge {
  bool recorded = false;
  ProfileMatrix measured = ProfileMatrix::Zero(), assumed = ProfileMatrix::Zero();
  std::string measured_from;  // "the scan", "the data", "the scan and the data", or ""
  double tolerance_mm = 0;    // the assumed per-term sigma (the largest), 0 if none
};
HeldProfileKnowledge KnowledgeOfHeldProfile(const RigParams& rig, int m);

// Decides `check` (a held profile's, its value and limit set) at k sigma (one-sided probability
// Phi(k) for each side): PASS when the known part's upper quantile is within the limit, FAIL
// when its lower one is beyond it, else UNDECIDED; the note says from what and, for UNDECIDED,
// why (the limit within the bound; nothing measured bounds it, and whether the assumed tolerance
// alone would decide). The sigma shown is (upper - value) / k of the known part (none when
// nothing measured bounds it).
void DecideHeldProfile(const RigParams& rig, int m, double k, ToleranceCheck* check);

}  // namespace omni::design
