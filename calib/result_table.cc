// The table printed after a calibration (calibrate.h ResultTable).
#include "calib/calibrate.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "model/rig_parameters.h"

namespace omni::calib {

namespace {

// Value and unit of a parameter in assembly units (deg for tilts).
double Display(const std::string& name, double value, const char** unit) {
  const RigParameter* p = FindRigParameter(name);
  *unit = DisplayUnit(*p);
  return DisplayValue(*p, value);
}

double TruthOf(const RigParams& rig, const std::string& name) {
  const double* value = ParameterOf(rig, name);
  return value ? *value : NAN;
}

}  // namespace

std::string ResultTable(const CalibrationResult& result, const RigParams* truth) {
  std::ostringstream out;
  char line[256];
  // With considered parameters, `sigma` includes their share and `noise` is the pixel noise's.
  const bool with_noise =
      !result.uncertainty.considered.empty() &&
      result.uncertainty.noise_sigma.size() == static_cast<long>(result.estimate.names.size());
  std::snprintf(line, sizeof(line), "%-12s %14s %12s %-4s", "parameter", "value", "sigma", "unit");
  out << line;
  if (with_noise) out << "        noise";
  if (truth) out << "         truth   (value-truth)/sigma";
  out << "\n";
  for (size_t i = 0; i < result.estimate.names.size(); ++i) {
    const char* unit = "";
    const double value = Display(result.estimate.names[i], result.estimate.values(i), &unit);
    const double sigma = Display(result.estimate.names[i], result.uncertainty.sigma(i), &unit);
    std::snprintf(line, sizeof(line), "%-12s %14.6f %12.6f %-4s", result.estimate.names[i].c_str(),
                  value, sigma, unit);
    out << line;
    if (with_noise) {
      std::snprintf(line, sizeof(line), " %12.6f",
                    Display(result.estimate.names[i], result.uncertainty.noise_sigma(i), &unit));
      out << line;
    }
    if (truth) {
      const double t =
          Display(result.estimate.names[i], TruthOf(*truth, result.estimate.names[i]), &unit);
      std::snprintf(line, sizeof(line), " %14.6f %8.2f", t, sigma > 0 ? (value - t) / sigma : 0.0);
      out << line;
    }
    out << "\n";
  }
  for (const auto& c : result.uncertainty.considered) {
    // A profile term held for want of evidence (profile: auto): its tolerance as narrowed by
    // the data is what the sigmas carry.
    const RigParameter* p = FindRigParameter(c.name);
    bool updated = false;
    for (int m = 0; m < 2 && p; ++m) {
      updated |= BlockOf(*p) == ProfileBlock(m == 0 ? Mirror::kOne : Mirror::kTwo) &&
                 result.residuals.profile[m].updated;
    }
    std::snprintf(line, sizeof(line),
                  "%s: held at %.6g; its uncertainty (sigma %.3g%s) is carried into the sigmas\n",
                  c.name.c_str(), c.value, c.sigma,
                  updated ? ", narrowed by what the data tell of the profile" : "");
    out << line;
  }
  for (const auto& u : result.uncertainty.unobservable) {
    out << u.name << ": not determined by this session (unobservable); needs " << u.hint << "\n";
  }
  for (const auto& note : result.solve.notes) out << note << "\n";
  if (result.estimate.rig.Single()) {  // one mirror: its RMS is the line's
    std::snprintf(line, sizeof(line),
                  "residuals: rms %.4f px over %d observations, %zu left out, weighted variance "
                  "factor %.4g\n",
                  result.residuals.rms_px, result.residuals.n_observations,
                  result.residuals.rejected.size(), result.uncertainty.variance_factor);
  } else {
    std::snprintf(line, sizeof(line),
                  "residuals: rms %.4f px (mirror 1: %.4f, mirror 2: %.4f) over %d observations, "
                  "%zu left out, weighted variance factor %.4g\n",
                  result.residuals.rms_px, result.residuals.per_mirror_rms_px[0],
                  result.residuals.per_mirror_rms_px[1], result.residuals.n_observations,
                  result.residuals.rejected.size(), result.uncertainty.variance_factor);
  }
  out << line;
  if (result.residuals.n_lip_points > 0 || result.residuals.n_lip_rejected > 0) {
    std::snprintf(line, sizeof(line),
                  "lips: rms %.4f px across the edge over %d edge points (in the solve as %d "
                  "normal points: their means over the images per %.2f deg of azimuth per edge), "
                  "%d left out\n",
                  result.residuals.lip_rms_px, result.residuals.n_lip_points,
                  result.residuals.n_lip_normal_points, kLipSpacingDeg,
                  result.residuals.n_lip_rejected);
    out << line;
  }
  for (const auto& c : result.uncertainty.variance_components) {
    std::snprintf(line, sizeof(line),
                  "noise %-15s s = %.4f px per axis over %d (redundancy %.0f)%s, weighted as "
                  "%.4f px\n",
                  c.group.c_str(), c.sigma_px, c.count, c.redundancy,
                  c.correlation_factor > 1
                      ? (", correlation factor " + std::to_string(c.correlation_factor).substr(0, 6)).c_str()
                      : "",
                  c.weight_sigma_px);
    out << line;
  }
  return out.str();
}

}  // namespace omni::calib
