#include "synthetic/scene_file.h"

#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>

#include <Eigen/Geometry>
#include <yaml-cpp/yaml.h>

#include "io/file_util.h"
#include "synthetic/tag_texture.h"

namespace omni::synthetic {
namespace {

using io::InputError;

[[noreturn]] void Fail(const std::string& file, const std::string& key, const std::string& what) {
  throw InputError(file + ": " + key + ": " + what);
}

double Number(const YAML::Node& node, const std::string& file, const std::string& key) {
  if (!node || !node.IsScalar()) Fail(file, key, "expected a number");
  double v = 0;
  if (!io::ParseDouble(node.Scalar(), &v) || !std::isfinite(v)) {
    Fail(file, key, "expected a finite number, got '" + node.Scalar() + "'");
  }
  return v;
}

double NumberOr(const YAML::Node& node, const std::string& file, const std::string& key, double d) {
  return node ? Number(node, file, key) : d;
}

bool BoolOr(const YAML::Node& node, const std::string& file, const std::string& key, bool d) {
  if (!node) return d;
  bool value = d;
  if (!node.IsScalar() || !YAML::convert<bool>::decode(node, value)) {
    Fail(file, key, "expected true or false" +
                        (node.IsScalar() ? ", got '" + node.Scalar() + "'" : std::string()));
  }
  return value;
}

Eigen::Vector3d Vec3(const YAML::Node& node, const std::string& file, const std::string& key) {
  if (!node || !node.IsSequence() || node.size() != 3) Fail(file, key, "expected [x, y, z]");
  return Eigen::Vector3d(Number(node[0], file, key), Number(node[1], file, key),
                         Number(node[2], file, key));
}

// A whole number that fits the integer it goes into (a cast from a double out of range is
// undefined behaviour: scripts/fuzz.sh's fuzz_scene found image.width 9.6e29).
long WholeNumber(const YAML::Node& node, const std::string& file, const std::string& key,
                 long lo, long hi) {
  const double v = Number(node, file, key);
  if (v != std::floor(v) || v < static_cast<double>(lo) || v > static_cast<double>(hi)) {
    Fail(file, key, "expected a whole number from " + std::to_string(lo) + " to " +
                        std::to_string(hi) + ", got '" + node.Scalar() + "'");
  }
  return static_cast<long>(v);
}

int Int(const YAML::Node& node, const std::string& file, const std::string& key) {
  return static_cast<int>(WholeNumber(node, file, key, std::numeric_limits<int>::min(),
                                      std::numeric_limits<int>::max()));
}

unsigned SeedOr(const YAML::Node& node, const std::string& file, const std::string& key,
                unsigned d) {
  return node ? static_cast<unsigned>(
                    WholeNumber(node, file, key, 0, std::numeric_limits<unsigned>::max()))
              : d;
}

// One entry of `targets:` with the session file's keys (io/session_file.h):
// {type: chessboard, rows, cols, square} | {type: apriltag_grid, family: tag36h11, rows, cols,
// tag_size, spacing, first_id} | {type: kalibr_aprilgrid, rows, cols, tag_size, spacing, first_id}.
TargetSpec ReadTarget(const YAML::Node& node, const std::string& file, const std::string& key) {
  if (!node.IsMap()) Fail(file, key, "expected a map {type: ..., rows: ..., cols: ...}");
  TargetSpec t;
  const std::string type = node["type"] && node["type"].IsScalar() ? node["type"].Scalar() : "";
  if (!ParseTargetType(type, &t.type)) {
    Fail(file, key + ".type",
         "expected chessboard, apriltag_grid or kalibr_aprilgrid, got '" + type + "'");
  }
  t.rows = Int(node["rows"], file, key + ".rows");
  t.cols = Int(node["cols"], file, key + ".cols");
  if (t.type == TargetType::kChessboard) {
    t.square_mm = Number(node["square"], file, key + ".square");
    if (t.rows < 2 || t.cols < 2 || t.square_mm <= 0) {
      Fail(file, key, "expected rows, cols >= 2 (inner corners) and square > 0 (mm)");
    }
    return t;
  }
  if (node["family"]) {
    t.family = node["family"].IsScalar() ? node["family"].Scalar() : "";
  }
  t.tag_size_mm = Number(node["tag_size"], file, key + ".tag_size");
  t.spacing = Number(node["spacing"], file, key + ".spacing");
  t.first_id = node["first_id"] ? Int(node["first_id"], file, key + ".first_id") : 0;
  std::string error;
  if (!CheckTagGrid(t, &error)) Fail(file, key, error);
  return t;
}

// `camera_effects:` as a preset name, or a map {preset: NAME, key: value...} whose keys override
// the preset's (camera_effects.h; the preset defaults to clean).
CameraEffects ReadCameraEffects(const YAML::Node& node, const std::string& file) {
  const std::string key = "camera_effects";
  const auto preset = [&](const std::string& name) {
    const auto e = CameraPreset(name);
    if (!e) {
      std::string names;
      for (const auto& n : CameraPresetNames()) names += (names.empty() ? "" : ", ") + n;
      Fail(file, key, "expected a preset (" + names + ") or a map of effects, got '" + name + "'");
    }
    return *e;
  };
  if (node.IsScalar()) return preset(node.Scalar());
  if (!node.IsMap()) Fail(file, key, "expected a preset name or a map {preset: ..., defocus_sigma_px: [outer, inner], ...}");
  CameraEffects e = preset(node["preset"] && node["preset"].IsScalar() ? node["preset"].Scalar() : "clean");
  const std::string prefix = key + ".";
  for (const auto& kv : node) {
    const std::string k = kv.first.Scalar();
    const YAML::Node& v = kv.second;
    if (k == "preset") continue;
    if (k == "defocus_sigma_px") {
      if (v.IsSequence() && v.size() == 2) {
        e.defocus_sigma_px[0] = Number(v[0], file, prefix + k);
        e.defocus_sigma_px[1] = Number(v[1], file, prefix + k);
      } else {
        e.defocus_sigma_px[0] = e.defocus_sigma_px[1] = Number(v, file, prefix + k);
      }
    } else if (k == "vignetting") {
      e.vignetting = Number(v, file, prefix + k);
    } else if (k == "exposure") {
      e.exposure = Number(v, file, prefix + k);
    } else if (k == "bayer") {
      const auto b = io::ParseBayerPattern(v.IsScalar() ? v.Scalar() : "?");
      if (!b) Fail(file, prefix + k, "expected RGGB, BGGR, GRBG, GBRG or none");
      e.bayer = *b;
    } else if (k == "demosaic") {
      const auto d = io::ParseDemosaic(v.IsScalar() ? v.Scalar() : "?");
      if (!d) Fail(file, prefix + k, "expected bilinear, edge_aware or vng");
      e.demosaic = *d;
    } else if (k == "full_well_e") {
      e.full_well_e = Number(v, file, prefix + k);
    } else if (k == "read_noise") {
      e.read_noise = Number(v, file, prefix + k);
    } else if (k == "tone") {
      const std::string t = v.IsScalar() ? v.Scalar() : "";
      if (t != "srgb" && t != "linear") Fail(file, prefix + k, "expected srgb or linear");
      e.tone = t == "srgb" ? ToneCurve::kSrgb : ToneCurve::kLinear;
    } else if (k == "bits") {
      e.bits = Int(v, file, prefix + k);
    } else if (k == "jpeg_quality") {
      e.jpeg_quality = Int(v, file, prefix + k);
    } else if (k == "raw_mosaic") {
      if (!v.IsScalar() || (v.Scalar() != "true" && v.Scalar() != "false")) {
        Fail(file, prefix + k, "expected true or false");
      }
      e.raw_mosaic = v.Scalar() == "true";
    } else {
      Fail(file, prefix + k,
           "unknown key (expected preset, defocus_sigma_px, vignetting, exposure, bayer, demosaic, "
           "full_well_e, read_noise, tone, bits, jpeg_quality, raw_mosaic)");
    }
  }
  if (const std::string error = e.Check(); !error.empty()) Fail(file, prefix + error.substr(0, error.find(':')), error.substr(error.find(':') + 2));
  return e;
}

// The session file's text of a target definition.
std::string TargetText(const TargetSpec& t) {
  auto num = [](double v) { return io::FormatDouble(v); };
  std::ostringstream out;
  out << "{type: " << TargetTypeName(t.type);
  if (t.type == TargetType::kAprilTagGrid) out << ", family: " << t.family;
  out << ", rows: " << t.rows << ", cols: " << t.cols;
  if (t.type == TargetType::kChessboard) {
    out << ", square: " << num(t.square_mm) << "}";
  } else {
    out << ", tag_size: " << num(t.tag_size_mm) << ", spacing: " << num(t.spacing)
        << ", first_id: " << t.first_id << "}";
  }
  return out.str();
}

}  // namespace

CameraEffects ParseCameraEffects(const std::string& text, const std::string& what) {
  YAML::Node node;
  try {
    node = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(what + ": malformed YAML: " + e.what());
  }
  return ReadCameraEffects(node, what);
}

namespace {

// A section that must be a map ({key: value, ...}) where it is given.
void ExpectMap(const YAML::Node& root, const std::string& path, const char* key) {
  if (root[key] && !root[key].IsMap()) Fail(path, key, "expected a map {name: value, ...}");
}

Scene ParseScene(const YAML::Node& root, const std::string& path, const RigModel& model);

}  // namespace

Scene ReadSceneFile(const std::string& path, const RigModel& model) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw InputError(path + ": cannot read the file");
  } catch (const YAML::Exception& e) {
    throw InputError(path + ": malformed YAML: " + e.what());
  }
  // Entries of an unexpected shape deep inside (a scalar where a list or map belongs) that the
  // checks below do not name reach yaml-cpp's own error, which gives the line and column.
  try {
    return ParseScene(root, path, model);
  } catch (const YAML::Exception& e) {
    std::string what = e.what();
    const std::string prefix = "yaml-cpp: error at ";
    if (what.rfind(prefix, 0) == 0) what = what.substr(prefix.size());
    throw InputError(path + ": " + what + " (an entry of the wrong shape: a list or map expected?)");
  }
}

namespace {

// The scene's sections, each read into `s` (the file's key names in every message).
void ReadImageSection(const YAML::Node& img, const std::string& path, const RigModel& model,
                      Scene* s) {
  s->width = Int(img["width"], path, "image.width");
  s->height = Int(img["height"], path, "image.height");
  if (s->width <= 0 || s->height <= 0) Fail(path, "image", "expected positive width and height");
  const RigParams& rig = model.params();
  if (static_cast<long>(s->width) * rig.image_height != static_cast<long>(s->height) * rig.image_width) {
    Fail(path, "image", "expected the model's aspect ratio " + std::to_string(rig.image_width) +
                            ":" + std::to_string(rig.image_height));
  }
}

void ReadRoomSection(const YAML::Node& room, const std::string& path, Scene* s) {
  s->room = BoolOr(room["enabled"], path, "room.enabled", true);
  s->room_half_size_mm = NumberOr(room["half_size"], path, "room.half_size", s->room_half_size_mm);
  s->room_floor_mm = NumberOr(room["floor"], path, "room.floor", s->room_floor_mm);
  s->room_ceiling_mm = NumberOr(room["ceiling"], path, "room.ceiling", s->room_ceiling_mm);
  if (const auto texture = room["texture"]) {
    const std::string t = texture.Scalar();
    if (t != "granite" && t != "plain") Fail(path, "room.texture", "expected granite or plain");
    s->room_plain = t == "plain";
  }
  s->room_texture_seed = SeedOr(room["texture_seed"], path, "room.texture_seed", 0);
}

// `images`: each image's name (default its number, 0001...) and its target placements.
void ReadImagesSection(const YAML::Node& images, const std::string& path, Scene* s) {
  for (size_t i = 0; i < images.size(); ++i) {
    const std::string key = "images[" + std::to_string(i) + "]";
    SceneImage image;
    char name[32];
    std::snprintf(name, sizeof(name), "%04d", static_cast<int>(i) + 1);
    image.name = images[i]["name"] ? images[i]["name"].Scalar() : name;
    for (size_t k = 0; images[i]["placements"] && k < images[i]["placements"].size(); ++k) {
      const auto pn = images[i]["placements"][k];
      const std::string pk = key + ".placements[" + std::to_string(k) + "]";
      Placement p;
      p.target = Int(pn["target"], path, pk + ".target");
      if (p.target < 0 || p.target >= static_cast<int>(s->targets.size())) {
        Fail(path, pk + ".target", "expected an index into targets");
      }
      const Eigen::Vector3d w = Vec3(pn["rotation"], path, pk + ".rotation");
      p.cam_from_target_rotation =
          w.norm() > 0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                       : Eigen::Matrix3d::Identity();
      p.cam_from_target_translation = Vec3(pn["translation"], path, pk + ".translation");
      image.placements.push_back(p);
    }
    s->images.push_back(image);
  }
}

// `random`: images of randomly placed targets (synthetic/scene.h AddRandomImages).
void ReadRandomSection(const YAML::Node& r, const std::string& path, const RigModel& model,
                       Scene* s) {
  RandomPlacement rp;
  // A bound, so that a typo cannot make the parser place millions of images (scripts/fuzz.sh's
  // fuzz_scene: images 25601 took > 10 s before rendering anything); a session is ~10-50.
  constexpr long kMaxRandomImages = 1000;
  rp.images = static_cast<int>(WholeNumber(r["images"], path, "random.images", 0, kMaxRandomImages));
  if (r["targets"]) {
    rp.targets_min = Int(r["targets"][0], path, "random.targets");
    rp.targets_max = Int(r["targets"][1], path, "random.targets");
  }
  if (r["range"]) {
    rp.range_min_mm = Number(r["range"][0], path, "random.range");
    rp.range_max_mm = Number(r["range"][1], path, "random.range");
  }
  if (const auto tr = r["target_ranges"]) {
    if (!tr.IsSequence() || tr.size() != s->targets.size()) {
      Fail(path, "random.target_ranges", "expected one [min, max] (mm) per target, " +
                                             std::to_string(s->targets.size()) + " in all");
    }
    for (size_t k = 0; k < tr.size(); ++k) {
      const std::string key = "random.target_ranges[" + std::to_string(k) + "]";
      if (!tr[k].IsSequence() || tr[k].size() != 2) Fail(path, key, "expected [min, max] in mm");
      const double lo = Number(tr[k][0], path, key), hi = Number(tr[k][1], path, key);
      if (!(lo > 0 && lo <= hi)) Fail(path, key, "expected 0 < min <= max");
      rp.target_ranges_mm.emplace_back(lo, hi);
    }
  }
  rp.max_tilt_rad = NumberOr(r["max_tilt_deg"], path, "random.max_tilt_deg", 20.0) * M_PI / 180;
  rp.seed = SeedOr(r["seed"], path, "random.seed", 1);
  if (rp.images < 0 || rp.targets_min < 1 || rp.targets_max < rp.targets_min ||
      rp.range_min_mm <= 0 || rp.range_max_mm < rp.range_min_mm) {
    Fail(path, "random", "expected images >= 0, 1 <= targets[0] <= targets[1], 0 < range[0] <= range[1]");
  }
  std::string error;
  if (!AddRandomImages(model, rp, s, &error)) Fail(path, "random", error);
}

// `rings`: one image of chessboards in rings at the given ranges (synthetic/scene.h AddRingImage).
void ReadRingsSection(const YAML::Node& r, const std::string& path, const RigModel& model,
                      Scene* s) {
  RingPlacement rp;
  if (!r["ranges"] || !r["ranges"].IsSequence() || r["ranges"].size() == 0) {
    Fail(path, "rings.ranges", "expected a list of horizontal ranges in mm");
  }
  for (size_t i = 0; i < r["ranges"].size(); ++i) {
    rp.ranges_mm.push_back(Number(r["ranges"][i], path, "rings.ranges"));
    if (rp.ranges_mm.back() <= 0) Fail(path, "rings.ranges", "expected ranges > 0");
  }
  rp.per_range = r["per_range"] ? Int(r["per_range"], path, "rings.per_range") : 4;
  rp.rows = r["rows"] ? Int(r["rows"], path, "rings.rows") : 4;
  rp.cols = r["cols"] ? Int(r["cols"], path, "rings.cols") : 5;
  rp.square_at_1m_mm = NumberOr(r["square_at_1m"], path, "rings.square_at_1m", 40.0);
  if (rp.per_range < 1 || rp.rows < 2 || rp.cols < 2 || rp.square_at_1m_mm <= 0) {
    Fail(path, "rings", "expected per_range >= 1, rows, cols >= 2, square_at_1m > 0");
  }
  AddRingImage(model, rp, s);
}

Scene ParseScene(const YAML::Node& root, const std::string& path, const RigModel& model) {
  if (!root.IsMap()) Fail(path, "format", "expected a YAML mapping with format: omnistereo-scene/1");
  for (const char* key : {"image", "render", "room", "random", "rings", "posts"}) ExpectMap(root, path, key);
  const std::string format = root["format"] && root["format"].IsScalar() ? root["format"].Scalar() : "";
  if (format.rfind("omnistereo-scene/1", 0) != 0) {
    Fail(path, "format", "expected omnistereo-scene/1, got '" + format + "'");
  }
  Scene s;
  if (const auto img = root["image"]) ReadImageSection(img, path, model, &s);
  if (const auto r = root["render"]) {
    s.antialias = BoolOr(r["antialias"], path, "render.antialias", s.antialias);
    s.noise_sigma = NumberOr(r["noise_sigma"], path, "render.noise_sigma", 0.0);
    if (s.noise_sigma < 0) Fail(path, "render.noise_sigma", "expected >= 0");
    s.noise_seed = SeedOr(r["noise_seed"], path, "render.noise_seed", 1);
  }
  if (const auto camera = root["camera_effects"]) {
    s.camera = ReadCameraEffects(camera, path);
    if (!s.camera.IsClean() && s.noise_sigma > 0) {
      Fail(path, "render.noise_sigma",
           "expected 0 with camera_effects (their full_well_e and read_noise model the sensor's noise)");
    }
  }
  if (const auto room = root["room"]) ReadRoomSection(room, path, &s);
  if (const auto posts = root["posts"]) {
    s.post_grey = NumberOr(posts["grey"], path, "posts.grey", s.post_grey);
    if (!(s.post_grey >= 0 && s.post_grey <= 1)) Fail(path, "posts.grey", "expected a grey level in [0, 1]");
  }
  if (const auto targets = root["targets"]) {
    if (!targets.IsSequence()) Fail(path, "targets", "expected a list of target definitions");
    for (size_t i = 0; i < targets.size(); ++i) {
      s.targets.push_back(ReadTarget(targets[i], path, "targets[" + std::to_string(i) + "]"));
    }
  }
  if (const auto images = root["images"]) ReadImagesSection(images, path, &s);
  if (const auto m = root["markers"]) {
    for (size_t i = 0; i < m.size(); ++i) {
      const std::string key = "markers[" + std::to_string(i) + "]";
      s.markers.push_back({Vec3(m[i]["center"], path, key + ".center"),
                           Number(m[i]["radius"], path, key + ".radius")});
    }
  }
  if (const auto r = root["random"]) ReadRandomSection(r, path, model, &s);
  if (const auto r = root["rings"]) ReadRingsSection(r, path, model, &s);
  if (s.images.empty() && s.markers.empty()) Fail(path, "images", "expected images, random or markers");
  if (s.images.empty()) s.images.push_back(SceneImage{"0001", {}});
  return s;
}

}  // namespace

std::string TruthText(const Scene& scene, const RigModel& model, const std::string& model_file) {
  auto num = [](double v) { return io::FormatDouble(v); };
  std::ostringstream out;
  out << "# Ground truth of a synthetic session: exact pixels from our model (null: not visible).\n"
      << "format: omnistereo-truth/1\n"
      << "model: " << model_file << "\n"
      << "targets:\n";
  for (const auto& t : scene.targets) out << "  - " << TargetText(t) << "\n";
  out << "# Lips: each flat annulus as its two boundary circles in C (mirror pose applied): centre,\n"
      << "# unit normal (the mirror body's +z), radii in mm.\n"
      << "lips:\n";
  for (const LipTruth& lip : LipsInCam(model.params())) {
    auto vec = [&](const Eigen::Vector3d& v) {
      return "[" + num(v.x()) + ", " + num(v.y()) + ", " + num(v.z()) + "]";
    };
    // Paints are names or "#rrggbb" (model/lip.h); unquoted, YAML would read # as a comment.
    const std::string color = lip.color[0] == '#' ? "\"" + lip.color + "\"" : lip.color;
    out << "  - {mirror: " << lip.mirror << ", color: " << color
        << ", centre: " << vec(lip.centre_in_cam) << ", normal: " << vec(lip.normal_in_cam)
        << ", r_inner: " << num(lip.r_inner) << ", r_outer: " << num(lip.r_outer) << "}\n";
  }
  out << "images:\n";
  for (const auto& image : scene.images) {
    out << "  - file: " << image.name << ImageExtension(scene.camera) << "\n    placements:\n";
    for (const auto& p : image.placements) {
      const Eigen::AngleAxisd aa(p.cam_from_target_rotation);
      const Eigen::Vector3d w = aa.angle() * aa.axis();
      out << "      - {target: " << p.target << ", rotation: [" << num(w.x()) << ", "
          << num(w.y()) << ", " << num(w.z()) << "], translation: ["
          << num(p.cam_from_target_translation.x()) << ", "
          << num(p.cam_from_target_translation.y()) << ", "
          << num(p.cam_from_target_translation.z()) << "]}\n";
    }
    out << "    # [placement, target, corner id, x, y, z (mm, C), u1, v1, u2, v2]\n"
        << "    corners:\n";
    for (const auto& c : ComputeTruth(model, scene, image)) {
      out << "      - [" << c.placement << ", " << c.target << ", " << c.id << ", "
          << num(c.point_in_cam.x()) << ", " << num(c.point_in_cam.y()) << ", "
          << num(c.point_in_cam.z());
      for (const auto& px : c.pixel) {
        if (px) out << ", " << num(px->x()) << ", " << num(px->y());
        else out << ", null, null";
      }
      out << "]\n";
    }
  }
  return out.str();
}

std::optional<CameraEffects> CameraFromEnvironment(const char* variable) {
  const char* text = std::getenv(variable);
  if (text == nullptr) return std::nullopt;
  return ParseCameraEffects(text, variable);
}

}  // namespace omni::synthetic
