#include "design/tolerance_file.h"

#include "io/yaml_reader.h"

namespace omni::design {

// The shared YAML reader and its errors (io/yaml_reader.h).
using namespace omni::io;
namespace {

// A limit >= 0 under `name` (or `name`_deg for angles), -1 if absent.
double Limit(const Reader& in, const YAML::Node& map, const std::string& path, const char* name,
             bool angle) {
  const std::string deg = std::string(name) + "_deg";
  if (!map[name].IsDefined() && !(angle && map[deg].IsDefined())) return -1;
  const double value = angle ? in.Angle(map, path, name) : in.Number(map, path, name);
  if (value < 0) {
    in.Fail(Join(path, map[name].IsDefined() ? name : deg.c_str()), "expected a limit >= 0",
            FormatDouble(value));
  }
  return value;
}

}  // namespace

ToleranceFile ReadToleranceFile(const std::string& path) {
  const YAML::Node root = LoadYamlFile(path, "tolerance file");
  const Reader in(path);
  if (!IsMap(root)) in.Fail("format", "expected a YAML map starting with 'format:'", Describe(root));
  CheckFormat(in, root, "omnistereo-tolerances/", 1);
  ToleranceFile file;
  bool any = false;
  for (int m = 0; m < 2; ++m) {
    const char* body = m == 0 ? "mirror1" : "mirror2";
    if (!root[body].IsDefined()) continue;
    const YAML::Node map = in.Map(root, body, body);
    BodyTolerance& tol = file.spec.mirror[m];
    tol.decentre_mm = Limit(in, map, body, "decentre", false);
    tol.tilt_rad = Limit(in, map, body, "tilt", true);
    tol.axial_mm = Limit(in, map, body, "axial", false);
    tol.profile_pv_mm = Limit(in, map, body, "profile_pv", false);
    any = any || tol.decentre_mm >= 0 || tol.tilt_rad >= 0 || tol.axial_mm >= 0 ||
          tol.profile_pv_mm >= 0;
  }
  if (root["reflex"].IsDefined()) {
    const YAML::Node map = in.Map(root, "reflex", "reflex");
    file.spec.reflex_tilt_rad = Limit(in, map, "reflex", "tilt", true);
    file.spec.reflex_dz_mm = Limit(in, map, "reflex", "dz", false);
    any = any || file.spec.reflex_tilt_rad >= 0 || file.spec.reflex_dz_mm >= 0;
  }
  if (!any) {
    in.Fail("mirror1", "expected at least one limit (mirror1/mirror2: decentre, tilt_deg, axial, profile_pv; "
            "reflex: tilt_deg, dz)", "none");
  }
  if (root["confidence_sigmas"].IsDefined()) {
    file.spec.confidence_sigmas = in.Positive(root, "", "confidence_sigmas");
  }
  if (root["simulate"].IsDefined()) {
    const YAML::Node map = in.Map(root, "simulate", "simulate");
    if (map["samples"].IsDefined()) file.simulate_samples = in.Integer(map, "simulate", "samples", 0);
    if (map["range"].IsDefined()) file.simulate_range_mm = in.Positive(map, "simulate", "range");
    if (map["seed"].IsDefined()) file.simulate_seed = in.Integer(map, "simulate", "seed", 0);
  }
  return file;
}

}  // namespace omni::design
