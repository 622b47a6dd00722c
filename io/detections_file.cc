#include "io/detections_file.h"

#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>

#include "io/yaml_reader.h"

namespace omni::io {
namespace {

constexpr char kFormatPrefix[] = "omnistereo-detections/";
constexpr int kFormatMajor = 1;

namespace fs = std::filesystem;

// `path` relative to `base_dir` when it lies below it, else as given.
std::string RelativeTo(const std::string& path, const fs::path& base_dir) {
  std::error_code ec;
  const fs::path abs = fs::absolute(path, ec), base = fs::absolute(base_dir, ec);
  const fs::path rel = abs.lexically_normal().lexically_relative(base.lexically_normal());
  if (rel.empty() || *rel.begin() == "..") return path;
  return rel.string();
}

int IntegerAt(const Reader& in, const YAML::Node& row, std::size_t i, const std::string& key,
              int min) {
  const double v = in.Number(row[i], key + "[" + std::to_string(i) + "]");
  // Range first: casting a double beyond int's range is undefined behaviour.
  if (!(v >= min && v <= std::numeric_limits<int>::max()) || v != std::floor(v)) {
    in.Fail(key + "[" + std::to_string(i) + "]", "expected an integer >= " + std::to_string(min),
            Describe(row[i]));
  }
  return static_cast<int>(v);
}

Eigen::Vector2d Point(const Reader& in, const YAML::Node& node, const std::string& key) {
  if (!IsSequence(node) || node.size() != 2) in.Fail(key, "expected [u, v]", Describe(node));
  return Eigen::Vector2d(in.Number(node[0], key + "[0]"), in.Number(node[1], key + "[1]"));
}

CornerObservation ReadCorner(const Reader& in, const YAML::Node& row, const std::string& key) {
  if (!IsSequence(row) || row.size() != 5) {
    in.Fail(key, "expected [target, corner id, mirror, u, v]", Describe(row));
  }
  CornerObservation c;
  c.target = IntegerAt(in, row, 0, key, 0);
  c.id = IntegerAt(in, row, 1, key, 0);
  const int mirror = IntegerAt(in, row, 2, key, 1);
  if (mirror > 2) in.Fail(key + "[2]", "expected mirror 1 or 2", Describe(row[2]));
  c.mirror = mirror == 1 ? Mirror::kOne : Mirror::kTwo;
  c.pixel = Eigen::Vector2d(in.Number(row[3], key + "[3]"), in.Number(row[4], key + "[4]"));
  return c;
}

LipEdgeObservation ReadLip(const Reader& in, const YAML::Node& node, const std::string& key) {
  if (!IsMap(node)) in.Fail(key, "expected {mirror, edge, points}", Describe(node));
  LipEdgeObservation lip;
  const int mirror = in.Integer(node, key, "mirror", 1);
  if (mirror > 2) in.Fail(Join(key, "mirror"), "expected 1 or 2", Describe(node["mirror"]));
  lip.mirror = mirror == 1 ? Mirror::kOne : Mirror::kTwo;
  if (!ParseBandEdge(in.String(node, key, "edge"), &lip.edge)) {
    in.Fail(Join(key, "edge"), "expected inner or outer", Describe(node["edge"]));
  }
  if (node["circle"].IsDefined()) {
    LipCircle circle;
    if (!ParseLipCircle(in.String(node, key, "circle"), &circle)) {
      in.Fail(Join(key, "circle"), "expected r_inner or r_outer", Describe(node["circle"]));
    }
    lip.circle = circle;
  }
  if (node["path"].IsDefined()) {
    LipPath path;
    if (!ParseLipPath(in.String(node, key, "path"), &path)) {
      in.Fail(Join(key, "path"), "expected direct, via_mirror1, via_reflex or via_mirror2",
              Describe(node["path"]));
    }
    if (LipOwner(path) != lip.mirror) {
      in.Fail(Join(key, "path"),
              std::string("expected a path imaging mirror ") + std::to_string(mirror) +
                  "'s lip (" + LipPathName(path) + " images mirror " +
                  std::to_string(MirrorIndex(LipOwner(path))) + "'s)",
              Describe(node["path"]));
    }
    lip.path = path;
  }
  const YAML::Node points = node["points"];
  const std::string pkey = Join(key, "points");
  if (!IsSequence(points)) in.Fail(pkey, "expected a list of [u, v]", Describe(points));
  for (std::size_t i = 0; i < points.size(); ++i) {
    lip.points.push_back(Point(in, points[i], pkey + "[" + std::to_string(i) + "]"));
  }
  return lip;
}

}  // namespace

Observations ReadDetectionsFile(const std::string& path) {
  const YAML::Node root = LoadYamlFile(path, "detections file");
  const Reader in(path);
  if (!IsMap(root)) in.Fail("format", "expected a YAML map starting with 'format:'", Describe(root));
  CheckFormat(in, root, kFormatPrefix, kFormatMajor);
  Observations d;
  if (root["session"].IsDefined()) d.session = in.String(root, "", "session");
  const YAML::Node images = root["images"];
  if (!IsSequence(images)) in.Fail("images", "expected a list of images", Describe(images));
  for (std::size_t i = 0; i < images.size(); ++i) {
    const std::string key = "images[" + std::to_string(i) + "]";
    const YAML::Node node = images[i];
    if (!IsMap(node)) in.Fail(key, "expected {file, width, height, corners, lips}", Describe(node));
    ImageObservations image;
    image.file = in.String(node, key, "file");
    image.width = in.Integer(node, key, "width", 1);
    image.height = in.Integer(node, key, "height", 1);
    const YAML::Node corners = node["corners"];
    if (corners.IsDefined() && !corners.IsNull()) {
      const std::string ckey = Join(key, "corners");
      if (!IsSequence(corners)) in.Fail(ckey, "expected a list of corner rows", Describe(corners));
      image.corners.reserve(corners.size());
      for (std::size_t k = 0; k < corners.size(); ++k) {
        image.corners.push_back(ReadCorner(in, corners[k], ckey + "[" + std::to_string(k) + "]"));
      }
    }
    const YAML::Node lips = node["lips"];
    if (lips.IsDefined() && !lips.IsNull()) {
      const std::string lkey = Join(key, "lips");
      if (!IsSequence(lips)) in.Fail(lkey, "expected a list of lip edges", Describe(lips));
      for (std::size_t k = 0; k < lips.size(); ++k) {
        image.lips.push_back(ReadLip(in, lips[k], lkey + "[" + std::to_string(k) + "]"));
      }
    }
    d.images.push_back(std::move(image));
  }
  return d;
}

std::string DetectionsText(const Observations& d) {
  std::ostringstream out;
  auto quote = [](const std::string& s) {
    std::string q = "\"";
    for (char c : s) {
      if (c == '"' || c == '\\') q += '\\';
      q += c;
    }
    return q + "\"";
  };
  out << "format: omnistereo-detections/1\n";
  if (!d.session.empty()) out << "session: " << quote(d.session) << "\n";
  out << "images:" << (d.images.empty() ? " []" : "") << "\n";
  for (const ImageObservations& image : d.images) {
    out << "  - file: " << quote(image.file) << "\n";
    out << "    width: " << image.width << "\n    height: " << image.height << "\n";
    out << "    # [target, corner id, mirror, u, v]\n";
    out << "    corners:" << (image.corners.empty() ? " []" : "") << "\n";
    for (const CornerObservation& c : image.corners) {
      out << "      - [" << c.target << ", " << c.id << ", " << MirrorIndex(c.mirror) << ", "
          << FormatDouble(c.pixel.x()) << ", " << FormatDouble(c.pixel.y()) << "]\n";
    }
    out << "    lips:" << (image.lips.empty() ? " []" : "") << "\n";
    for (const LipEdgeObservation& lip : image.lips) {
      out << "      - {mirror: " << MirrorIndex(lip.mirror) << ", edge: " << BandEdgeName(lip.edge);
      if (lip.circle) out << ", circle: " << LipCircleName(*lip.circle);
      if (lip.path) out << ", path: " << LipPathName(*lip.path);
      out << ", points: [";
      for (std::size_t i = 0; i < lip.points.size(); ++i) {
        out << (i ? ", " : "") << "[" << FormatDouble(lip.points[i].x()) << ", "
            << FormatDouble(lip.points[i].y()) << "]";
      }
      out << "]}\n";
    }
  }
  return out.str();
}

void WriteDetectionsFile(const std::string& path, const Observations& detections) {
  WriteFileAtomically(path, DetectionsText(detections));
}

Observations WithPathsRelativeToFile(Observations detections, const std::string& path) {
  const fs::path folder = fs::absolute(path).parent_path();
  for (ImageObservations& image : detections.images) image.file = RelativeTo(image.file, folder);
  detections.session = RelativeTo(detections.session, folder);
  return detections;
}

std::vector<std::string> ImagePathsOf(const Observations& detections, const std::string& path,
                                      const std::vector<std::string>& fallback) {
  std::vector<std::string> out;
  const fs::path base = fs::path(path).parent_path();
  for (size_t i = 0; i < detections.images.size(); ++i) {
    const std::string& file = detections.images[i].file;
    std::string found = i < fallback.size() ? fallback[i] : file;
    for (const fs::path& candidate : {fs::path(file), base / file}) {
      if (fs::is_regular_file(candidate)) {
        found = candidate.string();
        break;
      }
    }
    out.push_back(found);
  }
  return out;
}

}  // namespace omni::io
