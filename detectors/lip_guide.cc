#include "detectors/lip_guide.h"

#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <utility>

#include "detectors/common/option_check.h"
#include "detectors/lips/lip_detector.h"
#include "detectors/lips/lip_intrinsics.h"
#include "io/image_file.h"

namespace omni::detectors {

std::vector<size_t> LipGuideImages(size_t n) {
  constexpr size_t kImages = 3;
  std::vector<size_t> out;
  if (n <= kImages) {
    for (size_t i = 0; i < n; ++i) out.push_back(i);
    return out;
  }
  // First, middle and last: the targets move, the lips do not, but an image may have a lip
  // hidden by a target held close.
  for (size_t k = 0; k < kImages; ++k) out.push_back(k * (n - 1) / (kImages - 1));
  return out;
}

namespace {

// The lips' edges in the guide's images as `model` predicts them, and the lip-only fit from them.
struct LipSearch {
  std::vector<LipEdgeObservation> edges;
  std::optional<LipIntrinsics> fit;
};

LipSearch SearchLips(const std::vector<GuideImage>& images, const RigModel& model,
                     io::ToneCurve tone, LipPredictionCache* cache) {
  LipSearch search;
  const RigParams& rig = model.params();
  for (const GuideImage& one : images) {
    const cv::Mat& image = one.image;
    if (image.channels() < 3 || image.cols != rig.image_width || image.rows != rig.image_height) {
      continue;
    }
    const std::vector<LipEdgeObservation> found = DetectLips(
        LipInput(io::LinearImage(image, tone)), model, LipOptionsFor(image, one.chroma_halved, one.luma),
        cache);
    search.edges.insert(search.edges.end(), found.begin(), found.end());
  }
  search.fit = InitialIntrinsicsFromLips(search.edges, model, /*fit_reflex_tilt=*/true);
  return search;
}

}  // namespace

std::string LipGuideOptions::Check() const {
  if (!(min_f_change > 0)) return OptionError("min_f_change", "a fraction > 0 of f", min_f_change);
  if (!(min_pp_move_px > 0)) return OptionError("min_pp_move_px", "a move > 0 px", min_pp_move_px);
  if (!(min_inner_move_px > 0)) return OptionError("min_inner_move_px", "a move > 0 px", min_inner_move_px);
  if (!(max_f_change > min_f_change)) {
    return OptionError("max_f_change", "a fraction of f above min_f_change", max_f_change);
  }
  if (!(max_move_per_f > 0)) return OptionError("max_move_per_f", "a fraction > 0 of f", max_move_per_f);
  if (!(max_rms_px > 0)) return OptionError("max_rms_px", "an rms > 0 px", max_rms_px);
  for (double s : f_scan) {
    if (!(s > 0.5 && s < 2)) return OptionError("f_scan", "scales of f in (0.5, 2)", s);
  }
  return "";
}

LipGuide GuideByLips(const std::vector<GuideImage>& images, DetectorContext* ctx,
                     const LipGuideOptions& options) {
  if (const std::string error = options.Check(); !error.empty()) throw std::invalid_argument(error);
  const RigParams& rig = ctx->model.params();
  LipGuide guide;
  guide.f_before = 0.5 * (rig.camera[kFx] + rig.camera[kFy]);
  guide.pp_before = Eigen::Vector2d(rig.camera[kCx], rig.camera[kCy]);
  guide.reflex_before = guide.reflex_after = Eigen::Vector2d(rig.reflex[kReflexRx], rig.reflex[kReflexRy]);
  guide.mirror2_tz_before = guide.mirror2_tz_after = rig.mirror2_pose[kTz];
  guide.mount_in_model = rig.mount.present;
  for (const GuideImage& one : images) {
    guide.images += one.image.channels() >= 3 && one.image.cols == rig.image_width &&
                    one.image.rows == rig.image_height;
  }
  if (guide.images == 0) {
    guide.why_not = "no colour image to find the lips in";
    return guide;
  }
  LipSearch search = SearchLips(images, ctx->model, ctx->tone, &ctx->lip_prediction);
  // A model whose f is several percent off (the design's f at another camera's size) predicts
  // the lips beyond the detector's search (+-1.4% of f: about +-4% of f in the lips' radii): the
  // lips are looked for again with f scaled in steps within that reach, and the search that
  // finds the most edge points whose fit holds is kept.
  const auto holds = [&](const LipSearch& s) { return s.fit && s.fit->rms_px <= options.max_rms_px; };
  if (!holds(search)) {
    for (double scale : options.f_scan) {
      RigParams scaled = rig;
      scaled.camera[kFx] *= scale;
      scaled.camera[kFy] *= scale;
      LipSearch candidate = SearchLips(images, RigModel(scaled), ctx->tone, &ctx->lip_prediction);
      if (holds(candidate) && (!holds(search) || candidate.fit->n_points > search.fit->n_points)) {
        search = std::move(candidate);
        guide.f_scanned = scale;
      }
    }
  }
  // A fit far from the model it was searched with (a scaled f, or a start whose lips lay at the
  // search's reach) came from the edges that prediction reached, which may be a few: the lips
  // are looked for again with its f and principal point (the model's reflex tilt: a few edges
  // set it poorly), and the search with more edge points kept.
  if (holds(search) &&
      (std::abs(search.fit->f / guide.f_before - 1) > options.min_f_change ||
       (Eigen::Vector2d(search.fit->cx, search.fit->cy) - guide.pp_before).norm() > options.min_pp_move_px)) {
    RigParams refit = rig;
    refit.camera[kFx] = refit.camera[kFy] = search.fit->f;
    refit.camera[kCx] = search.fit->cx;
    refit.camera[kCy] = search.fit->cy;
    LipSearch again = SearchLips(images, RigModel(refit), ctx->tone, &ctx->lip_prediction);
    if (holds(again) && again.fit->n_points >= search.fit->n_points) search = std::move(again);
  }
  const std::vector<LipEdgeObservation>& edges = search.edges;
  const std::optional<LipIntrinsics>& lips = search.fit;
  if (!lips) {
    guide.why_not = "too few lip edge points (" + std::to_string(edges.size()) +
                    " edges) for the lip-only fit: check the lips' paints (color:) in the model file "
                    "and the overlays";
    return guide;
  }
  guide.points = lips->n_points;
  guide.rms_px = lips->rms_px;
  guide.f_after = lips->f;
  guide.pp_after = Eigen::Vector2d(lips->cx, lips->cy);
  if (lips->reflex_tilt) guide.reflex_after = *lips->reflex_tilt;
  const double f_change = std::abs(guide.f_after / guide.f_before - 1);
  // The principal point's move, and the inner ring's by the reflex's tilt (mirrored rays turn by
  // twice the plane's tilt).
  const double pp_move_px = (guide.pp_after - guide.pp_before).norm();
  const double inner_move_px = 2 * guide.f_after * (guide.reflex_after - guide.reflex_before).norm();
  if (f_change < options.min_f_change && pp_move_px < options.min_pp_move_px &&
      inner_move_px < options.min_inner_move_px) {
    guide.why_not = "the model already agrees with the lips";
    return guide;
  }
  const double move_px = pp_move_px + inner_move_px;
  if (f_change > options.max_f_change || move_px > options.max_move_per_f * guide.f_after ||
      lips->rms_px > options.max_rms_px) {
    char line[200];
    std::snprintf(line, sizeof line,
                  "the lip-only fit is not trusted (f %+.1f%%, the rings moved %.1f px, rms "
                  "%.2f px)",
                  100 * (guide.f_after / guide.f_before - 1), move_px, lips->rms_px);
    guide.why_not = line;
    return guide;
  }
  RigParams corrected = rig;
  corrected.camera[kFx] = corrected.camera[kFy] = lips->f;
  corrected.camera[kCx] = lips->cx;
  corrected.camera[kCy] = lips->cy;
  corrected.reflex[kReflexRx] = guide.reflex_after.x();
  corrected.reflex[kReflexRy] = guide.reflex_after.y();
  if (lips->mirror2_tz) corrected.mirror2_pose[kTz] = guide.mirror2_tz_after = *lips->mirror2_tz;
  ctx->SetModel(corrected);
  guide.applied = true;
  return guide;
}

std::string Describe(const LipGuide& guide) {
  char line[520];
  if (guide.applied) {
    std::snprintf(line, sizeof line,
                  "detection guided by the lips in %d image(s): f %.1f -> %.1f px, principal "
                  "point (%.1f, %.1f) -> (%.1f, %.1f) px, reflex tilt (%.2f, %.2f) -> (%.2f, "
                  "%.2f) deg, mirror 2's tz %.2f -> %.2f mm (the inner ring's scale) (rms %.2f px "
                  "over %d edge points; the session's model is unchanged)",
                  guide.images, guide.f_before, guide.f_after, guide.pp_before.x(),
                  guide.pp_before.y(), guide.pp_after.x(), guide.pp_after.y(),
                  guide.reflex_before.x() * 180 / M_PI, guide.reflex_before.y() * 180 / M_PI,
                  guide.reflex_after.x() * 180 / M_PI, guide.reflex_after.y() * 180 / M_PI,
                  guide.mirror2_tz_before, guide.mirror2_tz_after, guide.rms_px, guide.points);
  } else {
    std::snprintf(line, sizeof line, "detection guided by the model as it is: %s",
                  guide.why_not.c_str());
  }
  return line;
}

LipGuide GuideByLipsOf(size_t count, const std::function<GuideImage(size_t i)>& read,
                       DetectorContext* ctx, const LipGuideOptions& options) {
  std::vector<GuideImage> images;
  for (size_t i : LipGuideImages(count)) images.push_back(read(i));
  return GuideByLips(images, ctx, options);
}

}  // namespace omni::detectors
