#include "io/measured_profile.h"

#include <filesystem>
#include <stdexcept>

#include "io/profile_scan_file.h"
#include "model/rig_parameters.h"

namespace omni::io {

namespace {

using TermMatrix = Eigen::Matrix<double, kProfileTerms, kProfileTerms>;

std::string Quoted(const std::string& text) {
  std::string out = "\"";
  for (char ch : text) {
    if (ch == '"' || ch == '\\') out += '\\';
    out += ch;
  }
  return out + "\"";
}

std::string List(const double* values, int n) {
  std::string out = "[";
  for (int i = 0; i < n; ++i) out += (i ? ", " : "") + FormatDouble(values[i]);
  return out + "]";
}

// `profile_measured:` (MeasuredProfileText): the fit a calibrated model was calibrated with; the
// mirror's coefficients are its `profile:` map's (the calibration's values).
void ReadWrittenFit(const Reader& in, const YAML::Node& mirror_map, Mirror mirror, RigParams* rig) {
  const std::string mirror_path = mirror == Mirror::kOne ? "mirror1" : "mirror2";
  const std::string path = Join(mirror_path, "profile_measured");
  const YAML::Node map = in.Map(mirror_map, path, "profile_measured");
  if (!(mirror == Mirror::kOne ? rig->profile1 : rig->profile2).present) {
    in.Fail(Join(mirror_path, "profile"), "a profile map beside profile_measured (its coefficients)",
            "nothing (key missing)");
  }
  MeasuredProfile measured;
  measured.scan_file = in.String(map, path, "scan");
  measured.accuracy_mm = in.Positive(map, path, "accuracy_mm");
  ProfileFit& fit = measured.fit;
  fit.points = in.Integer(map, path, "points", 1);
  fit.piston_mm = in.Number(map, path, "piston_mm");
  fit.residual_pv_mm = in.Number(map, path, "residual_pv_mm");
  fit.residual_rms_mm = in.Number(map, path, "residual_rms_mm");
  const std::vector<std::string>& names = BlockParameterNames(kRigBlocks[ProfileBlock(mirror)].name);
  for (const std::string& term : in.Strings(map, path, "terms")) {
    int k = 0;
    while (k < kProfileTerms && names[k] != mirror_path + "." + term) ++k;
    if (k == kProfileTerms) in.Fail(Join(path, "terms"), "profile term names (sag_p1 ..)", Abbreviate(term));
    fit.measured[k] = true;
  }
  const std::vector<double> sag = in.Numbers(map, path, "sag");
  const std::vector<double> covariance = in.Numbers(map, path, "covariance");
  if (sag.size() != kProfileTerms) {
    in.Fail(Join(path, "sag"), "6 numbers (sag_p1 .. sag_sin2)", std::to_string(sag.size()));
  }
  if (covariance.size() != kProfileTerms * kProfileTerms) {
    in.Fail(Join(path, "covariance"), "36 numbers (6 x 6, row-major)",
            std::to_string(covariance.size()));
  }
  std::copy(sag.begin(), sag.end(), fit.coeffs.begin());
  fit.covariance = Eigen::Map<const Eigen::Matrix<double, kProfileTerms, kProfileTerms, Eigen::RowMajor>>(
      covariance.data());
  if (!fit.covariance.isApprox(fit.covariance.transpose(), 1e-9) ||
      fit.covariance.diagonal().minCoeff() < 0) {
    in.Fail(Join(path, "covariance"), "a symmetric covariance", "another matrix");
  }
  rig->measured_profile[MirrorIndex(mirror) - 1] = std::move(measured);
}

}  // namespace

std::string MeasuredProfileText(const RigParams& rig, Mirror mirror) {
  const std::optional<MeasuredProfile>& measured = rig.measured_profile[MirrorIndex(mirror) - 1];
  if (!measured) return "";
  const ProfileFit& fit = measured->fit;
  const std::vector<std::string>& names = BlockParameterNames(kRigBlocks[ProfileBlock(mirror)].name);
  std::string terms;
  for (int k = 0; k < kProfileTerms; ++k) {
    if (fit.measured[k]) terms += (terms.empty() ? "" : ", ") + names[k].substr(names[k].find('.') + 1);
  }
  const Eigen::Matrix<double, kProfileTerms, kProfileTerms, Eigen::RowMajor> c = fit.covariance;
  return "  profile_measured: {scan: " + Quoted(measured->scan_file) +
         ", accuracy_mm: " + FormatDouble(measured->accuracy_mm) +
         ", points: " + std::to_string(fit.points) + ", piston_mm: " + FormatDouble(fit.piston_mm) +
         ", residual_pv_mm: " + FormatDouble(fit.residual_pv_mm) +
         ", residual_rms_mm: " + FormatDouble(fit.residual_rms_mm) + ", terms: [" + terms +
         "],\n                     sag: " + List(fit.coeffs.data(), kProfileTerms) +
         ",\n                     covariance: " + List(c.data(), kProfileTerms * kProfileTerms) +
         "}  # the scan's fit it was calibrated with (its prior)\n";
}

void ReadMeasuredProfile(const Reader& in, const std::string& model_file,
                         const YAML::Node& mirror_map, Mirror mirror, const ProfileBounds& bounds,
                         RigParams* rig) {
  const std::string path = mirror == Mirror::kOne ? "mirror1" : "mirror2";
  const std::string key = Join(path, "profile_from");
  if (mirror_map["profile_measured"].IsDefined() && mirror_map["profile_from"].IsDefined()) {
    in.Fail(Join(path, "profile_measured"),
            "either profile_from (a scan to fit) or profile_measured (a fit written with a "
            "calibrated model)",
            "both");
  }
  if (mirror_map["profile_measured"].IsDefined()) {
    ReadWrittenFit(in, mirror_map, mirror, rig);
    return;
  }
  if (!mirror_map["profile_from"].IsDefined()) {
    for (const char* stray : {"profile_accuracy_mm", "profile_max_gap_mm"}) {
      if (mirror_map[stray].IsDefined()) {
        in.Fail(Join(path, stray), "only beside profile_from (a measured profile's scan)",
                Describe(mirror_map[stray]));
      }
    }
    return;
  }
  if (rig->kind == ModelKind::kIdeal) {
    in.Fail(key, "no measured profile because kind is ideal (an ideal rig has exact quadrics; "
                 "kind: noncentral with zero poses starts from the design)",
            "one");
  }
  const std::string scan_file = in.String(mirror_map, path, "profile_from");
  const double accuracy_mm = in.Positive(mirror_map, path, "profile_accuracy_mm");
  ProfileScanLimits limits;
  if (mirror_map["profile_max_gap_mm"].IsDefined()) {
    limits.max_gap_mm = in.Positive(mirror_map, path, "profile_max_gap_mm");
  }
  ProfileShape& shape = mirror == Mirror::kOne ? rig->profile1 : rig->profile2;
  auto& coeffs = mirror == Mirror::kOne ? rig->mirror1_profile : rig->mirror2_profile;
  const YAML::Node profile = mirror_map["profile"];
  if (IsMap(profile)) {
    for (const std::string& name : BlockParameterNames(kRigBlocks[ProfileBlock(mirror)].name)) {
      const std::string term = name.substr(name.find('.') + 1);
      if (profile[term].IsDefined()) {
        in.Fail(Join(Join(path, "profile"), term),
                "no coefficient beside profile_from (the scan's fit sets them; the profile map "
                "may give the radii and a ripple)",
                Describe(profile[term]));
      }
    }
  } else {
    shape = DefaultProfileShape(*rig, mirror);
  }
  // A radius inside mirror 2's hole or beyond the rim is not on the mirror.
  limits.rim_mm = rig->r_sys;
  limits.hole_mm = mirror == Mirror::kTwo ? rig->r_cam : 0;
  limits.max_sag_mm = bounds.max_sag_mm;
  namespace fs = std::filesystem;
  fs::path scan_path(scan_file);
  if (scan_path.is_relative()) scan_path = fs::path(model_file).parent_path() / scan_path;

  MeasuredProfile measured;
  measured.scan_file = scan_file;
  measured.accuracy_mm = accuracy_mm;
  measured.scan = ReadProfileScan(scan_path.string(), shape, limits);
  try {
    measured.fit = FitProfileToScan(measured.scan, shape, accuracy_mm);
  } catch (const std::invalid_argument& e) {
    throw InputError(scan_path.string() + ": " + e.what());
  }
  const ProfileExtent extent = MeasureProfile(measured.fit.coeffs, shape);
  if (!(extent.max_sag_mm <= bounds.max_sag_mm)) {
    in.Fail(key, "a fitted profile of at most " + FormatDouble(bounds.max_sag_mm) +
                     " mm over the profile's radii (a machining error; a larger one is another "
                     "mirror: a new design)",
            "a sag of " + FormatDouble(extent.max_sag_mm) + " mm");
  }
  if (!(extent.max_slope <= bounds.max_slope)) {
    in.Fail(key, "a fitted profile with slopes of at most " + FormatDouble(bounds.max_slope) +
                     " rad (a smooth correction)",
            "a slope of " + FormatDouble(extent.max_slope) + " rad");
  }
  coeffs = measured.fit.coeffs;
  shape.present = true;
  rig->measured_profile[MirrorIndex(mirror) - 1] = std::move(measured);
}

}  // namespace omni::io
