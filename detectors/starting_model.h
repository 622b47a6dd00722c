// The starting model of a built rig's photos (`omnistereo init`): the design at the photos' size,
// its intrinsics from the lips where the first photos show them, the mount's posts where they
// show them. What was found is said in lines for the user.
#pragma once

#include <string>
#include <vector>

#include "model/rig_params.h"

namespace omni::detectors {

// The photos' common size; io::InputError naming the first photo of another size (all photos of
// a session come from one camera at one setting) or an unreadable one.
void CommonImageSize(const std::vector<std::string>& images, int* width, int* height);

struct StartingModelOptions {
  std::string design_name;  // how the user named the design (in the lines)
  size_t lip_images = 3;    // the first photos the lips are looked for in
  size_t post_images = 5;   // the first photos the posts are looked for in
  // The mount's posts to find: -1 as many as the design's mount has, 0 none (the model gets no
  // mount). With a design without a mount: posts of post_width (mm) just outside the wider lip,
  // from lip plane to lip plane, carried by mirror 1.
  int posts = -1;
  double post_width = 3.0;
};

struct StartingModel {
  RigParams rig;
  std::vector<std::string> lines;  // what was found, one line each (no newline)
};

// The design's camera at the photos' size: focal length scaled with the width, the principal
// point at the centre; then, where the first photos show the lips, f and the principal point
// from them (lips/lip_intrinsics.h). Then the posts (lips/post_finder.h): their azimuths from the
// photos, or the design's mount kept (or none) when the photos do not show the posts asked for.
StartingModel StartingModelFromPhotos(const RigParams& design, const std::vector<std::string>& images,
                                      int width, int height, const StartingModelOptions& options);

}  // namespace omni::detectors
