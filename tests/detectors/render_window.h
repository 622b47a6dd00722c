// The detector tests render only windows of a frame around their targets (full 1280x960 frames
// take ~15 s each): POV-Ray's options for the window `box` of the rig's image, and the rendered
// window pasted into a full pinhole frame (black elsewhere) before lens distortion and noise.
#pragma once

#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/synthetic/pov_scene.h"
#include "model/rig_params.h"

namespace omni::testing {

inline synthetic::RenderOptions WindowOptions(const RigParams& rig, const cv::Rect& box) {
  synthetic::RenderOptions options;
  options.width = rig.image_width;
  options.height = rig.image_height;
  options.col0 = box.x;
  options.col1 = box.x + box.width;
  options.row0 = box.y;
  options.row1 = box.y + box.height;
  return options;
}

// Renders `pov` with `options` (a window: WindowOptions) to `png` and copies the window `box`
// into `pinhole` (CV_8UC3, the full frame). False (with `error`) if POV-Ray failed.
inline bool RenderWindowInto(const std::string& pov, const cv::Rect& box,
                             const synthetic::RenderOptions& options, const std::string& png,
                             cv::Mat* pinhole, std::string* error) {
  if (!synthetic::RenderScene(pov, png, options, error)) return false;
  cv::imread(png, cv::IMREAD_COLOR)(box).copyTo((*pinhole)(box));
  return true;
}

}  // namespace omni::testing
