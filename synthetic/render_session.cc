#include "synthetic/render_session.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "io/file_util.h"
#include "io/model_file.h"
#include "model/rig_model.h"
#include "model/rig_parameters.h"
#include "synthetic/camera_effects.h"
#include "synthetic/image_effects.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene_file.h"
#include "synthetic/tag_texture.h"

namespace omni::synthetic {
namespace {

// Scene image i as DIR/<name>.png (or .jpg): POV-Ray's pinhole render, then the camera: lens
// distortion and the scene's camera_effects (camera_effects.h), or render.noise_sigma alone.
void RenderImage(const Scene& scene, size_t i, const RigParams& render_rig,
                 const RenderOptions& options, const std::string& dir, bool keep_pinhole) {
  const auto& image = scene.images[i];
  const std::string tmp = dir + "/" + image.name + ".pinhole.png";
  std::string error;
  if (!RenderScene(PovSceneText(render_rig, ContentOf(scene, image)), tmp, options, &error)) {
    throw std::runtime_error(image.name + ": " + error);
  }
  const cv::Mat pinhole = cv::imread(tmp, cv::IMREAD_UNCHANGED);
  if (pinhole.empty()) throw std::runtime_error(image.name + ": cannot read POV-Ray's " + tmp);
  const unsigned seed = scene.noise_seed + static_cast<unsigned>(i);
  cv::Mat img;
  if (scene.camera.IsClean()) {
    img = ApplyDistortion(pinhole, render_rig);
    AddNoise(&img, scene.noise_sigma, seed);
  } else {
    img = ApplyCamera(pinhole, render_rig, scene.camera, seed);
  }
  if (!keep_pinhole) std::filesystem::remove(tmp);
  std::error_code ec;
  std::filesystem::rename(dir + "/" + image.name + ".pinhole.pov", dir + "/" + image.name + ".pov",
                          ec);
  std::vector<uchar> bytes;
  if (!EncodeCameraImage(img, scene.camera, &bytes)) {
    throw std::runtime_error("cannot encode " + image.name);
  }
  io::WriteFileAtomically(dir + "/" + image.name + ImageExtension(scene.camera),
                          std::string(bytes.begin(), bytes.end()));
}

// Runs render(i) for i < n on `jobs` threads; the first exception stops the others and is
// rethrown.
void ForEachImage(size_t n, int jobs, const std::function<void(size_t)>& render) {
  std::atomic<size_t> next{0};
  std::mutex mutex;
  std::exception_ptr first_error;
  auto worker = [&] {
    for (size_t i = next++; i < n; i = next++) {
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (first_error) return;
      }
      try {
        render(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!first_error) first_error = std::current_exception();
        return;
      }
    }
  };
  std::vector<std::thread> threads;
  for (int j = 0; j < jobs && n > 0; ++j) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  if (first_error) std::rethrow_exception(first_error);
}

}  // namespace

std::string RenderSessionOptions::Check() const {
  if (dir.empty()) return "--out: expected the output folder";
  if (jobs < 1) return "--jobs: expected a number >= 1";
  return "";
}

io::Session SessionOfRender(const Scene& scene, const std::string& dir) {
  io::Session session;
  session.model_path = dir + "/model.yaml";
  for (const auto& image : scene.images) {
    session.images.push_back(dir + "/" + image.name + ImageExtension(scene.camera));
  }
  if (scene.camera.raw_mosaic) session.bayer = scene.camera.bayer;
  session.tone = scene.camera.FileTone();
  session.targets = scene.targets;
  session.estimate = DefaultEstimateBlocks();
  return session;
}

RenderSessionStats RenderSession(const Scene& scene, const RigParams& rig_in,
                                 const RenderSessionOptions& options) {
  if (const std::string error = options.Check(); !error.empty()) throw io::InputError(error);
  // The scene's image size renders the same rig at that resolution; model.yaml and the truth
  // describe the images as rendered.
  const RigParams rig =
      scene.width > 0 ? RigAtImageSize(rig_in, scene.width, scene.height) : rig_in;
  std::error_code ec;
  std::filesystem::create_directories(options.dir, ec);
  if (ec) throw io::InputError(options.dir + ": cannot create the output folder: " + ec.message());
  io::WriteModelFile(options.dir + "/model.yaml", rig);

  RenderOptions render;
  render.width = rig.image_width;
  render.height = rig.image_height;
  render.antialias = scene.antialias;
  // The camera's tone curve needs linear precision (and so do effects applied later).
  render.bits = scene.camera.IsClean() && !options.keep_pinhole ? 8 : 16;
  std::string texture_error;
  if (options.render && !WriteTagTextures(scene.targets, options.dir, &texture_error)) {
    throw std::runtime_error(texture_error);
  }
  const size_t n = options.render ? scene.images.size() : 0;
  RenderSessionStats stats;
  stats.width = render.width;
  stats.height = render.height;
  stats.jobs = static_cast<int>(std::min<size_t>(options.jobs, std::max<size_t>(1, n)));
  // Each POV-Ray process gets its share of the cores (its parse and set-up are serial, which is
  // what running several processes wins back).
  if (stats.jobs > 1) {
    render.threads =
        std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / stats.jobs);
  }
  std::mutex mutex;
  const auto t_start = std::chrono::steady_clock::now();
  ForEachImage(n, stats.jobs, [&](size_t i) {
    const auto t0 = std::chrono::steady_clock::now();
    RenderImage(scene, i, rig, render, options.dir, options.keep_pinhole);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::lock_guard<std::mutex> lock(mutex);
    ++stats.rendered;
    if (options.progress) {
      options.progress(stats.rendered, static_cast<int>(n),
                       options.dir + "/" + scene.images[i].name + ImageExtension(scene.camera), s);
    }
  });
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();

  io::WriteFileAtomically(options.dir + "/truth.yaml",
                          TruthText(scene, RigModel(rig), "model.yaml"));
  if (n > 0) {
    io::WriteFileAtomically(options.dir + "/session.yaml",
                            io::SessionText(SessionOfRender(scene, options.dir), options.dir));
  }
  return stats;
}

}  // namespace omni::synthetic
