// `omnistereo project` and `omnistereo unproject` (docs/design.md, Conventions): stream a CSV through the
// non-central rig model (model/rig_model.h). The output is written to a temporary file and
// renamed into place only after the last row, so bad input never leaves a half-written file.
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "io/csv.h"
#include "io/model_file.h"
#include "model/rig_model.h"

namespace omni::apps {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

void RequireFlag(const std::string& value, const char* flag, const char* what) {
  if (value.empty()) throw io::InputError(std::string("--") + flag + ": expected " + what);
}

// Reads the next row and checks that every value is finite.
bool ReadFiniteRow(io::CsvReader* in, const std::vector<std::string>& columns,
                   std::vector<double>* row) {
  if (!in->ReadRow(row)) return false;
  for (size_t k = 0; k < columns.size(); ++k) {
    if (!std::isfinite((*row)[k])) {
      throw io::InputError(in->path() + ": line " + std::to_string(in->line()) + ": column '" +
                           columns[k] + "': expected a finite number, got " +
                           io::FormatDouble((*row)[k]));
    }
  }
  return true;
}

}  // namespace

int RunProject() {
  RequireFlag(FLAGS_model, "model", "a model file (omnistereo-model/1)");
  RequireFlag(FLAGS_points, "points", "a CSV file with columns x_mm,y_mm,z_mm");
  RequireFlag(FLAGS_out, "out", "the output CSV path");
  const RigModel model(io::ReadModelFile(FLAGS_model));
  const std::vector<std::string> columns = {"x_mm", "y_mm", "z_mm"};
  io::CsvReader in(FLAGS_points, columns);
  io::CsvWriter out(FLAGS_out, {"u1", "v1", "valid1", "u2", "v2", "valid2"});
  std::vector<double> row;
  long n = 0, valid1 = 0, valid2 = 0;
  while (ReadFiniteRow(&in, columns, &row)) {
    const Eigen::Vector3d point_in_cam(row[0], row[1], row[2]);
    const auto px1 = model.Project(point_in_cam, Mirror::kOne);
    const auto px2 = model.Project(point_in_cam, Mirror::kTwo);
    out.WriteRow({px1 ? px1->x() : kNan, px1 ? px1->y() : kNan, px1 ? 1.0 : 0.0,
                  px2 ? px2->x() : kNan, px2 ? px2->y() : kNan, px2 ? 1.0 : 0.0});
    ++n;
    valid1 += px1.has_value();
    valid2 += px2.has_value();
  }
  out.Commit();
  std::printf("project: %ld points, %ld valid via mirror 1, %ld via mirror 2 -> %s\n", n, valid1,
              valid2, FLAGS_out.c_str());
  return 0;
}

int RunUnproject() {
  RequireFlag(FLAGS_model, "model", "a model file (omnistereo-model/1)");
  RequireFlag(FLAGS_pixels, "pixels", "a CSV file with columns u,v");
  RequireFlag(FLAGS_out, "out", "the output CSV path");
  const RigModel model(io::ReadModelFile(FLAGS_model));
  const std::vector<std::string> columns = {"u", "v"};
  io::CsvReader in(FLAGS_pixels, columns);
  io::CsvWriter out(FLAGS_out, {"mirror", "ox", "oy", "oz", "dx", "dy", "dz", "valid"});
  std::vector<double> row;
  long n = 0, valid[3] = {0, 0, 0};
  while (ReadFiniteRow(&in, columns, &row)) {
    const auto ray = model.Unproject(Eigen::Vector2d(row[0], row[1]));
    if (ray) {
      const Eigen::Vector3d& o = ray->ray.origin;
      const Eigen::Vector3d& d = ray->ray.direction;
      out.WriteRow({double(MirrorIndex(ray->mirror)), o.x(), o.y(), o.z(), d.x(), d.y(), d.z(), 1.0});
      ++valid[MirrorIndex(ray->mirror)];
    } else {
      out.WriteRow({0.0, kNan, kNan, kNan, kNan, kNan, kNan, 0.0});
    }
    ++n;
  }
  out.Commit();
  std::printf("unproject: %ld pixels, %ld rays via mirror 1, %ld via mirror 2, %ld invalid -> %s\n",
              n, valid[1], valid[2], n - valid[1] - valid[2], FLAGS_out.c_str());
  return 0;
}

}  // namespace omni::apps
