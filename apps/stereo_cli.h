// What `panorama` and `depth` share: flag checks, reading the raw image, writing images
// atomically.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "model/rig_model.h"
#include "stereo/panorama.h"

namespace omni::apps {

// The flag's value; io::InputError "--<flag>: expected <what>" if empty.
const std::string& RequireStereoFlag(const std::string& value, const char* flag, const char* what);
// --image read as 8-bit BGR; InputError if unreadable or not the model's size.
cv::Mat ReadModelImage(const RigModel& model);
// The same for the image at `path` (InputError naming it).
cv::Mat ReadModelImage(const RigModel& model, const std::string& path);
// --out as an existing or newly created folder.
std::string RequireOutputFolder();
stereo::PanoramaOptions PanoramaOptionsFromFlags();
// cv::imwrite to a temporary name in the same folder, then rename (nothing half-written).
void WriteImageAtomically(const std::string& path, const cv::Mat& image);

}  // namespace omni::apps
