#include "detectors/detect_image.h"

#include <algorithm>
#include <iterator>
#include <set>
#include <string>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "detectors/apriltag/apriltag_detector.h"
#include "detectors/chessboard/raw_board.h"
#include "detectors/lips/lip_detector.h"
#include "detectors/lips/rim_edge.h"
#include "io/file_util.h"

namespace omni::detectors {
namespace {

// The chessboards at the absolute saddle threshold; where the context also takes dim junctions
// (saddle_relative_contrast > 0: single mirrors) and a chessboard of the session is still
// missing, a second pass with them, whose boards are added for the targets the first lacked.
// Why two passes: dim junctions found everywhere also wake the room's faint texture, whose
// saddles join a bright board's region and cost boards the first pass finds (12 realistic renders
// of a single hyperboloid: 100% -> 61% of the corners with them always on), while a board in a
// dark corridor (Mei's photos: ~80 grey levels per junction in linear light) has no saddle at
// all above the absolute threshold (5 of 10 boards lost).
std::vector<CornerObservation> ChessboardsBrightThenDim(const cv::Mat& grey,
                                                        const DetectorContext& ctx,
                                                        std::vector<int>* repeated) {
  ChessboardOptions bright = ctx.chessboard;
  bright.saddle_relative_contrast = 0;
  std::vector<CornerObservation> corners =
      DetectChessboards(grey, ctx.views, ctx.model, ctx.targets, bright, repeated);
  if (!(ctx.chessboard.saddle_relative_contrast > 0)) return corners;
  std::set<int> found;
  for (const CornerObservation& c : corners) found.insert(c.target);
  bool missing = false;
  for (size_t t = 0; t < ctx.targets.size(); ++t) {
    missing = missing || (ctx.targets[t].type == TargetType::kChessboard && !found.count(t));
  }
  if (!missing) return corners;
  std::vector<int> dim_repeated;
  for (const CornerObservation& c : DetectChessboards(grey, ctx.views, ctx.model, ctx.targets,
                                                      ctx.chessboard, &dim_repeated)) {
    if (!found.count(c.target)) corners.push_back(c);
  }
  if (repeated) {
    for (int t : dim_repeated) {
      if (!found.count(t)) repeated->push_back(t);
    }
  }
  return corners;
}

// A single mirror's chessboard of which the views found less than the whole board in this
// photo: searched in the photo itself (raw_board.h); where that finds more of it, its corners
// replace the views' (the same ids: one rule).
void ChessboardsInThePhoto(const cv::Mat& image, const cv::Mat& grey, const DetectorContext& ctx,
                           std::vector<CornerObservation>* corners) {
  cv::Mat photo;
  double blur = -1;
  for (size_t t = 0; t < ctx.targets.size(); ++t) {
    const TargetSpec& spec = ctx.targets[t];
    if (spec.type != TargetType::kChessboard) continue;
    const auto seen = std::count_if(corners->begin(), corners->end(), [&](const CornerObservation& c) {
      return c.target == static_cast<int>(t);
    });
    if (seen >= CornerCount(spec)) continue;
    if (photo.empty()) {
      photo = ToGrey(image);
      if (photo.depth() != CV_8U) photo.convertTo(photo, CV_8U, photo.depth() == CV_16U ? 1.0 / 257 : 1.0);
      blur = 0;
      for (const RingView& v : ctx.views) {
        if (v.blur_sigma) {
          blur = v.RawBlurAt(Eigen::Vector2d(v.cx, v.cy));
          break;
        }
      }
    }
    const auto board = FindBoardInPhoto(photo, grey, ctx.model, spec, static_cast<int>(t), blur,
                                        ctx.chessboard);
    if (!board || static_cast<long>(board->ids.size()) <= seen) continue;
    corners->erase(std::remove_if(corners->begin(), corners->end(),
                                  [&](const CornerObservation& c) { return c.target == static_cast<int>(t); }),
                   corners->end());
    for (size_t i = 0; i < board->ids.size(); ++i) {
      CornerObservation o;
      o.target = board->target;
      o.id = board->ids[i];
      o.mirror = board->mirror;
      o.pixel = board->raw_pixels[i];
      corners->push_back(o);
    }
  }
}

}  // namespace

cv::Mat LipInput(const cv::Mat& linear) {
  if (linear.channels() != 4) return linear;
  cv::Mat bgr;
  cv::cvtColor(linear, bgr, cv::COLOR_BGRA2BGR);
  return bgr;
}

LipDetectorOptions LipOptionsFor(const cv::Mat& image, bool chroma_halved, const cv::Mat& luma) {
  LipDetectorOptions options;
  options.chroma_halved = chroma_halved;
  if (chroma_halved && luma.size() == image.size()) options.luma = luma;
  return options;
}

namespace {

// "30-37, 40" from a set of ids.
std::string IdRanges(const std::set<int>& ids) {
  std::string out;
  for (auto it = ids.begin(); it != ids.end();) {
    int last = *it;
    auto next = std::next(it);
    while (next != ids.end() && *next == last + 1) last = *next++;
    out += (out.empty() ? "" : ", ") + std::to_string(*it) + (last > *it ? "-" + std::to_string(last) : "");
    it = next;
  }
  return out;
}

// One line for tags read that no target holds: which, and the ids the session's targets of that
// layout take.
std::string UnclaimedTagsLine(TargetType layout, const std::set<int>& ids,
                              const std::vector<TargetSpec>& targets) {
  std::set<int> taken;
  for (const TargetSpec& t : targets) {
    if (t.type != layout) continue;
    for (int id = t.first_id; id < t.first_id + t.rows * t.cols; ++id) taken.insert(id);
  }
  return std::string(TargetTypeName(layout)) + " tag ids " + IdRanges(ids) +
         " read that no target of the session holds (its " + TargetTypeName(layout) + " targets take " +
         (taken.empty() ? std::string("none") : IdRanges(taken)) +
         "): check first_id, rows x cols and the layout of the printed sheets";
}

}  // namespace

DetectorContext::DetectorContext(const RigParams& rig, std::vector<TargetSpec> target_specs,
                                 bool lips, const ViewOptions& views_wanted)
    : view_options(views_wanted),
      model(rig),
      layout(ComputeRingLayout(model)),
      views(MakeRingViews(model, view_options)),
      targets(std::move(target_specs)),
      use_lips(lips) {
  SetSingleMirrorOptions();
}

void DetectorContext::SetSingleMirrorOptions() {
  chessboard.smooth_grid_correction = model.params().Single();
  // Dim boards' junctions (chessboard_detector.h, saddle_relative_contrast).
  chessboard.saddle_relative_contrast = model.params().Single() ? 0.4 : 0.0;
  // No painted lips beside a single mirror's boards (ChessboardOptions::foreign_edge_slope).
  chessboard.foreign_edge_slope = model.params().Single() ? 0.7 : 0.5;
  // Boards no view holds whole (a large board held close; a start far from an unknown mirror).
  chessboard.search_photo = model.params().Single();
}

void DetectorContext::SetModel(const RigParams& rig) {
  model = RigModel(rig);
  SetSingleMirrorOptions();
  layout = ComputeRingLayout(model);
  views = MakeRingViews(model, view_options);
}

ImageObservations DetectImage(const cv::Mat& image, DetectorContext* ctx,
                                std::vector<std::string>* warnings, std::vector<bool>* guided,
                                std::vector<int>* repeated) {
  const RigParams& rig = ctx->model.params();
  if (image.empty()) throw io::InputError("the image is empty or could not be decoded");
  if (image.cols != rig.image_width || image.rows != rig.image_height) {
    throw io::InputError("the image is " + std::to_string(image.cols) + "x" +
                         std::to_string(image.rows) + ", the model expects " +
                         std::to_string(rig.image_width) + "x" + std::to_string(rig.image_height));
  }
  ImageObservations out;
  out.width = image.cols;
  out.height = image.rows;
  // Edges are found as halfway levels between surfaces: only in linear light are they there.
  const cv::Mat linear = io::LinearImage(image, ctx->tone);
  const cv::Mat grey = ToGrey(linear);
  RenderViews(grey, &ctx->views);
  out.corners = ChessboardsBrightThenDim(grey, *ctx, repeated);
  if (rig.Single() && ctx->chessboard.search_photo) ChessboardsInThePhoto(image, grey, *ctx, &out.corners);
  // Tag grids (plain tag36h11 and Kalibr AprilGrids) in the same, already rendered views.
  bool any_tags = false;
  for (const TargetSpec& t : ctx->targets) any_tags = any_tags || t.type != TargetType::kChessboard;
  if (any_tags) {
    UnclaimedTags unclaimed;
    const std::vector<CornerObservation> tags =
        DetectTagGrids(grey, ctx->views, ctx->model, ctx->targets, &unclaimed);
    out.corners.insert(out.corners.end(), tags.begin(), tags.end());
    if (warnings) {
      for (const auto& [layout, ids] : {std::pair{TargetType::kKalibrAprilGrid, &unclaimed.kalibr},
                                        std::pair{TargetType::kAprilTagGrid, &unclaimed.plain}}) {
        if (ids->size() >= 2) warnings->push_back(UnclaimedTagsLine(layout, *ids, ctx->targets));
      }
    }
  }
  const size_t per_ring = out.corners.size();
  const std::vector<CornerObservation> across =
      GuidedCorners(grey, ctx->views, ctx->model, ctx->targets, out.corners, ctx->guided);
  out.corners.insert(out.corners.end(), across.begin(), across.end());
  if (guided) {
    guided->assign(out.corners.size(), false);
    std::fill(guided->begin() + per_ring, guided->end(), true);
  }
  // A single mirror without a painted lip: its rim's edge is the observation (rim_edge.h).
  if (ctx->use_lips && rig.Single() && !HasLip(rig, Mirror::kOne)) {
    std::string why;
    if (auto rim = DetectRimEdge(grey, ctx->model, RimEdgeOptions{}, &why)) {
      out.lips.push_back(std::move(*rim));
    } else if (warnings) {
      warnings->push_back("the mirror's rim: " + why);
    }
  } else if (ctx->use_lips) {
    if (image.channels() >= 3) {
      out.lips = DetectLips(LipInput(linear), ctx->model, LipOptionsFor(image, ctx->chroma_halved, ctx->luma),
                           &ctx->lip_prediction);
    } else if (warnings) {
      warnings->push_back("grey image: the coloured lips cannot be detected");
    }
  }
  return out;
}

}  // namespace omni::detectors
