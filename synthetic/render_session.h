// A synthetic session rendered into a folder (the `render` command's work): every scene image
// through POV-Ray and the camera, the tag textures, the truth and a session file over the images.
#pragma once

#include <functional>
#include <string>

#include "io/session_file.h"
#include "model/rig_params.h"
#include "synthetic/scene.h"

namespace omni::synthetic {

struct RenderSessionOptions {
  std::string dir;            // the output folder (created)
  bool render = true;         // false: only the model and the ground truth (the fast path)
  int jobs = 2;               // images rendered at the same time (POV-Ray processes)
  bool keep_pinhole = false;  // keep POV-Ray's linear render as DIR/<name>.pinhole.png
  // Called after each image with its number (1-based), the count and its seconds.
  std::function<void(int done, int total, const std::string& file, double seconds)> progress;

  // Empty if the options are consistent, else what is wrong, naming the command's flag.
  std::string Check() const;
};

struct RenderSessionStats {
  int rendered = 0;
  int jobs = 1;          // POV-Ray processes used
  double seconds = 0;    // rendering wall time
  int width = 0, height = 0;
};

// Renders `scene` through `rig` (at the scene's image size if it gives one) into options.dir:
// DIR/model.yaml, DIR/<name>.png or .jpg (POV-Ray's pinhole render, then lens distortion and the
// scene's camera_effects, or render.noise_sigma alone), DIR/<name>.pov, the tag textures,
// DIR/truth.yaml, and with images DIR/session.yaml for `detect` and `calibrate`. Throws
// io::InputError for a folder it cannot create and std::runtime_error when POV-Ray fails.
RenderSessionStats RenderSession(const Scene& scene, const RigParams& rig,
                                 const RenderSessionOptions& options);

// The session file over a rendered scene's images in `dir`, starting from DIR/model.yaml.
io::Session SessionOfRender(const Scene& scene, const std::string& dir);

}  // namespace omni::synthetic
