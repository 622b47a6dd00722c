// `export` as one call: its options (one field per flag, checked by the flag's name) and the
// export of a model in one of the formats (docs/exports.md): the file's bytes, what to print,
// and for the central fits the residual map's data. The caller writes the file (io/) and draws
// the map.
#pragma once

#include <vector>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "exports/central_fit.h"
#include "model/rig_params.h"
#include "stereo/panorama.h"

namespace omni::exports {

// `export`'s flags; each field is the flag of its name.
struct ExportOptions {
  std::string model;   // the model file's path (named in messages and in the central files)
  std::string format;  // rays | panorama_maps | kalibr | basalt
  std::string out;     // ending as the format writes it: .npy, .npz, .yaml, .json
  std::string frame = "cam";      // cam | mirror1 (rays, kalibr, basalt)
  std::string dtype = "float32";  // float32 | float64 (rays)
  stereo::PanoramaOptions panorama;  // width and cylinder_radius_mm (panorama_maps)
  bool allow_uncalibrated = false;   // export a model without a calibration: section

  // Empty when consistent, else one line "--<flag>: expected <what>" (the format's flags only).
  std::string Check() const;
};

struct ModelExport {
  std::string bytes;    // the file at options.out
  std::string summary;  // what `export` prints (newline-terminated)
  // kalibr, basalt: the fit per ring, the rings' residual map at map_distance_mm (CV_32F, 0
  // where neither ring sees; `seen` CV_8U 255 where one does), its colour scale (the larger
  // ring maximum, 1 px when none) and its path (out without its extension + "_residual.png").
  std::optional<std::vector<CentralRing>> rings;  // one per ring of the rig
  cv::Mat residual_map, seen;
  double scale_px = 0, map_distance_mm = 0;
  std::string residual_map_path;
};

// The export of `rig` as `options` asks (Check() must pass). Throws InputError naming
// options.model when the model has no calibration: section and !options.allow_uncalibrated: an
// export of the design is not the user's rig.
ModelExport ExportModel(const RigParams& rig, const ExportOptions& options);

}  // namespace omni::exports
