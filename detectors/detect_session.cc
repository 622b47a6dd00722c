#include "detectors/detect_session.h"

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <utility>

#include "detectors/lips/lip_intrinsics.h"
#include "detectors/lips/post_finder.h"
#include "io/image_file.h"

namespace omni::detectors {

LipGuide GuideSessionByLips(const io::Session& session, DetectorContext* ctx,
                            bool* nothing_read) {
  ctx->tone = session.tone;
  if (nothing_read) *nothing_read = false;
  if (!session.use_lips) {
    LipGuide none;
    none.why_not = "the session does not use the lips (lips: false)";
    return none;
  }
  const RigParams& rig = ctx->model.params();
  if (rig.Single() && !HasLip(rig, Mirror::kOne)) {
    LipGuide none;
    none.why_not = "the single mirror's model paints no lip";
    return none;
  }
  // The guide's picks; an unreadable one (DetectSession reports it) is replaced by the next
  // readable image after it not picked already, so that the guide reads none only when the
  // session has no readable image.
  const std::vector<size_t> picks = LipGuideImages(session.images.size());
  std::vector<bool> taken(session.images.size(), false);
  for (size_t i : picks) taken[i] = true;
  std::vector<GuideImage> images;
  for (size_t i : picks) {
    for (size_t k = i; k < session.images.size(); ++k) {
      if (k != i && taken[k]) continue;
      taken[k] = true;
      const std::string& file = session.images[k];
      try {
        GuideImage one;
        one.image = io::ReadImage(file, session.bayer);
        one.chroma_halved = io::HasHalvedChroma(file);
        if (one.chroma_halved) one.luma = io::ReadStoredLuma(file);
        images.push_back(std::move(one));
        break;
      } catch (const io::UnreadableImage&) {
        // DetectSession reports it; the next image is tried in its place.
      }
    }
  }
  if (images.empty() && !session.images.empty()) {
    if (nothing_read) *nothing_read = true;
    LipGuide none;
    none.why_not = "none of the session's images could be read";
    return none;
  }
  return GuideByLips(images, ctx);
}

std::string GuideLine(const LipGuide& guide) {
  std::string line = Describe(guide);
  if (guide.points == 0) return line;
  // What the lip-only fit's rms says (experiments.md: 0.43-0.45 px on rigs whose model fits
  // the lips, the posts in the model or none on the rig; 2.0-2.4 px from an ideal design or with
  // the posts missing from the model).
  char judgement[480];
  if (guide.rms_px <= kGuideRmsFinePx) {
    std::snprintf(judgement, sizeof judgement,
                  "\n  lip fit rms %.2f px: fine (under %.1f px; 0.4-0.5 px where the model fits "
                  "the rig's lips)",
                  guide.rms_px, kGuideRmsFinePx);
  } else if (guide.mount_in_model) {
    // The posts are in the model and the lip points beside them left out: not their want.
    std::snprintf(judgement, sizeof judgement,
                  "\n  lip fit rms %.2f px: high (over %.1f px; 0.4-0.5 px where the model fits): "
                  "the model does not fit the lips well (its posts are in it, the lip points "
                  "beside them left out): a start far from the rig, a post the model misplaces "
                  "(mount: in the model file), blur or a wrong paint; check the overlays' lip points",
                  guide.rms_px, kGuideRmsFinePx);
  } else {
    std::snprintf(judgement, sizeof judgement,
                  "\n  lip fit rms %.2f px: high (over %.1f px; 0.4-0.5 px where the model fits): "
                  "the model does not fit the lips well: posts not in the model (`omnistereo "
                  "init --posts N`), a start far from the rig, blur or a wrong paint; check the "
                  "overlays' lip points",
                  guide.rms_px, kGuideRmsFinePx);
  }
  // f scales both lips' images as the mirrors' distances from the camera do: the bodies' axial
  // offsets, which the lips cannot see, go into it (experiments.md: -0.46% for offsets of 0.3-0.4
  // mm, 0.002% with the true offsets).
  return line + judgement +
         "; f is good to ~0.1% per 0.1 mm of the mirrors' axial offsets, which the lips cannot "
         "see: the calibration measures it";
}

namespace {

// Warnings where this photo's posts disagree with the model's mount (CompareMountWithPhoto): the
// mount turned, a post where the model has none, a model post not seen. Detection goes on with
// the model's mount either way: the sectors it names are where corners are expected hidden.
void CheckPosts(const cv::Mat& image, const RigModel& model, std::vector<std::string>* warnings) {
  const Mount& mount = model.params().mount;
  if (!mount.present || mount.azimuths.empty()) return;
  const MountInPhoto compared = CompareMountWithPhoto(ToGrey(image), model);
  char line[320];
  if (compared.turn) {
    std::snprintf(line, sizeof line,
                  "the mount's posts show %+.1f deg from where the model puts them (mount.azimuths_deg): "
                  "another rig's model, or a mount turned since; `omnistereo init --posts %zu` finds them",
                  *compared.turn * 180 / M_PI, mount.azimuths.size());
    warnings->push_back(line);
    return;
  }
  for (const FoundPost& post : compared.unexpected) {
    std::snprintf(line, sizeof line,
                  "a post at %.1f deg (a band %.1f deg wide) where the model's mount has none "
                  "(mount.azimuths_deg): boards it crosses there are not expected to be cut; "
                  "`omnistereo init --posts %zu` puts it in the model",
                  post.azimuth * 180 / M_PI, post.width * 180 / M_PI, mount.azimuths.size() + 1);
    warnings->push_back(line);
  }
  for (int i : compared.unseen) {
    std::snprintf(line, sizeof line,
                  "the model's post at %.1f deg (mount.azimuths_deg) is not seen in this photo: a "
                  "target in front of it, or a mount without it (its sector is still taken to hide "
                  "what lies behind it)",
                  mount.azimuths[i] * 180 / M_PI);
    warnings->push_back(line);
  }
}

}  // namespace

void RepeatedSheets::Add(const ImageReport& report) {
  const std::set<int> targets(report.repeated_targets.begin(), report.repeated_targets.end());
  for (int t : targets) ++photos_[t];
}

std::string RepeatedSheets::Note(const std::vector<TargetSpec>& targets) const {
  if (photos_.empty()) return "";
  std::string which;
  for (const auto& [t, photos] : photos_) {
    const TargetSpec& spec = targets[t];
    which += (which.empty() ? "" : ", ") + std::string("target ") + std::to_string(t) + " (" +
             TargetName(spec) + ") in " + std::to_string(photos) + " photo(s)";
  }
  return "more copies of one sheet in a ring than the session lists targets of its pattern: " +
         which + "; one copy per ring was kept, the others left out. List an identical chessboard "
         "once per copy under targets: (the copies are then told apart by azimuth), or give "
         "each sheet its own pattern (chessboards another rows x cols, tag grids their own "
         "first_id range: `omnistereo target`) and list each as its own entry "
         "(docs/formats/session.md)";
}

Observations DetectSession(const io::Session& session, DetectorContext* ctx,
                             const ImageCallback& on_image) {
  if (session.images.empty()) {
    throw io::InputError(session.path + ": images: expected the photos (paths or globs); a "
                         "session without them only serves calibrate and report with --detections");
  }
  const RigParams& rig = ctx->model.params();
  ctx->tone = session.tone;
  Observations detections;
  detections.session = session.path;
  const size_t n = session.images.size();
  std::string first_unreadable;
  for (size_t i = 0; i < n; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    ImageReport report;
    report.index = i;
    report.total = n;
    report.file = session.images[i];
    report.rings = rig.Paths();
    cv::Mat image;
    try {
      image = io::ReadImage(report.file, session.bayer);
    } catch (const io::UnreadableImage& e) {
      if (first_unreadable.empty()) first_unreadable = e.what();
      report.skipped = true;
      report.warnings.push_back(std::string(e.what()).substr(report.file.size() + 2));
      if (on_image) on_image(report, cv::Mat(), nullptr);
      continue;
    }
    if (image.cols != rig.image_width || image.rows != rig.image_height) {
      throw io::InputError(report.file + ": expected a " + std::to_string(rig.image_width) + "x" +
                           std::to_string(rig.image_height) + " image (the model's size, " +
                           session.model_path + "), got " + std::to_string(image.cols) + "x" +
                           std::to_string(image.rows) + "; nothing written");
    }
    ctx->chroma_halved = io::HasHalvedChroma(report.file);
    ctx->luma = ctx->chroma_halved ? io::ReadStoredLuma(report.file) : cv::Mat();
    CheckPosts(image, ctx->model, &report.warnings);
    ImageObservations det =
        DetectImage(image, ctx, &report.warnings, nullptr, &report.repeated_targets);
    det.file = report.file;
    det.width = image.cols;
    det.height = image.rows;
    if (det.corners.empty() && !ctx->targets.empty()) {
      report.warnings.push_back("no target corners found");
    }
    for (const auto& c : det.corners) ++report.corners[MirrorIndex(c.mirror) - 1];
    report.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (on_image) on_image(report, image, &det);
    detections.images.push_back(std::move(det));
  }
  if (detections.images.empty()) {
    throw io::InputError(session.path + ": none of the " + std::to_string(n) +
                         " images could be read (missing or undecodable; the first: " +
                         first_unreadable + ")");
  }
  return detections;
}

std::string ImageLine(const ImageReport& report, const ImageObservations& detections,
                      bool detail) {
  char line[512];
  if (report.rings == 1) {
    std::snprintf(line, sizeof(line), "[%zu/%zu] %s: %d corners", report.index + 1, report.total,
                  report.file.c_str(), report.corners[0]);
    std::string out = line;
    if (detail) out += ", " + std::to_string(detections.lips.size()) + " lip edges";
    std::snprintf(line, sizeof(line), " (%.0f ms)", report.ms);
    return out + line;
  }
  if (!detail) {
    std::snprintf(line, sizeof(line), "[%zu/%zu] %s: %d corners in ring 1, %d in ring 2 (%.0f ms)",
                  report.index + 1, report.total, report.file.c_str(), report.corners[0],
                  report.corners[1], report.ms);
    return line;
  }
  std::map<int, std::array<int, 2>> per_target;
  for (const CornerObservation& c : detections.corners) {
    ++per_target[c.target][MirrorIndex(c.mirror) - 1];
  }
  std::string targets;
  for (const auto& [t, count] : per_target) {
    targets += (targets.empty() ? "; " : ", ") + std::string("target ") + std::to_string(t) +
               " " + std::to_string(count[0]) + " / " + std::to_string(count[1]);
  }
  std::snprintf(line, sizeof(line),
                "[%zu/%zu] %s: %d corners in ring 1, %d in ring 2, %zu lip edges (%.0f ms)%s",
                report.index + 1, report.total, report.file.c_str(), report.corners[0],
                report.corners[1], detections.lips.size(), report.ms, targets.c_str());
  return line;
}

SessionDetection DetectSessionReported(const io::Session& session, const RigParams& rig,
                                       const SessionDetectOptions& options,
                                       const SessionDetectHooks& hooks) {
  DetectorContext ctx(rig, session.targets, session.use_lips);
  std::string guide_line;
  if (options.guide_by_lips) {
    bool nothing_read = false;
    const LipGuide guide = GuideSessionByLips(session, &ctx, &nothing_read);
    if (!nothing_read) guide_line = GuideLine(guide);
  }
  if (hooks.before_images) hooks.before_images(guide_line);
  SessionDetection out;
  RepeatedSheets repeated;
  out.detections = DetectSession(
      session, &ctx, [&](const ImageReport& r, const cv::Mat& image, ImageObservations* det) {
        repeated.Add(r);
        // An unreadable image has its one warning, the reason (DetectSession).
        if (r.skipped) {
          ++out.skipped;
          if (hooks.image_done) {
            hooks.image_done("warning: " + r.file + ": " + r.warnings.front() + "; skipped");
          }
          return;
        }
        if (hooks.warning) {
          for (const auto& w : r.warnings) hooks.warning("warning: " + r.file + ": " + w);
        }
        out.corners += r.corners[0] + r.corners[1];
        if (hooks.detected) hooks.detected(r, image, *det, ctx.layout);
        if (hooks.image_done) hooks.image_done(ImageLine(r, *det, options.image_detail));
      });
  out.repeated_note = repeated.Note(session.targets);
  return out;
}

std::string TargetSummary(const std::vector<TargetSpec>& targets, const Observations& detections,
                          int paths) {
  std::string out;
  for (size_t t = 0; t < targets.size(); ++t) {
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
    char line[512];
    const char* never = photos == 0 ? ": never found (check its rows/cols, size and first_id)" : "";
    if (paths == 1) {  // a single-mirror rig: one ring
      std::snprintf(line, sizeof line, "  target %zu (%s): in %d of %zu photos, %d corners%s\n", t,
                    TargetName(targets[t]).c_str(), photos, detections.images.size(), ring[0],
                    never);
    } else {
      std::snprintf(line, sizeof line,
                    "  target %zu (%s): in %d of %zu photos, %d corners in ring 1, %d in ring 2%s\n",
                    t, TargetName(targets[t]).c_str(), photos, detections.images.size(), ring[0],
                    ring[1], never);
    }
    out += line;
  }
  return out;
}

std::string LipsOnlyCheck(const Observations& detections, const RigModel& model) {
  const RigParams& p = model.params();
  const auto lips = InitialIntrinsicsFromLipsOf(detections, model);
  char line[1024];
  if (!lips) {
    size_t edges = 0;
    for (const auto& image : detections.images) edges += image.lips.size();
    std::snprintf(line, sizeof line,
                  "lips only: too few lip edge points for an intrinsics check (%zu edges found): "
                  "check the lips' paints (color:) in the model file and the overlays\n",
                  edges);
    return line;
  }
  const double f_model = 0.5 * (p.camera[kFx] + p.camera[kFy]);
  std::snprintf(line, sizeof line,
                "lips only: f %.1f px (sigma %.2f; the model's %.1f: %+.2f%%), principal point "
                "(%.1f, %.1f) px (sigma %.2f, %.2f; the model's (%.1f, %.1f)), rms %.3f px over %d "
                "edge points\n",
                lips->f, lips->sigma_f, f_model, 100 * (lips->f / f_model - 1), lips->cx, lips->cy,
                lips->sigma_cx, lips->sigma_cy, p.camera[kCx], p.camera[kCy], lips->rms_px,
                lips->n_points);
  return std::string(line) +
         "  a check, not a calibration: from the design as the model, the lips put the "
         "principal point where the mirror bodies put the lips' centres (a few px from it on "
         "a misaligned rig) and f within ~0.6% (lens distortion, axial offsets); calibrate "
         "with targets for the model\n";
}

}  // namespace omni::detectors
