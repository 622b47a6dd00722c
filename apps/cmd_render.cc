// `omnistereo render --model M --scene S --out DIR [--no_render]`: a synthetic session. Writes
// DIR/NNNN.png (POV-Ray through the model's true mirror geometry, then lens distortion and noise),
// DIR/NNNN.pov, DIR/target<i>_<type>.png (the tag grids' textures), DIR/model.yaml and
// DIR/truth.yaml (exact pixels from our model). --no_render writes only the ground truth (the
// fast path).
#include <chrono>
#include <cstdio>
#include <filesystem>

#include <gflags/gflags.h>
#include <opencv2/imgcodecs.hpp>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "calib/synthetic/image_effects.h"
#include "calib/synthetic/pov_scene.h"
#include "calib/synthetic/scene_file.h"
#include "calib/synthetic/tag_texture.h"
#include "model/io/file_util.h"
#include "model/io/model_file.h"
#include "model/rig_model.h"

DEFINE_bool(no_render, false, "write only the ground truth, without running POV-Ray");

namespace omni::apps {

int RunRender() {
  if (FLAGS_model.empty() || FLAGS_scene.empty() || FLAGS_out.empty()) {
    throw io::InputError("--model, --scene and --out are required");
  }
  const RigParams rig = io::ReadModelFile(FLAGS_model);
  const RigModel model(rig);
  const synthetic::Scene scene = synthetic::ReadSceneFile(FLAGS_scene, model);
  std::error_code ec;
  std::filesystem::create_directories(FLAGS_out, ec);
  if (ec) throw io::InputError(FLAGS_out + ": cannot create the output folder: " + ec.message());
  io::WriteModelFile(FLAGS_out + "/model.yaml", rig);

  synthetic::RenderOptions options;
  options.width = scene.width > 0 ? scene.width : rig.image_width;
  options.height = scene.height > 0 ? scene.height : rig.image_height;
  options.antialias = scene.antialias;
  RigParams render_rig = rig;
  render_rig.image_width = options.width;
  render_rig.image_height = options.height;
  std::string texture_error;
  if (!FLAGS_no_render &&
      !synthetic::WriteTagTextures(scene.targets, FLAGS_out, &texture_error)) {
    throw std::runtime_error(texture_error);
  }
  int rendered = 0;
  double seconds = 0;
  for (size_t i = 0; i < scene.images.size() && !FLAGS_no_render; ++i) {
    const auto& image = scene.images[i];
    const std::string png = FLAGS_out + "/" + image.name + ".png";
    const std::string tmp = FLAGS_out + "/" + image.name + ".pinhole.png";
    const auto t0 = std::chrono::steady_clock::now();
    std::string error;
    if (!synthetic::RenderScene(synthetic::PovSceneText(render_rig, synthetic::ContentOf(scene, image)),
                                tmp, options, &error)) {
      throw std::runtime_error(image.name + ": " + error);
    }
    cv::Mat img = synthetic::ApplyDistortion(cv::imread(tmp, cv::IMREAD_COLOR), render_rig);
    synthetic::AddNoise(&img, scene.noise_sigma, scene.noise_seed + static_cast<unsigned>(i));
    std::filesystem::remove(tmp);
    std::filesystem::rename(FLAGS_out + "/" + image.name + ".pinhole.pov",
                            FLAGS_out + "/" + image.name + ".pov", ec);
    if (!cv::imwrite(png, img)) throw std::runtime_error("cannot write " + png);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    seconds += s;
    ++rendered;
    std::fprintf(stderr, "[%zu/%zu] %s rendered in %.1f s\n", i + 1, scene.images.size(),
                 png.c_str(), s);
  }
  io::WriteFileAtomically(FLAGS_out + "/truth.yaml",
                          synthetic::TruthText(scene, model, "model.yaml"));
  std::printf("%zu images, %d rendered (%.1f s per %dx%d frame), truth in %s/truth.yaml\n",
              scene.images.size(), rendered, rendered ? seconds / rendered : 0.0, options.width,
              options.height, FLAGS_out.c_str());
  return 0;
}

}  // namespace omni::apps
