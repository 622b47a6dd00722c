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

// "a deg (sigma s), w mm (sigma s)" for a found post at `radius` (mm).
std::string PostText(const FoundPost& post, double radius) {
  const double side = PostSideFromBand(post.width, radius);
  const double sigma_side = 0.5 * (PostSideFromBand(post.width + post.sigma_width, radius) -
                                   PostSideFromBand(std::max(0.0, post.width - post.sigma_width), radius));
  double deg = post.azimuth * 180 / M_PI;
  if (deg >= 359.95) deg -= 360;  // printed as 0.0, not 360.0
  return Format("%.1f deg (sigma %.2f), %.1f mm (sigma %.2f; %.1f deg wide)", deg,
                post.sigma_azimuth * 180 / M_PI, side, sigma_side, post.width * 180 / M_PI);
}

// The posts' radius (mm): the design's mount's, or posts just outside the wider lip (their axis
// half the widest post's side beyond it), the sides measured at that radius.
double PostRadius(const RigParams& rig, const std::vector<FoundPost>& found, double seed_width) {
  if (rig.mount.present) return rig.mount.radius;
  const double lip = std::max(rig.lip1.r_outer, rig.lip2.r_outer);
  double radius = lip + 0.5 * seed_width;
  for (int iteration = 0; iteration < 3; ++iteration) {
    double widest = 0;
    for (const FoundPost& post : found) widest = std::max(widest, PostSideFromBand(post.width, radius));
    if (widest > 0) radius = lip + 0.5 * widest;
  }
  return radius;
}

// The mount's posts where the first photos show them: their azimuths and sides, with the design's
// mount's radius and span (or, without one, posts just outside the wider lip from lip plane to lip
// plane). Fewer than asked for: what was searched, found and refused, and the model keeps the
// design's mount (or none).
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
  const PostSearch search = SearchPosts(greys, RigModel(*rig), wanted);
  std::vector<FoundPost> found = search.found;
  std::sort(found.begin(), found.end(), [](const FoundPost& a, const FoundPost& b) { return a.azimuth < b.azimuth; });
  const double radius = PostRadius(*rig, found, options.post_width);
  std::string list;
  for (const FoundPost& post : found) list += Format("\n  post at %s", PostText(post, radius).c_str());
  if (static_cast<int>(found.size()) < wanted) {
    std::string refused;
    for (const RefusedPost& r : search.refused) {
      refused += Format("\n  refused: a band at %.1f deg, %.1f deg wide: %s", r.azimuth * 180 / M_PI,
                        r.width * 180 / M_PI, r.why.c_str());
    }
    if (search.refused.empty()) refused = "\n  no other band scored (a post shows as a plain radial band in both rings, unlike the room beside it)";
    out->lines.push_back(Format(
        "posts: found %zu of the %d asked for in %d photos, searching %s of both rings; the starting "
        "model has %s",
        found.size(), wanted, search.photos, search.searched.c_str(),
        rig->mount.present ? "the design's mount" : "no mount: give it in the model file (mount:)") +
        list + refused);
    return;
  }
  Mount mount = rig->mount;
  if (!mount.present) {
    mount.present = true;
    mount.body = Mirror::kOne;
    mount.z_min = std::min(rig->lip1.z, rig->lip2.z);
    mount.z_max = std::max(rig->lip1.z, rig->lip2.z);
  }
  mount.radius = radius;
  mount.azimuths.clear();
  mount.widths.clear();
  double worst_move = 0;
  for (const FoundPost& post : found) {
    mount.azimuths.push_back(post.azimuth);
    mount.widths.push_back(PostSideFromBand(post.width, radius));
    if (rig->mount.present) {
      double nearest = M_PI;
      for (double b : rig->mount.azimuths) {
        nearest = std::min(nearest, std::abs(std::remainder(post.azimuth - b, 2 * M_PI)));
      }
      worst_move = std::max(worst_move, nearest);
    }
  }
  mount.width = mount.MaxWidth();
  if (PostsOverlap(mount)) {
    out->lines.push_back(Format("posts: the photos' bands would make posts that meet; the starting "
                                "model keeps %s",
                                rig->mount.present ? "the design's mount" : "no mount") + list);
    return;
  }
  out->lines.push_back(Format("posts: %d found in the first %d photos, at %.1f mm from the axis%s; "
                              "projection leaves their sectors out",
                              wanted, search.photos, radius,
                              rig->mount.present ? " (the design's)" : " (just outside the wider lip)") +
                       list);
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
