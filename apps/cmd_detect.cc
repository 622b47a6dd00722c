// `omnistereo detect --session S --out detections.yaml [--overlay DIR] [--model M]`: target corners of every
// kind (chessboards, AprilTag grids; per ring, with ids consistent between the rings) and lip
// band edges (colour images, when the session uses lips) in every image of a session, written as an
// `omnistereo-detections/1` file. Unreadable images (missing, empty, undecodable) get one warning
// line each and are left out; if no image is usable nothing is written and the exit code is 2.
// An image of an unsupported layout (float, 32 bit, colour with a session `bayer:` key) or not
// of the model's size stops the session with one line naming it: nothing is written.
// --overlay writes DIR/<image>.png (apps/overlay.h): the ring boundaries, corners coloured by
// ring (mirror 1 green, mirror 2 magenta), each board named once per ring and the ids that can be
// read, lip edge points as single yellow pixels, a legend.
// A lips-only session (`targets: []`) finds the lips alone and prints the intrinsics they give
// against the model's: a quick check of a new camera (or of the lips' paints) before any target
// is printed.
// --model M detects with M instead of the session's model (a second pass from the calibrated model).
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <gflags/gflags.h>
#include <opencv2/imgcodecs.hpp>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/overlay.h"
#include "apps/progress.h"
#include "detectors/detect_image.h"
#include "detectors/detect_session.h"
#include "detectors/lips/lip_intrinsics.h"
#include "io/detections_file.h"
#include "io/file_util.h"
#include "io/model_file.h"
#include "io/session_file.h"

DEFINE_string(overlay, "", "folder for overlay PNGs (corners by ring, board names and ids, lip edge points, ring boundaries, a legend)");

namespace omni::apps {
namespace {

namespace fs = std::filesystem;

// `path` relative to `base_dir` when it lies below it, else as given.
std::string RelativeTo(const std::string& path, const fs::path& base_dir) {
  std::error_code ec;
  const fs::path abs = fs::absolute(path, ec), base = fs::absolute(base_dir, ec);
  const fs::path rel = abs.lexically_normal().lexically_relative(base.lexically_normal());
  if (rel.empty() || *rel.begin() == "..") return path;
  return rel.string();
}

// The overlay (apps/overlay.h) of one photo, written whole or not at all.
void WriteOverlay(const std::string& path, const cv::Mat& image, const detectors::RingLayout& layout,
                  const ImageObservations& det, const std::vector<TargetSpec>& targets) {
  std::vector<uchar> png;
  if (!cv::imencode(".png", DrawOverlay(image, layout, det, targets), png)) {
    throw std::runtime_error("cannot encode " + path);
  }
  io::WriteFileAtomically(path, std::string(png.begin(), png.end()));
}

// The intrinsics the lips alone give, against the model's. A check, not a calibration: the fit
// puts the principal point where the mirror bodies put the lips' centres, which moves with
// their misalignment, and f absorbs the lens's radial distortion and the bodies' axial offsets
// (lip_intrinsics.h: f within ~0.6%, the principal point a few px off on a misaligned rig).
void PrintLipCheck(const Observations& detections, const RigModel& model) {
  const RigParams& p = model.params();
  const auto lips = detectors::InitialIntrinsicsFromLipsOf(detections, model);
  if (!lips) {
    size_t edges = 0;
    for (const auto& image : detections.images) edges += image.lips.size();
    std::printf("lips only: too few lip edge points for an intrinsics check (%zu edges found): "
                "check the lips' paints (color:) in the model file and the overlays\n",
                edges);
    return;
  }
  const double f_model = 0.5 * (p.camera[kFx] + p.camera[kFy]);
  std::printf("lips only: f %.1f px (sigma %.2f; the model's %.1f: %+.2f%%), principal point "
              "(%.1f, %.1f) px (sigma %.2f, %.2f; the model's (%.1f, %.1f)), rms %.3f px over %d "
              "edge points\n",
              lips->f, lips->sigma_f, f_model, 100 * (lips->f / f_model - 1), lips->cx, lips->cy,
              lips->sigma_cx, lips->sigma_cy, p.camera[kCx], p.camera[kCy], lips->rms_px,
              lips->n_points);
  std::printf("  a check, not a calibration: from the design as the model, the lips put the "
              "principal point where the mirror bodies put the lips' centres (a few px from it on "
              "a misaligned rig) and f within ~0.6%% (lens distortion, axial offsets); calibrate "
              "with targets for the model\n");
}

// One photo's progress line: its corners per ring, lip edges, time, and per target corners in
// ring 1 / ring 2 (what a user checks each photo by).
std::string ImageLine(const detectors::ImageReport& r, const ImageObservations& det) {
  // Per target: corners in ring 1 / ring 2 (what a user checks each photo by).
  std::map<int, std::array<int, 2>> per_target;
  for (const CornerObservation& c : det.corners) ++per_target[c.target][MirrorIndex(c.mirror) - 1];
  std::string targets;
  for (const auto& [t, count] : per_target) {
    targets += (targets.empty() ? "; " : ", ") + std::string("target ") + std::to_string(t) +
               " " + std::to_string(count[0]) + " / " + std::to_string(count[1]);
  }
  char line[512];
  std::snprintf(line, sizeof(line),
                "[%zu/%zu] %s: %d corners in ring 1, %d in ring 2, %zu lip edges (%.0f ms)%s",
                r.index + 1, r.total, r.file.c_str(), r.corners[0], r.corners[1], det.lips.size(),
                r.ms, targets.c_str());
  return line;
}

// The session per target: in how many photos it was found, its corners per ring.
void PrintTargetSummary(const io::Session& session, const Observations& detections) {
  for (size_t t = 0; t < session.targets.size(); ++t) {
    int photos = 0, ring[2] = {0, 0};
    for (const ImageObservations& image : detections.images) {
      bool seen = false;
      for (const CornerObservation& c : image.corners) {
        if (c.target != static_cast<int>(t)) continue;
        seen = true;
        ++ring[MirrorIndex(c.mirror) - 1];
      }
      photos += seen;
    }
    const TargetSpec& spec = session.targets[t];
    std::printf("  target %zu (%s): in %d of %zu photos, %d corners in ring 1, %d in ring 2%s\n",
                t, TargetName(spec).c_str(), photos, detections.images.size(),
                ring[0], ring[1], photos == 0 ? ": never found (check its rows/cols, size and first_id)" : "");
  }
}

void CreateFolder(const std::string& folder, const char* flag) {
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) throw io::InputError(std::string(flag) + " " + folder + ": cannot create the folder: " + ec.message());
}

}  // namespace

int RunDetect() {
  if (FLAGS_session.empty() || FLAGS_out.empty()) {
    throw io::InputError("--session and --out are required");
  }
  const io::Session session = io::ReadSessionFile(FLAGS_session);
  if (session.targets.empty() && !session.use_lips) {
    throw io::InputError(FLAGS_session + ": targets: [] and lips: false: nothing to detect");
  }
  // --model: another model than the session's, e.g. the calibrated one for a second pass (its
  // rings' edges and its predictions from one ring into the other are where the rig has them,
  // so guided detection finds more corners).
  const RigParams rig = io::ReadModelFile(FLAGS_model.empty() ? session.model_path : FLAGS_model);
  detectors::DetectorContext ctx(rig, session.targets, session.use_lips);
  bool nothing_read = false;
  const detectors::LipGuide guide = detectors::GuideSessionByLips(session, &ctx, &nothing_read);
  if (!nothing_read) std::printf("%s\n", detectors::GuideLine(guide).c_str());
  std::fflush(stdout);  // before the progress lines on stderr
  if (!FLAGS_overlay.empty()) CreateFolder(FLAGS_overlay, "--overlay");
  const fs::path out_dir = fs::absolute(FLAGS_out).parent_path();
  int bad = 0, corners = 0;
  const size_t n = session.images.size();
  detectors::RepeatedSheets repeated;
  ProgressLine progress("detect", static_cast<int>(n));
  Observations detections = detectors::DetectSession(
      session, &ctx,
      [&](const detectors::ImageReport& r, const cv::Mat& image, ImageObservations* det) {
        repeated.Add(r);
        const char* file = r.file.c_str();
        if (r.skipped) {
          progress.Done(std::string("warning: ") + file + ": " + r.warnings.front() + "; skipped");
          ++bad;
          return;
        }
        for (const auto& w : r.warnings) progress.Print(std::string("warning: ") + file + ": " + w);
        corners += r.corners[0] + r.corners[1];
        if (!FLAGS_overlay.empty()) {
          WriteOverlay((fs::path(FLAGS_overlay) / (fs::path(r.file).stem().string() + ".png")).string(),
                       image, ctx.layout, *det, session.targets);
        }
        det->file = RelativeTo(r.file, out_dir);
        progress.Done(ImageLine(r, *det));
      });
  progress.Finish();
  const std::string note = repeated.Note(session.targets);
  if (!note.empty()) std::fprintf(stderr, "warning: %s: %s\n", FLAGS_session.c_str(), note.c_str());
  detections.session = RelativeTo(session.path, out_dir);
  io::WriteDetectionsFile(FLAGS_out, detections);
  std::printf("%zu of %zu images used (%d skipped), %d corners, detections in %s\n",
              detections.images.size(), n, bad, corners, FLAGS_out.c_str());
  PrintTargetSummary(session, detections);
  if (session.targets.empty()) PrintLipCheck(detections, RigModel(rig));
  return 0;
}

}  // namespace omni::apps
