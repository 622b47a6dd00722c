// `omnistereo render --model M --scene S --out DIR [--no_render] [--jobs N]`: a synthetic session. Writes
// DIR/NNNN.png (POV-Ray through the model's true mirror geometry, then the camera: lens distortion
// and the scene's camera_effects; .jpg when they say JPEG),
// DIR/NNNN.pov, DIR/target<i>_<type>.png (the tag grids' textures), DIR/model.yaml and
// DIR/truth.yaml (exact pixels from our model), and DIR/session.yaml (omnistereo-session/1 over the
// rendered images, starting from DIR/model.yaml) for `detect` and `calibrate`. --no_render writes
// only the model and the ground truth (the fast path). --jobs N renders N images at a time.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <thread>
#include <vector>

#include <gflags/gflags.h>
#include <opencv2/imgcodecs.hpp>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "calib/synthetic/camera_effects.h"
#include "calib/synthetic/image_effects.h"
#include "calib/synthetic/pov_scene.h"
#include "calib/synthetic/scene_file.h"
#include "calib/synthetic/tag_texture.h"
#include "model/io/file_util.h"
#include "model/io/model_file.h"
#include "model/io/session_file.h"
#include "model/rig_parameters.h"
#include "model/rig_model.h"

DEFINE_bool(no_render, false, "write only the ground truth, without running POV-Ray");
DEFINE_int32(jobs, 2, "images rendered at the same time (POV-Ray processes)");
DEFINE_bool(keep_pinhole, false,
            "keep POV-Ray's linear pinhole render as DIR/<name>.pinhole.png (16 bit with "
            "camera_effects), to apply other camera effects later (bench/eval_camera)");

namespace omni::apps {
namespace {

// Scene image i as DIR/<name>.png (or .jpg): POV-Ray's pinhole render, then the camera: lens
// distortion and the scene's camera_effects (camera_effects.h), or render.noise_sigma alone.
void RenderImage(const synthetic::Scene& scene, size_t i, const RigParams& render_rig,
                 const synthetic::RenderOptions& options, const std::string& dir) {
  const auto& image = scene.images[i];
  const std::string tmp = dir + "/" + image.name + ".pinhole.png";
  std::string error;
  if (!synthetic::RenderScene(synthetic::PovSceneText(render_rig, synthetic::ContentOf(scene, image)),
                              tmp, options, &error)) {
    throw std::runtime_error(image.name + ": " + error);
  }
  const cv::Mat pinhole = cv::imread(tmp, cv::IMREAD_UNCHANGED);
  if (pinhole.empty()) throw std::runtime_error(image.name + ": cannot read POV-Ray's " + tmp);
  const unsigned seed = scene.noise_seed + static_cast<unsigned>(i);
  cv::Mat img;
  if (scene.camera.IsClean()) {
    img = synthetic::ApplyDistortion(pinhole, render_rig);
    synthetic::AddNoise(&img, scene.noise_sigma, seed);
  } else {
    img = synthetic::ApplyCamera(pinhole, render_rig, scene.camera, seed);
  }
  if (!FLAGS_keep_pinhole) std::filesystem::remove(tmp);
  std::error_code ec;
  std::filesystem::rename(dir + "/" + image.name + ".pinhole.pov", dir + "/" + image.name + ".pov",
                          ec);
  std::vector<uchar> bytes;
  if (!synthetic::EncodeCameraImage(img, scene.camera, &bytes)) {
    throw std::runtime_error("cannot encode " + image.name);
  }
  io::WriteFileAtomically(dir + "/" + image.name + synthetic::ImageExtension(scene.camera),
                          std::string(bytes.begin(), bytes.end()));
}

}  // namespace

int RunRender() {
  if (FLAGS_model.empty() || FLAGS_scene.empty() || FLAGS_out.empty()) {
    throw io::InputError("--model, --scene and --out are required");
  }
  RigParams rig = io::ReadModelFile(FLAGS_model);
  const synthetic::Scene scene = synthetic::ReadSceneFile(FLAGS_scene, RigModel(rig));
  // The scene's image size renders the same rig at that resolution; model.yaml and the truth
  // describe the images as rendered.
  if (scene.width > 0) rig = synthetic::RigAtImageSize(rig, scene.width, scene.height);
  const RigModel model(rig);
  std::error_code ec;
  std::filesystem::create_directories(FLAGS_out, ec);
  if (ec) throw io::InputError(FLAGS_out + ": cannot create the output folder: " + ec.message());
  io::WriteModelFile(FLAGS_out + "/model.yaml", rig);

  synthetic::RenderOptions options;
  options.width = rig.image_width;
  options.height = rig.image_height;
  options.antialias = scene.antialias;
  // The camera's tone curve needs linear precision (and so do effects applied later).
  options.bits = scene.camera.IsClean() && !FLAGS_keep_pinhole ? 8 : 16;
  if (!scene.camera.IsClean()) std::fprintf(stderr, "camera: %s\n", scene.camera.Summary().c_str());
  std::string texture_error;
  if (!FLAGS_no_render &&
      !synthetic::WriteTagTextures(scene.targets, FLAGS_out, &texture_error)) {
    throw std::runtime_error(texture_error);
  }
  const size_t n_render = FLAGS_no_render ? 0 : scene.images.size();
  const int jobs = static_cast<int>(std::min<size_t>(std::max(1, FLAGS_jobs), std::max<size_t>(1, n_render)));
  // Each POV-Ray process gets its share of the cores (its parse and set-up are serial, which is
  // what running several processes wins back).
  if (jobs > 1) {
    options.threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / jobs);
  }
  std::atomic<size_t> next{0};
  std::atomic<int> rendered{0};
  std::mutex mutex;
  std::string first_error;
  const auto t_start = std::chrono::steady_clock::now();
  auto worker = [&] {
    for (size_t i = next++; i < n_render; i = next++) {
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (!first_error.empty()) return;
      }
      const auto t0 = std::chrono::steady_clock::now();
      try {
        RenderImage(scene, i, rig, options, FLAGS_out);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(mutex);
        if (first_error.empty()) first_error = e.what();
        return;
      }
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::lock_guard<std::mutex> lock(mutex);
      std::fprintf(stderr, "[%d/%zu] %s/%s%s rendered in %.1f s\n", ++rendered, n_render,
                   FLAGS_out.c_str(), scene.images[i].name.c_str(),
                   synthetic::ImageExtension(scene.camera).c_str(), s);
    }
  };
  std::vector<std::thread> threads;
  for (int j = 0; j < jobs && n_render > 0; ++j) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  if (!first_error.empty()) throw std::runtime_error(first_error);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();

  io::WriteFileAtomically(FLAGS_out + "/truth.yaml",
                          synthetic::TruthText(scene, model, "model.yaml"));
  if (n_render > 0) {
    // A session that `detect` and `calibrate` run on as it is.
    io::Session session;
    session.model_path = FLAGS_out + "/model.yaml";
    for (const auto& image : scene.images) session.images.push_back(FLAGS_out + "/" + image.name +
                                                 synthetic::ImageExtension(scene.camera));
    if (scene.camera.raw_mosaic) session.bayer = scene.camera.bayer;
    session.tone = scene.camera.raw_mosaic ? io::ToneCurve::kLinear : scene.camera.tone;
    session.targets = scene.targets;
    session.estimate = DefaultEstimateBlocks();
    io::WriteFileAtomically(FLAGS_out + "/session.yaml", io::SessionText(session, FLAGS_out));
  }
  if (n_render == 0) {
    std::printf("%zu images, ground truth only (%dx%d), truth in %s/truth.yaml\n",
                scene.images.size(), options.width, options.height, FLAGS_out.c_str());
  } else {
    std::printf("%zu images rendered in %.1f s with %d POV-Ray process(es) (%.1f s per %dx%d "
                "frame), truth in %s/truth.yaml, session in %s/session.yaml\n",
                n_render, seconds, jobs, seconds / n_render, options.width, options.height,
                FLAGS_out.c_str(), FLAGS_out.c_str());
  }
  return 0;
}

}  // namespace omni::apps
