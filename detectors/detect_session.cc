#include "detectors/detect_session.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <utility>

#include "detectors/post_finder.h"
#include "model/io/image_file.h"

namespace omni::detectors {

LipGuide GuideSessionByLips(const io::Session& session, DetectorContext* ctx) {
  ctx->tone = session.tone;
  if (!session.use_lips) {
    LipGuide none;
    none.why_not = "the session does not use the lips (lips: false)";
    return none;
  }
  std::vector<GuideImage> images;
  for (size_t i : LipGuideImages(session.images.size())) {
    const std::string& file = session.images[i];
    try {
      GuideImage one;
      one.image = io::ReadImage(file, session.bayer);
      one.chroma_halved = io::HasHalvedChroma(file);
      if (one.chroma_halved) one.luma = io::ReadStoredLuma(file);
      images.push_back(std::move(one));
    } catch (const io::UnreadableImage&) {
      // DetectSession reports it.
    }
  }
  return GuideByLips(images, ctx);
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
    ImageObservations det = DetectImage(image, ctx, &report.warnings);
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
  return detections;
}

}  // namespace omni::detectors
