#include "apps/stereo_cli.h"

#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <system_error>

#include <unistd.h>

#include <opencv2/imgcodecs.hpp>

#include "apps/common_flags.h"
#include "io/file_util.h"
#include "io/png_fast.h"

namespace omni::apps {

const std::string& RequireStereoFlag(const std::string& value, const char* flag,
                                     const char* what) {
  if (value.empty()) throw io::InputError(std::string("--") + flag + ": expected " + what);
  return value;
}

void RequireTwoRings(const RigParams& rig, const std::string& model_path, const std::string& why) {
  if (rig.Paths() >= 2) return;
  throw io::InputError(model_path + ": a single-mirror rig (rig: single) has one ring; " + why);
}

cv::Mat ReadModelImage(const RigModel& model) {
  RequireStereoFlag(FLAGS_image, "image", "a raw omnidirectional image");
  return ReadModelImage(model, FLAGS_image);
}

cv::Mat ReadModelImage(const RigModel& model, const std::string& path) {
  const cv::Mat image = io::ReadColorImage(path);  // cv::imread's pixels, PNGs faster
  if (image.empty()) throw io::InputError(path + ": expected a readable image");
  const RigParams& rig = model.params();
  if (image.cols != rig.image_width || image.rows != rig.image_height) {
    throw io::InputError(path + ": expected the model's image size " +
                         std::to_string(rig.image_width) + "x" + std::to_string(rig.image_height) +
                         ", got " + std::to_string(image.cols) + "x" + std::to_string(image.rows));
  }
  return image;
}

std::string RequireOutputFolder() {
  RequireStereoFlag(FLAGS_out, "out", "an output folder");
  std::error_code ec;
  std::filesystem::create_directories(FLAGS_out, ec);
  if (!std::filesystem::is_directory(FLAGS_out)) {
    throw io::InputError("--out: expected a folder that exists or can be created, got '" +
                         FLAGS_out + "'");
  }
  return FLAGS_out;
}

stereo::PanoramaOptions PanoramaOptionsFromFlags() {
  if (FLAGS_panorama_width < 64 || FLAGS_panorama_width > 16384) {
    throw io::InputError("--panorama_width: expected 64..16384 pixels, got " +
                         std::to_string(FLAGS_panorama_width));
  }
  if (!(FLAGS_cylinder_radius_mm > 0)) {
    throw io::InputError("--cylinder_radius_mm: expected a number > 0");
  }
  stereo::PanoramaOptions options;
  options.width = FLAGS_panorama_width;
  options.cylinder_radius_mm = FLAGS_cylinder_radius_mm;
  return options;
}

void WriteImageAtomically(const std::string& path, const cv::Mat& image) {
  const std::filesystem::path final_path(path);
  const std::filesystem::path temp =
      final_path.parent_path() / (".tmp_" + final_path.stem().string() + "_" +
                                  std::to_string(::getpid()) + final_path.extension().string());
  if (!cv::imwrite(temp.string(), image)) {
    std::filesystem::remove(temp);
    throw std::runtime_error(path + ": cannot write the image");
  }
  std::error_code ec;
  std::filesystem::rename(temp, final_path, ec);
  if (ec) {
    std::filesystem::remove(temp);
    throw std::runtime_error(path + ": cannot write the image (" + ec.message() + ")");
  }
}

}  // namespace omni::apps
