#include "io/model_file.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <sys/stat.h>

#include "io/measured_profile.h"
#include "io/yaml_reader.h"
#include "model/lip.h"
#include "model/rig_frames.h"
#include "model/rig_parameters.h"

namespace omni::io {
namespace {

constexpr char kFormatPrefix[] = "omnistereo-model/";
constexpr int kFormatMajor = 1;

// The map at `section` ("mirror1.cam_from_mirror") below `parent` (the map at the section's
// first `start` characters), each map on the way read as one.
YAML::Node MapAt(const Reader& in, const YAML::Node& parent, const std::string& section,
                 size_t start = 0) {
  const size_t dot = std::min(section.find('.', start), section.size());
  const YAML::Node node =
      in.Map(parent, section.substr(0, dot), section.substr(start, dot - start).c_str());
  return dot == section.size() ? node : MapAt(in, node, section, dot + 1);
}
// A block's map in a model file (its table section).
YAML::Node SectionMap(const Reader& in, const YAML::Node& root, RigBlockId block) {
  return MapAt(in, root, kRigBlocks[block].section);
}
// Its key in that map's parent ("cam_from_mirror").
std::string SectionKey(RigBlockId block) {
  const std::string section = kRigBlocks[block].section;
  return section.substr(section.rfind('.') + 1);
}

// One parameter's value from its block's map (`path`), under its table key: tilts read as
// angles, and the value checked as the table says.
double ReadParameter(const Reader& in, const YAML::Node& map, const std::string& path,
                     const RigParameter& p) {
  const std::string key = p.Key();
  switch (p.file_check) {
    case FileCheck::kPositive:
      return in.Positive(map, path, key.c_str());
    case FileCheck::kHyperboloidK: {
      // [hyperboloid]: k <= 2 is no hyperboloid (the eccentricity becomes undefined or 1).
      const double k = in.Number(map, path, key.c_str());
      if (!(k > 2)) in.Fail(Join(path, key), "expected k > 2", Describe(map[key]));
      return k;
    }
    case FileCheck::kAny:
      break;
  }
  return p.unit == ParameterUnit::kRadian ? in.Angle(map, path, key.c_str())
                                          : in.Number(map, path, key.c_str());
}

// A parameter block's values from its map, each under its table key (model/rig_parameters.h).
void ReadBlock(const Reader& in, const YAML::Node& map, RigBlockId block, double* values) {
  const RigParameter* p = BlockParameters(block);
  for (int i = 0; i < kRigBlocks[block].size; ++i) {
    values[i] = ReadParameter(in, map, kRigBlocks[block].section, p[i]);
  }
}

Lip ReadLip(const Reader& in, const YAML::Node& map, const std::string& path) {
  Lip lip;
  // Renderer and detector both need the paint's colour (model/lip.h), so an unknown one stops
  // here. An unquoted #rrggbb reads as null: YAML takes it for a comment.
  if (map["color"].IsDefined() && map["color"].IsNull()) {
    in.Fail(Join(path, "color"), "expected a paint: " + LipPaintChoices(), Describe(map["color"]));
  }
  lip.color = in.String(map, path, "color");
  if (!LipPaintRgb(lip.color)) {
    in.Fail(Join(path, "color"), "expected a paint: " + LipPaintChoices(), Describe(map["color"]));
  }
  lip.r_inner = in.Number(map, path, "r_inner");
  if (lip.r_inner < 0) in.Fail(Join(path, "r_inner"), "expected a radius >= 0", Describe(map["r_inner"]));
  lip.r_outer = in.Number(map, path, "r_outer");
  if (!(lip.r_outer > lip.r_inner)) {
    in.Fail(Join(path, "r_outer"), "expected a radius > r_inner (" + FormatDouble(lip.r_inner) + ")",
            Describe(map["r_outer"]));
  }
  lip.z = in.Number(map, path, "z");
  return lip;
}

// A profile moving the surface by more than this is not a machining error of the designed
// mirror but another mirror (a new design); a slope beyond kMaxProfileSlope is no smooth
// correction (mirror_profile.h).
constexpr double kMaxProfileSagMm = 0.1;
constexpr double kMaxProfileSlope = 0.02;
// Finer ripples are surface roughness (they scatter, they do not bend a ray coherently).
constexpr double kMinRipplePeriodMm = 0.5;

// `mirrorN.profile`: the radii (default: the mirror's used annulus), the coefficients (default
// 0) and an optional ripple; refused where it leaves the mirror's radii or is no small smooth
// correction.
void ReadProfile(const Reader& in, const YAML::Node& map, const std::string& path,
                 const RigParams& rig, Mirror mirror, ProfileShape* shape, double* coeffs) {
  *shape = DefaultProfileShape(rig, mirror);
  auto optional = [&](const char* key, double* value) {
    if (map[key].IsDefined()) *value = in.Number(map, path, key);
  };
  optional("r_min", &shape->r_min);
  optional("r_max", &shape->r_max);
  if (!(shape->r_min >= 0 && shape->r_min < rig.r_sys)) {
    in.Fail(Join(path, "r_min"), "expected a radius in [0, r_sys) = [0, " + FormatDouble(rig.r_sys) + ")",
            FormatDouble(shape->r_min));
  }
  if (!(shape->r_max > shape->r_min && shape->r_max <= rig.r_sys)) {
    in.Fail(Join(path, "r_max"),
            "expected a radius in (r_min, r_sys] = (" + FormatDouble(shape->r_min) + ", " +
                FormatDouble(rig.r_sys) + "] (the mirror's radii)",
            FormatDouble(shape->r_max));
  }
  const RigParameter* terms = BlockParameters(ProfileBlock(mirror));
  for (int i = 0; i < kProfileTerms; ++i) {
    coeffs[i] = 0;
    optional(terms[i].Key().c_str(), &coeffs[i]);
  }
  optional("ripple_amplitude", &shape->ripple_amplitude);
  optional("ripple_period", &shape->ripple_period);
  optional("ripple_phase", &shape->ripple_phase);
  if (shape->ripple_amplitude != 0 && !(shape->ripple_period >= kMinRipplePeriodMm)) {
    in.Fail(Join(path, "ripple_period"),
            "expected a period >= " + FormatDouble(kMinRipplePeriodMm) +
                " mm with a ripple_amplitude (finer marks are roughness, not a profile)",
            map["ripple_period"].IsDefined() ? Describe(map["ripple_period"]) : "none");
  }
  std::array<double, kProfileTerms> c{};
  std::copy(coeffs, coeffs + kProfileTerms, c.begin());
  const ProfileExtent extent = MeasureProfile(c, *shape);
  if (!(extent.max_sag_mm <= kMaxProfileSagMm)) {
    in.Fail(path, "a sag of at most " + FormatDouble(kMaxProfileSagMm) +
                      " mm over the profile's radii (a machining error; a larger one is another "
                      "mirror: a new design)",
            "a sag of " + FormatDouble(extent.max_sag_mm) + " mm");
  }
  if (!(extent.max_slope <= kMaxProfileSlope)) {
    in.Fail(path, "a smooth correction: slopes of at most " + FormatDouble(kMaxProfileSlope) +
                      " rad",
            "a slope of " + FormatDouble(extent.max_slope) + " rad");
  }
}

// `mount:` (model/mount.h): the posts that hold the rig. Refused where a post stands inside the
// mirrors' radius, has no width, spans no height, or meets another post.
Mount ReadMount(const Reader& in, const YAML::Node& map, const RigParams& rig) {
  const std::string path = "mount";
  Mount mount;
  mount.present = true;
  if (map["body"].IsDefined()) {
    const std::string body = in.String(map, path, "body");
    if (body != "mirror1" && body != "mirror2") {
      in.Fail(Join(path, "body"), "expected mirror1 or mirror2", Describe(map["body"]));
    }
    mount.body = body == "mirror1" ? Mirror::kOne : Mirror::kTwo;
  }
  const int count = in.Integer(map, path, "count", 1);
  // `width:` for posts alike, or `widths:` one per post (a prototype's standoffs need not match).
  if (map["widths"].IsDefined()) {
    if (map["width"].IsDefined()) {
      in.Fail(Join(path, "widths"), "width or widths, not both", "both");
    }
    mount.widths = in.Numbers(map, path, "widths");
    if (static_cast<int>(mount.widths.size()) != count) {
      in.Fail(Join(path, "widths"), "expected " + std::to_string(count) + " widths (count)",
              std::to_string(mount.widths.size()));
    }
    for (double w : mount.widths) {
      if (!(w > 0)) in.Fail(Join(path, "widths"), "expected widths > 0 mm", FormatDouble(w));
    }
    mount.width = mount.MaxWidth();
  } else {
    mount.width = in.Number(map, path, "width");
    if (!(mount.width > 0)) in.Fail(Join(path, "width"), "expected a width > 0 mm", Describe(map["width"]));
  }
  mount.radius = in.Number(map, path, "radius");
  if (!(mount.radius - 0.5 * mount.MaxWidth() > rig.r_sys)) {
    in.Fail(Join(path, "radius"),
            "expected the posts outside the mirrors: radius - width/2 > r_sys (" +
                FormatDouble(rig.r_sys) + " mm)",
            Describe(map["radius"]));
  }
  mount.z_min = in.Number(map, path, "z_min");
  mount.z_max = in.Number(map, path, "z_max");
  if (!(mount.z_max > mount.z_min)) {
    in.Fail(Join(path, "z_max"), "expected z_max > z_min (" + FormatDouble(mount.z_min) + ")",
            Describe(map["z_max"]));
  }
  if (map["azimuths_deg"].IsDefined()) {
    for (double deg : in.Numbers(map, path, "azimuths_deg")) mount.azimuths.push_back(deg * M_PI / 180);
    if (static_cast<int>(mount.azimuths.size()) != count) {
      in.Fail(Join(path, "azimuths_deg"), "expected " + std::to_string(count) + " azimuths (count)",
              std::to_string(mount.azimuths.size()));
    }
  } else {
    // Evenly spaced from +y (90 deg), as the prototype's three standoffs.
    for (int i = 0; i < count; ++i) mount.azimuths.push_back(M_PI / 2 + 2 * M_PI * i / count);
  }
  if (PostsOverlap(mount)) {
    in.Fail(Join(path, "azimuths_deg"), "posts that do not meet (centres at least width * sqrt 2 apart)",
            "overlapping posts");
  }
  return mount;
}

std::string MountMap(const Mount& mount) {
  std::vector<std::string> deg;
  for (double a : mount.azimuths) deg.push_back(FormatDouble(a * 180 / M_PI));
  std::string widths;
  if (mount.EqualWidths()) {
    widths = ", width: " + FormatDouble(mount.WidthOf(0));
  } else {
    for (size_t i = 0; i < mount.widths.size(); ++i) widths += (i ? ", " : "") + FormatDouble(mount.widths[i]);
    widths = ", widths: [" + widths + "]";
  }
  std::string out = std::string("{body: ") + (mount.body == Mirror::kOne ? "mirror1" : "mirror2") +
                    ", count: " + std::to_string(mount.azimuths.size()) + widths +
                    ", radius: " + FormatDouble(mount.radius) +
                    ", z_min: " + FormatDouble(mount.z_min) + ", z_max: " + FormatDouble(mount.z_max) +
                    ", azimuths_deg: [";
  for (size_t i = 0; i < deg.size(); ++i) out += (i ? ", " : "") + deg[i];
  return out + "]}";
}

// kind: ideal means exactly the SVP rig: a nonzero misalignment would be silently dropped.
void CheckIdeal(const Reader& in, const RigParams& rig) {
  // The blocks an ideal model holds at 0.
  for (RigBlockId block : {kDistortionBlock, kPose1Block, kReflexBlock, kPose2Block}) {
    const RigParameter* p = BlockParameters(block);
    for (int i = 0; i < kRigBlocks[block].size; ++i) {
      const double value = BlockIn(rig, block)[i];
      if (value != 0) {
        in.Fail(Join(kRigBlocks[block].section, p[i].Key()), "expected 0 because kind is ideal",
                FormatDouble(value));
      }
    }
  }
  for (RigBlockId block : {kProfile1Block, kProfile2Block}) {
    const bool present = (block == kProfile1Block ? rig.profile1 : rig.profile2).present;
    if (present) in.Fail(kRigBlocks[block].section, "no profile because kind is ideal", "one");
  }
}

// calibration.held_profiles: each held, considered profile's prior and the data's information
// on its terms (HeldProfileInfo).
std::vector<HeldProfileInfo> ReadHeldProfiles(const Reader& in, const YAML::Node& cal,
                                              const std::string& cal_path) {
  const std::string path = Join(cal_path, "held_profiles");
  const YAML::Node list = cal["held_profiles"];
  if (!IsSequence(list)) in.Fail(path, "expected a list of held profiles", Describe(list));
  const std::size_t n2 = kProfileTerms * kProfileTerms;
  std::vector<HeldProfileInfo> out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string key = path + "[" + std::to_string(i) + "]";
    const YAML::Node node = list[i];
    if (!IsMap(node)) in.Fail(key, "expected a map of keys", Describe(node));
    HeldProfileInfo held;
    held.mirror = in.Integer(node, key, "mirror", 1);
    if (held.mirror > 2) in.Fail(Join(key, "mirror"), "expected 1 or 2", Describe(node["mirror"]));
    held.prior = in.String(node, key, "prior");
    if (held.prior != "tolerance" && held.prior != "scan") {
      in.Fail(Join(key, "prior"), "expected tolerance or scan", Describe(node["prior"]));
    }
    held.r_min = in.Number(node, key, "r_min");
    held.r_max = in.Number(node, key, "r_max");
    if (!(held.r_min >= 0 && held.r_max > held.r_min)) {
      in.Fail(Join(key, "r_max"), "expected radii 0 <= r_min < r_max", Describe(node["r_max"]));
    }
    held.prior_covariance = in.Numbers(node, key, "prior_covariance");
    if (held.prior_covariance.size() != n2) {
      in.Fail(Join(key, "prior_covariance"), "expected " + std::to_string(n2) + " numbers (row-major)",
              std::to_string(held.prior_covariance.size()));
    }
    if (node["data_information"].IsDefined()) {
      held.data_information = in.Numbers(node, key, "data_information");
      if (held.data_information.size() != n2) {
        in.Fail(Join(key, "data_information"),
                "expected " + std::to_string(n2) + " numbers (row-major)",
                std::to_string(held.data_information.size()));
      }
    }
    out.push_back(std::move(held));
  }
  return out;
}

// `calibration.lip_reference` (optional): the check's lip bins on the calibration photos.
void ReadLipReference(const Reader& in, const YAML::Node& cal, const std::string& cal_path,
                      CalibrationInfo* info) {
  const std::string path = Join(cal_path, "lip_reference");
  const YAML::Node ref = in.Map(cal, path, "lip_reference");
  info->lip_reference_sectors = in.Integer(ref, path, "azimuth_bins", 1);
  if (ref["rim_scene_px"].IsDefined()) {
    info->lip_reference_rim_scene_px = in.Number(ref, path, "rim_scene_px");
    if (!(info->lip_reference_rim_scene_px >= 0)) {
      in.Fail(Join(path, "rim_scene_px"), "expected a standard deviation >= 0 px",
              FormatDouble(info->lip_reference_rim_scene_px));
    }
  }
  if (ref["edge_radius"].IsDefined()) {
    info->lip_reference_edge_radius = in.Number(ref, path, "edge_radius");
    if (!(info->lip_reference_edge_radius > 0)) {
      in.Fail(Join(path, "edge_radius"), "expected a radius > 0 mm",
              FormatDouble(info->lip_reference_edge_radius));
    }
  }
  const std::string bins_path = Join(path, "bins");
  const YAML::Node bins = ref["bins"];
  if (!IsSequence(bins)) in.Fail(bins_path, "expected a list of bins", Describe(bins));
  for (std::size_t i = 0; i < bins.size(); ++i) {
    const std::string item = bins_path + "[" + std::to_string(i) + "]";
    if (!IsMap(bins[i])) {
      in.Fail(item, "expected {edge, azimuth_deg, photos, mean_px, scatter_px}",
              Describe(bins[i]));
    }
    LipReferenceBin bin;
    bin.edge = in.String(bins[i], item, "edge");
    bin.azimuth_deg = in.Number(bins[i], item, "azimuth_deg");
    bin.photos = in.Integer(bins[i], item, "photos", 1);
    bin.mean_px = in.Number(bins[i], item, "mean_px");
    bin.scatter_px = in.Number(bins[i], item, "scatter_px");
    if (bin.scatter_px < 0) {
      in.Fail(Join(item, "scatter_px"), "expected a standard deviation >= 0",
              FormatDouble(bin.scatter_px));
    }
    info->lip_reference.push_back(bin);
  }
}

CalibrationInfo ReadCalibration(const Reader& in, const YAML::Node& root) {
  const std::string path = "calibration";
  const YAML::Node cal = in.Map(root, path, "calibration");
  CalibrationInfo info;
  info.parameters = in.Strings(cal, path, "parameters");
  const std::size_t n = info.parameters.size();
  std::set<std::string> seen;
  for (std::size_t i = 0; i < n; ++i) {
    if (!seen.insert(info.parameters[i]).second) {
      in.Fail(path + ".parameters[" + std::to_string(i) + "]", "expected a unique name",
              "a second " + Abbreviate(info.parameters[i]));
    }
  }
  auto check_length = [&](const std::vector<double>& values, const char* name, std::size_t want,
                          const char* what) {
    if (values.size() != want) {
      in.Fail(Join(path, name),
              "expected " + std::to_string(want) + " numbers (" + what + ", " +
                  std::to_string(n) + " parameters)",
              std::to_string(values.size()));
    }
  };
  info.values = in.Numbers(cal, path, "values");
  check_length(info.values, "values", n, "one per parameter");
  info.sigma = in.Numbers(cal, path, "sigma");
  check_length(info.sigma, "sigma", n, "one per parameter");
  for (std::size_t i = 0; i < n; ++i) {
    if (info.sigma[i] < 0) {
      in.Fail(path + ".sigma[" + std::to_string(i) + "]", "expected a standard deviation >= 0",
              FormatDouble(info.sigma[i]));
    }
  }
  info.covariance = in.Numbers(cal, path, "covariance");
  check_length(info.covariance, "covariance", n * n, "row-major, parameters^2");
  if (cal["noise_covariance"].IsDefined()) {
    info.noise_covariance = in.Numbers(cal, path, "noise_covariance");
    check_length(info.noise_covariance, "noise_covariance", n * n, "row-major, parameters^2");
  }

  const std::string res_path = Join(path, "residuals");
  const YAML::Node res = in.Map(cal, res_path, "residuals");
  info.rms_px = in.Number(res, res_path, "rms_px");
  if (info.rms_px < 0) in.Fail(Join(res_path, "rms_px"), "expected a number >= 0", Describe(res["rms_px"]));
  info.n_observations = in.Integer(res, res_path, "n_observations", 0);
  info.n_outliers = in.Integer(res, res_path, "n_outliers", 0);
  info.per_mirror_rms_px = in.Numbers(res, res_path, "per_mirror_rms_px");
  if (res["n_rejected"].IsDefined()) info.n_rejected = in.Integer(res, res_path, "n_rejected", 0);
  if (res["n_lip_points"].IsDefined()) {
    info.n_lip_points = in.Integer(res, res_path, "n_lip_points", 0);
  }
  if (res["lip_rms_px"].IsDefined()) info.lip_rms_px = in.Number(res, res_path, "lip_rms_px");
  if (cal["unobservable"].IsDefined()) {
    info.unobservable = in.Strings(cal, path, "unobservable");
    if (cal["unobservable_hints"].IsDefined()) {
      info.unobservable_hints = in.Strings(cal, path, "unobservable_hints");
    }
    if (info.unobservable_hints.size() != info.unobservable.size()) {
      in.Fail(Join(path, "unobservable_hints"),
              "expected " + std::to_string(info.unobservable.size()) +
                  " strings (one per unobservable parameter)",
              std::to_string(info.unobservable_hints.size()));
    }
  }

  if (cal["held_profiles"].IsDefined()) info.held_profiles = ReadHeldProfiles(in, cal, path);
  if (cal["lip_reference"].IsDefined()) ReadLipReference(in, cal, path, &info);

  const std::string data_path = Join(path, "dataset");
  const YAML::Node data = in.Map(cal, data_path, "dataset");
  info.session = in.String(data, data_path, "session");
  info.images = in.Integer(data, data_path, "images", 0);
  info.targets = in.String(data, data_path, "targets");

  info.tool_version = in.String(cal, path, "tool_version");
  info.date = in.String(cal, path, "date");
  return info;
}

// ---------------------------------------------------------------------------------------------
// Writing: a small emitter of our own, so the layout is the one of formats/model_example.yaml.

bool IsPlainSafe(const std::string& text) {
  if (text.empty() || !std::isalpha(static_cast<unsigned char>(text[0]))) return false;
  for (char ch : text) {
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_' && ch != '.' && ch != '-' &&
        ch != '/') {
      return false;
    }
  }
  // Words other YAML readers (YAML 1.1) turn into booleans or null.
  static const char* const kReserved[] = {"true", "false", "yes", "no", "on", "off",
                                          "y",    "n",     "null", "nan", "inf"};
  std::string lower;
  for (char ch : text) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  for (const char* word : kReserved) {
    if (lower == word) return false;
  }
  return true;
}

std::string Text(const std::string& text) {
  if (IsPlainSafe(text)) return text;
  std::string out = "\"";
  for (char ch : text) {
    const unsigned char u = static_cast<unsigned char>(ch);
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += ch;
    } else if (ch == '\n') {
      out += "\\n";
    } else if (ch == '\t') {
      out += "\\t";
    } else if (u < 0x20 || u == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\x%02x", u);
      out += buf;
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

// Shortest round-trip text, with a '.' in the mantissa so that every YAML reader (also YAML 1.1
// ones) sees a float: 37 -> 37.0, 1e-07 -> 1.0e-07.
std::string Num(double value) {
  if (std::isnan(value)) return ".nan";
  if (std::isinf(value)) return value > 0 ? ".inf" : "-.inf";
  std::string text = FormatDouble(value);
  if (text.find('.') == std::string::npos) {
    const std::size_t e = text.find('e');
    text.insert(e == std::string::npos ? text.size() : e, ".0");
  }
  return text;
}

std::string Vec(const Eigen::Vector3d& v) {
  return "[" + Num(v.x()) + ", " + Num(v.y()) + ", " + Num(v.z()) + "]";
}

// key: value, with an optional comment aligned at column 30 as in the format example.
void Line(std::string* out, int indent, const std::string& key_value, const char* comment = "") {
  std::string line(indent, ' ');
  line += key_value;
  if (*comment) {
    if (line.size() < 30) line.resize(30, ' ');
    else line += "  ";
    line += "# ";
    line += comment;
  }
  *out += line + "\n";
}

// A flow list, wrapped after `per_line` items with continuation lines indented past the key.
std::string FlowList(const std::vector<std::string>& items, int indent, std::size_t per_line) {
  std::string out = "[";
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i > 0) {
      out += ",";
      out += (i % per_line == 0) ? "\n" + std::string(indent + 3, ' ') : " ";
    }
    out += items[i];
  }
  return out + "]";
}

std::vector<std::string> Nums(const std::vector<double>& values) {
  std::vector<std::string> items;
  items.reserve(values.size());
  for (double v : values) items.push_back(Num(v));
  return items;
}

// A parameter block as a flow map under its table keys, after `lead` ("model: radtan, ").
std::string BlockMap(const RigParams& rig, RigBlockId block, const std::string& lead = "") {
  std::string out = "{" + lead;
  const RigParameter* p = BlockParameters(block);
  for (int i = 0; i < kRigBlocks[block].size; ++i) {
    out += (i > 0 ? ", " : "") + p[i].Key() + ": " + Num(BlockIn(rig, block)[i]);
  }
  return out + "}";
}

std::string ProfileMap(const RigParams& rig, Mirror mirror) {
  const ProfileShape& shape = mirror == Mirror::kOne ? rig.profile1 : rig.profile2;
  const RigBlockId block = ProfileBlock(mirror);
  std::string out = "{r_min: " + Num(shape.r_min) + ", r_max: " + Num(shape.r_max);
  const RigParameter* p = BlockParameters(block);
  for (int i = 0; i < kRigBlocks[block].size; ++i) {
    out += ", " + p[i].Key() + ": " + Num(BlockIn(rig, block)[i]);
  }
  if (shape.ripple_amplitude != 0) {
    out += ", ripple_amplitude: " + Num(shape.ripple_amplitude) +
           ", ripple_period: " + Num(shape.ripple_period) +
           ", ripple_phase: " + Num(shape.ripple_phase);
  }
  return out + "}";
}

std::string LipMap(const Lip& lip) {
  return "{color: " + Text(lip.color) + ", r_inner: " + Num(lip.r_inner) +
         ", r_outer: " + Num(lip.r_outer) + ", z: " + Num(lip.z) + "}";
}

}  // namespace

namespace {

// `rig:` (folded | single, default folded) and `lens:` (perspective | telecentric, default
// perspective); the folded rig's design is for a perspective lens only.
void ReadRigAndLens(const Reader& in, const YAML::Node& root, RigParams* rig) {
  if (root["rig"].IsDefined()) {
    const std::string kind = in.String(root, "", "rig");
    if (kind == "single") {
      rig->rig = RigKind::kSingle;
    } else if (kind != "folded") {
      in.Fail("rig", "expected 'folded' or 'single'", Describe(root["rig"]));
    }
  }
  if (root["lens"].IsDefined()) {
    const std::string lens = in.String(root, "", "lens");
    if (lens == "telecentric") {
      rig->lens = LensKind::kTelecentric;
    } else if (lens != "perspective") {
      in.Fail("lens", "expected 'perspective' or 'telecentric'", Describe(root["lens"]));
    }
  }
  if (rig->lens == LensKind::kTelecentric && !rig->Single()) {
    in.Fail("lens", "expected 'perspective': the folded rig's design needs a perspective lens "
                    "(telecentric lenses: rig: single)", "telecentric");
  }
}

// A single-mirror rig (rig: single): camera, `design: {R, K, vertex_z, r_sys, r_cam}` and
// `mirror1: {cam_from_mirror, lip (optional), profile (optional)}`; the folded rig's keys refused.
void ReadSingleRig(const Reader& in, const YAML::Node& root, const std::string& file,
                   RigParams* rig) {
  ReadBlock(in, SectionMap(in, root, kCameraBlock), kCameraBlock, rig->camera.data());
  const YAML::Node dist = SectionMap(in, root, kDistortionBlock);
  const std::string dist_path = kRigBlocks[kDistortionBlock].section;
  if (in.String(dist, dist_path, "model") != "radtan") {
    in.Fail(Join(dist_path, "model"), "expected 'radtan'", Describe(dist["model"]));
  }
  ReadBlock(in, dist, kDistortionBlock, rig->distortion.data());
  const YAML::Node design = in.Map(root, "design", "design");
  for (const char* key : {"c1", "c2", "k1", "k2", "d", "r_ref"}) {
    if (design[key].IsDefined()) {
      in.Fail(Join("design", key), "no folded-rig key in a single-mirror model (rig: single): "
                                   "its mirror is design.R, design.K", "one");
    }
  }
  for (const char* key : {"mirror2", "reflex"}) {
    if (root[key].IsDefined()) {
      in.Fail(key, "no folded-rig key in a single-mirror model (rig: single)", "one");
    }
  }
  const double R = in.Positive(design, "design", "R");
  const double K = in.Number(design, "design", "K");
  rig->mirror1_shape = {R, K};
  rig->vertex_z = in.Number(design, "design", "vertex_z");
  rig->r_sys = in.Positive(design, "design", "r_sys");
  rig->r_cam = design["r_cam"].IsDefined() ? in.Number(design, "design", "r_cam") : 0.0;
  if (!(rig->r_cam >= 0 && rig->r_cam < rig->r_sys)) {
    in.Fail("design.r_cam", "expected a radius in [0, r_sys) = [0, " + FormatDouble(rig->r_sys) + ")",
            Describe(design["r_cam"]));
  }
  if (!Conic<double>{R, K}.Covers(rig->r_sys * rig->r_sys)) {
    in.Fail("design.K", "a conic that reaches the rim r_sys = " + FormatDouble(rig->r_sys) +
                            " mm (an ellipsoid or sphere closes at R / sqrt(1 + K) = " +
                            FormatDouble(R / std::sqrt(1 + K)) + " mm)",
            FormatDouble(K));
  }
  if (rig->lens == LensKind::kPerspective && !(rig->vertex_z > 0)) {
    in.Fail("design.vertex_z", "expected the mirror's vertex above the camera (> 0 mm)",
            Describe(design["vertex_z"]));
  }
  const YAML::Node m1 = in.Map(root, "mirror1", "mirror1");
  if (m1["reflex"].IsDefined()) {
    in.Fail("mirror1.reflex", "no reflex disc in a single-mirror model (rig: single)", "one");
  }
  ReadBlock(in, SectionMap(in, root, kPose1Block), kPose1Block, rig->mirror1_pose.data());
  rig->lip1 = m1["lip"].IsDefined()
                  ? ReadLip(in, in.Map(m1, "mirror1.lip", "lip"), "mirror1.lip")
                  : Lip{"", rig->r_sys, rig->r_sys,
                        rig->vertex_z + Conic<double>{R, K}.Sag(rig->r_sys * rig->r_sys)};
  if (m1[SectionKey(kProfile1Block)].IsDefined()) {
    ReadProfile(in, SectionMap(in, root, kProfile1Block), kRigBlocks[kProfile1Block].section, *rig,
                Mirror::kOne, &rig->profile1, rig->mirror1_profile.data());
  }
  ReadMeasuredProfile(in, file, m1, Mirror::kOne, {kMaxProfileSagMm, kMaxProfileSlope}, rig);
  if (root["mount"].IsDefined()) rig->mount = ReadMount(in, in.Map(root, "mount", "mount"), *rig);
  if (rig->kind == ModelKind::kIdeal) CheckIdeal(in, *rig);
  if (root["calibration"].IsDefined()) rig->calibration = ReadCalibration(in, root);
}

// The single-mirror rig's part of a model file (ModelFileText).
void WriteSingleRig(const RigParams& rig, std::string* out) {
  Line(out, 0, "design:", "the mirror: a conic of vertex radius R (mm) and conic constant K");
  Line(out, 2, "R: " + Num(rig.mirror1_shape[kShapeC]));
  Line(out, 2, "K: " + Num(rig.mirror1_shape[kShapeK]),
       "0 sphere, -1 paraboloid, < -1 hyperboloid, -1..0 ellipsoid");
  Line(out, 2, "vertex_z: " + Num(rig.vertex_z), "the vertex's height in mirror 1's frame");
  Line(out, 2, "r_sys: " + Num(rig.r_sys), "the rim's radius");
  Line(out, 2, "r_cam: " + Num(rig.r_cam), "the centre the camera does not use");
  Line(out, 0, "mirror1:", "body of the mirror");
  Line(out, 2, SectionKey(kPose1Block) + ": " + BlockMap(rig, kPose1Block));
  if (!rig.lip1.color.empty()) Line(out, 2, "lip: " + LipMap(rig.lip1), "flat annulus, mirror-1 frame");
  if (rig.profile1.present) {
    Line(out, 2, SectionKey(kProfile1Block) + ": " + ProfileMap(rig, Mirror::kOne),
         "sag over the conic along +z (mm): docs/formats/model.md");
  }
  *out += MeasuredProfileText(rig, Mirror::kOne);
  if (rig.mount.present) {
    Line(out, 0, "mount: " + MountMap(rig.mount), "posts (square prisms) in that body's frame, mm / deg");
  }
  const ModelDerived derived = ComputeModelDerived(rig);
  Line(out, 0, "derived:", "written for people and other tools; ignored when read");
  Line(out, 2, "focus1_in_cam: " + Vec(derived.focus1_in_cam), "the mirror's near focus");
  Line(out, 2, "axis1_in_cam: " + Vec(derived.axis1_in_cam));
  if (derived.has_far_focus) {
    Line(out, 2, "far_focus1_in_cam: " + Vec(derived.far_focus1_in_cam),
         "a perspective camera is central when this is 0");
  }
}

}  // namespace

RigParams ParseModelText(const std::string& text, const std::string& file) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    // yaml-cpp counts lines and columns from 0.
    throw InputError(file + ": line " + std::to_string(e.mark.line + 1) + ", column " +
                     std::to_string(e.mark.column + 1) + ": expected valid YAML, got " + e.msg);
  }
  const Reader in(file);
  if (!IsMap(root)) in.Fail("format", "expected a YAML map starting with 'format:'", Describe(root));
  CheckFormat(in, root, kFormatPrefix, kFormatMajor);

  RigParams rig;
  const std::string kind = in.String(root, "", "kind");
  if (kind == "ideal") {
    rig.kind = ModelKind::kIdeal;
  } else if (kind == "noncentral") {
    rig.kind = ModelKind::kNoncentral;
  } else {
    in.Fail("kind", "expected 'ideal' or 'noncentral'", Describe(root["kind"]));
  }

  if (root["units"].IsDefined()) {
    const YAML::Node units = in.Map(root, "units", "units");
    if (units["length"].IsDefined() && in.String(units, "units", "length") != "mm") {
      in.Fail("units.length", "expected 'mm' (other units: not supported)", Describe(units["length"]));
    }
    if (units["angle"].IsDefined() && in.String(units, "units", "angle") != "rad") {
      in.Fail("units.angle", "expected 'rad' (degrees only in keys ending _deg)",
              Describe(units["angle"]));
    }
  }

  const YAML::Node image = in.Map(root, "image", "image");
  rig.image_width = in.Integer(image, "image", "width", 1);
  rig.image_height = in.Integer(image, "image", "height", 1);
  ReadRigAndLens(in, root, &rig);
  if (rig.Single()) {
    ReadSingleRig(in, root, file, &rig);
    return rig;
  }

  const YAML::Node camera = SectionMap(in, root, kCameraBlock);
  ReadBlock(in, camera, kCameraBlock, rig.camera.data());
  const YAML::Node dist = SectionMap(in, root, kDistortionBlock);
  const std::string dist_path = kRigBlocks[kDistortionBlock].section;
  const std::string dist_model = in.String(dist, dist_path, "model");
  if (dist_model != "radtan") {
    in.Fail(Join(dist_path, "model"), "expected 'radtan'", Describe(dist["model"]));
  }
  ReadBlock(in, dist, kDistortionBlock, rig.distortion.data());

  // The shapes' c1, c2, then k1, k2, among the design's numbers.
  const YAML::Node design = SectionMap(in, root, kShape1Block);
  for (int i = 0; i < kRigBlocks[kShape1Block].size; ++i) {
    for (RigBlockId block : {kShape1Block, kShape2Block}) {
      BlockIn(&rig, block)[i] =
          ReadParameter(in, design, kRigBlocks[block].section, BlockParameters(block)[i]);
    }
  }
  rig.d = in.Positive(design, "design", "d");
  rig.r_sys = in.Positive(design, "design", "r_sys");
  for (const auto& [name, slot] : {std::pair<const char*, double*>{"r_ref", &rig.r_ref},
                                   std::pair<const char*, double*>{"r_cam", &rig.r_cam}}) {
    *slot = in.Number(design, "design", name);
    if (!(*slot > 0 && *slot < rig.r_sys)) {
      in.Fail(Join("design", name),
              "expected a radius in (0, r_sys) = (0, " + FormatDouble(rig.r_sys) + ")",
              Describe(design[name]));
    }
  }

  const YAML::Node m1 = in.Map(root, "mirror1", "mirror1");
  ReadBlock(in, SectionMap(in, root, kPose1Block), kPose1Block, rig.mirror1_pose.data());
  ReadBlock(in, SectionMap(in, root, kReflexBlock), kReflexBlock, rig.reflex.data());
  rig.lip1 = ReadLip(in, in.Map(m1, "mirror1.lip", "lip"), "mirror1.lip");
  if (m1[SectionKey(kProfile1Block)].IsDefined()) {
    ReadProfile(in, SectionMap(in, root, kProfile1Block), kRigBlocks[kProfile1Block].section, rig,
                Mirror::kOne, &rig.profile1, rig.mirror1_profile.data());
  }
  ReadMeasuredProfile(in, file, m1, Mirror::kOne, {kMaxProfileSagMm, kMaxProfileSlope}, &rig);

  const YAML::Node m2 = in.Map(root, "mirror2", "mirror2");
  ReadBlock(in, SectionMap(in, root, kPose2Block), kPose2Block, rig.mirror2_pose.data());
  rig.lip2 = ReadLip(in, in.Map(m2, "mirror2.lip", "lip"), "mirror2.lip");
  if (m2[SectionKey(kProfile2Block)].IsDefined()) {
    ReadProfile(in, SectionMap(in, root, kProfile2Block), kRigBlocks[kProfile2Block].section, rig,
                Mirror::kTwo, &rig.profile2, rig.mirror2_profile.data());
  }
  ReadMeasuredProfile(in, file, m2, Mirror::kTwo, {kMaxProfileSagMm, kMaxProfileSlope}, &rig);

  if (root["mount"].IsDefined()) rig.mount = ReadMount(in, in.Map(root, "mount", "mount"), rig);
  if (rig.kind == ModelKind::kIdeal) CheckIdeal(in, rig);
  // `derived:` is recomputed from the blocks above, never read back.
  if (root["calibration"].IsDefined()) rig.calibration = ReadCalibration(in, root);
  return rig;
}

RigParams ReadModelFile(const std::string& path) {
  return ParseModelText(ReadWholeFile(path, "model file"), path);
}

namespace {
void WriteFoldedRig(const RigParams& rig, std::string* out);
void WriteCalibration(const CalibrationInfo& cal, std::string* out);
}  // namespace

std::string ModelFileText(const RigParams& rig) {
  std::string out;
  out += rig.Single()
             ? "# omnistereo-model/1: a single-mirror catadioptric camera (a camera looking at one\n"
               "# mirror of any conic: rig: single), written by the omnistereo toolkit.\n"
             : "# omnistereo-model/1: a single-camera folded catadioptric omnistereo rig (camera, two\n"
               "# hyperboloidal mirrors, reflex plane), written by the omnistereo toolkit.\n";
  out +=
      "# Units: mm and rad. Frames (docs/design.md, Conventions): camera C (OpenCV: +z along the optical axis),\n"
      "# mirror bodies M1, M2; cam_from_mirror maps M_i to C with tilt = rotation vector (rx, ry, 0).\n"
      "# Numbers are written to full double precision; `derived:` is for people and other tools\n"
      "# and is ignored when the file is read.\n";
  Line(&out, 0, std::string("format: ") + kFormatPrefix + std::to_string(kFormatMajor));
  Line(&out, 0, std::string("kind: ") + (rig.kind == ModelKind::kIdeal ? "ideal" : "noncentral"),
       "ideal | noncentral  (ideal: every pose below is zero, no distortion)");
  if (rig.Single()) {
    Line(&out, 0, "rig: single", "folded | single  (single: one mirror of any conic, ring 1 only)");
    Line(&out, 0, std::string("lens: ") + LensKindName(rig.lens), "perspective | telecentric");
  }
  Line(&out, 0, "units: {length: mm, angle: rad}");
  Line(&out, 0, "image: {width: " + std::to_string(rig.image_width) +
                    ", height: " + std::to_string(rig.image_height) + "}");
  Line(&out, 0, kRigBlocks[kCameraBlock].section + std::string(":"));
  for (int i = 0; i < kRigBlocks[kCameraBlock].size; ++i) {
    Line(&out, 2, BlockParameters(kCameraBlock)[i].Key() + ": " + Num(rig.camera[i]));
  }
  Line(&out, 2, SectionKey(kDistortionBlock) + ": " + BlockMap(rig, kDistortionBlock, "model: radtan, "));
  if (rig.Single()) {
    WriteSingleRig(rig, &out);
  } else {
    WriteFoldedRig(rig, &out);
  }
  if (rig.calibration) WriteCalibration(*rig.calibration, &out);
  return out;
}

namespace {

// The folded rig's part of a model file (ModelFileText).
void WriteFoldedRig(const RigParams& rig, std::string* out_text) {
  std::string& out = *out_text;
  Line(&out, 0, kRigBlocks[kShape1Block].section + std::string(":"),
       "the paper's primary parameters (mm, unitless k) and physical radii");
  for (int i = 0; i < kRigBlocks[kShape1Block].size; ++i) {
    for (RigBlockId block : {kShape1Block, kShape2Block}) {
      Line(&out, 2, BlockParameters(block)[i].Key() + ": " + Num(BlockIn(rig, block)[i]));
    }
  }
  Line(&out, 2, "d: " + Num(rig.d));
  Line(&out, 2, "r_sys: " + Num(rig.r_sys));
  Line(&out, 2, "r_ref: " + Num(rig.r_ref), "radius of the planar reflex disc");
  Line(&out, 2, "r_cam: " + Num(rig.r_cam), "radius of mirror 2's central hole");
  Line(&out, 0, "mirror1:", "body of mirror 1; the reflex disc is part of it");
  Line(&out, 2, SectionKey(kPose1Block) + ": " + BlockMap(rig, kPose1Block));
  Line(&out, 2, SectionKey(kReflexBlock) + ": " + BlockMap(rig, kReflexBlock),
       "mirror-1 frame: plane through (0,0,d/2+dz), normal exp([rx,ry,0])*(0,0,-1)");
  Line(&out, 2, "lip: " + LipMap(rig.lip1), "flat annulus, mirror-1 frame");
  if (rig.profile1.present) {
    Line(&out, 2, SectionKey(kProfile1Block) + ": " + ProfileMap(rig, Mirror::kOne),
         "sag over the conic along +z (mm): docs/formats/model.md");
  }
  out += MeasuredProfileText(rig, Mirror::kOne);
  Line(&out, 0, "mirror2:");
  Line(&out, 2, SectionKey(kPose2Block) + ": " + BlockMap(rig, kPose2Block));
  Line(&out, 2, "lip: " + LipMap(rig.lip2), "flat annulus, mirror-2 frame");
  if (rig.profile2.present) {
    Line(&out, 2, SectionKey(kProfile2Block) + ": " + ProfileMap(rig, Mirror::kTwo),
         "sag over the conic along +z (mm): docs/formats/model.md");
  }
  out += MeasuredProfileText(rig, Mirror::kTwo);

  if (rig.mount.present) {
    Line(&out, 0, "mount: " + MountMap(rig.mount),
         "posts (square prisms) in that body's frame, mm / deg");
  }

  const ModelDerived derived = ComputeModelDerived(rig);
  Line(&out, 0, "derived:", "written for people and other tools; ignored when read");
  Line(&out, 2, "focus1_in_cam: " + Vec(derived.focus1_in_cam));
  Line(&out, 2, "axis1_in_cam: " + Vec(derived.axis1_in_cam));
  Line(&out, 2, "focus2_in_cam: " + Vec(derived.focus2_in_cam));
  Line(&out, 2, "axis2_in_cam: " + Vec(derived.axis2_in_cam));
  Line(&out, 2, "reflex_point_in_cam: " + Vec(derived.reflex_point_in_cam));
  Line(&out, 2, "reflex_normal_in_cam: " + Vec(derived.reflex_normal_in_cam));
  Line(&out, 2, "baseline: " + Num(derived.baseline), "distance between the two primary foci");
}

// A calibrated model's `calibration:` section (ModelFileText).
void WriteCalibration(const CalibrationInfo& cal, std::string* out_text) {
  std::string& out = *out_text;
  std::vector<std::string> names;
  for (const std::string& name : cal.parameters) names.push_back(Text(name));
  const std::size_t n = std::max<std::size_t>(cal.parameters.size(), 1);
  Line(&out, 0, "calibration:", "what the calibration estimated, and from what");
  Line(&out, 2, "parameters: " + FlowList(names, 2, 8), "names in the order of the covariance");
  Line(&out, 2, "values: " + FlowList(Nums(cal.values), 2, 6));
  Line(&out, 2, "sigma: " + FlowList(Nums(cal.sigma), 2, 6), "standard deviations");
  Line(&out, 2, "covariance:",
       ("row-major, " + std::to_string(cal.parameters.size()) + " x " +
        std::to_string(cal.parameters.size()))
           .c_str());
  // One covariance row per line, as a flow list indented under the key.
  out += "    " + FlowList(Nums(cal.covariance), 2, n) + "\n";
  if (!cal.noise_covariance.empty()) {
    Line(&out, 2, "noise_covariance:",
         "the same from the pixel noise alone, without the considered parameters' share");
    out += "    " + FlowList(Nums(cal.noise_covariance), 2, n) + "\n";
  }
  Line(&out, 2, "residuals: {rms_px: " + Num(cal.rms_px) +
                    ", n_observations: " + std::to_string(cal.n_observations) +
                    ", n_outliers: " + std::to_string(cal.n_outliers) +
                    ", per_mirror_rms_px: " + FlowList(Nums(cal.per_mirror_rms_px), 2, 100) +
                    ", n_rejected: " + std::to_string(cal.n_rejected) +
                    ", n_lip_points: " + std::to_string(cal.n_lip_points) +
                    ", lip_rms_px: " + Num(cal.lip_rms_px) + "}");
  if (!cal.unobservable.empty()) {
    std::vector<std::string> un, hints;
    for (const std::string& name : cal.unobservable) un.push_back(Text(name));
    for (const std::string& hint : cal.unobservable_hints) hints.push_back(Text(hint));
    Line(&out, 2, "unobservable: " + FlowList(un, 2, 8),
         "not determined by the data: no value given");
    Line(&out, 2, "unobservable_hints: " + FlowList(hints, 2, 1), "what data would determine each");
  }
  if (!cal.held_profiles.empty()) {
    Line(&out, 2, "held_profiles:",
         "profiles held, not refined: the prior (machining tolerance or scan, mm^2) and what the "
         "data tell of the terms (1/mm^2), each 6 x 6 row-major");
    for (const HeldProfileInfo& held : cal.held_profiles) {
      std::string item = "- {mirror: " + std::to_string(held.mirror) + ", prior: " + held.prior +
                         ", r_min: " + Num(held.r_min) + ", r_max: " + Num(held.r_max) +
                         ",\n      prior_covariance: " + FlowList(Nums(held.prior_covariance), 6, 6);
      if (!held.data_information.empty()) {
        item += ",\n      data_information: " + FlowList(Nums(held.data_information), 6, 6);
      }
      Line(&out, 4, item + "}");
    }
  }
  if (!cal.lip_reference.empty()) {
    Line(&out, 2, "lip_reference:",
         "the health check's lip bins on the calibration photos under this model: `check` "
         "measures change from them");
    Line(&out, 4, "azimuth_bins: " + std::to_string(cal.lip_reference_sectors));
    if (cal.lip_reference_rim_scene_px > 0) {
      Line(&out, 4, "rim_scene_px: " + Num(cal.lip_reference_rim_scene_px),
           "what one photo's scene moves the rim's edge by as a whole (its scale, shift, tilt)");
    }
    if (cal.lip_reference_edge_radius > 0) {
      Line(&out, 4, "edge_radius: " + Num(cal.lip_reference_edge_radius),
           "mm: the mirror circle the image's edge is (not its rim), at this model's scale");
    }
    Line(&out, 4, "bins:", "mean_px: the edge detector's bias there; scatter_px: of one photo's");
    for (const LipReferenceBin& bin : cal.lip_reference) {
      Line(&out, 6, "- {edge: " + Text(bin.edge) + ", azimuth_deg: " + Num(bin.azimuth_deg) +
                        ", photos: " + std::to_string(bin.photos) + ", mean_px: " +
                        Num(bin.mean_px) + ", scatter_px: " + Num(bin.scatter_px) + "}");
    }
  }
  Line(&out, 2, "dataset: {session: " + Text(cal.session) + ", images: " +
                    std::to_string(cal.images) + ", targets: " + Text(cal.targets) + "}");
  Line(&out, 2, "tool_version: " + Text(cal.tool_version));
  Line(&out, 2, "date: " + Text(cal.date));
}

}  // namespace

void WriteModelFile(const std::string& path, const RigParams& rig) {
  const std::string text = ModelFileText(rig);
  // Never write a file this program would refuse to read: parse the text back first.
  try {
    ParseModelText(text, path);
  } catch (const InputError& e) {
    throw std::runtime_error("cannot write '" + path + "': the model is invalid: " + e.what());
  }
  WriteFileAtomically(path, text);
}

}  // namespace omni::io
