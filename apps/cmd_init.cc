// `omnistereo init --images 'DIR/*.jpg' --design big_rig|small_rig|FILE --targets '[...]'
// --out session.yaml`: a session for a built rig's photos. Reads the images' size
// (all must agree), picks the starting model (the design at that size; its intrinsics from the
// lips when the first images show them, else from the image size), lists the images and writes
// the session with comments, and the starting model beside it (start_model.yaml). Nothing is
// written when an input is wrong.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "design/design_config.h"
#include "design/optimizer.h"
#include "detectors/common/views.h"
#include "detectors/detect_session.h"
#include "detectors/lips/lip_intrinsics.h"
#include "detectors/lips/post_finder.h"
#include "io/file_util.h"
#include "io/image_file.h"
#include "io/model_file.h"
#include "io/session_file.h"
#include "io/yaml_reader.h"
#include "model/mount.h"
#include "model/rig_parameters.h"

DEFINE_string(design, "big_rig", "init: the rig as designed: big_rig | small_rig (the paper's) | a "
                                 "model file (omnistereo-model/1) | a design config "
                                 "(omnistereo-design/1)");
DEFINE_string(targets, "", "init: the printed targets as a YAML list of session entries, e.g. "
                           "'[{type: chessboard, rows: 6, cols: 8, square: 40}]' (what "
                           "`omnistereo target` prints)");

DEFINE_int32(posts, -1, "init: the posts of the rig's mount to find in the photos (the paper's "
                        "prototype: 3 standoffs); -1: as many as the design's mount has, 0: none");
DEFINE_double(post_width, 3.0, "init: with --posts and a design without a mount: the posts' side "
                               "(mm); they stand just outside the wider lip, lip plane to lip plane");

namespace omni::apps {
namespace {

namespace fs = std::filesystem;

// The starting model of --design, at its own image size.
RigParams DesignedRig() {
  std::string path = FLAGS_design;
  if (path == "big_rig") return io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/big_rig_ideal.yaml");
  if (path == "small_rig") path = std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/small_rig_design.yaml";
  if (!fs::exists(path)) {
    throw io::InputError("--design: expected big_rig, small_rig or an existing file, got '" + path + "'");
  }
  if (io::ReadFormatKey(path).rfind("omnistereo-design/", 0) != 0) return io::ReadModelFile(path);
  const design::DesignConfig config = design::ReadDesignConfig(path);
  const design::OptimizerResult result = design::OptimizeBaseline(config.options);
  if (result.status != design::OptimizerStatus::kConverged &&
      result.status != design::OptimizerStatus::kMaxEvaluations) {
    throw io::InputError(path + ": the design could not be solved: " + result.message);
  }
  return MakeIdealRig(result.best.theta, config.options.r_cam, config.camera, config.image_width,
                      config.image_height);
}

// The images of --images (globs expanded, sorted per pattern) and their common size.
std::vector<std::string> Images(int* width, int* height) {
  const std::vector<std::string> images = ImagesFromFlags();
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
  return images;
}

// The design's camera at the photos' size: focal length scaled with the width, the principal
// point at the centre; then, where the first photos show the lips, f and the principal point
// from them.
void StartingIntrinsics(const std::vector<std::string>& images, RigParams* rig, int width,
                        int height) {
  const double scale = static_cast<double>(width) / rig->image_width;
  rig->camera[0] *= scale;
  rig->camera[1] *= scale;
  rig->camera[2] = 0.5 * (width - 1);
  rig->camera[3] = 0.5 * (height - 1);
  rig->image_width = width;
  rig->image_height = height;
  io::Session lips_only;
  lips_only.images.assign(images.begin(), images.begin() + std::min<size_t>(3, images.size()));
  detectors::SessionDetectOptions options;
  options.guide_by_lips = false;  // the lips alone, from the design's shape at this size
  const Observations found = detectors::DetectSessionReported(lips_only, *rig, options).detections;
  const auto lips = detectors::InitialIntrinsicsFromLipsOf(found, RigModel(*rig));
  if (!lips) {
    std::printf("intrinsics from the image size (f %.1f px, principal point at the centre): no "
                "lips found in the first photos (check `color:` of the lips in %s)\n",
                rig->camera[0], FLAGS_design.c_str());
    return;
  }
  rig->camera[0] = rig->camera[1] = lips->f;
  rig->camera[2] = lips->cx;
  rig->camera[3] = lips->cy;
  std::printf("intrinsics from the lips in the first %zu photos: f %.1f px (sigma %.1f), "
              "principal point (%.1f, %.1f) px, %d edge points\n",
              lips_only.images.size(), lips->f, lips->sigma_f, lips->cx, lips->cy, lips->n_points);
}

// The mount's posts where the first photos show them (detectors/lips/post_finder.h): their azimuths,
// with the design's mount (or, without one, --post_width posts just outside the wider lip from
// lip plane to lip plane, carried by mirror 1). Says what it found; leaves the model without a
// mount when the photos do not show the posts asked for.
void PostsFromPhotos(const std::vector<std::string>& images, RigParams* rig) {
  const int wanted = FLAGS_posts >= 0 ? FLAGS_posts : (rig->mount.present ? static_cast<int>(rig->mount.azimuths.size()) : 0);
  if (wanted == 0) {
    rig->mount = Mount();
    return;
  }
  std::vector<cv::Mat> greys;
  for (size_t i = 0; i < std::min<size_t>(5, images.size()); ++i) {
    greys.push_back(detectors::ToGrey(io::ReadImage(images[i])));
  }
  const std::vector<detectors::FoundPost> found = detectors::FindPosts(greys, RigModel(*rig), wanted);
  if (static_cast<int>(found.size()) < wanted) {
    std::printf("posts: found %zu of the %d asked for in the first %zu photos (a post shows as a plain "
                "radial band across both rings in every photo, against a textured room); the "
                "starting model has %s\n", found.size(), wanted, greys.size(),
                rig->mount.present ? "the design's mount" : "no mount: give it in the model file (mount:)");
    return;
  }
  Mount mount = rig->mount;
  if (!mount.present) {
    mount.present = true;
    mount.body = Mirror::kOne;
    mount.width = FLAGS_post_width;
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
    char one[32];
    std::snprintf(one, sizeof one, "%s%.1f", list.empty() ? "" : ", ", a * 180 / M_PI);
    list += one;
    if (rig->mount.present) {
      double nearest = M_PI;
      for (double b : rig->mount.azimuths) nearest = std::min(nearest, std::abs(std::remainder(a - b, 2 * M_PI)));
      worst_move = std::max(worst_move, nearest);
    }
  }
  mount.azimuths = azimuths;
  if (PostsOverlap(mount)) {
    std::printf("posts: the photos' flat bands at %s deg would make posts that meet; the starting "
                "model keeps %s\n", list.c_str(), rig->mount.present ? "the design's mount" : "no mount");
    return;
  }
  std::printf("posts found in the first %zu photos at azimuths %s deg (%d posts of %.1f mm at %.1f mm "
              "from the axis); projection leaves their sectors out\n",
              greys.size(), list.c_str(), wanted, mount.width, mount.radius);
  if (rig->mount.present && worst_move > 1.0 * M_PI / 180) {
    std::printf("warning: the design's posts are up to %.1f deg from where the photos show them: the "
                "photos' azimuths are used\n", worst_move * 180 / M_PI);
  }
  rig->mount = mount;
}

}  // namespace

int RunInit() {
  if (FLAGS_images.empty() || FLAGS_out.empty()) {
    throw io::InputError("--images (a glob of the photos) and --out (the session file) are required");
  }
  if (!(FLAGS_post_width > 0)) {
    throw io::InputError("--post_width: expected the posts' side in mm (> 0), got " + std::to_string(FLAGS_post_width));
  }
  io::Session session;
  session.estimate = DefaultEstimateBlocks();
  session.targets = io::ParseTargetList(FLAGS_targets, "--targets");
  if (session.targets.empty()) {
    throw io::InputError("--targets: expected the printed targets, e.g. '[{type: chessboard, "
                         "rows: 6, cols: 8, square: 40}]' (`omnistereo target` prints the entry)");
  }
  int width = 0, height = 0;
  session.images = Images(&width, &height);
  RigParams rig = DesignedRig();
  StartingIntrinsics(session.images, &rig, width, height);
  PostsFromPhotos(session.images, &rig);

  const fs::path out = fs::absolute(FLAGS_out);
  const std::string model_path = (out.parent_path() / "start_model.yaml").string();
  session.model_path = model_path;
  const std::string text =
      "# omnistereo-session/1 written by `omnistereo init` from " + FLAGS_images + ".\n"
      "# model: the starting model (the design " + FLAGS_design + " at the photos' " +
      std::to_string(width) + "x" + std::to_string(height) + "; calibrate refines it).\n"
      "# images: the photos (globs allowed); targets: what was printed, exactly (mm).\n"
      "# lips: use the coloured lips at the mirror rims; tone: srgb for colour cameras and JPEG,\n"
      "# linear for machine-vision cameras with gamma off; bayer: RGGB|... for raw frames.\n"
      "# Next: omnistereo detect --session " + FLAGS_out + " --out detections.yaml --overlay overlays/\n" +
      io::SessionText(session, out.parent_path().string());
  io::WriteModelFile(model_path, rig);
  io::WriteFileAtomically(out.string(), text);
  std::printf("%zu photos of %dx%d, %zu target(s); session %s, starting model %s\n",
              session.images.size(), width, height, session.targets.size(), FLAGS_out.c_str(),
              model_path.c_str());
  return 0;
}

}  // namespace omni::apps
