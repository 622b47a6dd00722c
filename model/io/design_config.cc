#include "model/io/design_config.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <sstream>

namespace omni::io {
namespace {

constexpr char kFormatPrefix[] = "omnistereo-design/";
constexpr int kFormatMajor = 1;
constexpr double kRadPerDeg = M_PI / 180.0;

// Every error is one line "<file>: <key>: <expected>, got <what>", the style of model_file.cc.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void Fail(const std::string& key, const std::string& expected,
                         const std::string& got) const {
    throw InputError(file_ + ": " + key + ": " + expected + ", got " + got);
  }

  static std::string Describe(const YAML::Node& node) {
    if (!node.IsDefined()) return "nothing (key missing)";
    if (node.IsNull()) return "an empty value";
    if (node.IsSequence()) return "a list";
    if (node.IsMap()) return "a map";
    std::string s = node.Scalar();
    if (s.size() > 40) s = s.substr(0, 40) + "...";
    return "'" + s + "'";
  }
  static std::string Join(const std::string& parent, const std::string& key) {
    return parent.empty() ? key : parent + "." + key;
  }

  YAML::Node Map(const YAML::Node& parent, const std::string& parent_key, const char* name) const {
    const YAML::Node node = parent[name];
    if (!node.IsDefined() || !node.IsMap()) {
      Fail(Join(parent_key, name), "expected a map of keys", Describe(node));
    }
    return node;
  }

  double Number(const YAML::Node& parent, const std::string& parent_key, const char* name) const {
    const std::string key = Join(parent_key, name);
    const YAML::Node node = parent[name];
    // An undefined node from a missing key throws on IsScalar(): test IsDefined() first.
    if (!node.IsDefined() || !node.IsScalar()) Fail(key, "expected a number", Describe(node));
    double value = 0;
    try {
      value = node.as<double>();
    } catch (const YAML::Exception&) {
      Fail(key, "expected a number", Describe(node));
    }
    if (!std::isfinite(value)) Fail(key, "expected a finite number", Describe(node));
    return value;
  }
  double Number(const YAML::Node& parent, const std::string& parent_key, const char* name,
                double fallback) const {
    return parent[name] ? Number(parent, parent_key, name) : fallback;
  }
  double Positive(const YAML::Node& parent, const std::string& parent_key, const char* name) const {
    const double v = Number(parent, parent_key, name);
    if (!(v > 0)) Fail(Join(parent_key, name), "expected a number > 0", Describe(parent[name]));
    return v;
  }
  int Integer(const YAML::Node& parent, const std::string& parent_key, const char* name,
              int min_value, int fallback) const {
    if (!parent[name]) return fallback;
    const double v = Number(parent, parent_key, name);
    if (v != std::floor(v) || v < min_value || v > 1e9) {
      Fail(Join(parent_key, name), "expected an integer >= " + std::to_string(min_value),
           Describe(parent[name]));
    }
    return static_cast<int>(v);
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

  std::string file_;
};

YAML::Node Load(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the design config file (missing or unreadable)");
  std::stringstream buffer;
  buffer << in.rdbuf();
  try {
    return YAML::Load(buffer.str());
  } catch (const YAML::Exception& e) {
    std::ostringstream msg;
    msg << path << ": malformed YAML at line " << e.mark.line + 1 << ", column "
        << e.mark.column + 1 << ": " << e.msg;
    throw InputError(msg.str());
  }
}

}  // namespace

DesignConfig ReadDesignConfig(const std::string& path) {
  const YAML::Node root = Load(path);
  const Reader r(path);
  if (!root.IsMap()) {
    r.Fail("format", "expected a YAML map starting with 'format: omnistereo-design/1'",
           Reader::Describe(root));
  }
  const YAML::Node format = root["format"];
  const std::string format_text = format.IsDefined() && format.IsScalar() ? format.Scalar() : "";
  const std::string prefix = kFormatPrefix;
  if (format_text.compare(0, prefix.size(), prefix) != 0) {
    r.Fail("format", "expected 'omnistereo-design/1'", Reader::Describe(format));
  }
  {
    const std::string version = format_text.substr(prefix.size());
    const std::string major = version.substr(0, version.find('.'));
    if (major != std::to_string(kFormatMajor)) {
      r.Fail("format", "unknown major version (this tool reads omnistereo-design/1)",
             Reader::Describe(format));
    }
  }

  DesignConfig config;
  design::OptimizerOptions& o = config.options;

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
                     ? design::MassModel::kAuthors
                     : design::MassModel::kFull;
  o.h_sys_max = r.Positive(c, ck, "h_sys_max");
  o.vertex_offset_min = r.Number(c, ck, "vertex_offset_min");
  o.theta1_max_limit = r.Number(c, ck, "theta1_max_limit_deg") * kRadPerDeg;
  o.theta1_max_sense = r.Word(c, ck, "theta1_max_sense", "at_least", "at_most", "at_least") ==
                               "at_least"
                           ? design::Theta1MaxSense::kAtLeast
                           : design::Theta1MaxSense::kAtMost;
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
    o.starts = design::DefaultStarts(o);
    o.starts.insert(o.starts.begin(), r.Theta(root, "", "start"));
  }

  std::string why;
  if (!o.Check(&why)) throw InputError(path + ": " + why);
  return config;
}

}  // namespace omni::io
