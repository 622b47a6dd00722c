#include "io/truth_file.h"

#include "io/csv.h"
#include "io/yaml_reader.h"

namespace omni::io {

Truth ReadTruthFile(const std::string& path) {
  const Reader in(path);
  const YAML::Node root = LoadYamlFile(path, "truth file (omnistereo-truth/1)");
  CheckFormat(in, root, "omnistereo-truth/", 1);
  Truth truth;
  if (IsScalar(root["model"])) truth.model = root["model"].Scalar();
  const YAML::Node images = root["images"];
  if (!IsSequence(images)) in.Fail("images", "expected a list of images", Describe(images));
  for (std::size_t i = 0; i < images.size(); ++i) {
    const std::string key = "images[" + std::to_string(i) + "]";
    const YAML::Node image = images[i];
    if (!IsMap(image)) in.Fail(key, "expected a map", Describe(image));
    TruthImage out;
    out.file = in.String(image, key, "file");
    const YAML::Node placements = image["placements"];
    if (!IsSequence(placements)) {
      in.Fail(key + ".placements", "expected a list", Describe(placements));
    }
    for (std::size_t p = 0; p < placements.size(); ++p) {
      const std::string pkey = key + ".placements[" + std::to_string(p) + "]";
      const std::vector<double> t = in.Numbers(placements[p], pkey, "translation");
      if (t.size() != 3) in.Fail(pkey + ".translation", "expected 3 numbers", "another count");
      out.placement_translation.emplace_back(t[0], t[1], t[2]);
    }
    const YAML::Node corners = image["corners"];
    if (corners.IsDefined() && !corners.IsNull()) {
      if (!corners.IsSequence()) in.Fail(key + ".corners", "expected a list", Describe(corners));
      for (std::size_t c = 0; c < corners.size(); ++c) {
        const std::string ckey = key + ".corners[" + std::to_string(c) + "]";
        const YAML::Node row = corners[c];
        if (!IsSequence(row) || row.size() != 10) {
          in.Fail(ckey, "expected [placement, target, id, x, y, z, u1, v1, u2, v2]",
                  Describe(row));
        }
        TruthCorner tc;
        tc.placement = static_cast<int>(in.Number(row[0], ckey + "[0]"));
        tc.target = static_cast<int>(in.Number(row[1], ckey + "[1]"));
        tc.id = static_cast<int>(in.Number(row[2], ckey + "[2]"));
        if (tc.placement < 0 || tc.placement >= static_cast<int>(out.placement_translation.size())) {
          in.Fail(ckey + "[0]", "expected a placement index of this image", Describe(row[0]));
        }
        for (int k = 0; k < 3; ++k) {
          tc.point_in_cam[k] = in.Number(row[3 + k], ckey + "[" + std::to_string(3 + k) + "]");
        }
        for (int m = 0; m < 2; ++m) {
          const YAML::Node u = row[6 + 2 * m], v = row[7 + 2 * m];
          if (u.IsNull() || v.IsNull()) continue;
          tc.pixel[m] = Eigen::Vector2d(in.Number(u, ckey + "[" + std::to_string(6 + 2 * m) + "]"),
                                        in.Number(v, ckey + "[" + std::to_string(7 + 2 * m) + "]"));
        }
        out.corners.push_back(tc);
      }
    }
    truth.images.push_back(std::move(out));
  }
  return truth;
}

std::vector<ReferenceRow> ReadReferenceTable(const std::string& path) {
  std::vector<ReferenceRow> rows;
  if (path.empty()) return rows;
  CsvReader in(path, {"range_m", "rmse_mm", "sd_mm"});
  std::vector<double> v;
  while (in.ReadRow(&v)) {
    if (!(v[0] > 0) || !(v[1] >= 0) || !(v[2] >= 0)) {
      throw InputError(path + ": line " + std::to_string(in.line()) +
                       ": expected range_m > 0 and rmse_mm, sd_mm >= 0");
    }
    rows.push_back({v[0], v[1], v[2]});
  }
  return rows;
}

}  // namespace omni::io
