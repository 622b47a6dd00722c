// `omnistereo init --images 'DIR/*.jpg' --design big_rig|small_rig|FILE --targets '[...]'
// --out session.yaml`: a session for a built rig's photos. Reads the images' size
// (all must agree), picks the starting model (the design at that size; its intrinsics from the
// lips when the first images show them, else from the image size), lists the images and writes
// the session with comments, and the starting model beside it (start_model.yaml). Nothing is
// written when an input is wrong.
// `--design single_mirror` (a single-mirror camera nobody designed for us): the start from the
// mirror's rim in the photos and what the builder knows (--mirror_diameter, --mirror, --lens,
// --camera_distance, --focal_px, --magnification, --unified; detectors/single_mirror_start.h).
#include <cstdio>
#include <filesystem>
#include <string>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "design/design_config.h"
#include "design/optimizer.h"
#include "detectors/single_mirror_start.h"
#include "detectors/starting_model.h"
#include "io/file_util.h"
#include "io/model_file.h"
#include "io/session_file.h"
#include "io/yaml_reader.h"
#include "model/rig_parameters.h"

DEFINE_string(design, "big_rig", "init: the rig as designed: big_rig | small_rig (the paper's) | a "
                                 "model file (omnistereo-model/1) | a design config "
                                 "(omnistereo-design/1) | single_mirror (one mirror seen "
                                 "directly, found by its rim in the photos)");
DEFINE_string(targets, "", "init: the printed targets as a YAML list of session entries, e.g. "
                           "'[{type: chessboard, rows: 6, cols: 8, square: 40}]' (what "
                           "`omnistereo target` prints)");

DEFINE_int32(posts, -1, "init: the posts of the rig's mount to find in the photos (the paper's "
                        "prototype: 3 standoffs), each placed (azimuth) and measured (side, mm) "
                        "with its uncertainty; -1: as many as the design's mount has, 0: none");
DEFINE_double(post_width, 3.0, "init: with --posts and a design without a mount: the posts stand just "
                               "outside the wider lip, lip plane to lip plane; their sides are measured "
                               "in the photos, this side (mm) only seeds their distance from the axis");

DEFINE_double(mirror_diameter, 0, "init, single_mirror: the mirror rim's measured diameter (mm): "
                                  "the model's scale (not given: from --magnification or "
                                  "--camera_distance, else a nominal 50 mm, and the absolute "
                                  "size is left undetermined)");
DEFINE_string(mirror, "unknown", "init, single_mirror: hyperbolic | parabolic | spherical | unknown "
                                 "(its shape is estimated either way; a declared paraboloid or "
                                 "sphere keeps its K)");
DEFINE_string(lens, "perspective", "init: perspective | telecentric (single_mirror only: with a "
                                   "parabolic, spherical or unknown mirror)");
DEFINE_double(camera_distance, 0, "init, single_mirror: the lens's rough distance to the mirror's "
                                  "vertex (mm); a sphere seen in perspective needs it (or --focal_px); "
                                  "with --focal_px it checks --mirror_diameter (within 30%)");
DEFINE_double(focal_px, 0, "init, single_mirror, perspective lens: the lens's focal length in px "
                           "(focal mm / pixel pitch mm), if known: it places the camera");
DEFINE_string(unified, "", "init, single_mirror: XI,GAMMA_PX of a central fit's unified model "
                          "(cv::omnidir, Mei): the start's conic and distance from it, scaled by "
                          "the rim, instead of the rim-at-the-horizon assumption");
DEFINE_double(magnification, 0, "init, single_mirror, telecentric lens: px per mm (the lens's "
                                "magnification / pixel pitch mm), if known: it checks "
                                "--mirror_diameter (within 5%)");

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

// The single-mirror knowledge flags, checked (naming the flag).
detectors::SingleMirrorKnowledge KnowledgeFromFlags() {
  detectors::SingleMirrorKnowledge know;
  know.mirror_diameter = FLAGS_mirror_diameter;
  if (!detectors::ParseMirrorKnowledge(FLAGS_mirror, &know.mirror)) {
    throw io::InputError("--mirror: expected hyperbolic, parabolic, spherical or unknown, got '" +
                         FLAGS_mirror + "'");
  }
  know.lens = FLAGS_lens == "telecentric" ? LensKind::kTelecentric : LensKind::kPerspective;
  know.camera_distance = FLAGS_camera_distance;
  know.focal_px = FLAGS_focal_px;
  know.magnification = FLAGS_magnification;
  if (!FLAGS_unified.empty()) {
    char rest = 0;
    if (std::sscanf(FLAGS_unified.c_str(), "%lf,%lf%c", &know.unified_xi, &know.unified_gamma,
                    &rest) != 2) {
      throw io::InputError("--unified: expected XI,GAMMA_PX (e.g. 0.96,410.5), got '" +
                           FLAGS_unified + "'");
    }
  }
  if (const std::string bad = know.Check(); !bad.empty()) throw io::InputError("--" + bad);
  return know;
}

// The flags that only a single-mirror design takes, refused with another design.
void RefuseSingleMirrorFlags() {
  if (FLAGS_lens == "telecentric") {
    throw io::InputError("--lens: telecentric needs --design single_mirror; the folded rig ('" +
                         FLAGS_design + "') is built with a perspective camera");
  }
  for (const auto& [flag, set] : {std::pair<const char*, bool>{"mirror_diameter", FLAGS_mirror_diameter != 0},
                                  {"mirror", FLAGS_mirror != "unknown"},
                                  {"camera_distance", FLAGS_camera_distance != 0},
                                  {"focal_px", FLAGS_focal_px != 0},
                                  {"magnification", FLAGS_magnification != 0},
                                  {"unified", !FLAGS_unified.empty()}}) {
    if (set) throw io::InputError(std::string("--") + flag + ": only with --design single_mirror");
  }
}

// The starting model and the session's comment on it (its choices made in the session).
struct Start {
  RigParams rig;
  std::string about;
};

// A single mirror: the rim in the photos, the model and the session's estimate, priors, lips.
Start SingleMirrorStart(io::Session* session) {
  const detectors::SingleMirrorKnowledge know = KnowledgeFromFlags();
  std::string why;
  const auto start = detectors::SingleMirrorStartFromPhotos(
      detectors::GreyPhotosForRim(session->images), know, &why);
  if (!start) throw io::InputError("--" + why);
  for (const std::string& line : start->lines) std::printf("%s\n", line.c_str());
  session->estimate = start->estimate;
  for (const auto& [name, prior] : start->priors) session->priors[name] = prior;
  // The rim's edge (detectors/lips/rim_edge.h): the scale's datum, where it is the rim (calibrate
  // judges that at the calibrated mirror: model/single_rim.h RimEdgeIsTheRim).
  session->use_lips = true;
  std::string about = "# model: the starting model (a single mirror found by its rim in the "
                      "photos, " + FLAGS_mirror + " mirror, " + FLAGS_lens +
                      " lens; calibrate refines it).\n";
  for (const std::string& line : start->comments) about += "# " + line + "\n";
  return {start->rig, about};
}

// A built rig: the design at the photos' size, its intrinsics from the lips, its posts.
Start DesignStart(const io::Session& session, int width, int height) {
  detectors::StartingModelOptions options;
  options.design_name = FLAGS_design;
  options.posts = FLAGS_posts;
  options.post_width = FLAGS_post_width;
  const detectors::StartingModel start =
      detectors::StartingModelFromPhotos(DesignedRig(), session.images, width, height, options);
  for (const std::string& line : start.lines) std::printf("%s\n", line.c_str());
  return {start.rig, "# model: the starting model (the design " + FLAGS_design +
                         " at the photos' " + std::to_string(width) + "x" +
                         std::to_string(height) + "; calibrate refines it).\n"};
}

// The flags every design checks first.
void CheckCommonFlags(bool single) {
  if (FLAGS_images.empty() || FLAGS_out.empty()) {
    throw io::InputError("--images (a glob of the photos) and --out (the session file) are required");
  }
  if (FLAGS_lens != "perspective" && FLAGS_lens != "telecentric") {
    throw io::InputError("--lens: expected perspective or telecentric, got '" + FLAGS_lens + "'");
  }
  if (!single) RefuseSingleMirrorFlags();
  if (!(FLAGS_post_width > 0)) {
    throw io::InputError("--post_width: expected the posts' side in mm (> 0), got " + std::to_string(FLAGS_post_width));
  }
}

}  // namespace

int RunInit() {
  const bool single = FLAGS_design == "single_mirror";
  CheckCommonFlags(single);
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
  const Start start = single ? SingleMirrorStart(&session) : DesignStart(session, width, height);

  const fs::path out = fs::absolute(FLAGS_out);
  const std::string model_path = (out.parent_path() / "start_model.yaml").string();
  session.model_path = model_path;
  const std::string text =
      "# omnistereo-session/1 written by `omnistereo init` from " + FLAGS_images + ".\n" +
      start.about +
      "# images: the photos (globs allowed); targets: what was printed, exactly (mm).\n" +
      std::string(single ? "# " : "# lips: use the coloured lips at the mirror rims; ") +
      "tone: srgb for colour cameras and JPEG,\n"
      "# linear for machine-vision cameras with gamma off; bayer: RGGB|... for raw frames.\n"
      "# Next: omnistereo detect --session " + FLAGS_out + " --out detections.yaml --overlay overlays/\n" +
      io::SessionText(session, out.parent_path().string());
  // The session's folder may be new (init --out work/session.yaml): made once everything is known.
  std::error_code ec;
  fs::create_directories(out.parent_path(), ec);
  if (ec) {
    throw io::InputError("--out: cannot create the folder " + out.parent_path().string() + " (" +
                         ec.message() + ")");
  }
  io::WriteModelFile(model_path, start.rig);
  io::WriteFileAtomically(out.string(), text);
  std::printf("%zu photos of %dx%d, %zu target(s); session %s, starting model %s\n",
              session.images.size(), width, height, session.targets.size(), FLAGS_out.c_str(),
              model_path.c_str());
  std::printf("next: omnistereo detect --session %s --out detections.yaml --overlay overlays/\n"
              "      omnistereo calibrate --session %s --detections detections.yaml --out "
              "calibrated.yaml\n",
              FLAGS_out.c_str(), FLAGS_out.c_str());
  return 0;
}

}  // namespace omni::apps
