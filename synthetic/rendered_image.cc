#include "synthetic/rendered_image.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "io/image_file.h"

namespace omni::synthetic {

RenderedImage ReadRenderedImage(const std::string& dir, const std::string& name,
                                const RigParams& rig, const CameraEffects* camera,
                                unsigned seed, const std::string& save_dir) {
  RenderedImage out;
  out.path = dir + "/" + name + ".png";
  if (camera) {
    out.path = dir + "/" + name + ".pinhole.png";
    const cv::Mat pinhole = cv::imread(out.path, cv::IMREAD_UNCHANGED);
    if (pinhole.empty()) return out;
    const cv::Mat raw = ApplyCamera(pinhole, rig, *camera, seed);
    std::vector<uchar> bytes;
    EncodeCameraImage(raw, *camera, &bytes);
    if (!save_dir.empty()) {
      const std::string ext = camera->jpeg_quality > 0 ? ".jpg" : ".png";
      if (std::FILE* f = std::fopen((save_dir + "/" + name + ext).c_str(), "wb")) {
        std::fwrite(bytes.data(), 1, bytes.size(), f);
        std::fclose(f);
      }
    }
    out.chroma_halved = io::HasHalvedChroma(bytes);
    out.luma = io::ReadStoredLuma(bytes);
    out.image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
    if (camera->raw_mosaic) {
      out.image = io::DemosaicImage(out.image, camera->bayer, io::Demosaic::kEdgeAware);
    }
    return out;
  }
  if (!std::filesystem::exists(out.path)) out.path = dir + "/" + name + ".jpg";
  out.image = cv::imread(out.path, cv::IMREAD_UNCHANGED);
  out.chroma_halved = io::HasHalvedChroma(out.path);
  out.luma = io::ReadStoredLuma(out.path);
  return out;
}

std::vector<std::string> NumberedRenders(const std::string& dir, bool pinhole) {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string ext = entry.path().extension().string();
    std::string stem = entry.path().stem().string();
    if (pinhole) {
      if (ext != ".png" || stem.size() < 8 || stem.substr(stem.size() - 8) != ".pinhole") continue;
      stem = stem.substr(0, stem.size() - 8);
    } else if (ext != ".png" && ext != ".jpg") {
      continue;
    }
    if (!stem.empty() &&
        std::all_of(stem.begin(), stem.end(), [](char c) { return std::isdigit(c); })) {
      files.push_back(entry.path().string());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace omni::synthetic
