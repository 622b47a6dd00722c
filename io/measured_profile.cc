#include "io/measured_profile.h"

#include <filesystem>
#include <stdexcept>

#include "io/profile_scan_file.h"
#include "model/rig_parameters.h"

namespace omni::io {

void ReadMeasuredProfile(const Reader& in, const std::string& model_file,
                         const YAML::Node& mirror_map, Mirror mirror, const ProfileBounds& bounds,
                         RigParams* rig) {
  const std::string path = mirror == Mirror::kOne ? "mirror1" : "mirror2";
  const std::string key = Join(path, "profile_from");
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
