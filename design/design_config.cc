#include "design/design_config.h"


#include <cmath>

#include "io/yaml_reader.h"

namespace omni::design {

// The shared YAML reader and its errors (io/yaml_reader.h).
using namespace omni::io;
namespace {

constexpr char kFormatPrefix[] = "omnistereo-design/";
constexpr int kFormatMajor = 1;

// The shared Reader (yaml_reader.h) plus this file's optional keys with defaults and its
// design-vector rule.
class DesignReader : public Reader {
 public:
  using Reader::Reader;
  using Reader::Integer;
  using Reader::Number;

  double Number(const YAML::Node& parent, const std::string& parent_key, const char* name,
                double fallback) const {
    return parent[name] ? Number(parent, parent_key, name) : fallback;
  }
  int Integer(const YAML::Node& parent, const std::string& parent_key, const char* name,
              int min_value, int fallback) const {
    return parent[name] ? Integer(parent, parent_key, name, min_value) : fallback;
  }
  std::string Word(const YAML::Node& parent, const std::string& parent_key, const char* name,
                   const std::string& a, const std::string& b, const std::string& fallback) const {
    const YAML::Node node = parent[name];
    if (!node) return fallback;
    if (!node.IsScalar() || (node.Scalar() != a && node.Scalar() != b)) {
      Fail(Join(parent_key, name), "expected '" + a + "' or '" + b + "'", Describe(node));
    }
    return node.Scalar();
  }

  // theta = [c1, c2, k1, k2, d, r_sys] with c, d, r_sys > 0 and k > 2 [hyperbolic_constraints].
  DesignParams Theta(const YAML::Node& parent, const std::string& parent_key,
                     const char* name) const {
    const YAML::Node map = Map(parent, parent_key, name);
    const std::string key = Join(parent_key, name);
    DesignParams t;
    t.c1 = Positive(map, key, "c1");
    t.c2 = Positive(map, key, "c2");
    t.k1 = AboveTwo(map, key, "k1");
    t.k2 = AboveTwo(map, key, "k2");
    t.d = Positive(map, key, "d");
    t.r_sys = Positive(map, key, "r_sys");
    return t;
  }

 private:
  double AboveTwo(const YAML::Node& parent, const std::string& parent_key, const char* name) const {
    const double v = Number(parent, parent_key, name);
    if (!(v > 2)) {
      Fail(Join(parent_key, name), "expected a number > 2 (a hyperboloid needs k > 2)",
           Describe(parent[name]));
    }
    return v;
  }

};

}  // namespace

DesignConfig ReadDesignConfig(const std::string& path) {
  const YAML::Node root = LoadYamlFile(path, "design config file");
  const DesignReader r(path);
  if (!root.IsMap()) {
    r.Fail("format", "expected a YAML map starting with 'format: omnistereo-design/1'",
           Describe(root));
  }
  const YAML::Node format = root["format"];
  const std::string format_text = format.IsDefined() && format.IsScalar() ? format.Scalar() : "";
  const std::string prefix = kFormatPrefix;
  if (format_text.compare(0, prefix.size(), prefix) != 0) {
    r.Fail("format", "expected 'omnistereo-design/1'", Describe(format));
  }
  {
    const std::string version = format_text.substr(prefix.size());
    const std::string major = version.substr(0, version.find('.'));
    if (major != std::to_string(kFormatMajor)) {
      r.Fail("format", "unknown major version (this tool reads omnistereo-design/1)",
             Describe(format));
    }
  }

  DesignConfig config;
  OptimizerOptions& o = config.options;

  const YAML::Node box = r.Map(root, "", "search_box");
  o.lower = r.Theta(box, "search_box", "lower");
  o.upper = r.Theta(box, "search_box", "upper");
  {
    const double lo[] = {o.lower.c1, o.lower.c2, o.lower.k1, o.lower.k2, o.lower.d, o.lower.r_sys};
    const double hi[] = {o.upper.c1, o.upper.c2, o.upper.k1, o.upper.k2, o.upper.d, o.upper.r_sys};
    const char* names[] = {"c1", "c2", "k1", "k2", "d", "r_sys"};
    for (int i = 0; i < 6; ++i) {
      if (lo[i] > hi[i]) {
        std::ostringstream got;
        got << lo[i] << " > upper " << hi[i];
        r.Fail(std::string("search_box.lower.") + names[i],
               "expected a lower bound <= search_box.upper." + std::string(names[i]), got.str());
      }
    }
  }

  const YAML::Node c = r.Map(root, "", "constraints");
  const std::string ck = "constraints";
  o.k_ratio_min = r.Number(c, ck, "k_ratio_min");
  o.mass_max_g = r.Positive(c, ck, "mass_max_g");
  o.mass_model = r.Word(c, ck, "mass_model", "authors", "full", "authors") == "authors"
                     ? MassModel::kAuthors
                     : MassModel::kFull;
  o.h_sys_max = r.Positive(c, ck, "h_sys_max");
  o.vertex_offset_min = r.Number(c, ck, "vertex_offset_min");
  o.theta1_max_limit = r.Number(c, ck, "theta1_max_limit_deg") * kRadPerDeg;
  o.theta1_max_sense = r.Word(c, ck, "theta1_max_sense", "at_least", "at_most", "at_least") ==
                               "at_least"
                           ? Theta1MaxSense::kAtLeast
                           : Theta1MaxSense::kAtMost;
  o.theta1_min_limit = r.Number(c, ck, "theta1_min_limit_deg") * kRadPerDeg;
  o.theta2_min_limit = r.Number(c, ck, "theta2_min_limit_deg") * kRadPerDeg;

  if (root["mass"]) {
    const YAML::Node map = r.Map(root, "", "mass");
    MassInputs& in = o.mass_inputs;
    in.mirror_wall_mm = r.Number(map, "mass", "mirror_wall_mm", in.mirror_wall_mm);
    in.mirror_density = r.Number(map, "mass", "mirror_density", in.mirror_density);
    in.camera_mass_g = r.Number(map, "mass", "camera_mass_g", in.camera_mass_g);
    in.tube_wall_mm = r.Number(map, "mass", "tube_wall_mm", in.tube_wall_mm);
    in.tube_density = r.Number(map, "mass", "tube_density", in.tube_density);
  }

  o.r_cam = r.Positive(root, "", "r_cam");

  const YAML::Node cam = r.Map(root, "", "camera");
  config.camera.fx = r.Positive(cam, "camera", "fx");
  config.camera.fy = r.Positive(cam, "camera", "fy");
  config.camera.cx = r.Number(cam, "camera", "cx");
  config.camera.cy = r.Number(cam, "camera", "cy");
  config.camera.skew = r.Number(cam, "camera", "skew", 0.0);
  const YAML::Node image = r.Map(root, "", "image");
  config.image_width = r.Integer(image, "image", "width", 1, -1);
  config.image_height = r.Integer(image, "image", "height", 1, -1);
  if (config.image_width < 0) {
    r.Fail("image.width", "expected an integer >= 1", "nothing (key missing)");
  }
  if (config.image_height < 0) {
    r.Fail("image.height", "expected an integer >= 1", "nothing (key missing)");
  }

  if (root["solver"]) {
    const YAML::Node s = r.Map(root, "", "solver");
    o.num_default_starts = r.Integer(s, "solver", "starts", 1, o.num_default_starts);
    o.max_evaluations_per_start =
        r.Integer(s, "solver", "max_evaluations_per_start", 1, o.max_evaluations_per_start);
  }
  if (root["start"]) {
    // The given start goes first, followed by the default set.
    o.starts = DefaultStarts(o);
    o.starts.insert(o.starts.begin(), r.Theta(root, "", "start"));
  }

  if (const std::string why = o.Check(); !why.empty()) throw InputError(path + ": " + why);
  return config;
}

}  // namespace omni::design
