// Each mirror's profile in the calibration: held and considered, or freed with a
// manufacturing-tolerance prior where the corners cover the radii it acts on; and the corners'
// radial residual pattern along each mirror's radius, which shows a profile the model lacks.
#include <algorithm>

#include "calib/calibration_steps.h"
#include "calib/chi2_quantile.h"
#include "calib/profile_comparison.h"

namespace omni::calib {
namespace {

// The radii a mirror's corners reach are split into kProfileBands bands of equal width in r^2
// (equal steps of the Legendre variable w); a band with kMinCornersPerBand corners is covered.
// Four Legendre terms need the range's both ends and its middle: kMinBandsToFree of the bands.
constexpr int kProfileBands = 6;
constexpr int kMinCornersPerBand = 10;
constexpr int kMinBandsToFree = 5;
// A pattern whose band means sit this many standard errors from zero (chi^2 per band) is a
// smooth error the model lacks.
constexpr double kPatternChi2 = 4.0;

const ProfileShape& ShapeOf(const RigParams& rig, int m) { return m == 0 ? rig.profile1 : rig.profile2; }

}  // namespace

ProfileState SetUpProfiles(const RigParams& start, const CalibrationOptions& options,
                           RigParams* rig, Refinement* refined) {
  ProfileState profiles;
  refined->profile_sigma_mm = options.profile_sigma_mm;
  const std::string& mode = options.profile;
  // The mode and the tolerance are valid (CalibrationOptions::Check, in Calibrate).
  for (int m = 0; m < start.Paths(); ++m) {
    ProfileShape& shape = m == 0 ? rig->profile1 : rig->profile2;
    auto& coeffs = m == 0 ? rig->mirror1_profile : rig->mirror2_profile;
    profiles.given[m] = (m == 0 ? start.profile1 : start.profile2).present;
    refined->profile_mean[m] = coeffs;
    // "off": the start's profile (if any) stays as it is, neither refined nor considered.
    if (mode == "off") continue;
    if (!shape.present) {
      shape = DefaultProfileShape(*rig, m == 0 ? Mirror::kOne : Mirror::kTwo);
      coeffs.fill(0);
      refined->profile_mean[m] = coeffs;
    }
    // A measured profile's prior is its fit (the coefficients the model file set from it).
    const std::optional<MeasuredProfile>& measured = start.measured_profile[m];
    if (measured) {
      // The fit, not the start's coefficients: a calibrated model carries its calibrated values
      // beside the fit it was calibrated with (solved again, the prior is the same).
      refined->profile_mean[m] = measured->fit.coeffs;
      refined->profile_covariance[m] =
          MeasuredPriorCovariance(measured->fit, options.profile_sigma_mm);
    }
    // Held through the robust stages in every mode (a fine correction, freed once the rig is
    // aligned: DecideProfiles), considered with its prior's sigmas.
    refined->groups.set(kProfileGroups[m]);
    refined->profile_free[m] = false;
    const std::vector<std::string>& names = BlockParameterNames(kRigBlocks[kProfileGroups[m]].name);
    for (int k = 0; k < kProfileTerms; ++k) {
      refined->considered_sigma.emplace(
          names[k], measured ? std::sqrt((*refined->profile_covariance[m])(k, k))
                             : options.profile_sigma_mm);
    }
  }
  return profiles;
}

std::vector<RadialResidualBin> RadialPattern(const RigState& rig,
                                             const ObservationSet& observations,
                                             const ProfileState& profiles, int mirror,
                                             double* chi2) {
  // The bands span the radii the corners reach (FitProfileRadiiToCorners), else the profile's.
  const ProfileShape& shape = ShapeOf(rig.params, mirror - 1);
  const double(&reach)[2] = profiles.corner_radii[mirror - 1];
  const double lo = reach[1] > 0 ? reach[0] : shape.r_min;
  const double hi = reach[1] > 0 ? reach[1] : shape.r_max;
  const double r2_lo = lo * lo, r2_hi = hi * hi;
  std::vector<RadialResidualBin> bins(kProfileBands);
  std::vector<double> sum(kProfileBands, 0), sum2(kProfileBands, 0);
  for (int b = 0; b < kProfileBands; ++b) {
    bins[b].r_lo = std::sqrt(r2_lo + (r2_hi - r2_lo) * b / kProfileBands);
    bins[b].r_hi = std::sqrt(r2_lo + (r2_hi - r2_lo) * (b + 1) / kProfileBands);
  }
  const Eigen::Vector2d centre(rig.params.camera[kCx], rig.params.camera[kCy]);
  for (const auto& o : observations.corners) {
    if (o.rejected || o.mirror != mirror) continue;
    Eigen::Vector2d px;
    double r = 0;
    if (!ReprojectOnMirror(rig, observations, o, &px, &r)) continue;
    const double r2 = r * r;
    const int b = static_cast<int>(std::floor((r2 - r2_lo) / (r2_hi - r2_lo) * kProfileBands));
    if (b < 0 || b >= kProfileBands) continue;
    const double radial = (px - o.pixel).dot((px - centre).normalized());
    sum[b] += radial;
    sum2[b] += radial * radial;
    ++bins[b].count;
  }
  *chi2 = 0;
  int used = 0;
  for (int b = 0; b < kProfileBands; ++b) {
    const int n = bins[b].count;
    if (n < 2) continue;
    bins[b].mean_px = sum[b] / n;
    const double var = std::max(0.0, (sum2[b] - n * bins[b].mean_px * bins[b].mean_px) / (n - 1));
    bins[b].sem_px = std::sqrt(var / n);
    if (n >= kMinCornersPerBand && bins[b].sem_px > 0) {
      *chi2 += bins[b].mean_px * bins[b].mean_px / (bins[b].sem_px * bins[b].sem_px);
      ++used;
    }
  }
  if (used > 0) *chi2 /= used;
  return bins;
}

namespace {

// A profile's radii set to those mirror m's corners reach (the rig's fixed data made anew with
// them: the costs are rebuilt with it when next used, CostCache).
void FitProfileRadiiToCorners(int m, const ObservationSet& observations, RigState* rig,
                              ProfileState* profiles) {
  double r_lo = HUGE_VAL, r_hi = 0;
  for (const auto& o : observations.corners) {
    if (o.rejected || o.mirror != m + 1) continue;
    Eigen::Vector2d px;
    double r = 0;
    if (!ReprojectOnMirror(*rig, observations, o, &px, &r)) continue;
    r_lo = std::min(r_lo, r);
    r_hi = std::max(r_hi, r);
  }
  if (!(r_hi > r_lo + 1.0)) return;  // too few corners to say: the default radii stay
  profiles->corner_radii[m][0] = r_lo;
  profiles->corner_radii[m][1] = r_hi;
  if (profiles->given[m]) return;  // a given profile keeps its radii
  // Out to the rim always: the lips' paths reflect there, and the Legendre terms grow fast
  // beyond w = 1 (a profile fitted to 35.5 mm gave 14% range errors at 2 m through the rim).
  ProfileShape shape = ShapeOf(rig->params, m);
  shape.r_min = std::max(0.0, std::min(r_lo, rig->params.r_sys - 1.0));
  shape.r_max = rig->params.r_sys;
  (m == 0 ? rig->params.profile1 : rig->params.profile2) = shape;
  for (std::shared_ptr<const RigFixed>* f : {&rig->fixed, &rig->corner_bounds[0],
                                              &rig->corner_bounds[1], &rig->lip_bounds[0],
                                              &rig->lip_bounds[1]}) {
    auto changed = std::make_shared<RigFixed>(**f);
    (m == 0 ? changed->profile1 : changed->profile2) = shape;
    *f = std::move(changed);
  }
}

}  // namespace

bool DecideProfiles(const ObservationSet& observations, const CalibrationOptions& options,
                    RigState* rig, ProfileState* profiles, Refinement* refined,
                    CalibrationResult* result) {
  if (options.profile == "off") return false;
  bool freed = false;
  for (int m = 0; m < rig->params.Paths(); ++m) {
    // A profile the start did not have is laid from the smallest radius the corners reach on the
    // mirror out to its rim (its Legendre variable spans them; below them it would only
    // extrapolate). Its coefficients are zero, so the model is unchanged.
    FitProfileRadiiToCorners(m, observations, rig, profiles);
    ProfileDecision& d = result->residuals.profile[m];
    const double(&reach)[2] = profiles->corner_radii[m];
    d.r_min = reach[1] > 0 ? reach[0] : ShapeOf(rig->params, m).r_min;
    d.r_max = reach[1] > 0 ? reach[1] : ShapeOf(rig->params, m).r_max;
    d.pattern_before = RadialPattern(*rig, observations, *profiles, m + 1, &d.pattern_chi2_before);
    d.bins = kProfileBands;
    d.bins_covered = 0;
    for (const auto& b : d.pattern_before) d.bins_covered += b.count >= kMinCornersPerBand;
    const bool asked = options.profile == "free" ||
                       std::count(options.estimate.begin(), options.estimate.end(),
                                  kRigBlocks[kProfileGroups[m]].name);
    // A measured profile is freed in auto whatever the coverage: its prior holds the terms the
    // corners do not reach.
    d.measured = refined->profile_covariance[m].has_value();
    if (d.measured) {
      d.prior_mean = refined->profile_mean[m];
      d.prior_covariance = *refined->profile_covariance[m];
    }
    // auto frees an unmeasured profile on evidence: the corners cover its radii AND their radial
    // residuals with the profile held show a pattern beyond chance (an exact conic leaves none,
    // and freeing it then only opens the profile-axial valley: on exact mirrors the points in
    // mirror 1's body at 1 m came out 0.029 -> 0.055 px). A profile error that leaves no pattern
    // hides in the axial positions and the focal length, where the considered tolerance carries
    // it into their sigmas.
    int used = 0;
    for (const auto& b : d.pattern_before) used += b.count >= kMinCornersPerBand && b.sem_px > 0;
    d.evidence_threshold = used > 0 ? Chi2Quantile99(used) / used : 0;
    d.evidence = used > 0 && d.pattern_chi2_before > d.evidence_threshold;
    bool& free = refined->profile_free[m];
    if (!free && (asked || (options.profile == "auto" &&
                            (d.measured || (d.bins_covered >= kMinBandsToFree && d.evidence))))) {
      free = true;
      freed = true;
    }
    d.freed = free;
    // Held by auto for want of evidence: the data bound the profile's components that they tell
    // from the refined parameters, so its considered tolerance is updated by them (the
    // covariance the refined parameters would have with it freed under the tolerance, the
    // estimate kept at the held profile's precision); along the components they cannot tell (the
    // power term against the axial positions and the focal length) the tolerance stays whole.
    refined->profile_updated[m] = options.profile == "auto" && !free && !d.measured && !d.evidence;
    d.updated = refined->profile_updated[m];
  }
  if (freed) {
    Progress(options,
             std::string("profiles freed where the corners cover the mirror's radii and show a "
                         "radial pattern: mirror 1 ") +
                 (refined->profile_free[0] ? "yes" : "no") +
                 (rig->params.Single()
                      ? std::string()
                      : std::string(", mirror 2 ") + (refined->profile_free[1] ? "yes" : "no")));
  }
  return freed;
}

namespace {

// A measured profile's note: the scan and its fit, the prior, and the calibrated profile against
// the measured one (their largest difference over the radii and azimuths, in sigmas of it).
std::string MeasuredProfileNote(int mirror, const MeasuredProfile& measured,
                                const ProfileDecision& d, const RigParams& rig,
                                const CalibrationResult& result) {
  const ProfileFit& fit = measured.fit;
  double lo = HUGE_VAL, hi = 0;
  for (int k = 0; k < kProfileTerms; ++k) {
    if (!fit.measured[k]) continue;
    lo = std::min(lo, std::sqrt(d.prior_covariance(k, k)));
    hi = std::max(hi, std::sqrt(d.prior_covariance(k, k)));
  }
  double worst_um = 0, worst_sigmas = 0;
  for (int a = 0; a < 8; ++a) {
    for (const ProfileSample& s : CompareWithMeasured(rig, result, mirror, M_PI * a / 8, 41)) {
      worst_um = std::max(worst_um, 1000 * std::abs(s.difference_mm));
      if (s.sigma_mm > 0) worst_sigmas = std::max(worst_sigmas, std::abs(s.difference_mm) / s.sigma_mm);
    }
  }
  char buf[1024];
  std::snprintf(
      buf, sizeof(buf),
      "mirror %d's profile measured (%s: %d points inside its radii, stated accuracy %.3g um; the "
      "fit's residual %.3g um PV, %.3g um RMS, the form its terms cannot take) and %s with the fit "
      "as prior (sigmas %.3g-%.3g um per measured term%s); calibrated minus measured: at most "
      "%.3g um over the radii, %.2g sigma of their difference%s; radial residual pattern chi^2 "
      "per band %.2g before, %.2g after",
      mirror, measured.scan_file.c_str(), fit.points, 1000 * measured.accuracy_mm,
      1000 * fit.residual_pv_mm, 1000 * fit.residual_rms_mm,
      d.freed ? "refined" : "held, considered", 1000 * lo, 1000 * hi,
      fit.measured[4] ? "" : "; the astigmatism, which one or two scan azimuths cannot tell, at the machining tolerance",
      worst_um, worst_sigmas,
      worst_sigmas > 3 ? ": the photos disagree with the scan (a mirror other than the one scanned, "
                         "a scan of another reference, or an accuracy stated too small)"
                       : "",
      d.pattern_chi2_before, d.pattern_chi2_after);
  return buf;
}

}  // namespace

namespace {

// Profiles held for want of evidence: what their updated tolerance adds to the sigmas, said for
// the axial positions and the focal length, and any other parameter whose sigma it grows by half
// or more:
// "mirror1.tz 0.81 mm (0.22 without it), ...". Empty when none is held so.
std::string HeldProfilesShare(const CalibrationResult& result) {
  const CalibrationUncertainty& u = result.uncertainty;
  const int n = static_cast<int>(result.estimate.names.size());
  if (u.considered_sensitivity.rows() != n ||
      u.considered_sensitivity.cols() != u.considered_column_sigma.size() ||
      u.considered_column_names.size() != static_cast<size_t>(u.considered_column_sigma.size())) {
    return "";
  }
  std::string out;
  for (int i = 0; i < n; ++i) {
    double share = 0;
    for (int c = 0; c < u.considered_column_sigma.size(); ++c) {
      if (u.considered_column_names[c].rfind(kHeldProfileColumn, 0) != 0) continue;
      const double s = u.considered_sensitivity(i, c) * u.considered_column_sigma(c);
      share += s * s;
    }
    const double total = u.sigma(i) * u.sigma(i);
    const RigParameter* p = FindRigParameter(result.estimate.names[i]);
    if (!p || !(share > 0)) continue;
    // The axial positions always (what the held profile leaves open of them), others where it
    // grows the sigma by half or more.
    if (p->role != SolveRole::kAxialScale && total < 2.25 * (total - share)) continue;
    char item[160];
    const std::string unit = *DisplayUnit(*p) ? std::string(" ") + DisplayUnit(*p) : "";
    std::snprintf(item, sizeof(item), "%s%s sigma %.3g%s (%.3g without it)",
                  out.empty() ? "" : ", ", result.estimate.names[i].c_str(),
                  DisplayValue(*p, u.sigma(i)), unit.c_str(),
                  DisplayValue(*p, std::sqrt(std::max(total - share, 0.0))));
    out += item;
  }
  return out;
}

}  // namespace

void FinishProfiles(const ObservationSet& observations, const ProfileState& profiles,
                    const CalibrationOptions& options, RigState* rig, CalibrationResult* result) {
  if (options.profile == "off") return;
  // Held for want of evidence: the sigmas carry what the held profile leaves open, said.
  if (const std::string share = HeldProfilesShare(*result); !share.empty()) {
    result->solve.notes.push_back(
        "the held profiles' tolerance, updated by what this session tells of them, is in the "
        "sigmas (the estimate is the held profile's): the data bound the profile components "
        "they tell from the rig's parameters; the power term, which bends the rays as an axial "
        "shift or a focal length does, keeps its whole tolerance: " + share +
        "; a measured profile (profile_from: its scan in the starting model) would narrow them");
  }
  // What the profiles' tolerance leaves open, said where the table names it unobservable.
  std::string traded;
  for (const auto& u : result->uncertainty.unobservable) {
    const RigParameter* p = FindRigParameter(u.name);
    if (p && p->role == SolveRole::kAxialScale) traded += (traded.empty() ? "" : ", ") + u.name;
  }
  if (!traded.empty()) {
    char buf[768];
    std::snprintf(buf, sizeof(buf),
                  "%s: the mirrors' profiles trade with them (a profile's power term bends the "
                  "rays as an axial shift or a focal length does, and targets and lips fit either "
                  "at the noise), so the profiles' priors (the machining tolerance, "
                  "profile_sigma_mm %.3g mm, or a measured profile's fit) leave them open: "
                  "projections stay determined; a measured mirror (profile_from: its scan in the "
                  "starting model) would narrow them",
                  traded.c_str(), options.profile_sigma_mm);
    result->solve.notes.push_back(buf);
  }
  for (int m = 0; m < rig->params.Paths(); ++m) {
    ProfileDecision& d = result->residuals.profile[m];
    d.pattern_after = RadialPattern(*rig, observations, profiles, m + 1, &d.pattern_chi2_after);
    char buf[640];
    const double um = 1000 * options.profile_sigma_mm;
    if (const std::optional<MeasuredProfile>& measured = rig->params.measured_profile[m]) {
      result->solve.notes.push_back(MeasuredProfileNote(m + 1, *measured, d, rig->params, *result));
      continue;  // a measured profile is given: never dropped
    }
    if (d.freed) {
      std::snprintf(buf, sizeof(buf),
                    "mirror %d's profile refined (prior sigma %.3g um per term): the corners cover "
                    "%d of %d bands of the radii they reach on it, %.1f-%.1f mm; their radial residual pattern along "
                    "the mirror's radius, chi^2 per band %.2g before, %.2g after%s",
                    m + 1, um, d.bins_covered, d.bins, d.r_min, d.r_max, d.pattern_chi2_before,
                    d.pattern_chi2_after,
                    d.pattern_chi2_after > kPatternChi2
                        ? ": a pattern the profile's four radial terms cannot take remains "
                          "(finer than them, e.g. turning marks, or another mirror's error "
                          "passed on through the shared parameters); it bounds what this model "
                          "can reach"
                        : "");
    } else if (d.updated && d.bins_covered >= kMinBandsToFree) {
      std::snprintf(buf, sizeof(buf),
                    "mirror %d's profile held at the %s and considered (sigma %.3g um per term, "
                    "the machining tolerance, updated by what the session tells of it): the "
                    "corners cover %d of %d bands of the radii they reach on it, %.1f-%.1f mm, but "
                    "show no radial pattern with it held (chi^2 per band %.2g, the 1%% level "
                    "%.2g): the conic fits them, and freeing the profile would only trade with "
                    "the axial positions (session profile: free frees it)",
                    m + 1, profiles.given[m] ? "starting model's profile" : "conic", um,
                    d.bins_covered, d.bins, d.r_min, d.r_max, d.pattern_chi2_before,
                    d.evidence_threshold);
    } else {
      std::snprintf(buf, sizeof(buf),
                    "mirror %d's profile held at the %s and considered (sigma %.3g um per term, "
                    "the machining tolerance%s): the corners fill %d of %d bands of the radii they reach on it, "
                    "%.1f-%.1f mm (%d needed to refine it: targets low and high in the ring); "
                    "radial residual pattern chi^2 per band %.2g%s",
                    m + 1, profiles.given[m] ? "starting model's profile" : "conic", um,
                    d.updated ? ", updated by what the session tells of it" : "",
                    d.bins_covered, d.bins, d.r_min, d.r_max, kMinBandsToFree,
                    d.pattern_chi2_after,
                    d.pattern_chi2_after > kPatternChi2
                        ? ": a smooth error along the radius that the model lacks; refine the "
                          "profile (session profile: free) with targets over the ring's whole "
                          "radius"
                        : "");
    }
    result->solve.notes.push_back(buf);
    // A held zero profile is no profile: the model file stays an exact-quadric one.
    if (!d.freed && !profiles.given[m]) {
      (m == 0 ? rig->params.profile1 : rig->params.profile2).present = false;
    }
  }
}

}  // namespace omni::calib
