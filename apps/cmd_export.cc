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
#include "exports/model_export.h"
#include "io/file_util.h"
#include "io/model_file.h"

DEFINE_string(format, "", "export format: rays | panorama_maps | kalibr | basalt");
DEFINE_string(dtype, "float32", "rays: element type of the table: float32 | float64");
DEFINE_bool(allow_uncalibrated, false, "export a model without a calibration: section (a design "
                                       "or a synthetic rig)");

namespace omni::apps {
namespace {

// The flags as export options; throws io::InputError naming the flag.
exports::ExportOptions OptionsFromFlags() {
  exports::ExportOptions options;
  options.model = FLAGS_model;
  options.format = FLAGS_format;
  options.out = FLAGS_out;
  options.frame = FLAGS_frame;
  options.dtype = FLAGS_dtype;
  options.panorama.width = FLAGS_panorama_width;
  options.panorama.cylinder_radius_mm = FLAGS_cylinder_radius_mm;
  options.allow_uncalibrated = FLAGS_allow_uncalibrated;
  if (const std::string error = options.Check(); !error.empty()) throw io::InputError(error);
  return options;
}

// Both rings' residual maps in one colour image over the frame: blue 0 px, red at the export's
// scale (the larger ring maximum), drawn as a colour bar (top right).
void WriteResidualMap(const exports::ModelExport& result) {
  cv::Mat scaled, colour;
  result.residual_map.convertTo(scaled, CV_8U, 255.0 / result.scale_px);
  cv::applyColorMap(scaled, colour, cv::COLORMAP_JET);
  colour.setTo(cv::Scalar(0, 0, 0), ~result.seen);
  char title[64];
  std::snprintf(title, sizeof title, "central fit's residual at %.0f m",
                result.map_distance_mm / 1000);
  DrawColourBar(&colour, cv::COLORMAP_JET, result.scale_px, "px", title);
  WriteImageAtomically(result.residual_map_path, colour);
}

}  // namespace

int RunExport() {
  const exports::ExportOptions options = OptionsFromFlags();
  const exports::ModelExport result =
      exports::ExportModel(io::ReadModelFile(options.model), options);
  io::WriteFileAtomically(options.out, result.bytes);
  // Whole or nothing: the file first (a bad --out fails here, naming it, before any map is
  // written), then the map; if the map fails, the file goes again.
  if (result.rings) {
    try {
      WriteResidualMap(result);
    } catch (...) {
      std::remove(options.out.c_str());
      throw;
    }
  }
  std::printf("%s", result.summary.c_str());
  return 0;
}

}  // namespace omni::apps
