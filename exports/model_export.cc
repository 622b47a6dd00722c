#include "exports/model_export.h"

#include <cstdio>

#include "exports/camchain.h"
#include "exports/central_report.h"
#include "exports/npy.h"
#include "exports/panorama_maps.h"
#include "exports/ray_table.h"
#include "io/text_append.h"
#include "model/input_error.h"
#include "model/rig_model.h"

namespace omni::exports {
namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

ReferenceBody Frame(const ExportOptions& options) {
  return options.frame == "mirror1" ? ReferenceBody::kMirror1 : ReferenceBody::kCam;
}

ModelExport Rays(const RigModel& model, const ExportOptions& options) {
  const NpyArray table = RayTable(
      model, Frame(options), options.dtype == "float32" ? DType::kFloat32 : DType::kFloat64);
  ModelExport out;
  out.bytes = NpyBytes(table);
  io::AppendFormat(&out.summary, "ray table %s: shape (%lld, %lld, %lld, 6) %s, [ring][v][u][ox, "
                   "oy, oz (mm), dx, dy, dz], frame %s, NaN where a pixel does not see the ring\n",
                   options.out.c_str(), static_cast<long long>(table.shape[0]),
                   static_cast<long long>(table.shape[1]),
                   static_cast<long long>(table.shape[2]), options.dtype.c_str(),
                   options.frame == "mirror1" ? "M1 (mirror 1's body)" : "C (camera)");
  return out;
}

ModelExport Panoramas(const RigModel& model, const ExportOptions& options) {
  const std::vector<NpyArray> maps = PanoramaMaps(model, options.panorama);
  ModelExport out;
  out.bytes = NpzBytes(maps);
  io::AppendFormat(&out.summary, "panorama maps %s: %s (%lld x %lld, "
                   "float32, -1 where the ring does not see), elevation_rad, azimuth_rad, "
                   "viewpoints_mm, cam_from_cylinder, radius_mm\n",
                   options.out.c_str(),
                   model.params().Paths() == 1 ? "ring1_map_x/y" : "ring1_map_x/y, ring2_map_x/y",
                   static_cast<long long>(maps[0].shape[0]),
                   static_cast<long long>(maps[0].shape[1]));
  return out;
}

ModelExport Central(const RigModel& model, const ExportOptions& options) {
  const CentralModel kind =
      options.format == "kalibr" ? CentralModel::kUnified : CentralModel::kDoubleSphere;
  CentralFitOptions fit;
  fit.frame = Frame(options);
  ModelExport out;
  out.rings = FitCentral(model, kind, fit);
  const int w = model.params().image_width, h = model.params().image_height;
  out.bytes = kind == CentralModel::kUnified
                  ? KalibrCamchainYaml(*out.rings, w, h, options.model, fit.frame)
                  : BasaltCalibrationJson(*out.rings, w, h, options.model, fit.frame);
  double max_px = 0;
  out.residual_map = BothResidualMaps(*out.rings, &out.seen, &max_px);
  out.scale_px = max_px > 0 ? max_px : 1;
  out.map_distance_mm = fit.map_distance_mm;
  out.residual_map_path = options.out.substr(0, options.out.rfind('.')) + "_residual.png";
  io::AppendFormat(&out.summary, "%s approximation of each ring (central, fitted to the "
                   "non-central model):\n", CentralModelName(kind));
  out.summary += ResidualLines(*out.rings);
  io::AppendFormat(&out.summary, "written to %s; residual map at %.0f m (blue 0 .. red %.3f px) "
                   "%s\n", options.out.c_str(), out.map_distance_mm / 1000, out.scale_px,
                   out.residual_map_path.c_str());
  return out;
}

}  // namespace

std::string ExportOptions::Check() const {
  if (model.empty() || format.empty() || out.empty()) {
    return "--model, --format (rays | panorama_maps | kalibr | basalt) and --out are required";
  }
  const char* suffix = format == "rays"            ? ".npy"
                       : format == "panorama_maps" ? ".npz"
                       : format == "kalibr"        ? ".yaml"
                       : format == "basalt"        ? ".json"
                                                   : nullptr;
  if (suffix == nullptr) {
    return "--format: expected rays, panorama_maps, kalibr or basalt, got '" + format + "'";
  }
  if (!EndsWith(out, suffix)) {
    return "--out: expected a path ending in " + std::string(suffix) + " for --format " + format +
           ", got '" + out + "'";
  }
  if (format == "rays" && dtype != "float32" && dtype != "float64") {
    return "--dtype: expected float32 or float64, got '" + dtype + "'";
  }
  if (format == "panorama_maps") {
    if (panorama.width < 64 || panorama.width > 16384) {
      return "--panorama_width: expected 64..16384 pixels, got " + std::to_string(panorama.width);
    }
    if (!(panorama.cylinder_radius_mm > 0)) return "--cylinder_radius_mm: expected a number > 0";
  } else if (frame != "cam" && frame != "mirror1") {
    return "--frame: expected cam or mirror1, got '" + frame + "'";
  }
  return "";
}

ModelExport ExportModel(const RigParams& rig, const ExportOptions& options) {
  if (!rig.calibration && !options.allow_uncalibrated) {
    throw InputError(options.model + ": calibration: missing; export describes a calibrated rig "
                     "(`omnistereo calibrate` writes one; --allow_uncalibrated exports the model "
                     "as it is)");
  }
  const RigModel model(rig);
  if (options.format == "rays") return Rays(model, options);
  if (options.format == "panorama_maps") return Panoramas(model, options);
  return Central(model, options);
}

}  // namespace omni::exports
