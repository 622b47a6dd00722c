#include "detectors/starting_model.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "detectors/common/views.h"
#include "detectors/detect_session.h"
#include "detectors/lips/lip_intrinsics.h"
#include "detectors/lips/post_finder.h"
#include "io/image_file.h"
#include "io/session_file.h"
#include "model/mount.h"

namespace omni::detectors {
namespace {

// printf into a std::string (the lines are for the user, as the commands print them).
template <typename... Args>
std::string Format(const char* format, Args... args) {
  char line[1024];
  std::snprintf(line, sizeof line, format, args...);
  return line;
}

// The design's camera at the photos' size, then f and the principal point from the lips.
void StartingIntrinsics(const std::vector<std::string>& images, const StartingModelOptions& options,
                        int width, int height, StartingModel* out) {
  RigParams* rig = &out->rig;
  const double scale = static_cast<double>(width) / rig->image_width;
  rig->camera[kFx] *= scale;
  rig->camera[kFy] *= scale;
  rig->camera[kCx] = 0.5 * (width - 1);
  rig->camera[kCy] = 0.5 * (height - 1);
  rig->image_width = width;
  rig->image_height = height;
  io::Session lips_only;
  lips_only.images.assign(images.begin(),
                          images.begin() + std::min(options.lip_images, images.size()));
  SessionDetectOptions detect;
  detect.guide_by_lips = false;  // the lips alone, from the design's shape at this size
  const Observations found = DetectSessionReported(lips_only, *rig, detect).detections;
  const auto lips = InitialIntrinsicsFromLipsOf(found, RigModel(*rig));
  if (!lips) {
    out->lines.push_back(Format(
        "intrinsics from the image size (f %.1f px, principal point at the centre): no lips "
        "found in the first photos (check `color:` of the lips in %s)",
        rig->camera[kFx], options.design_name.c_str()));
    return;
  }
  rig->camera[kFx] = rig->camera[kFy] = lips->f;
  rig->camera[kCx] = lips->cx;
  rig->camera[kCy] = lips->cy;
  out->lines.push_back(Format("intrinsics from the lips in the first %zu photos: f %.1f px "
                              "(sigma %.1f), principal point (%.1f, %.1f) px, %d edge points",
                              lips_only.images.size(), lips->f, lips->sigma_f, lips->cx, lips->cy,
                              lips->n_points));
}

// The mount's posts where the first photos show them: their azimuths, with the design's mount
// (or, without one, options.post_width posts just outside the wider lip).
void PostsFromPhotos(const std::vector<std::string>& images, const StartingModelOptions& options,
                     StartingModel* out) {
  RigParams* rig = &out->rig;
  const int wanted = options.posts >= 0 ? options.posts
                     : rig->mount.present ? static_cast<int>(rig->mount.azimuths.size())
                                          : 0;
  if (wanted == 0) {
    rig->mount = Mount();
    return;
  }
  std::vector<cv::Mat> greys;
  for (size_t i = 0; i < std::min(options.post_images, images.size()); ++i) {
    greys.push_back(ToGrey(io::ReadImage(images[i])));
  }
  const std::vector<FoundPost> found = FindPosts(greys, RigModel(*rig), wanted);
  if (static_cast<int>(found.size()) < wanted) {
    out->lines.push_back(Format(
        "posts: found %zu of the %d asked for in the first %zu photos (a post shows as a plain "
        "radial band across both rings in every photo, against a textured room); the starting "
        "model has %s",
        found.size(), wanted, greys.size(),
        rig->mount.present ? "the design's mount" : "no mount: give it in the model file (mount:)"));
    return;
  }
  Mount mount = rig->mount;
  if (!mount.present) {
    mount.present = true;
    mount.body = Mirror::kOne;
    mount.width = options.post_width;
    mount.radius = std::max(rig->lip1.r_outer, rig->lip2.r_outer) + 0.5 * mount.width;
    mount.z_min = std::min(rig->lip1.z, rig->lip2.z);
    mount.z_max = std::max(rig->lip1.z, rig->lip2.z);
  }
  std::vector<double> azimuths;
  for (const auto& post : found) azimuths.push_back(post.azimuth);
  std::sort(azimuths.begin(), azimuths.end());
  std::string list;
  double worst_move = 0;
  for (double a : azimuths) {
    list += Format("%s%.1f", list.empty() ? "" : ", ", a * 180 / M_PI);
    if (rig->mount.present) {
      double nearest = M_PI;
      for (double b : rig->mount.azimuths) {
        nearest = std::min(nearest, std::abs(std::remainder(a - b, 2 * M_PI)));
      }
      worst_move = std::max(worst_move, nearest);
    }
  }
  mount.azimuths = azimuths;
  if (PostsOverlap(mount)) {
    out->lines.push_back(Format("posts: the photos' flat bands at %s deg would make posts that "
                                "meet; the starting model keeps %s",
                                list.c_str(),
                                rig->mount.present ? "the design's mount" : "no mount"));
    return;
  }
  out->lines.push_back(Format("posts found in the first %zu photos at azimuths %s deg (%d posts "
                              "of %.1f mm at %.1f mm from the axis); projection leaves their "
                              "sectors out",
                              greys.size(), list.c_str(), wanted, mount.width, mount.radius));
  if (rig->mount.present && worst_move > 1.0 * M_PI / 180) {
    out->lines.push_back(Format("warning: the design's posts are up to %.1f deg from where the "
                                "photos show them: the photos' azimuths are used",
                                worst_move * 180 / M_PI));
  }
  rig->mount = mount;
}

}  // namespace

void CommonImageSize(const std::vector<std::string>& images, int* width, int* height) {
  *width = *height = 0;
  for (const std::string& path : images) {
    const cv::Mat image = io::ReadImage(path);
    if (*width == 0) {
      *width = image.cols;
      *height = image.rows;
    } else if (image.cols != *width || image.rows != *height) {
      throw io::InputError(path + ": expected " + std::to_string(*width) + "x" +
                           std::to_string(*height) + " like " + images.front() + ", got " +
                           std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                           " (all photos of a session come from one camera at one setting)");
    }
  }
}

StartingModel StartingModelFromPhotos(const RigParams& design, const std::vector<std::string>& images,
                                      int width, int height, const StartingModelOptions& options) {
  StartingModel out;
  out.rig = design;
  StartingIntrinsics(images, options, width, height, &out);
  PostsFromPhotos(images, options, &out);
  return out;
}

}  // namespace omni::detectors
