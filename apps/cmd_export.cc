// `omnistereo export --model M --format F --out PATH`: model data for programs that
// do not link this library.
//   rays           PATH.npy: the ray table (exports/ray_table.h), --frame cam|mirror1,
//                  --dtype float32|float64
//   panorama_maps  PATH.npz: both rings' cv::remap maps with the row -> elevation and column ->
//                  azimuth tables (exports/panorama_maps.h), --panorama_width, --cylinder_radius_mm
//   kalibr         PATH.yaml: Kalibr camchain of the rings' unified-model approximations
//   basalt         PATH.json: basalt calibration of the rings' double-sphere approximations
//                  (both exports/central_fit.h, --frame cam|mirror1; the fit's residual per ring
//                  at 0.25, 1 and 8 m printed and written into the file, and a map of it at 1 m
//                  as PATH-without-extension_residual.png)
// An uncalibrated model (no calibration: section) is refused unless --allow_uncalibrated: an
// export of the design is not the user's rig. Files are written whole or not at all.
#include <cstdio>
#include <string>

#include <opencv2/imgproc.hpp>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/overlay.h"
#include "apps/stereo_cli.h"
#include "exports/camchain.h"
#include "exports/central_fit.h"
#include "exports/central_report.h"
#include "exports/npy.h"
#include "exports/panorama_maps.h"
#include "exports/ray_table.h"
#include "io/file_util.h"
#include "io/model_file.h"

DEFINE_string(format, "", "export format: rays | panorama_maps | kalibr | basalt");
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

ReferenceBody FrameFromFlag() {
  if (FLAGS_frame != "cam" && FLAGS_frame != "mirror1") {
    throw io::InputError("--frame: expected cam or mirror1, got '" + FLAGS_frame + "'");
  }
  return FLAGS_frame == "mirror1" ? ReferenceBody::kMirror1 : ReferenceBody::kCam;
}

int ExportRays(const RigModel& model) {
  RequireSuffix(".npy");
  if (FLAGS_dtype != "float32" && FLAGS_dtype != "float64") {
    throw io::InputError("--dtype: expected float32 or float64, got '" + FLAGS_dtype + "'");
  }
  const exports::NpyArray table = exports::RayTable(
      model, FrameFromFlag(),
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

// Both rings' residual maps in one colour image over the frame (exports::BothResidualMaps): blue
// 0 px, red at the larger ring maximum; the scale is printed and drawn as a colour bar (top right).
void WriteResidualMap(const std::array<exports::CentralRing, 2>& rings, const std::string& path,
                      double distance_mm, double* scale_px) {
  cv::Mat seen, scaled, colour;
  double max_px = 0;
  const cv::Mat both = exports::BothResidualMaps(rings, &seen, &max_px);
  *scale_px = max_px > 0 ? max_px : 1;
  both.convertTo(scaled, CV_8U, 255.0 / *scale_px);
  cv::applyColorMap(scaled, colour, cv::COLORMAP_JET);
  colour.setTo(cv::Scalar(0, 0, 0), ~seen);
  char title[64];
  std::snprintf(title, sizeof title, "central fit's residual at %.0f m", distance_mm / 1000);
  DrawColourBar(&colour, cv::COLORMAP_JET, *scale_px, "px", title);
  WriteImageAtomically(path, colour);
}

int ExportCentral(const RigModel& model, exports::CentralModel kind) {
  const bool kalibr = kind == exports::CentralModel::kUnified;
  RequireSuffix(kalibr ? ".yaml" : ".json");
  exports::CentralFitOptions options;
  options.frame = FrameFromFlag();
  const auto rings = exports::FitCentral(model, kind, options);
  const int w = model.params().image_width, h = model.params().image_height;
  const std::string text =
      kalibr ? exports::KalibrCamchainYaml(rings, w, h, FLAGS_model, options.frame)
             : exports::BasaltCalibrationJson(rings, w, h, FLAGS_model, options.frame);
  const std::string map_path = FLAGS_out.substr(0, FLAGS_out.rfind('.')) + "_residual.png";
  double scale = 0;
  // Whole or nothing: the file first (a bad --out fails here, naming it, before any map is
  // written), then the map; if the map fails, the file goes again.
  io::WriteFileAtomically(FLAGS_out, text);
  try {
    WriteResidualMap(rings, map_path, options.map_distance_mm, &scale);
  } catch (...) {
    std::remove(FLAGS_out.c_str());
    throw;
  }
  std::printf("%s approximation of each ring (central, fitted to the non-central model):\n%s",
              exports::CentralModelName(kind), exports::ResidualLines(rings).c_str());
  std::printf("written to %s; residual map at %.0f m (blue 0 .. red %.3f px) %s\n",
              FLAGS_out.c_str(), options.map_distance_mm / 1000, scale, map_path.c_str());
  return 0;
}

}  // namespace

int RunExport() {
  if (FLAGS_model.empty() || FLAGS_format.empty() || FLAGS_out.empty()) {
    throw io::InputError(
        "--model, --format (rays | panorama_maps | kalibr | basalt) and --out are required");
  }
  if (FLAGS_format != "rays" && FLAGS_format != "panorama_maps" && FLAGS_format != "kalibr" &&
      FLAGS_format != "basalt") {
    throw io::InputError("--format: expected rays, panorama_maps, kalibr or basalt, got '" +
                         FLAGS_format + "'");
  }
  const RigParams rig = io::ReadModelFile(FLAGS_model);
  if (!rig.calibration && !FLAGS_allow_uncalibrated) {
    throw io::InputError(FLAGS_model + ": calibration: missing; export describes a calibrated rig "
                         "(`omnistereo calibrate` writes one; --allow_uncalibrated exports the "
                         "model as it is)");
  }
  const RigModel model(rig);
  if (FLAGS_format == "rays") return ExportRays(model);
  if (FLAGS_format == "panorama_maps") return ExportPanoramaMaps(model);
  return ExportCentral(model, FLAGS_format == "kalibr" ? exports::CentralModel::kUnified
                                                       : exports::CentralModel::kDoubleSphere);
}

}  // namespace omni::apps
