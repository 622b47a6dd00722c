// `omnistereo panorama --model M --image I --out DIR`: both rings unwarped into the panoramas
// Xi_1 (DIR/panorama1.png, outer ring) and Xi_2 (DIR/panorama2.png, inner ring) through the
// model's look-up tables [panorama_pixel_mapping_function] (stereo/panorama.h documents
// the viewpoints and the cylinder used for a non-central model). A single-mirror rig has one
// ring: DIR/panorama1.png alone.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/stereo_cli.h"
#include "io/model_file.h"
#include "stereo/panorama.h"

namespace omni::apps {

int RunPanorama() {
  const RigModel model(io::ReadModelFile(RequireStereoFlag(FLAGS_model, "model", "a model file")));
  const cv::Mat image = ReadModelImage(model);
  const std::string dir = RequireOutputFolder();
  const stereo::PanoramaOptions options = PanoramaOptionsFromFlags();
  const auto t0 = std::chrono::steady_clock::now();
  const stereo::PanoramaLuts luts = stereo::BuildPanoramaLuts(model, options);
  const double lut_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string paths[2] = {dir + "/panorama1.png", dir + "/panorama2.png"};
  const int rings = luts.geometry.rings;
  for (int i = 0; i < rings; ++i) {
    cv::Mat panorama;
    stereo::Unwarp(image, luts, i == 0 ? Mirror::kOne : Mirror::kTwo, &panorama);
    WriteImageAtomically(paths[i], panorama);
  }
  const auto& g = luts.geometry;
  std::printf("panorama: %dx%d per ring (elevation %.1f..%.1f deg, cylinder radius %.0f mm), "
              "LUTs in %.2f s -> %s%s%s\n",
              g.width, g.height, std::atan(g.z_min) * 180 / M_PI, std::atan(g.z_max) * 180 / M_PI,
              g.radius_mm, lut_s, paths[0].c_str(), rings > 1 ? ", " : "",
              rings > 1 ? paths[1].c_str() : "");
  return 0;
}

}  // namespace omni::apps
