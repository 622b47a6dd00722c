// Tests that render only windows of a frame around their targets (full 1280x960 frames
// take ~15 s each): POV-Ray's options for the window `box` of the rig's image, the rendered
// window pasted into a full pinhole frame (black elsewhere) before the camera (lens distortion,
// noise, camera_effects), the windows around a scene image's targets, and the lips' strips.
#pragma once

#include <algorithm>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <gtest/gtest.h>

#include "model/rig_params.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene.h"
#include "tests/temp_dir.h"

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
// into `pinhole` (the full frame: CV_8UC3, or CV_16UC3 with options.bits = 16). False (with
// `error`) if POV-Ray failed.
inline bool RenderWindowInto(const std::string& pov, const cv::Rect& box,
                             const synthetic::RenderOptions& options, const std::string& png,
                             cv::Mat* pinhole, std::string* error) {
  if (!synthetic::RenderScene(pov, png, options, error)) return false;
  cv::imread(png, pinhole->depth() == CV_16U ? cv::IMREAD_UNCHANGED : cv::IMREAD_COLOR)(box)
      .copyTo((*pinhole)(box));
  return true;
}

// Renders the windows around every target's corners in each ring (padded by two of the largest
// square or tag steps in that ring, plus 12 px: the outer squares and white margin) into
// `pinhole` (the full frame, CV_8UC3 or CV_16UC3 for a 16-bit linear render), files in `dir`.
inline bool RenderTargetWindows(const RigParams& rig, const synthetic::Scene& scene,
                                const synthetic::SceneImage& image,
                                const std::vector<TruthCorner>& truth,
                                const std::string& dir, cv::Mat* pinhole, std::string* error) {
  const std::string pov = synthetic::PovSceneText(rig, synthetic::ContentOf(scene, image));
  for (size_t t = 0; t < scene.targets.size(); ++t) {
    for (int m = 0; m < 2; ++m) {
      std::vector<Eigen::Vector2d> pixels;
      for (const auto& c : truth) {
        if (c.target == static_cast<int>(t) && c.pixel[m]) pixels.push_back(*c.pixel[m]);
      }
      if (pixels.empty()) continue;
      double step = 0;  // the largest distance from a corner to its nearest neighbour
      for (const auto& a : pixels) {
        double nearest = 1e9;
        for (const auto& b : pixels) {
          if (&a != &b) nearest = std::min(nearest, (a - b).norm());
        }
        if (nearest < 1e9) step = std::max(step, nearest);
      }
      const int pad = static_cast<int>(2 * step) + 12;
      cv::Rect box;
      for (const auto& px : pixels) {
        const cv::Rect one(static_cast<int>(px.x()) - pad, static_cast<int>(px.y()) - pad,
                           2 * pad + 1, 2 * pad + 1);
        box = box.empty() ? one : (box | one);
      }
      box &= cv::Rect(0, 0, rig.image_width, rig.image_height);
      if (box.empty()) continue;
      synthetic::RenderOptions options = WindowOptions(rig, box);
      options.bits = pinhole->depth() == CV_16U ? 16 : 8;
      const std::string png = dir + "/w" + std::to_string(t) + std::to_string(m) + ".png";
      if (!RenderWindowInto(pov, box, options, png, pinhole, error)) return false;
    }
  }
  return true;
}

// The rig with nothing in front of it, rendered in a horizontal and a vertical strip through the
// principal point (4 arcs of every band; full frames are slow): the linear pinhole render at
// `bits` per channel (lens distortion not yet applied).
inline cv::Mat RenderLipStrips(const RigParams& rig, const std::string& tag, int bits = 8) {
  const std::string dir = UniqueTempDir("omni_lips_" + tag);
  std::filesystem::create_directories(dir);
  const int cx = static_cast<int>(rig.camera[kCx]), cy = static_cast<int>(rig.camera[kCy]);
  cv::Mat combined;
  for (int strip = 0; strip < 2; ++strip) {
    synthetic::RenderOptions opt;
    opt.width = rig.image_width;
    opt.height = rig.image_height;
    opt.bits = bits;
    if (strip == 0) {
      opt.col0 = 0, opt.col1 = rig.image_width, opt.row0 = cy - 60, opt.row1 = cy + 60;
    } else {
      opt.col0 = cx - 60, opt.col1 = cx + 60, opt.row0 = 0, opt.row1 = rig.image_height;
    }
    const std::string png = dir + "/strip" + std::to_string(strip) + ".png";
    std::string error;
    if (!synthetic::RenderScene(synthetic::PovSceneText(rig, {}), png, opt, &error)) {
      ADD_FAILURE() << error;
      return {};
    }
    const cv::Mat img = cv::imread(png, cv::IMREAD_COLOR | cv::IMREAD_ANYDEPTH);
    if (img.empty()) return {};
    combined = combined.empty() ? img : cv::max(combined, img);
  }
  std::filesystem::remove_all(dir);
  return combined;
}

}  // namespace omni::testing
