#include "design/tolerance_file.h"

#include <algorithm>
#include <string>
#include <vector>

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

// The keys a part's map may hold, and refuses others (a misspelt limit would go unchecked).
void CheckKeys(const Reader& in, const YAML::Node& map, const std::string& part,
               const std::vector<std::string>& allowed) {
  for (const auto& item : map) {
    const std::string key = item.first.Scalar();
    if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
    std::string choices;
    for (const std::string& a : allowed) choices += (choices.empty() ? "" : ", ") + a;
    in.Fail(Join(part, key.c_str()), "expected one of " + choices, "an unknown key");
  }
}

// A part toleranced in both frames at once: the first key of each frame found in `map` (or in
// `other`, the map that holds the same part's other frame), refused naming both.
void CheckOneFrame(const Reader& in, const YAML::Node& camera_map, const std::string& camera_part,
                   const std::vector<std::string>& camera_keys, const YAML::Node& body_map,
                   const std::string& body_part, const std::vector<std::string>& body_keys) {
  auto first = [](const YAML::Node& map, const std::vector<std::string>& keys) -> std::string {
    if (!map.IsDefined() || !map.IsMap()) return "";
    for (const std::string& k : keys) {
      if (map[k].IsDefined()) return k;
    }
    return "";
  };
  const std::string camera_key = first(camera_map, camera_keys);
  const std::string body_key = first(body_map, body_keys);
  if (camera_key.empty() || body_key.empty()) return;
  in.Fail(Join(body_part, body_key.c_str()),
          "expected the part toleranced in one frame (against mirror 1's axis here, or against "
          "the camera as " + Join(camera_part, camera_key.c_str()) + " does), not both",
          "both");
}

}  // namespace

ToleranceFile ReadToleranceFile(const std::string& path) {
  const YAML::Node root = LoadYamlFile(path, "tolerance file");
  const Reader in(path);
  if (!IsMap(root)) in.Fail("format", "expected a YAML map starting with 'format:'", Describe(root));
  CheckFormat(in, root, "omnistereo-tolerances/", 1);
  ToleranceFile file;
  bool any = false;
  for (const char* part : {"mirror1", "mirror2", "reflex", "camera"}) {
    if (root[part].IsDefined()) in.Map(root, part, part);
  }
  const std::vector<std::string> pose_keys = {"decentre", "tilt", "tilt_deg", "axial"};
  if (root["mirror1"].IsDefined()) {
    CheckKeys(in, root["mirror1"], "mirror1",
              {"decentre", "tilt", "tilt_deg", "axial", "profile_pv"});
  }
  if (root["mirror2"].IsDefined()) {
    CheckKeys(in, root["mirror2"], "mirror2",
              {"decentre", "tilt", "tilt_deg", "axial", "profile_pv", "decentre_to_mirror1",
               "tilt_to_mirror1", "tilt_to_mirror1_deg", "spacing"});
    CheckOneFrame(in, root["mirror2"], "mirror2", pose_keys, root["mirror2"], "mirror2",
                  {"decentre_to_mirror1", "tilt_to_mirror1", "tilt_to_mirror1_deg", "spacing"});
  }
  if (root["reflex"].IsDefined()) CheckKeys(in, root["reflex"], "reflex", {"tilt", "tilt_deg", "dz"});
  if (root["camera"].IsDefined()) {
    CheckKeys(in, root["camera"], "camera",
              {"decentre_to_axis", "tilt_to_axis", "tilt_to_axis_deg"});
    // Mirror 1's pose in C is the camera against mirror 1 seen from the camera.
    CheckOneFrame(in, root["mirror1"], "mirror1", pose_keys, root["camera"], "camera",
                  {"decentre_to_axis", "tilt_to_axis", "tilt_to_axis_deg"});
  }
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
  RigBodyTolerance& body = file.spec.rig_body;
  if (root["mirror2"].IsDefined()) {
    const YAML::Node map = root["mirror2"];
    body.mirror2_decentre_mm = Limit(in, map, "mirror2", "decentre_to_mirror1", false);
    body.mirror2_tilt_rad = Limit(in, map, "mirror2", "tilt_to_mirror1", true);
    body.mirror2_spacing_mm = Limit(in, map, "mirror2", "spacing", false);
  }
  if (root["camera"].IsDefined()) {
    const YAML::Node map = root["camera"];
    body.camera_decentre_mm = Limit(in, map, "camera", "decentre_to_axis", false);
    body.camera_tilt_rad = Limit(in, map, "camera", "tilt_to_axis", true);
  }
  any = any || body.Any();
  if (root["reflex"].IsDefined()) {
    const YAML::Node map = in.Map(root, "reflex", "reflex");
    file.spec.reflex_tilt_rad = Limit(in, map, "reflex", "tilt", true);
    file.spec.reflex_dz_mm = Limit(in, map, "reflex", "dz", false);
    any = any || file.spec.reflex_tilt_rad >= 0 || file.spec.reflex_dz_mm >= 0;
  }
  if (!any) {
    in.Fail("mirror1", "expected at least one limit (mirror1/mirror2: decentre, tilt_deg, axial, profile_pv; "
            "mirror2: decentre_to_mirror1, tilt_to_mirror1_deg, spacing; reflex: tilt_deg, dz; "
            "camera: decentre_to_axis, tilt_to_axis_deg)", "none");
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
