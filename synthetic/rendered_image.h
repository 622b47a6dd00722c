// A rendered session's image as a detector gets it (the benches' evaluations): the file the
// render wrote, or the kept linear render (`render --keep_pinhole`) through another camera and
// encoded as that camera writes its files, so that presets and single effects are measured on
// the same renders.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "model/rig_params.h"
#include "synthetic/camera_effects.h"

namespace omni::synthetic {

struct RenderedImage {
  std::string path;          // the file read
  cv::Mat image;             // as decoded (IMREAD_UNCHANGED; demosaiced for a raw mosaic); empty
                             // when the file cannot be read
  bool chroma_halved = false;  // io::HasHalvedChroma of the file (as the camera wrote it)
  cv::Mat luma;                // io::ReadStoredLuma of it
};

// DIR/NAME.png, else DIR/NAME.jpg; with `camera`, DIR/NAME.pinhole.png through ApplyCamera(rig,
// *camera, noise seed `seed`), encoded (EncodeCameraImage) and decoded again, the encoded file
// also written to save_dir/NAME.jpg or .png when save_dir is not empty (to look at).
RenderedImage ReadRenderedImage(const std::string& dir, const std::string& name,
                                const RigParams& rig, const CameraEffects* camera,
                                unsigned seed, const std::string& save_dir = "");

// A render folder's numbered images (DIR/NNNN.png or .jpg), sorted; with `pinhole` the kept
// linear renders DIR/NNNN.pinhole.png instead (`render --keep_pinhole`).
std::vector<std::string> NumberedRenders(const std::string& dir, bool pinhole);

}  // namespace omni::synthetic
