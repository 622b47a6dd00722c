// `omnistereo init --images 'DIR/*.jpg' --design big_rig|small_rig|FILE --targets '[...]'
// --out session.yaml`: a session for a built rig's photos. Reads the images' size
// (all must agree), picks the starting model (the design at that size; its intrinsics from the
// lips when the first images show them, else from the image size), lists the images and writes
// the session with comments, and the starting model beside it (start_model.yaml). Nothing is
// written when an input is wrong.
#include <cstdio>
#include <filesystem>
#include <string>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "design/design_config.h"
#include "design/optimizer.h"
#include "detectors/starting_model.h"
#include "io/file_util.h"
#include "io/model_file.h"
#include "io/session_file.h"
#include "io/yaml_reader.h"
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
  session.images = ImagesFromFlags();
  int width = 0, height = 0;
  detectors::CommonImageSize(session.images, &width, &height);
  detectors::StartingModelOptions options;
  options.design_name = FLAGS_design;
  options.posts = FLAGS_posts;
  options.post_width = FLAGS_post_width;
  const detectors::StartingModel start =
      detectors::StartingModelFromPhotos(DesignedRig(), session.images, width, height, options);
  for (const std::string& line : start.lines) std::printf("%s\n", line.c_str());
  const RigParams& rig = start.rig;

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
