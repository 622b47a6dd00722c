#include "detectors/detect_session.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <set>
#include <utility>

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
  char judgement[320];
  if (guide.rms_px <= kGuideRmsFinePx) {
    std::snprintf(judgement, sizeof judgement,
                  "\n  lip fit rms %.2f px: fine (under %.1f px; 0.4-0.5 px where the model fits "
                  "the rig's lips)",
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

// A warning where this photo shows the model's posts turned (MountTurnInPhoto).
void CheckPosts(const cv::Mat& image, const RigModel& model, std::vector<std::string>* warnings) {
  const Mount& mount = model.params().mount;
  if (!mount.present || mount.azimuths.empty()) return;
  const std::optional<double> turn = MountTurnInPhoto(ToGrey(image), model);
  if (!turn) return;
  char line[220];
  std::snprintf(line, sizeof line,
                "the mount's posts show %+.1f deg from where the model puts them (mount.azimuths_deg): "
                "another rig's model, or a mount turned since; `omnistereo init --posts %zu` finds them",
                *turn * 180 / M_PI, mount.azimuths.size());
  warnings->push_back(line);
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

}  // namespace omni::detectors
