// Flags shared by several subcommands (gflags allows one definition per name).
#pragma once

#include <string>
#include <vector>

#include <gflags/gflags.h>

DECLARE_string(model);
DECLARE_string(out);
DECLARE_string(config);
DECLARE_string(session);
DECLARE_string(scene);
DECLARE_string(detections);
DECLARE_string(points);
DECLARE_string(pixels);
// 3D sensing (triangulate, panorama, depth).
DECLARE_string(image);
DECLARE_string(images);
DECLARE_double(sigma_px);
DECLARE_int32(panorama_width);
DECLARE_double(cylinder_radius_mm);
// Output frame (triangulate, export).
DECLARE_string(frame);

namespace omni::apps {

// The photos of --image and --images (a path or glob each; several separated by commas), globs
// expanded and sorted per pattern; InputError if a pattern matches nothing or none is given.
std::vector<std::string> ImagesFromFlags();

}  // namespace omni::apps
