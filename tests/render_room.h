// Tests that render a whole frame of a rig in the textured room (no targets): POV-Ray at the
// rig's image size into a fresh temporary folder, read back as colour (sRGB).
#pragma once

#include <filesystem>
#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <gtest/gtest.h>

#include "model/rig_params.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene.h"
#include "tests/temp_dir.h"

namespace omni::testing {

// The room's texture shifted by `texture_offset_mm` (another room for each photo); *png_path,
// if given, receives the file rendered. Empty on a failed render (and a test failure).
inline cv::Mat RenderRoom(const RigParams& rig, const std::string& tag,
                          const Eigen::Vector3d& texture_offset_mm = Eigen::Vector3d::Zero(),
                          std::string* png_path = nullptr) {
  synthetic::SceneContent content;
  content.room = true;
  content.room_texture_offset_mm = texture_offset_mm;
  const std::filesystem::path dir = UniqueTempDir(tag);
  std::filesystem::create_directories(dir);
  const std::string png = (dir / "room.png").string();
  synthetic::RenderOptions options;
  options.width = rig.image_width;
  options.height = rig.image_height;
  std::string error;
  EXPECT_TRUE(synthetic::RenderScene(synthetic::PovSceneText(rig, content), png, options, &error))
      << error;
  if (png_path) *png_path = png;
  const cv::Mat image = cv::imread(png, cv::IMREAD_COLOR);
  EXPECT_FALSE(image.empty()) << png;
  return image;
}

}  // namespace omni::testing
