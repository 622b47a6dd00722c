#include "health/check_file.h"

#include <sstream>

#include "io/file_util.h"

namespace omni::health {

std::string CheckResultYaml(const CheckResult& r, const std::string& model) {
  std::ostringstream y;
  y << "format: omnistereo-check/1\n"
    << "model: " << model << "\n"
    << "verdict: " << VerdictName(r.verdict) << "\n"
    << "reason: \"" << r.reason << "\"\n"
    << "named_group: " << (r.named_group.empty() ? "null" : r.named_group) << "\n"
    << "runner_up: " << (r.runner_up.empty() ? "null" : r.runner_up) << "\n"
    << "images: " << r.n_images << "\n"
    << "matches: " << r.n_matches << "\n"
    << "lip_points: " << r.n_lip_points << "\n"
    << "gap_rms_px: " << io::FormatDouble(r.gap_rms_px) << "\n"
    << "lip_rms_px: " << io::FormatDouble(r.lip_rms_px) << "\n"
    << "covered_azimuth_sectors: " << r.covered_azimuth_bins << "\n"
    << "referenced_lip_bins: " << r.referenced_lip_bins
    << "  # lip bins measured from the calibration photos' own\n"
    << "chi2: " << io::FormatDouble(r.chi2) << "\n"
    << "dof: " << r.dof << "\n"
    << "p_value: " << io::FormatDouble(r.p_value) << "\n";
  if (r.rim_scatter_factor > 0) {
    y << "rim_scatter_factor: " << io::FormatDouble(r.rim_scatter_factor)
      << "  # a single mirror: its rim bins' scatter about the move's harmonics per dof\n";
  }
  y << "model_covariance: " << (r.model_covariance ? "true" : "false") << "\n"
    << "groups:\n";
  for (const GroupFit& g : r.groups) {
    y << "  - {group: " << g.group << ", chi2: " << io::FormatDouble(g.chi2) << ", dof: " << g.dof
      << ", p_value: " << io::FormatDouble(g.p_value) << ", amounts: {";
    for (size_t k = 0; k < g.names.size(); ++k) {
      y << (k ? ", " : "") << g.names[k] << ": [" << io::FormatDouble(g.amounts[k]) << ", "
        << io::FormatDouble(g.sigma[k]) << "]";
    }
    y << "}}\n";
  }
  y << "bins:  # kind, azimuth_deg, count, mean_px, standard_error_px\n";
  for (const ResidualBin& b : r.bins) {
    y << "  - [\"" << b.kind << "\", " << b.azimuth_deg << ", " << b.count << ", "
      << io::FormatDouble(b.mean) << ", " << io::FormatDouble(b.standard_error) << "]\n";
  }
  return y.str();
}

}  // namespace omni::health
