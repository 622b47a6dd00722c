#include "apps/common_flags.h"

#include "io/file_util.h"
#include "io/session_file.h"

DEFINE_string(model, "", "model file (omnistereo-model/1 YAML)");
DEFINE_string(out, "", "output: model YAML (design, calibrate, refine), detections YAML (detect), "
                        "session YAML (init), CSV (project, unproject, triangulate), a folder "
                        "(render, report, panorama, depth, demo), the exported file (export), "
                        "the sheet (target), the verdict YAML (check)");
DEFINE_string(config, "", "configuration file (YAML)");
DEFINE_string(session, "", "session file (omnistereo-session/1 YAML)");
DEFINE_string(scene, "", "scene file (omnistereo-scene/1 YAML)");
DEFINE_string(detections, "", "detections file (omnistereo-detections/1 YAML)");
DEFINE_string(points, "", "CSV of 3D points in the camera frame, header x_mm,y_mm,z_mm");
DEFINE_string(pixels, "", "CSV of pixels, header u,v");
// 3D sensing (triangulate, panorama, depth).
DEFINE_string(images, "", "the photos (init, check, refine) or a video's frames (depth): a path "
                          "or glob (quote it: 'photos/*.jpg'); several separated by commas");
DEFINE_string(image, "", "raw omnidirectional image (PNG, JPEG, ...) of the model's size");
DEFINE_double(sigma_px, 1.0, "pixel noise sigma for the covariance [uncertainty_propagation]");
DEFINE_int32(panorama_width, 1280, "panorama width in pixels (height from [panorama_pixel_size])");
DEFINE_double(cylinder_radius_mm, 2000.0, "radius of the panorama projection cylinder (mm)");
DEFINE_string(frame, "cam", "frame of output points, covariances and rays: cam (C) | mirror1 "
                            "(M1, mirror 1's body)");

namespace omni::apps {

std::vector<std::string> ImagesFromFlags() {
  std::vector<std::string> images;
  std::string patterns = FLAGS_images;
  if (!FLAGS_image.empty()) patterns = FLAGS_image + (patterns.empty() ? "" : "," + patterns);
  size_t start = 0;
  while (start <= patterns.size()) {
    const size_t comma = patterns.find(',', start);
    const std::string pattern =
        patterns.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    start = comma == std::string::npos ? patterns.size() + 1 : comma + 1;
    if (pattern.empty()) continue;
    const std::vector<std::string> found = io::ExpandImagePattern(pattern);
    if (found.empty()) throw io::InputError("--images: no file matches '" + pattern + "'");
    images.insert(images.end(), found.begin(), found.end());
  }
  if (images.empty()) throw io::InputError("--images: expected a path or glob of the photos");
  return images;
}

}  // namespace omni::apps
