#include "detectors/apriltag_detector.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "detectors/kalibr_detector.h"
#include "detectors/saddle_points.h"

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
}

namespace omni::detectors {
namespace {

// The black border's width as a fraction of the tag side (model/target.h): libapriltag's
// tag36h11 is 8 bits across with a 1-bit border, Kalibr's 10 bits with a 2-bit border.
double BorderFraction(TargetType type) {
  return type == TargetType::kKalibrAprilGrid ? 2.0 / 10.0 : 1.0 / 8.0;
}

double Bilinear(const cv::Mat& grey, double u, double v) {
  if (!(u >= 0 && v >= 0 && u < grey.cols - 1 && v < grey.rows - 1)) return -1;
  const int x = static_cast<int>(u), y = static_cast<int>(v);
  const double a = u - x, b = v - y;
  const float* r0 = grey.ptr<float>(y);
  const float* r1 = grey.ptr<float>(y + 1);
  return (1 - b) * ((1 - a) * r0[x] + a * r0[x + 1]) + b * ((1 - a) * r1[x] + a * r1[x + 1]);
}

// A tag found in a view: its id, its corners in our k order (view pixels) and the view.
struct ViewTag {
  TargetType layout;
  int tag_id;
  Eigen::Vector2d corners[4];  // view pixels, index k
  int view;
};

std::vector<ViewTag> DetectPlainTags(const cv::Mat& view_grey, int view_index, float decimate) {
  std::vector<ViewTag> out;
  apriltag_family_t* family = tag36h11_create();
  apriltag_detector_t* detector = apriltag_detector_create();
  apriltag_detector_add_family_bits(detector, family, 0);  // exact codes only
  detector->quad_decimate = decimate;
  detector->nthreads = 1;
  image_u8_t im{view_grey.cols, view_grey.rows, static_cast<int32_t>(view_grey.step),
                view_grey.data};
  zarray_t* detections = apriltag_detector_detect(detector, &im);
  for (int i = 0; i < zarray_size(detections); ++i) {
    apriltag_detection_t* det;
    zarray_get(detections, i, &det);
    if (det->hamming != 0) continue;
    ViewTag tag{TargetType::kAprilTagGrid, det->id, {}, view_index};
    // libapriltag puts pixel centres at +0.5; p[k] is our k in an un-mirrored view.
    for (int k = 0; k < 4; ++k) tag.corners[k] = Eigen::Vector2d(det->p[k][0] - 0.5, det->p[k][1] - 0.5);
    out.push_back(tag);
  }
  apriltag_detections_destroy(detections);
  apriltag_detector_destroy(detector);
  tag36h11_destroy(family);
  return out;
}

// Kalibr AprilGrid tags (kalibr_detector.h), each checked against the other tags of its target
// seen in the same view.
std::vector<ViewTag> DetectKalibrTags(const cv::Mat& view_grey, int view_index,
                                      const std::vector<TargetSpec>& targets,
                                      const KalibrDetectorOptions& options) {
  std::map<int, std::vector<KalibrViewTag>> by_target;
  for (const KalibrViewTag& t : DetectKalibrTagsInView(view_grey, options)) {
    for (std::size_t i = 0; i < targets.size(); ++i) {
      int row = 0, col = 0;
      if (targets[i].type == TargetType::kKalibrAprilGrid && TagCell(targets[i], t.tag_id, &row, &col)) {
        by_target[static_cast<int>(i)].push_back(t);
        break;
      }
    }
  }
  std::vector<ViewTag> out;
  for (auto& [target, tags] : by_target) {
    DropTagsInconsistentWithNeighbours(targets[target], options.max_neighbour_error, &tags);
    for (const KalibrViewTag& t : tags) {
      ViewTag tag{TargetType::kKalibrAprilGrid, t.tag_id, {}, view_index};
      for (int k = 0; k < 4; ++k) tag.corners[k] = t.corners[k];
      out.push_back(tag);
    }
  }
  return out;
}

// Sub-pixel points on one tag edge: from the corner along `along` (unit, towards the next
// corner) at distances s in [s0, s1], the 50% crossing of the profile across the edge (the
// black tag on the `inward` side). Returns (s, t) pairs: t the crossing's offset along `inward`.
std::vector<Eigen::Vector2d> EdgePoints(const cv::Mat& grey, const Eigen::Vector2d& corner,
                                        const Eigen::Vector2d& along, const Eigen::Vector2d& inward,
                                        double s0, double s1, double reach_in, double reach_out,
                                        double black, double white) {
  std::vector<Eigen::Vector2d> points;
  constexpr double kStep = 0.1;
  for (double s = s0; s <= s1 + 1e-9; s += 0.5) {
    const Eigen::Vector2d base = corner + s * along;
    const int n = static_cast<int>((reach_in + reach_out) / kStep) + 1;
    std::vector<double> value(n);
    bool inside_image = true;
    for (int i = 0; i < n && inside_image; ++i) {
      const double t = reach_in - i * kStep;  // from inside the tag to outside
      const Eigen::Vector2d p = base + t * inward;
      value[i] = Bilinear(grey, p.x(), p.y());
      inside_image = value[i] >= 0;
    }
    if (!inside_image) continue;
    const double half = 0.5 * (black + white);
    // The crossing nearest to t = 0 (the predicted edge).
    double best_t = 1e9;
    for (int i = 0; i + 1 < n; ++i) {
      const double a = value[i] - half, b = value[i + 1] - half;
      if (a < 0 && b >= 0) {
        const double t = reach_in - (i + a / (a - b)) * kStep;
        if (std::abs(t) < std::abs(best_t)) best_t = t;
      }
    }
    if (best_t < 1e8) points.emplace_back(s, best_t);
  }
  return points;
}

// Least-squares t = c0 + c1 s + c2 s^2; rms of the fit in *rms.
bool FitQuadratic(const std::vector<Eigen::Vector2d>& st, Eigen::Vector3d* c, double* rms) {
  if (st.size() < 4) return false;
  Eigen::MatrixXd A(st.size(), 3);
  Eigen::VectorXd b(st.size());
  for (std::size_t i = 0; i < st.size(); ++i) {
    A.row(i) << 1, st[i].x(), st[i].x() * st[i].x();
    b(i) = st[i].y();
  }
  *c = A.colPivHouseholderQr().solve(b);
  *rms = std::sqrt((A * *c - b).squaredNorm() / st.size());
  return c->allFinite();
}

// A Kalibr corner that failed the grid check, refined again in its view by the first step's
// cornerSubPix with smaller windows, from where the grid puts it. Its window was cut by the ring's
// edge (the view's black outside the map, or the rim's dark band inside it); a smaller window can
// keep clear of it. Kept only if it then fits the grid tightly: a measurement, not the prediction.
bool RetryKalibrCorner(const cv::Mat& view_grey, const RingView& view, const GridFit& fit,
                       const TagDetectorOptions& options, TagCornerDetection* d) {
  if (view_grey.empty() || fit.residual_px < 0) return false;
  const double first_half = std::lround(0.15 * d->side_in_view);
  for (const double fraction : options.kalibr_retry_windows) {
    const int half = static_cast<int>(std::lround(fraction * first_half));
    if (half < 2 || half >= first_half) continue;
    Eigen::Vector2d refined;
    if (!RefineSaddleCorner(view_grey, fit.predicted_in_view, half, 0.1 * d->side_in_view,
                            &refined)) {
      continue;
    }
    const auto raw = view.ViewToRaw(refined);
    if (raw && (*raw - fit.predicted_raw).norm() <= options.kalibr_retry_max_residual_px) {
      d->in_view = refined;
      d->observation.pixel = *raw;
      d->mapped = *raw;
      d->grid_residual_px = (*raw - fit.predicted_raw).norm();
      return true;
    }
  }
  return false;
}

// The grid check (tag_grid_check.h) for every target and ring; Kalibr corners off the grid get
// one retry (RetryKalibrCorner).
void DropCornersOffTheirTarget(const std::vector<RingView>& views,
                               const std::vector<cv::Mat>& view_images, const RigModel& model,
                               const std::vector<TargetSpec>& targets,
                               const TagDetectorOptions& options,
                               std::vector<TagCornerDetection>* detections) {
  std::map<std::pair<int, int>, std::vector<std::size_t>> groups;  // (target, mirror) -> indices
  for (std::size_t i = 0; i < detections->size(); ++i) {
    const io::CornerObservation& o = (*detections)[i].observation;
    groups[{o.target, o.mirror}].push_back(i);
  }
  std::vector<bool> keep(detections->size(), true);
  for (const auto& [key, members] : groups) {
    std::vector<GridCorner> corners;
    for (const std::size_t i : members) {
      const TagCornerDetection& d = (*detections)[i];
      const Eigen::Vector3d p = CornerInTarget(targets[key.first], d.observation.id);
      corners.push_back({p.head<2>(), d.observation.pixel, d.view});
    }
    const std::vector<GridFit> fits =
        CornersFittingTargetHomography(views, model, corners, options.grid_check_options);
    for (std::size_t j = 0; j < members.size(); ++j) {
      TagCornerDetection& d = (*detections)[members[j]];
      d.grid_residual_px = fits[j].residual_px;
      keep[members[j]] = fits[j].keep;
      if (!fits[j].keep && targets[key.first].type == TargetType::kKalibrAprilGrid) {
        keep[members[j]] = RetryKalibrCorner(view_images[d.view], views[d.view], fits[j], options, &d);
      }
    }
  }
  std::vector<TagCornerDetection> kept;
  for (std::size_t i = 0; i < detections->size(); ++i) {
    if (keep[i]) kept.push_back((*detections)[i]);
  }
  *detections = std::move(kept);
}

}  // namespace

bool RefineTagCorner(const cv::Mat& grey, const Eigen::Vector2d& corner,
                     const Eigen::Vector2d& next, const Eigen::Vector2d& previous,
                     double border_fraction, const TagDetectorOptions& options,
                     Eigen::Vector2d* refined) {
  const Eigen::Vector2d e[2] = {next - corner, previous - corner};
  const double len[2] = {e[0].norm(), e[1].norm()};
  if (!(std::min(len[0], len[1]) >= options.min_edge_px)) return false;
  Eigen::Vector2d along[2], inward[2];
  Eigen::Vector3d curve[2];
  for (int i = 0; i < 2; ++i) {
    along[i] = e[i] / len[i];
    // Inward normal: towards the other edge's side of this one (the tag's interior).
    Eigen::Vector2d n(-along[i].y(), along[i].x());
    if (n.dot(e[1 - i]) < 0) n = -n;
    inward[i] = n;
  }
  // The tag's black and the outside's white: the darkest and brightest values around the
  // corner (narrow borders never reach full black on a single profile through their blur).
  double black = 1e9, white = -1e9;
  const double side = std::min(len[0], len[1]);
  const double level_reach = std::clamp(0.5 * side, 2.0, 8.0);
  for (double a = -level_reach; a <= level_reach; a += 0.5) {
    for (double b = -level_reach; b <= level_reach; b += 0.5) {
      const Eigen::Vector2d p = corner + a * along[0] + b * along[1];
      const double value = Bilinear(grey, p.x(), p.y());
      if (value < 0) continue;
      if (a > 0 && b > 0) black = std::min(black, value);  // the tag's quadrant
      if (a < 0 || b < 0) white = std::max(white, value);
    }
  }
  if (!(white - black > 0.15)) return false;
  for (int i = 0; i < 2; ++i) {
    // Measure along the border only (inside it, the data bits may be white), clear of the
    // corner's own blur, and within the first 40% of the side.
    const double border_px = border_fraction * len[1 - i];
    const double reach_in = std::clamp(0.8 * border_px, 0.8, 3.0);
    const double reach_out = std::clamp(0.8 * border_px, 0.8, 3.0);
    const double s0 = std::max(1.5, 0.6 * reach_in + 0.8);
    const double s1 = std::max(s0 + 2.0, std::min(0.4 * len[i], 12.0));
    const auto st = EdgePoints(grey, corner, along[i], inward[i], s0, s1, reach_in, reach_out, black,
                               white);
    double rms = 0;
    if (!FitQuadratic(st, &curve[i], &rms) || rms > options.max_edge_rms_px) return false;
  }
  // Intersect P_i(s) = corner + s along_i + t_i(s) inward_i by Newton from the corner.
  Eigen::Vector2d st(0, 0);  // (s on edge 0, s on edge 1)
  for (int it = 0; it < 10; ++it) {
    const auto point = [&](int i, double s) {
      return Eigen::Vector2d(corner + s * along[i] +
                             (curve[i](0) + curve[i](1) * s + curve[i](2) * s * s) * inward[i]);
    };
    const auto tangent = [&](int i, double s) {
      return Eigen::Vector2d(along[i] + (curve[i](1) + 2 * curve[i](2) * s) * inward[i]);
    };
    const Eigen::Vector2d r = point(0, st(0)) - point(1, st(1));
    Eigen::Matrix2d J;
    J.col(0) = tangent(0, st(0));
    J.col(1) = -tangent(1, st(1));
    const Eigen::Vector2d step = J.fullPivLu().solve(-r);
    if (!step.allFinite()) return false;
    st += step;
    if (step.norm() < 1e-8) break;
  }
  *refined = corner + st(0) * along[0] +
             (curve[0](0) + curve[0](1) * st(0) + curve[0](2) * st(0) * st(0)) * inward[0];
  return refined->allFinite() && (*refined - corner).norm() <= options.max_refine_shift_px;
}

std::vector<TagCornerDetection> DetectTagCorners(const cv::Mat& raw_bgr,
                                                 const std::vector<RingView>& views,
                                                 const RigModel& model,
                                                 const std::vector<TargetSpec>& targets,
                                                 const TagDetectorOptions& options) {
  std::vector<TagCornerDetection> out;
  bool want_plain = false, want_kalibr = false;
  for (const TargetSpec& t : targets) {
    want_plain |= t.type == TargetType::kAprilTagGrid;
    want_kalibr |= t.type == TargetType::kKalibrAprilGrid;
  }
  if ((!want_plain && !want_kalibr) || raw_bgr.empty()) return out;
  const cv::Mat raw_grey8 = ToGrey(raw_bgr);
  cv::Mat grey;
  raw_grey8.convertTo(grey, CV_32F, 1.0 / 255);

  // Neighbouring views overlap (views.h: 8 views of 90 degrees per ring): each ring's azimuth is
  // searched once by taking only the middle of each view, 360 / views-per-ring degrees plus
  // options.view_overlap_deg on each side, so a tag up to that wide lies whole in some crop.
  // Cuts the tag detectors' pixels by ~40% (they were ~290 ms of a 1280x960 image's ~390 ms).
  int views_per_ring = 0;
  for (const RingView& view : views) views_per_ring += view.mirror == views.front().mirror;
  std::vector<ViewTag> found;
  std::vector<cv::Mat> view_images(views.size());  // kept for the grid check's Kalibr retries
  for (std::size_t v = 0; v < views.size(); ++v) {
    const RingView& view = views[v];
    cv::Mat view_grey = view.image;
    if (view_grey.empty() || view_grey.cols != view.width || view_grey.rows != view.height) {
      cv::remap(raw_grey8, view_grey, view.map_fixed, view.map_interp, cv::INTER_LINEAR,
                cv::BORDER_CONSTANT, cv::Scalar(0));
    }
    view_images[v] = view_grey;
    const double half_deg = 180.0 / std::max(1, views_per_ring) + options.view_overlap_deg;
    const int half_px = static_cast<int>(std::ceil(view.f * std::tan(half_deg * M_PI / 180)));
    const int x0 = std::max(0, static_cast<int>(view.cx) - half_px);
    const int x1 = std::min(view.width, static_cast<int>(view.cx) + half_px + 2);
    const cv::Mat crop = view_grey.colRange(x0, x1).clone();
    std::vector<ViewTag> in_crop;
    if (want_plain) in_crop = DetectPlainTags(crop, static_cast<int>(v), options.quad_decimate);
    for (ViewTag& t : in_crop) {
      for (auto& c : t.corners) c.x() += x0;
      found.push_back(t);
    }
    if (want_kalibr) {
      // Kalibr tag corners are X-junctions (kalibr_detector.h): the quad finder (its contours on
      // the 2x enlarged view were 135 of 280 ms per calibration_scene_tags image) runs only on
      // the boxes of saddle-point clusters (saddle_points.h) within the crop, each with a margin
      // of 2.5 spacings + 8 px around its outermost saddles.
      const cv::Rect crop_rect(x0, 0, x1 - x0, view.height);
      RingView rendered = view;  // shallow: the maps are shared
      rendered.image = view_grey;
      std::vector<Region> regions;
      if (options.kalibr_saddle_gate) {
        regions = Regions(SaddlePoints(rendered, options.kalibr_saddles), view_grey.size(),
                          options.kalibr_saddles);
      } else {
        regions.emplace_back();
        regions.back().rect = crop_rect;
      }
      for (const Region& region : regions) {
        const int pad = static_cast<int>(options.kalibr_region_pad_px);
        const cv::Rect box =
            cv::Rect(region.rect.x - pad, region.rect.y - pad, region.rect.width + 2 * pad,
                     region.rect.height + 2 * pad) & crop_rect;
        if (box.empty()) continue;
        for (ViewTag t : DetectKalibrTags(view_grey(box).clone(), static_cast<int>(v), targets,
                                          options.kalibr)) {
          for (auto& c : t.corners) c += Eigen::Vector2d(box.x, box.y);
          found.push_back(t);
        }
      }
    }
  }

  // One detection per (layout, tag, ring): the one whose corners lie nearest its view's centre.
  std::map<std::tuple<int, int, int>, std::pair<double, const ViewTag*>> best;
  for (const ViewTag& t : found) {
    const RingView& view = views[t.view];
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (const auto& c : t.corners) centre += 0.25 * c;
    const double off = (centre - Eigen::Vector2d(view.cx, view.cy)).norm();
    const auto key = std::make_tuple(static_cast<int>(t.layout), t.tag_id, MirrorIndex(view.mirror));
    auto it = best.find(key);
    if (it == best.end() || off < it->second.first) best[key] = {off, &t};
  }

  for (const auto& [key, entry] : best) {
    const ViewTag& t = *entry.second;
    const RingView& view = views[t.view];
    // The target this id belongs to: the first of the detector's layout that holds it.
    int target = -1;
    for (std::size_t i = 0; i < targets.size() && target < 0; ++i) {
      int row = 0, col = 0;
      if (targets[i].type == t.layout && TagCell(targets[i], t.tag_id, &row, &col)) {
        target = static_cast<int>(i);
      }
    }
    if (target < 0) continue;
    Eigen::Vector2d mapped[4];
    bool ok = true;
    for (int k = 0; k < 4 && ok; ++k) {
      const auto raw = view.ViewToRaw(t.corners[k]);
      ok = raw.has_value();
      if (ok) mapped[k] = *raw;
    }
    if (!ok) continue;
    // Geometry: a convex quadrilateral with the same turning sense all round.
    double sign = 0;
    for (int k = 0; k < 4 && ok; ++k) {
      const Eigen::Vector2d a = mapped[(k + 1) % 4] - mapped[k];
      const Eigen::Vector2d b = mapped[(k + 2) % 4] - mapped[(k + 1) % 4];
      const double cross = a.x() * b.y() - a.y() * b.x();
      if (k == 0) sign = cross;
      ok = cross * sign > 0;
    }
    if (!ok) continue;
    Eigen::Vector2d refined[4];
    // Kalibr corners are judged one by one: a tag read exactly in its view (and consistent with
    // its neighbours there) next to the ring's rim has its corner squares and gaps on that side
    // cut off by the lip band (calibration_scene_tags 0016 and 0019, ring 1: 3 tags lost whole).
    // Those corners cannot be measured and are dropped; the tag's whole X-junctions are kept
    // (the grid check below still judges each against the target's other corners).
    bool whole[4] = {true, true, true, true};
    for (int k = 0; k < 4 && ok; ++k) {
      refined[k] = mapped[k];
      if (t.layout == TargetType::kKalibrAprilGrid) {
        // Kalibr's corners are X-junctions (kalibr_detector.h): saddle refinement in the raw
        // image, over the 2-bit border around the corner; only where the junction is whole.
        const double side = std::min((mapped[(k + 1) % 4] - mapped[k]).norm(),
                                     (mapped[(k + 3) % 4] - mapped[k]).norm());
        const Eigen::Vector2d to_next = (mapped[(k + 1) % 4] - mapped[k]).normalized();
        const Eigen::Vector2d to_previous = (mapped[(k + 3) % 4] - mapped[k]).normalized();
        whole[k] = IsKalibrXJunction(raw_grey8, mapped[k], to_next, to_previous,
                                     std::max(1.5, 0.12 * side), options.kalibr.min_contrast);
        if (whole[k] && options.kalibr_refine_in_raw) {
          whole[k] = RefineSaddleCorner(raw_grey8, mapped[k],
                                        static_cast<int>(std::lround(0.15 * side)),
                                        options.max_refine_shift_px, &refined[k]);
        }
        continue;
      }
      if (!options.refine_in_raw) continue;
      ok = RefineTagCorner(grey, mapped[k], mapped[(k + 1) % 4], mapped[(k + 3) % 4],
                           BorderFraction(t.layout), options, &refined[k]);
    }
    // Plain tags: the whole tag or nothing (a half-refined tag is suspect). Kalibr tags: at least
    // two whole junctions (fewer: the quad itself is doubtful).
    if (!ok || std::count(whole, whole + 4, true) < options.kalibr_min_whole_corners) continue;
    for (int k = 0; k < 4; ++k) {
      if (!whole[k]) continue;
      TagCornerDetection d;
      d.observation.target = target;
      d.observation.id = 4 * t.tag_id + k;
      d.observation.mirror = MirrorIndex(view.mirror);
      d.observation.pixel = refined[k];
      d.tag_id = t.tag_id;
      d.mapped = mapped[k];
      d.view = t.view;
      d.in_view = t.corners[k];
      for (int j = 0; j < 4; ++j) d.side_in_view += 0.25 * (t.corners[(j + 1) % 4] - t.corners[j]).norm();
      out.push_back(d);
    }
  }
  if (options.grid_check) DropCornersOffTheirTarget(views, view_images, model, targets, options, &out);
  return out;
}

std::vector<io::CornerObservation> DetectTagGrids(const cv::Mat& raw_bgr,
                                                  const std::vector<RingView>& views,
                                                  const RigModel& model,
                                                  const std::vector<TargetSpec>& targets) {
  std::vector<io::CornerObservation> out;
  for (const TagCornerDetection& d : DetectTagCorners(raw_bgr, views, model, targets)) {
    out.push_back(d.observation);
  }
  return out;
}

}  // namespace omni::detectors
