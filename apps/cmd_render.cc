// `omnistereo render --model M --scene S --out DIR [--no_render] [--jobs N]`: a synthetic session. Writes
// DIR/NNNN.png (POV-Ray through the model's true mirror geometry, then the camera: lens distortion
// and the scene's camera_effects; .jpg when they say JPEG),
// DIR/NNNN.pov, DIR/target<i>_<type>.png (the tag grids' textures), DIR/model.yaml and
// DIR/truth.yaml (exact pixels from our model), and DIR/session.yaml (omnistereo-session/1 over the
// rendered images, starting from DIR/model.yaml) for `detect` and `calibrate`. --no_render writes
// only the model and the ground truth (the fast path). --jobs N renders N images at a time.
#include <cstdio>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/progress.h"
#include "io/model_file.h"
#include "model/rig_model.h"
#include "synthetic/render_session.h"
#include "synthetic/scene_file.h"

DEFINE_bool(no_render, false, "write only the ground truth, without running POV-Ray");
DEFINE_int32(jobs, 2, "images rendered at the same time (POV-Ray processes)");
DEFINE_bool(keep_pinhole, false,
            "keep POV-Ray's linear pinhole render as DIR/<name>.pinhole.png (16 bit with "
            "camera_effects), to apply other camera effects later (bench/eval_camera)");

namespace omni::apps {

int RunRender() {
  if (FLAGS_model.empty() || FLAGS_scene.empty() || FLAGS_out.empty()) {
    throw io::InputError("--model, --scene and --out are required");
  }
  synthetic::RenderSessionOptions options;
  options.dir = FLAGS_out;
  options.render = !FLAGS_no_render;
  options.jobs = FLAGS_jobs;
  options.keep_pinhole = FLAGS_keep_pinhole;
  if (const std::string error = options.Check(); !error.empty()) throw io::InputError(error);
  const RigParams rig = io::ReadModelFile(FLAGS_model);
  const synthetic::Scene scene = synthetic::ReadSceneFile(FLAGS_scene, RigModel(rig));
  ProgressLine progress("render", static_cast<int>(scene.images.size()));
  options.progress = [&](int done, int total, const std::string& file, double seconds) {
    char line[512];
    std::snprintf(line, sizeof(line), "[%d/%d] %s rendered in %.1f s", done, total, file.c_str(),
                  seconds);
    progress.Done(line);
  };
  if (!scene.camera.IsClean()) std::fprintf(stderr, "camera: %s\n", scene.camera.Summary().c_str());

  const synthetic::RenderSessionStats stats = synthetic::RenderSession(scene, rig, options);
  if (stats.rendered == 0) {
    std::printf("%zu images, ground truth only (%dx%d), truth in %s/truth.yaml\n",
                scene.images.size(), stats.width, stats.height, FLAGS_out.c_str());
  } else {
    std::printf("%d images rendered in %.1f s with %d POV-Ray process(es) (%.1f s per %dx%d "
                "frame), truth in %s/truth.yaml, session in %s/session.yaml\n",
                stats.rendered, stats.seconds, stats.jobs, stats.seconds / stats.rendered,
                stats.width, stats.height, FLAGS_out.c_str(), FLAGS_out.c_str());
  }
  return 0;
}

}  // namespace omni::apps
