// `omnistereo export --model M --format F --out PATH` (issue 20): model data for programs that
// do not link this library.
//   rays           PATH.npy: the ray table (exports/ray_table.h), --frame cam|mirror1,
//                  --dtype float32|float64
//   panorama_maps  PATH.npz: both rings' cv::remap maps with the row -> elevation and column ->
//                  azimuth tables (exports/panorama_maps.h), --panorama_width, --cylinder_radius_mm
// An uncalibrated model (no calibration: section) is refused unless --allow_uncalibrated: an
// export of the design is not the user's rig. Files are written whole or not at all.
#include <cstdio>
#include <string>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/stereo_cli.h"
#include "exports/npy.h"
#include "exports/panorama_maps.h"
#include "exports/ray_table.h"
#include "model/io/file_util.h"
#include "model/io/model_file.h"

DEFINE_string(format, "", "export format: rays | panorama_maps");
DEFINE_string(dtype, "float32", "rays: element type of the table: float32 | float64");
DEFINE_bool(allow_uncalibrated, false, "export a model without a calibration: section (a design "
                                       "or a synthetic rig)");

namespace omni::apps {
namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

void RequireSuffix(const std::string& suffix) {
  if (!EndsWith(FLAGS_out, suffix)) {
    throw io::InputError("--out: expected a path ending in " + suffix + " for --format " +
                         FLAGS_format + ", got '" + FLAGS_out + "'");
  }
}

int ExportRays(const RigModel& model) {
  RequireSuffix(".npy");
  if (FLAGS_dtype != "float32" && FLAGS_dtype != "float64") {
    throw io::InputError("--dtype: expected float32 or float64, got '" + FLAGS_dtype + "'");
  }
  if (FLAGS_frame != "cam" && FLAGS_frame != "mirror1") {
    throw io::InputError("--frame: expected cam or mirror1, got '" + FLAGS_frame + "'");
  }
  const exports::NpyArray table = exports::RayTable(
      model, FLAGS_frame == "mirror1" ? ReferenceBody::kMirror1 : ReferenceBody::kCam,
      FLAGS_dtype == "float32" ? exports::DType::kFloat32 : exports::DType::kFloat64);
  io::WriteFileAtomically(FLAGS_out, exports::NpyBytes(table));
  std::printf("ray table %s: shape (2, %lld, %lld, 6) %s, [ring][v][u][ox, oy, oz (mm), dx, dy, "
              "dz], frame %s, NaN where a pixel does not see the ring\n",
              FLAGS_out.c_str(), static_cast<long long>(table.shape[1]),
              static_cast<long long>(table.shape[2]), FLAGS_dtype.c_str(),
              FLAGS_frame == "mirror1" ? "M1 (mirror 1's body)" : "C (camera)");
  return 0;
}

int ExportPanoramaMaps(const RigModel& model) {
  RequireSuffix(".npz");
  const std::vector<exports::NpyArray> maps =
      exports::PanoramaMaps(model, PanoramaOptionsFromFlags());
  io::WriteFileAtomically(FLAGS_out, exports::NpzBytes(maps));
  std::printf("panorama maps %s: ring1_map_x/y, ring2_map_x/y (%lld x %lld, float32, -1 where the "
              "ring does not see), elevation_rad, azimuth_rad, viewpoints_mm, cam_from_cylinder, "
              "radius_mm\n",
              FLAGS_out.c_str(), static_cast<long long>(maps[0].shape[0]),
              static_cast<long long>(maps[0].shape[1]));
  return 0;
}

}  // namespace

int RunExport() {
  if (FLAGS_model.empty() || FLAGS_format.empty() || FLAGS_out.empty()) {
    throw io::InputError("--model, --format (rays | panorama_maps) and --out are required");
  }
  if (FLAGS_format != "rays" && FLAGS_format != "panorama_maps") {
    throw io::InputError("--format: expected rays or panorama_maps, got '" + FLAGS_format + "'");
  }
  const RigParams rig = io::ReadModelFile(FLAGS_model);
  if (!rig.calibration && !FLAGS_allow_uncalibrated) {
    throw io::InputError(FLAGS_model + ": calibration: missing; export describes a calibrated rig "
                         "(`omnistereo calibrate` writes one; --allow_uncalibrated exports the "
                         "model as it is)");
  }
  const RigModel model(rig);
  if (FLAGS_format == "rays") return ExportRays(model);
  return ExportPanoramaMaps(model);
}

}  // namespace omni::apps
