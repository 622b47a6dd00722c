// What `panorama`, `depth` (and the commands that need two rings) share: flag checks, reading the raw image, writing images
// atomically.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "model/rig_model.h"
#include "stereo/panorama.h"

namespace omni::apps {

// The flag's value; io::InputError "--<flag>: expected <what>" if empty.
const std::string& RequireStereoFlag(const std::string& value, const char* flag, const char* what);
// io::InputError "<model_path>: a single-mirror rig (rig: single) has one ring; <why>" when `rig`
// is one: what `depth`, `triangulate`, `check` and `refine` need two rings for.
void RequireTwoRings(const RigParams& rig, const std::string& model_path, const std::string& why);
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
