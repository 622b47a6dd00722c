#include "detectors/guided_detection.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "detectors/apriltag/apriltag_detector.h"
#include "detectors/apriltag/kalibr_detector.h"
#include "detectors/apriltag/tag_pattern_fit.h"
#include "detectors/chessboard/chessboard_detector.h"
#include "detectors/chessboard/chessboard_trace.h"
#include "detectors/common/board_junction_fit.h"
#include "detectors/common/corner_refine.h"
#include "detectors/common/corner_window.h"
#include "detectors/common/option_check.h"
#include "detectors/common/saddle_points.h"
#include "pose/initial_pose.h"

namespace omni::detectors {
namespace {

// A target's junctions on its plane (mm): the corners it reports (ids) and, for the alignment's
// test, one row / column of the same lattice beyond them all round (no id).
// X-junctions (chessboards, Kalibr): parity tells which diagonal is dark (chessboard: row + col;
// Kalibr: k, the tag's black square and the corner square lie on one diagonal at k = 0, 2 and
// on the other at k = 1, 3). Plain tags' corners are L-corners: `quadrant` is the dark one
// (Polarity's sample order), the tag's inside.
struct Junction {
  int id = -1;
  Eigen::Vector2d plane = Eigen::Vector2d::Zero();
  int parity = 0;
  int quadrant = -1;  // L-corners only
};

struct Lattice {
  std::vector<Junction> corners, extension;
  double polarity_offset_mm = 0;  // along each axis, into the junction's four quadrants
};

std::optional<Lattice> LatticeOf(const TargetSpec& t) {
  Lattice lattice;
  if (t.type == TargetType::kChessboard) {
    const double sq = t.square_mm;
    for (int r = -1; r <= t.rows; ++r) {
      for (int c = -1; c <= t.cols; ++c) {
        const bool inside = r >= 0 && c >= 0 && r < t.rows && c < t.cols;
        Junction j{inside ? r * t.cols + c : -1, Eigen::Vector2d(c * sq, r * sq), (r + c) & 1};
        (inside ? lattice.corners : lattice.extension).push_back(j);
      }
    }
    lattice.polarity_offset_mm = 0.35 * sq;
    return lattice;
  }
  const bool kalibr = t.type == TargetType::kKalibrAprilGrid;
  // Plain tag corner k's inside (plane x right, y down) as a sample index of Quadrant:
  // k0 bottom-left (+x,-y), k1 bottom-right (-x,-y), k2 top-right (-x,+y), k3 top-left (+x,+y).
  const int inside_quadrant[4] = {2, 1, 3, 0};
  const double pitch = TagPitch(t);
  const int tag00 = TagIdAt(t, 0, 0);
  for (int r = -1; r <= t.rows; ++r) {
    for (int c = -1; c <= t.cols; ++c) {
      const bool inside = r >= 0 && c >= 0 && r < t.rows && c < t.cols;
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector2d p = CornerInTarget(t, 4 * tag00 + k).head<2>() +
                                  Eigen::Vector2d(c * pitch, r * pitch);
        Junction j{inside ? 4 * TagIdAt(t, r, c) + k : -1, p, k & 1, kalibr ? -1 : inside_quadrant[k]};
        (inside ? lattice.corners : lattice.extension).push_back(j);
      }
    }
  }
  // Kalibr: inside the corner square (side spacing * tag) and the 2-bit border; plain: inside the
  // 1-bit border (a bit is an eighth of the tag).
  lattice.polarity_offset_mm = kalibr ? 0.35 * t.spacing * t.tag_size_mm : 0.5 * t.tag_size_mm / 8;
  return lattice;
}

Eigen::Vector2d Apply(const cv::Mat& h, const Eigen::Vector2d& p) {
  const double x = h.at<double>(0, 0) * p.x() + h.at<double>(0, 1) * p.y() + h.at<double>(0, 2);
  const double y = h.at<double>(1, 0) * p.x() + h.at<double>(1, 1) * p.y() + h.at<double>(1, 2);
  const double w = h.at<double>(2, 0) * p.x() + h.at<double>(2, 1) * p.y() + h.at<double>(2, 2);
  return Eigen::Vector2d(x / w, y / w);
}

// The target's centre (its sheet's), the gap between its tags and their pitch in view pixels, as
// the plane -> view homography `h` puts them.
struct TargetInView {
  Eigen::Vector2d centre_plane, centre_view;
  double gap_px = 0, pitch_px = 0;
};
TargetInView TargetInViewOf(const cv::Mat& h, const TargetSpec& target) {
  TargetInView out;
  out.centre_plane = 0.5 * SheetBounds(target).head<2>() + 0.5 * SheetBounds(target).tail<2>();
  out.centre_view = Apply(h, out.centre_plane);
  const double d = 0.01 * target.tag_size_mm;
  Eigen::Matrix2d jacobian;  // view px per mm at the target's centre, times d
  jacobian << Apply(h, out.centre_plane + Eigen::Vector2d(d, 0)) - out.centre_view,
      Apply(h, out.centre_plane + Eigen::Vector2d(0, d)) - out.centre_view;
  const double px_per_mm = std::sqrt(std::abs(jacobian.determinant())) / d;
  out.gap_px = target.spacing * target.tag_size_mm * px_per_mm;
  out.pitch_px = (1 + target.spacing) * target.tag_size_mm * px_per_mm;
  return out;
}

double Sample(const cv::Mat& grey, const Eigen::Vector2d& p) {
  const double u = std::clamp(p.x(), 0.0, grey.cols - 1.001);
  const double v = std::clamp(p.y(), 0.0, grey.rows - 1.001);
  const int i = static_cast<int>(u), j = static_cast<int>(v);
  const double a = u - i, b = v - j;
  const auto at = [&](int y, int x) { return static_cast<double>(grey.at<uchar>(y, x)); };
  return (1 - b) * ((1 - a) * at(j, i) + a * at(j, i + 1)) +
         b * ((1 - a) * at(j + 1, i) + a * at(j + 1, i + 1));
}

// Which diagonal of the junction at `plane` is dark in the view (H: plane -> view), times
// (-1)^parity: +1 or -1, 0 where the four quadrants do not read as an X-junction (each dark
// sample darker than both bright ones by a quarter of the junction's contrast).
int Polarity(const cv::Mat& view_grey, const cv::Mat& h, const Junction& j, double offset) {
  double s[4];
  const Eigen::Vector2d d[4] = {{offset, offset}, {-offset, -offset}, {offset, -offset}, {-offset, offset}};
  for (int i = 0; i < 4; ++i) s[i] = Sample(view_grey, Apply(h, j.plane + d[i]));
  const double contrast = *std::max_element(s, s + 4) - *std::min_element(s, s + 4);
  if (contrast < 20) return 0;
  int sign = 0;
  if (std::min(s[2], s[3]) - std::max(s[0], s[1]) > 0.25 * contrast) sign = 1;   // (1,1) dark
  if (std::min(s[0], s[1]) - std::max(s[2], s[3]) > 0.25 * contrast) sign = -1;  // (1,-1) dark
  return (j.parity ? -1 : 1) * sign;
}

// The dark quadrant of an L-corner at `plane` (samples as Polarity's), -1 unless exactly one
// quadrant is dark (darker than the other three by 40% of the contrast).
int Quadrant(const cv::Mat& view_grey, const cv::Mat& h, const Eigen::Vector2d& plane, double offset) {
  double s[4];
  const Eigen::Vector2d d[4] = {{offset, offset}, {-offset, -offset}, {offset, -offset}, {-offset, offset}};
  for (int i = 0; i < 4; ++i) s[i] = Sample(view_grey, Apply(h, plane + d[i]));
  const int dark = static_cast<int>(std::min_element(s, s + 4) - s);
  const double contrast = *std::max_element(s, s + 4) - s[dark];
  if (contrast < 20) return -1;
  for (int i = 0; i < 4; ++i) {
    if (i != dark && s[i] - s[dark] < 0.4 * contrast) return -1;
  }
  return dark;
}

// The view of `mirror` that shows most of `raw` (ties: nearest its centre), with the view
// pixels of those it shows; -1 if none shows 4.
int BestView(const std::vector<RingView>& views, const RigModel& model, Mirror mirror,
             const std::vector<Eigen::Vector2d>& raw,
             std::vector<std::optional<Eigen::Vector2d>>* in_view) {
  int best = -1;
  size_t best_count = 0;
  double best_off = 1e18;
  for (size_t v = 0; v < views.size(); ++v) {
    if (views[v].mirror != mirror) continue;
    std::vector<std::optional<Eigen::Vector2d>> pixels(raw.size());
    size_t count = 0;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (size_t i = 0; i < raw.size(); ++i) {
      pixels[i] = views[v].RawToView(model, raw[i]);
      if (!pixels[i]) continue;
      ++count;
      mean += *pixels[i];
    }
    if (count < 4) continue;
    const double off = (mean / count - Eigen::Vector2d(views[v].cx, views[v].cy)).norm();
    if (count > best_count || (count == best_count && off < best_off)) {
      best = static_cast<int>(v);
      best_count = count;
      best_off = off;
      *in_view = std::move(pixels);
    }
  }
  return best;
}

// The raw pixel of view pixel at + step, or where the view's map ends before it (a target seen
// at the ring's edge through a model whose ring is offset from the image's: the ideal design of
// a misaligned rig, 10-25 raw px), extrapolated linearly from the longest of step / 2, / 4, / 8
// that maps (the local direction and length are what the callers need). nullopt if `at` does
// not map or none of them does.
std::optional<Eigen::Vector2d> RawTowards(const RingView& view, const Eigen::Vector2d& at,
                                          const Eigen::Vector2d& step) {
  const auto origin = view.ViewToRaw(at);
  if (!origin) return std::nullopt;
  for (double f = 1; f >= 0.125; f *= 0.5) {
    if (const auto p = view.ViewToRaw(at + f * step)) return *origin + (*p - *origin) / f;
  }
  return std::nullopt;
}

// Plane -> view homography of the junctions `ids` (lattice order) seen at `pixels`.
cv::Mat FitHomography(const std::vector<Eigen::Vector2d>& plane,
                      const std::vector<Eigen::Vector2d>& pixels, int method, double tolerance) {
  if (plane.size() < 4) return cv::Mat();
  std::vector<cv::Point2f> a, b;
  for (size_t i = 0; i < plane.size(); ++i) {
    a.emplace_back(static_cast<float>(plane[i].x()), static_cast<float>(plane[i].y()));
    b.emplace_back(static_cast<float>(pixels[i].x()), static_cast<float>(pixels[i].y()));
  }
  return cv::findHomography(a, b, method, tolerance);
}

// Saddle points as buckets for nearest-neighbour look-ups within `cell`.
class SaddleIndex {
 public:
  SaddleIndex(std::vector<Eigen::Vector2d> points, double cell) : points_(std::move(points)), cell_(cell) {
    for (size_t i = 0; i < points_.size(); ++i) {
      if (points_[i].cwiseAbs().maxCoeff() < 1e6) buckets_[Key(points_[i])].push_back(static_cast<int>(i));
    }
  }
  // The nearest point within `radius` (<= cell) of p; -1 if none.
  int Nearest(const Eigen::Vector2d& p, double radius) const {
    // A prediction far off the image (a degenerate pose or homography) has no bucket: its key
    // would not fit an int (UBSan: GuidedDetection.SmallKalibrTagsInTheInnerRingFromTheOuterRing).
    if (!(p.cwiseAbs().maxCoeff() < 1e6)) return -1;
    const auto [bx, by] = Key(p);
    int best = -1;
    double best_d = radius;
    for (int y = by - 1; y <= by + 1; ++y) {
      for (int x = bx - 1; x <= bx + 1; ++x) {
        const auto it = buckets_.find({x, y});
        if (it == buckets_.end()) continue;
        for (int i : it->second) {
          const double d = (points_[i] - p).norm();
          if (d <= best_d) {
            best_d = d;
            best = i;
          }
        }
      }
    }
    return best;
  }
  const std::vector<Eigen::Vector2d>& points() const { return points_; }

 private:
  std::pair<int, int> Key(const Eigen::Vector2d& p) const {
    return {static_cast<int>(std::floor(p.x() / cell_)), static_cast<int>(std::floor(p.y() / cell_))};
  }
  std::vector<Eigen::Vector2d> points_;
  double cell_;
  std::map<std::pair<int, int>, std::vector<int>> buckets_;
};

struct Seeds {
  std::vector<Eigen::Vector3d> plane;
  std::vector<Eigen::Vector2d> raw;
  std::vector<int> ids;
};

// Kalibr junctions of the aligned lattice (plane -> view `h`) that lie beyond the view's map,
// where the model's ring ends short of the image's (the ideal design of a misaligned rig: 10-25
// raw px; near_scene's 200 mm tags along the red lip), measured in the raw image from the
// target's corners around them: a quadratic of the plane coordinates fitted to the ring's corners
// of the target (own and guided, `known`) within 2 tag pitches (at least 10, within 0.15 px rms;
// a homography leaves 0.6-0.7 px over that reach in the inner ring) predicts the junction
// (extrapolated to the ring's edge: 0.2-1.3 px off), raw cornerSubPix, the same X-junction check
// and blurred-junction fit as inside the view measure it, and it is kept within
// max(0.5 px, 0.08 tag sides) of the prediction: the fit found the junction the lattice puts
// there, not a neighbour (a corner square's side, 0.3 tag sides, away). The view's grid check
// cannot see it. Ids from the lattice, as for every guided corner.
std::vector<CornerObservation> KalibrBeyondTheView(const cv::Mat& raw_grey, const RingView& view,
                                                       const TargetSpec& target, const Lattice& lattice,
                                                       const cv::Mat& h, const Seeds& own,
                                                       const std::vector<CornerObservation>& guided,
                                                       const GuidedOptions& options) {
  std::vector<CornerObservation> out;
  std::map<int, Eigen::Vector2d> known;
  for (size_t i = 0; i < own.ids.size(); ++i) known[own.ids[i]] = own.raw[i];
  for (const CornerObservation& o : guided) known[o.id] = o.pixel;
  if (known.size() < 6) return out;
  const TagDetectorOptions tag_options;
  const double pitch = TagPitch(target);
  // raw = a quadratic in the plane coordinates (per pitch, about the junction): the mirror's
  // image of a plane bends its rows over a few pitches (a homography leaves 0.6-0.7 px there).
  struct LocalMap {
    Eigen::Vector2d at = Eigen::Vector2d::Zero();
    Eigen::Matrix<double, 6, 2> coefficients;
    Eigen::Vector2d operator()(const Eigen::Vector2d& plane, double pitch) const {
      const Eigen::Vector2d d = (plane - at) / pitch;
      Eigen::Matrix<double, 6, 1> f;
      f << 1, d.x(), d.y(), d.x() * d.x(), d.x() * d.y(), d.y() * d.y();
      return coefficients.transpose() * f;
    }
  };
  const auto local_map = [&](const Eigen::Vector2d& at, LocalMap* map) {
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> near;
    for (const auto& [id, raw] : known) {
      const Eigen::Vector2d plane = CornerInTarget(target, id).head<2>();
      if ((plane - at).norm() <= 2.0 * pitch) near.emplace_back(plane, raw);
    }
    if (near.size() < 10) return false;
    Eigen::MatrixXd a(near.size(), 6), b(near.size(), 2);
    for (size_t i = 0; i < near.size(); ++i) {
      const Eigen::Vector2d d = (near[i].first - at) / pitch;
      a.row(i) << 1, d.x(), d.y(), d.x() * d.x(), d.x() * d.y(), d.y() * d.y();
      b.row(i) = near[i].second.transpose();
    }
    map->at = at;
    map->coefficients = a.colPivHouseholderQr().solve(b);
    double ss = 0;
    for (const auto& [plane, raw] : near) ss += ((*map)(plane, pitch) - raw).squaredNorm();
    return std::sqrt(ss / near.size()) <= 0.15;
  };
  for (const Junction& j : lattice.corners) {
    if (known.count(j.id) || view.ViewToRaw(Apply(h, j.plane))) continue;
    LocalMap map;
    if (!local_map(j.plane, &map)) continue;
    const int k = j.id % 4;
    const Eigen::Vector2d predicted = map(j.plane, pitch);
    const auto corner_of = [&](int other) {
      return map(CornerInTarget(target, 4 * (j.id / 4) + other).head<2>(), pitch);
    };
    const Eigen::Vector2d next = corner_of((k + 1) % 4), previous = corner_of((k + 3) % 4);
    const double side_raw = std::min((next - predicted).norm(), (previous - predicted).norm());
    Eigen::Vector2d start;
    if (!RefineSaddleCorner(raw_grey, predicted, TagCornerHalfWindow(side_raw), 0.2 * side_raw, &start) ||
        !IsKalibrXJunction(raw_grey, start, (next - predicted).normalized(), (previous - predicted).normalized(),
                           XJunctionProbe(side_raw), tag_options.kalibr.min_contrast)) {
      continue;
    }
    const auto line = [&](int other) -> std::optional<LocalLine> {
      const Eigen::Vector2d to = CornerInTarget(target, 4 * (j.id / 4) + other).head<2>() - j.plane;
      std::vector<std::optional<Eigen::Vector2d>> points = {map(j.plane - 0.5 * to, pitch), predicted,
                                                            map(j.plane + 0.5 * to, pitch)};
      return LineThroughCorner(points, 1, 3, 1, true);
    };
    const auto row = line((k + 1) % 4), col = line((k + 3) % 4);
    if (!row || !col) continue;
    const auto fit = FitBlurredJunction(raw_grey, start, *row, *col, tag_options.kalibr_junction_window * side_raw);
    if (!fit || (fit->corner - predicted).norm() > std::max(options.grid_check.max_residual_px, 0.08 * side_raw)) continue;
    CornerObservation o;
    o.id = j.id;
    o.pixel = fit->corner;
    out.push_back(o);
  }
  return out;
}

// What guiding one target into one ring works on: the target, its lattice, its corners in the
// source ring and in ring `dest` (`own`), and the images. Every step below reads it; none
// changes it.
struct GuideInputs {
  const cv::Mat& raw_grey;
  const cv::Mat& raw_grey32;
  const std::vector<RingView>& views;
  const RigModel& model;
  const TargetSpec& target;
  int ti;
  const Lattice& lattice;
  const Seeds& source;
  Mirror source_mirror;
  const Seeds& own;
  Mirror dest;
  const GuidedOptions& options;
  std::set<int> have;  // the ids ring `dest` has already (own.ids)
};

// Step 1's result: the prediction H0 (plane -> view `v` of ring `dest`) and the translation
// search radius (view px; 0: H0 from the ring's own corners).
struct Prediction {
  cv::Mat h0;
  int v = -1;
  double radius = 0;
};

// 1. The prediction H0 in a view of ring `dest`: from the ring's own corners where it has
// enough, else from the pose the source ring gives (the search radius then scales the model's
// prediction error from raw to view px). nullopt where no view holds the target.
std::optional<Prediction> PredictInRing(const GuideInputs& in) {
  const GuidedOptions& options = in.options;
  Prediction out;
  std::vector<std::optional<Eigen::Vector2d>> in_view;
  if (static_cast<int>(in.own.ids.size()) >= options.min_seed_corners) {
    out.v = BestView(in.views, in.model, in.dest, in.own.raw, &in_view);
    if (out.v < 0) return std::nullopt;
    std::vector<Eigen::Vector2d> p, q;
    for (size_t i = 0; i < in.own.raw.size(); ++i) {
      if (!in_view[i]) continue;
      p.push_back(in.own.plane[i].head<2>());
      q.push_back(*in_view[i]);
    }
    out.h0 = FitHomography(p, q, 0, 0);
  } else {
    PoseGuess pose;
    if (!CentralPoseFromRing(in.model, in.source_mirror, in.source.plane, in.source.raw, &pose)) return std::nullopt;
    const Eigen::Matrix3d cam_from_target =
        Eigen::AngleAxisd(pose.rotation.norm(), pose.rotation.normalized()).toRotationMatrix();
    std::vector<Eigen::Vector2d> raw, plane;
    for (const Junction& j : in.lattice.corners) {
      const Eigen::Vector3d point_in_cam =
          cam_from_target * Eigen::Vector3d(j.plane.x(), j.plane.y(), 0) + pose.translation;
      const auto pixel = in.model.Project(point_in_cam, in.dest);
      if (!pixel) continue;
      raw.push_back(*pixel);
      plane.push_back(j.plane);
    }
    out.v = BestView(in.views, in.model, in.dest, raw, &in_view);
    if (out.v < 0) return std::nullopt;
    std::vector<Eigen::Vector2d> p, q;
    double raw_span = 0, view_span = 0;
    for (size_t i = 0; i < raw.size(); ++i) {
      if (!in_view[i]) continue;
      p.push_back(plane[i]);
      q.push_back(*in_view[i]);
      if (q.size() > 1) {
        raw_span = std::max(raw_span, (raw[i] - raw[0]).norm());
        view_span = std::max(view_span, (*in_view[i] - q.front()).norm());
      }
    }
    out.h0 = FitHomography(p, q, 0, 0);
    if (raw_span <= 0) return std::nullopt;
    const double max_error_px = options.max_prediction_error_deg * CameraPixelsPerDegree(in.model.params());
    out.radius = max_error_px * view_span / raw_span;
  }
  if (out.h0.empty()) return std::nullopt;
  return out;
}

// Which diagonal is dark at parity-0 junctions in the source ring (its view, its corners'
// homography there): a one-square shift of a chessboard (Kalibr: a gap's) flips it, so the
// saddles are matched by it. +1 or -1; 0 for L-corners (matched by quadrant instead); nullopt
// where the source ring's junctions do not agree enough to tell.
std::optional<int> SourcePolarity(const GuideInputs& in, bool l_corners) {
  if (l_corners) return 0;
  std::vector<std::optional<Eigen::Vector2d>> source_view;
  const int sv = BestView(in.views, in.model, in.source_mirror, in.source.raw, &source_view);
  if (sv < 0) return std::nullopt;
  std::vector<Eigen::Vector2d> p, q;
  std::vector<int> ids;
  for (size_t i = 0; i < in.source.raw.size(); ++i) {
    if (!source_view[i]) continue;
    p.push_back(in.source.plane[i].head<2>());
    q.push_back(*source_view[i]);
    ids.push_back(in.source.ids[i]);
  }
  const cv::Mat hs = FitHomography(p, q, 0, 0);
  if (hs.empty()) return std::nullopt;
  std::map<int, const Junction*> by_id;
  for (const Junction& j : in.lattice.corners) by_id[j.id] = &j;
  int sum = 0, counted = 0;
  for (int id : ids) {
    const auto it = by_id.find(id);
    if (it == by_id.end()) continue;
    const int sign = Polarity(in.views[sv].image, hs, *it->second, in.lattice.polarity_offset_mm);
    sum += sign;
    counted += sign != 0;
  }
  if (counted == 0 || std::abs(sum) < in.options.min_polarity_agreement * counted) return std::nullopt;
  return sum > 0 ? 1 : -1;
}

// 2. The lattice as H0 puts it in the view: its junctions and its extension (view px), and the
// match tolerance and search radius that the junctions' spacing sets.
struct LatticeInView {
  std::vector<Eigen::Vector2d> predicted, extension;
  double spacing = 0, tolerance = 0, search_radius = 0;
};

// nullopt where the junctions are under ~3 view px apart: too close to be told apart by saddles.
std::optional<LatticeInView> PredictLattice(const Lattice& lattice, const Prediction& prediction,
                                            const GuidedOptions& options) {
  LatticeInView out;
  for (const Junction& j : lattice.corners) out.predicted.push_back(Apply(prediction.h0, j.plane));
  for (const Junction& j : lattice.extension) out.extension.push_back(Apply(prediction.h0, j.plane));
  std::vector<double> nearest;
  for (size_t i = 0; i < out.predicted.size(); ++i) {
    double d = 1e18;
    for (size_t k = 0; k < out.predicted.size(); ++k) {
      if (k != i) d = std::min(d, (out.predicted[k] - out.predicted[i]).norm());
    }
    nearest.push_back(d);
  }
  std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
  out.spacing = nearest[nearest.size() / 2];
  out.tolerance = options.match_fraction * out.spacing;
  if (!(out.tolerance >= 1.0)) return std::nullopt;  // junctions under ~3 view px apart: not searched
  out.search_radius = prediction.radius > 0 ? prediction.radius : 1.5 * out.tolerance;
  return out;
}

// The view's saddle points around the predicted lattice, indexed for look-ups: all of them
// (for the extension's test) and by class. A lattice junction matches only saddles of its own
// polarity (as the source ring shows it): X-junctions by their dark diagonal (1,1) or (1,-1),
// plain tags' L-corners by their dark quadrant.
struct SaddleMatcher {
  std::vector<Eigen::Vector2d> saddles;
  std::vector<SaddleIndex> any, classes;  // any: one index; classes: 4
  bool l_corners = false;
  int source_sign = 0;
  double tolerance = 0;

  // The saddle matching junction j at view pixel p; nullopt if none.
  std::optional<Eigen::Vector2d> Match(const Junction& j, const Eigen::Vector2d& p) const {
    const SaddleIndex& index =
        l_corners ? classes[j.quadrant] : classes[source_sign * (j.parity ? -1 : 1) > 0 ? 0 : 1];
    const int m = index.Nearest(p, tolerance);
    if (m < 0) return std::nullopt;
    return index.points()[m];
  }
  // Whether any saddle lies within the tolerance of p.
  bool AnyNear(const Eigen::Vector2d& p) const { return any.front().Nearest(p, tolerance) >= 0; }
};

// The saddle points in the view's crop around the extended lattice (plus the search radius and
// a spacing), classified as the prediction orients the target: the X test reads along its
// diagonals (an L-corner at a board's outer square passes the Hessian test), plain tags'
// L-corners (the Hessian test passes at their tips too) by their dark quadrant. nullopt where
// the crop is too small or fewer than min_matched saddles classify.
std::optional<SaddleMatcher> ClassifiedSaddles(const GuideInputs& in, const Prediction& prediction,
                                               const LatticeInView& lv, bool l_corners, int source_sign) {
  const RingView& view = in.views[prediction.v];
  const cv::Mat& grey = view.image;
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  for (const auto& p : lv.extension) {
    x0 = std::min(x0, p.x()), y0 = std::min(y0, p.y()), x1 = std::max(x1, p.x()), y1 = std::max(y1, p.y());
  }
  const double pad = lv.search_radius + lv.spacing;
  const cv::Rect roi = cv::Rect(cv::Point(static_cast<int>(x0 - pad), static_cast<int>(y0 - pad)),
                                cv::Point(static_cast<int>(x1 + pad) + 1, static_cast<int>(y1 + pad) + 1)) &
                       cv::Rect(0, 0, view.width, view.height);
  if (roi.width < 8 || roi.height < 8) return std::nullopt;
  RingView crop = view;  // shallow: headers on the view's own data
  crop.image = grey(roi);
  crop.map_x = view.map_x(roi);
  SaddleOptions saddle_options;
  saddle_options.min_contrast = in.options.saddle_min_contrast;
  SaddleMatcher out;
  std::vector<Eigen::Vector2d> by_class[4];  // X: dark diagonal (1,1), (1,-1); L: quadrant
  const cv::Mat h0_inverse = prediction.h0.inv();
  for (const cv::Point2f& s : SaddlePoints(crop, saddle_options)) {
    const Eigen::Vector2d at(s.x + roi.x, s.y + roi.y);
    const Junction probe{-1, Apply(h0_inverse, at), 0};
    int class_index = -1;
    if (l_corners) {
      class_index = Quadrant(grey, prediction.h0, probe.plane, in.lattice.polarity_offset_mm);
    } else if (const int sign = Polarity(grey, prediction.h0, probe, in.lattice.polarity_offset_mm)) {
      class_index = sign > 0 ? 0 : 1;
    }
    if (class_index < 0) continue;
    out.saddles.push_back(at);
    by_class[class_index].push_back(at);
  }
  if (static_cast<int>(out.saddles.size()) < in.options.min_matched) return std::nullopt;
  const double cell = std::max(lv.tolerance, 1.0);
  out.any.emplace_back(out.saddles, cell);
  for (int c = 0; c < 4; ++c) out.classes.emplace_back(by_class[c], cell);
  out.l_corners = l_corners;
  out.source_sign = source_sign;
  out.tolerance = lv.tolerance;
  return out;
}

// The translations (predicted junction -> saddle, within the search radius) scored by the
// junctions they match less the extension's (a lattice one row / column off matches the
// extension too); the best ones, distinct by 2 tolerances, at most alignments_refined of them.
// nullopt where no saddle lies within the search radius of any junction.
std::optional<std::vector<Eigen::Vector2d>> BestShifts(const Lattice& lattice, const LatticeInView& lv,
                                                       const SaddleMatcher& saddles,
                                                       const GuidedOptions& options) {
  const double tolerance = lv.tolerance;
  std::set<std::pair<long, long>> tried;
  std::vector<std::pair<int, Eigen::Vector2d>> scored;  // (in - ext, shift)
  for (const auto& p : lv.predicted) {
    for (const auto& s : saddles.saddles) {
      const Eigen::Vector2d shift = s - p;
      if (shift.norm() > lv.search_radius) continue;
      const std::pair<long, long> key{std::lround(2 * shift.x() / tolerance),
                                      std::lround(2 * shift.y() / tolerance)};
      if (!tried.insert(key).second) continue;
      int in = 0, ext = 0;
      for (size_t i = 0; i < lv.predicted.size(); ++i) {
        in += saddles.Match(lattice.corners[i], lv.predicted[i] + shift).has_value();
      }
      for (const auto& e : lv.extension) ext += saddles.AnyNear(e + shift);
      scored.emplace_back(in - ext, shift);
    }
  }
  if (scored.empty()) return std::nullopt;
  std::sort(scored.begin(), scored.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<Eigen::Vector2d> starts;
  for (const auto& [score, shift] : scored) {
    if (static_cast<int>(starts.size()) >= options.alignments_refined) break;
    bool distinct = true;
    for (const auto& s0 : starts) distinct &= (shift - s0).norm() > 2 * tolerance;
    if (distinct) starts.push_back(shift);
  }
  return starts;
}

// One alignment of the lattice to the saddles: its homography (plane -> view), the junctions it
// matches, the extension's junctions it matches, and its score (matched - ext).
struct Alignment {
  cv::Mat h;
  int score = 0, matched = 0, ext = 0;
};

// 3. A translation of H0 refined to the homography of its matched saddles (RANSAC, then least
// squares on the tight matches: the prediction's scale and turn are off too) and scored again.
Alignment RefineShift(const cv::Mat& h0, const Lattice& lattice, const SaddleMatcher& saddles,
                      const Eigen::Vector2d& shift) {
  Alignment a;
  cv::Mat h = h0.clone();
  h.row(0) += shift.x() * h.row(2);
  h.row(1) += shift.y() * h.row(2);
  for (int round = 0; round < 3; ++round) {
    std::vector<Eigen::Vector2d> p, q;
    for (const Junction& j : lattice.corners) {
      const auto m = saddles.Match(j, Apply(h, j.plane));
      if (!m) continue;
      p.push_back(j.plane);
      q.push_back(*m);
    }
    const cv::Mat refit = FitHomography(p, q, round == 0 ? cv::RANSAC : 0, saddles.tolerance);
    if (refit.empty()) break;
    h = refit;
  }
  a.h = h;
  for (const Junction& j : lattice.corners) a.matched += saddles.Match(j, Apply(h, j.plane)).has_value();
  for (const Junction& j : lattice.extension) a.ext += saddles.AnyNear(Apply(h, j.plane));
  a.score = a.matched - a.ext;
  return a;
}

// The centre of the target's junctions on its plane (mm).
Eigen::Vector2d LatticeCentre(const Lattice& lattice) {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const Junction& j : lattice.corners) centre += j.plane / lattice.corners.size();
  return centre;
}

// The best of the refined alignments, where it beats every other (one placing the target's
// centre more than a tolerance elsewhere) by the margin and matches at least min_matched
// junctions: a lattice repeats, and a close second is a guess. nullopt otherwise.
std::optional<Alignment> DistinctBestAlignment(const Prediction& prediction, const Lattice& lattice,
                                               const SaddleMatcher& saddles,
                                               const std::vector<Eigen::Vector2d>& starts,
                                               const GuidedOptions& options) {
  std::vector<Alignment> alignments;
  for (const auto& shift : starts) alignments.push_back(RefineShift(prediction.h0, lattice, saddles, shift));
  std::sort(alignments.begin(), alignments.end(), [](const auto& a, const auto& b) { return a.score > b.score; });
  const Eigen::Vector2d centre = LatticeCentre(lattice);
  const Alignment& best = alignments.front();
  int second = 0;
  for (size_t k = 1; k < alignments.size(); ++k) {
    if ((Apply(alignments[k].h, centre) - Apply(best.h, centre)).norm() > saddles.tolerance) {
      second = std::max(second, alignments[k].score);
    }
  }
  if (best.matched < options.min_matched ||
      best.score - second < std::max<double>(options.min_margin, options.min_margin_fraction * best.score)) {
    return std::nullopt;
  }
  return best;
}

// The target aligned in the view of ring `dest`: its homography, which junctions a saddle
// matched there, and each junction's place in the lattice (by id).
struct AlignedTarget {
  const RingView& view;
  cv::Mat h;  // plane -> view
  std::vector<int> match;  // per lattice corner: 1 where a saddle matched it under h, else -1
  std::map<int, size_t> index_of;  // id -> index in lattice.corners

  // The raw pixel of junction `id` under h; nullopt off the view's map (or not a junction).
  std::optional<Eigen::Vector2d> RawOf(const Lattice& lattice, int id) const {
    const auto it = index_of.find(id);
    if (it == index_of.end()) return std::nullopt;
    return view.ViewToRaw(Apply(h, lattice.corners[it->second].plane));
  }
};

// 4 (chessboards). The matched junctions the ring does not have yet, refined in raw as the
// chessboard detector refines its corners (its window, its windows' check, its junction fit).
// The ring's own corners take part as the guided ones' neighbours (their lines, their windows'
// check), as in the per-ring detector's board; only the guided ones are reported.
std::map<int, Eigen::Vector2d> RefineChessboardCorners(const GuideInputs& in, AlignedTarget& a) {
  std::map<int, Eigen::Vector2d> refined;
  const TargetSpec& target = in.target;
  const int n = target.rows * target.cols;
  std::vector<std::optional<Eigen::Vector2d>> corners(n);
  std::vector<int> halves(n, 1);
  std::vector<double> sides(n, 0);
  std::map<int, Eigen::Vector2d> own_raw;
  for (size_t i = 0; i < in.own.ids.size(); ++i) own_raw[in.own.ids[i]] = in.own.raw[i];
  int unmatched = 0, unrefined = 0, moved = 0;  // the trace's counts of junctions lost
  const double blur = a.view.RawBlurAt(Apply(a.h, LatticeCentre(in.lattice)));
  for (int id = 0; id < n; ++id) {
    const size_t i = a.index_of[id];
    const bool is_own = own_raw.count(id) > 0;
    if (a.match[i] < 0 && !is_own) {
      ++unmatched;
      continue;
    }
    const auto start = is_own ? std::optional<Eigen::Vector2d>(own_raw[id]) : a.RawOf(in.lattice, id);
    if (!start) continue;
    const int r = id / target.cols, c = id % target.cols;
    double side = 1e9;
    for (auto [dr, dc] : {std::pair{0, 1}, {0, -1}, {1, 0}, {-1, 0}}) {
      const int rr = r + dr, cc = c + dc;
      if (rr < 0 || cc < 0 || rr >= target.rows || cc >= target.cols) continue;
      if (const auto q = a.RawOf(in.lattice, rr * target.cols + cc)) side = std::min(side, (*q - *start).norm());
    }
    if (side > 1e8) continue;
    // The per-ring detector's window (corner_window.h): 0.55 squares.
    int half = ChessboardHalfWindow(side, CameraPixelsPerDegree(in.model.params()));
    // Squares small against the blur (the webcam's inner ring): on the board's outer rows and
    // columns the margin's blurred step would reach cornerSubPix's window and pull the corner
    // (or get it refused as a foreign edge): the window kept 3 sigmas inside the square.
    const bool border = r == 0 || c == 0 || r == target.rows - 1 || c == target.cols - 1;
    if (blur > kBlurredBoardFraction * side && border) {
      half = std::min(half, std::max(2, static_cast<int>(std::floor(side - 3 * blur))));
    }
    Eigen::Vector2d pixel = *start;
    if (!is_own && !RefineCornerInRaw(in.raw_grey, half, &pixel)) {
      ++unrefined;
      continue;
    }
    if ((pixel - *start).norm() > std::max(1.5, 0.3 * side)) {
      ++moved;
      continue;
    }
    corners[id] = pixel;
    halves[id] = half;
    sides[id] = side;
  }
  const std::vector<int> start_halves = halves;
  const int unclean = KeepWindowsOnTheirSquares(in.raw_grey, target.rows, target.cols, sides, 2, &halves, &corners, blur);
  if (trace::On()) {
    double side_sum = 0;
    int side_n = 0;
    for (const double s : sides) {
      if (s > 0) side_sum += s, ++side_n;
    }
    trace::Line("guided target %d -> ring %d: %d junctions, %d unmatched, %d unrefined, %d moved, %d windows "
                "unclean; square %.1f raw px, blur %.2f raw px",
                in.ti, static_cast<int>(in.dest), n, unmatched, unrefined, moved, unclean,
                side_n ? side_sum / side_n : 0.0, blur);
  }
  // The junction fit the chessboard detector runs (the curvature correction where it cannot).
  FitBoardJunctions(in.raw_grey, target.rows, target.cols, sides, halves, ChessboardOptions().junction_window_squares,
                    &corners);
  // Where the squares are small against the blur, the board's own far edges and its margin
  // reach that fit's window: the corners fitted again as the blurred board (board_junction_fit.h).
  double side_sum = 0;
  int side_count = 0;
  for (int id = 0; id < n; ++id) {
    if (corners[id]) side_sum += sides[id], ++side_count;
  }
  if (side_count && blur > kBlurredBoardFraction * side_sum / side_count) {
    FitBlurredBoard(in.raw_grey, target.rows, target.cols, sides, start_halves, halves,
                    kBlurredBoardWindowSquares, blur, &corners);
  }
  for (int id = 0; id < n; ++id) {
    if (corners[id] && !in.have.count(id)) refined[id] = *corners[id];
  }
  return refined;
}

// 4 (plain tags). Tags measured as the tag detector measures them: in blurred views the whole
// pattern (FitTagPattern), else the four edges (RefineTagCorners; the data bits behind the
// border from the code of the tag's place), from the corners the alignment puts there; a tag
// whole or not at all, and only where a saddle matched at least 3 of its corners.
std::map<int, Eigen::Vector2d> RefinePlainTagCorners(const GuideInputs& in, AlignedTarget& a) {
  std::map<int, Eigen::Vector2d> refined;
  TagDetectorOptions tag_options;
  const bool blurred = a.view.blur_sigma && *a.view.blur_sigma >= tag_options.blurred_view_sigma;
  if (!blurred) tag_options.edge_fit_reach_in_blurred = tag_options.edge_fit_reach_in;
  std::set<int> tags;
  for (const Junction& j : in.lattice.corners) tags.insert(j.id / 4);
  for (const int tag : tags) {
    Eigen::Vector2d corners[4], fitted[4];
    double curvature[4];
    int matched_here = 0, wanted = 0;
    bool ok = true;
    for (int k = 0; k < 4 && ok; ++k) {
      matched_here += a.match[a.index_of[4 * tag + k]] >= 0;
      wanted += !in.have.count(4 * tag + k);
      const auto raw = a.RawOf(in.lattice, 4 * tag + k);
      ok = raw.has_value();
      if (ok) corners[k] = *raw;
      curvature[k] = std::nan("");  // fitted
    }
    if (!ok || wanted == 0 || matched_here < 3) continue;
    Eigen::Vector2d in_view[4];
    for (int k = 0; k < 4; ++k) in_view[k] = Apply(a.h, in.lattice.corners[a.index_of[4 * tag + k]].plane);
    const auto pattern_fit = tag_options.fit_tag_pattern && blurred
                                 ? FitTagPattern(in.raw_grey32, a.view, in.target, tag, in_view)
                                 : std::nullopt;
    if (pattern_fit) {
      std::copy(pattern_fit->corners, pattern_fit->corners + 4, fitted);
    } else if (!RefineTagCorners(in.raw_grey32, corners, curvature, 1.0 / PlainTagLayout().bits, in.target.spacing,
                                 tag_options, fitted, tag)) {
      continue;
    }
    for (int k = 0; k < 4; ++k) {
      if (!in.have.count(4 * tag + k)) refined[4 * tag + k] = fitted[k];
    }
  }
  return refined;
}

// 4 (Kalibr grids). Each matched X-junction the ring does not have: cornerSubPix in the view,
// the Kalibr detector's X-junction check in raw, then its blurred-junction fit with the tag's
// edges as the view's map bends them. A corner the fit cannot measure is left out: guided
// corners have no decoded quad to vouch for them.
std::map<int, Eigen::Vector2d> RefineKalibrCorners(const GuideInputs& in, AlignedTarget& a) {
  std::map<int, Eigen::Vector2d> refined;
  const RingView& view = a.view;
  const cv::Mat& h = a.h;
  const Lattice& lattice = in.lattice;
  const TagDetectorOptions tag_options;  // the Kalibr detector's junction window
  const KalibrDetectorOptions& kalibr = tag_options.kalibr;
  for (size_t i = 0; i < lattice.corners.size(); ++i) {
    const int id = lattice.corners[i].id;
    if (a.match[i] < 0 || in.have.count(id)) continue;
    const int tag = id / 4, k = id % 4;
    const Eigen::Vector2d at_view = Apply(h, lattice.corners[i].plane);
    const auto view_of = [&](int other) { return Apply(h, lattice.corners[a.index_of[4 * tag + other]].plane); };
    // The tag's edges' directions and length in raw: its neighbouring corners may lie beyond
    // the view's map (a tag at the ring's edge seen through the ideal design) while this one
    // does not: from inside the view (near_scene 0002, 200 mm tags at 2 m: 37 -> 43 of 48).
    const auto raw = a.RawOf(lattice, id);
    const auto next = RawTowards(view, at_view, view_of((k + 1) % 4) - at_view);
    const auto previous = RawTowards(view, at_view, view_of((k + 3) % 4) - at_view);
    if (!raw || !next || !previous) continue;
    double side_view = 0;
    for (int m = 0; m < 4; ++m) {
      side_view += 0.25 * (Apply(h, lattice.corners[a.index_of[4 * tag + (m + 1) % 4]].plane) -
                           Apply(h, lattice.corners[a.index_of[4 * tag + m]].plane)).norm();
    }
    Eigen::Vector2d in_view;
    if (!RefineSaddleCorner(view.image, Apply(h, lattice.corners[i].plane),
                            TagCornerHalfWindow(side_view), 0.1 * side_view, &in_view)) {
      continue;
    }
    const auto pixel = view.ViewToRaw(in_view);
    if (!pixel) continue;
    const double side_raw = std::min((*next - *raw).norm(), (*previous - *raw).norm());
    if (!IsKalibrXJunction(in.raw_grey, *pixel, (*next - *raw).normalized(), (*previous - *raw).normalized(),
                           XJunctionProbe(side_raw), kalibr.min_contrast)) {
      continue;
    }
    const Eigen::Vector2d corner = *pixel;
    // The junction fitted as the Kalibr detector fits it (corner_refine.h FitBlurredJunction):
    // its lines the tag's edges through the corner, as the view's map bends them.
    const auto line = [&](int other) -> std::optional<LocalLine> {
      const Eigen::Vector2d step = 0.5 * (view_of(other) - at_view);
      std::vector<std::optional<Eigen::Vector2d>> points = {RawTowards(view, at_view, -step), *raw,
                                                            RawTowards(view, at_view, step)};
      if (!points[0] || !points[2]) return std::nullopt;
      return LineThroughCorner(points, 1, 3, 1, true);
    };
    // Over the same fraction of the tag side (the 2-bit border): at 0.15 the inner ring's
    // 9-12 px tags left a window of under 16 pixels, the fit refused, and the view's
    // cornerSubPix corner (0.3-0.9 px off there) was kept.
    const auto row = line((k + 1) % 4), col = line((k + 3) % 4);
    if (!row || !col) continue;
    const auto fit = FitBlurredJunction(in.raw_grey, corner, *row, *col, tag_options.kalibr_junction_window * side_raw);
    if (!fit) continue;
    refined[id] = fit->corner;
  }
  return refined;
}

// 2-4: the target aligned in the view by its junctions (h: plane -> view) and the matched
// junctions the ring does not have yet refined in raw (`refined`: id -> raw pixel). False where
// the saddles cannot align it unambiguously; `h` is set once an alignment wins.
bool AlignBySaddles(const GuideInputs& in, const Prediction& prediction, cv::Mat* h,
                    std::map<int, Eigen::Vector2d>* refined) {
  const Lattice& lattice = in.lattice;
  const bool l_corners = lattice.corners.front().quadrant >= 0;
  // The trace names the step that refuses a chessboard (OMNI_CHESSBOARD_TRACE).
  const auto refused = [&](const char* why) {
    if (in.target.type == TargetType::kChessboard && trace::On()) {
      trace::Line("guided target %d -> ring %d: not aligned: %s", in.ti, static_cast<int>(in.dest), why);
    }
    return false;
  };
  const std::optional<int> source_sign = SourcePolarity(in, l_corners);
  if (!source_sign) return refused("polarity disagrees in the seed ring");
  // 2. The lattice in the view and the saddle points around it.
  const std::optional<LatticeInView> lv = PredictLattice(lattice, prediction, in.options);
  if (!lv) return refused("no lattice in the view");
  const std::optional<SaddleMatcher> saddles = ClassifiedSaddles(in, prediction, *lv, l_corners, *source_sign);
  if (!saddles) return refused("no saddles round the lattice");
  // The translation most junctions agree on, against every other.
  const auto starts = BestShifts(lattice, *lv, *saddles, in.options);
  if (!starts) return refused("no translation with enough matched junctions");
  // 3. The best translations, each refined to a homography; the best must beat every other.
  const std::optional<Alignment> best = DistinctBestAlignment(prediction, lattice, *saddles, *starts, in.options);
  if (!best) return refused("no alignment beats the others by the margin");
  *h = best->h;
  if (best->ext > in.options.max_extension_fraction * best->matched) return refused("the lattice's extension matched");
  AlignedTarget aligned{in.views[prediction.v], *h, {}, {}};
  aligned.match.assign(lattice.corners.size(), -1);
  for (size_t i = 0; i < lattice.corners.size(); ++i) {
    aligned.match[i] = saddles->Match(lattice.corners[i], Apply(*h, lattice.corners[i].plane)) ? 1 : -1;
  }
  // 4. Refinement of the matched junctions the ring does not have yet.
  for (size_t i = 0; i < lattice.corners.size(); ++i) aligned.index_of[lattice.corners[i].id] = i;
  if (in.target.type == TargetType::kChessboard) {
    *refined = RefineChessboardCorners(in, aligned);
  } else if (l_corners) {
    *refined = RefinePlainTagCorners(in, aligned);
  } else {
    *refined = RefineKalibrCorners(in, aligned);
  }
  return true;
}

// Tag grids whose junctions the saddle points cannot align (too close, or too blurred to be
// saddles: the inner ring's smallest tags): the whole printed pattern (AlignTargetPattern),
// then each tag by its pattern (FitTagPattern); a tag whole or not at all. Sets `h` where the
// pattern aligns; true where some tag was fitted.
bool AlignByPattern(const GuideInputs& in, const Prediction& prediction, cv::Mat* h,
                    std::map<int, Eigen::Vector2d>* refined) {
  const TargetSpec& target = in.target;
  const GuidedOptions& options = in.options;
  if (target.type == TargetType::kChessboard || !options.pattern_alignment) return false;
  const RingView& view = in.views[prediction.v];
  Eigen::Matrix3d h0e;
  cv::cv2eigen(prediction.h0, h0e);
  // Where the ring has the target already, only for a small one (the gap between tags in view
  // px): a large one's missing corners are cut or unmeasurable, and its whole pattern costly.
  if (static_cast<int>(in.own.ids.size()) >= options.min_seed_corners &&
      !(TargetInViewOf(prediction.h0, target).gap_px < options.pattern_below_gap_px)) {
    return false;
  }
  const double search = prediction.radius > 0 ? prediction.radius : options.pattern_search_px;
  const auto aligned = AlignTargetPattern(in.raw_grey32, view, target, h0e, search);
  if (!aligned) return false;
  cv::eigen2cv(Eigen::Matrix3d(aligned->view_from_plane), *h);
  std::set<int> tags;
  for (const Junction& j : in.lattice.corners) tags.insert(j.id / 4);
  for (const int tag : tags) {
    bool wanted = false;
    Eigen::Vector2d in_view[4];
    for (int k = 0; k < 4; ++k) {
      wanted |= !in.have.count(4 * tag + k);
      in_view[k] = Apply(*h, CornerInTarget(target, 4 * tag + k).head<2>());
    }
    if (!wanted) continue;
    const auto fit = FitTagPattern(in.raw_grey32, view, target, tag, in_view);
    if (!fit) continue;
    for (int k = 0; k < 4; ++k) {
      if (!in.have.count(4 * tag + k)) (*refined)[4 * tag + k] = fit->corners[k];
    }
  }
  return !refined->empty();
}

// 5. The grid check with the ring's own corners of the target (view `v`); Kalibr grids then gain
// the junctions beyond the view's map (KalibrBeyondTheView, from `h`). Ids anchored by the
// ring's own corners need no quorum; ids from the other ring need min_kept.
std::vector<CornerObservation> CheckAgainstGrid(const GuideInputs& in, int v, const cv::Mat& h,
                                                const std::map<int, Eigen::Vector2d>& refined) {
  const GuidedOptions& options = in.options;
  const Seeds& own = in.own;
  std::vector<CornerObservation> kept;
  if (refined.empty() || (own.ids.empty() && static_cast<int>(refined.size()) < options.min_kept)) return kept;
  std::vector<GridCorner> grid;
  for (size_t i = 0; i < own.ids.size(); ++i) grid.push_back({own.plane[i].head<2>(), own.raw[i], v});
  std::vector<int> guided_ids;
  for (const auto& [id, pixel] : refined) {
    grid.push_back({CornerInTarget(in.target, id).head<2>(), pixel, v});
    guided_ids.push_back(id);
  }
  const std::vector<GridFit> fits = CornersFittingTargetHomography(in.views, in.model, grid, options.grid_check);
  for (size_t g = 0; g < guided_ids.size(); ++g) {
    const GridFit& fit = fits[own.ids.size() + g];
    if (!fit.keep || fit.residual_px < 0) continue;
    CornerObservation o;
    o.target = in.ti;
    o.id = guided_ids[g];
    o.mirror = in.dest;
    o.pixel = refined.at(guided_ids[g]);
    kept.push_back(o);
  }
  if (own.ids.empty() && static_cast<int>(kept.size()) < options.min_kept) kept.clear();
  if (trace::On() && in.target.type == TargetType::kChessboard) {
    trace::Line("guided target %d -> ring %d: %zu refined, %zu kept by the grid check", in.ti,
                static_cast<int>(in.dest), refined.size(), kept.size());
  }
  if (!kept.empty() && in.target.type == TargetType::kKalibrAprilGrid) {
    for (CornerObservation o :
         KalibrBeyondTheView(in.raw_grey, in.views[v], in.target, in.lattice, h, own, kept, options)) {
      o.target = in.ti;
      o.mirror = in.dest;
      kept.push_back(o);
    }
  }
  return kept;
}

// A tag grid's saddle alignment read against the printed codes: the junctions of a grid of
// small tags repeat every pitch, so where the prediction is a pitch or more off (the ideal
// design's on a built rig) the translation most junctions agree on may be a pitch off, with
// every id wrong (hid3: a 4 x 4 Kalibr grid of 35 mm tags at 0.4 m in the inner ring, 17
// corners a tag or a row off). The whole pattern aligned from there, over 1.5 pitches, must
// succeed and stay where the saddles put it (there the pattern failed its fit or scored under
// 0.5: the ids cannot be told, and no corners beat wrong ones).
// Where the ring's own decoded corners placed the lattice (radius 0) its ids are anchored.
bool SaddlesReadAsTheCode(const GuideInputs& in, const Prediction& prediction, const cv::Mat& h) {
  const TargetSpec& target = in.target;
  if (target.type == TargetType::kChessboard || !in.options.pattern_alignment || prediction.radius <= 0) return true;
  const RingView& view = in.views[prediction.v];
  const TargetInView placed = TargetInViewOf(h, target);
  if (!(placed.gap_px < in.options.pattern_below_gap_px)) return true;
  // The pattern is aligned only where the view's map holds the whole grid; a grid the map
  // cuts (a ring's edge through the design) keeps the saddles' placement unchecked, as before.
  for (int id = 0; id < CornerCount(target); ++id) {
    if (!view.ViewToRaw(Apply(h, CornerInTarget(target, id).head<2>()))) return true;
  }
  Eigen::Matrix3d he;
  cv::cv2eigen(h, he);
  TargetAlignOptions align;
  align.search_similarity = false;  // the saddles' homography has the scale and turn
  const auto aligned = AlignTargetPattern(in.raw_grey32, view, target, he, 1.5 * placed.pitch_px, align);
  if (!aligned) return false;
  const Eigen::Vector2d centre = (aligned->view_from_plane * placed.centre_plane.homogeneous()).hnormalized();
  return (centre - placed.centre_view).norm() < 0.5 * placed.pitch_px;
}

// Guided corners of the target in ring `in.dest` from its corners in the other ring: by the
// saddles (steps 1-5), and by the whole printed pattern where the saddles left most of the
// target's missing corners out.
std::vector<CornerObservation> GuideTarget(const GuideInputs& in) {
  const std::optional<Prediction> prediction = PredictInRing(in);
  if (!prediction) return {};
  cv::Mat h;
  std::map<int, Eigen::Vector2d> refined;  // id -> raw pixel
  std::vector<CornerObservation> kept;
  if (AlignBySaddles(in, *prediction, &h, &refined)) {
    kept = CheckAgainstGrid(in, prediction->v, h, refined);
    if (!kept.empty() && !SaddlesReadAsTheCode(in, *prediction, h)) kept.clear();
  }
  const int missing = CornerCount(in.target) - static_cast<int>(in.own.ids.size());
  if (static_cast<int>(kept.size()) < in.options.pattern_when_found_below * missing) {
    refined.clear();
    if (AlignByPattern(in, *prediction, &h, &refined)) {
      std::vector<CornerObservation> by_pattern_kept = CheckAgainstGrid(in, prediction->v, h, refined);
      if (by_pattern_kept.size() > kept.size()) kept = std::move(by_pattern_kept);
    }
  }
  return kept;
}

}  // namespace

std::string GuidedOptions::Check() const {
  if (min_seed_corners < 1) return OptionError("min_seed_corners", "at least 1 corner", min_seed_corners);
  if (!(max_prediction_error_deg > 0)) {
    return OptionError("max_prediction_error_deg", "an angle > 0 degrees", max_prediction_error_deg);
  }
  if (!(saddle_min_contrast > 0)) return OptionError("saddle_min_contrast", "grey levels > 0", saddle_min_contrast);
  if (!(match_fraction > 0 && match_fraction < 0.5)) {
    return OptionError("match_fraction", "a fraction in (0, 0.5) of the junctions' spacing", match_fraction);
  }
  if (min_matched < 1) return OptionError("min_matched", "at least 1 junction", min_matched);
  if (min_margin < 0) return OptionError("min_margin", "a junction count >= 0", min_margin);
  if (!(min_margin_fraction >= 0 && min_margin_fraction <= 1)) {
    return OptionError("min_margin_fraction", "a fraction in [0, 1]", min_margin_fraction);
  }
  if (!(max_extension_fraction >= 0)) {
    return OptionError("max_extension_fraction", "a fraction >= 0", max_extension_fraction);
  }
  if (!(min_polarity_agreement >= 0 && min_polarity_agreement <= 1)) {
    return OptionError("min_polarity_agreement", "a fraction in [0, 1]", min_polarity_agreement);
  }
  if (alignments_refined < 1) return OptionError("alignments_refined", "at least 1", alignments_refined);
  if (!(pattern_search_px > 0)) return OptionError("pattern_search_px", "a search > 0 view px", pattern_search_px);
  if (!(pattern_when_found_below >= 0)) {
    return OptionError("pattern_when_found_below", "a fraction >= 0", pattern_when_found_below);
  }
  if (!(pattern_below_gap_px >= 0)) return OptionError("pattern_below_gap_px", "a gap >= 0 view px", pattern_below_gap_px);
  if (min_kept < 1) return OptionError("min_kept", "at least 1 corner", min_kept);
  return NestedOptionError("grid_check", grid_check.Check());
}

std::vector<CornerObservation> GuidedCorners(const cv::Mat& raw_grey,
                                                 const std::vector<RingView>& views,
                                                 const RigModel& model,
                                                 const std::vector<TargetSpec>& targets,
                                                 const std::vector<CornerObservation>& found,
                                                 const GuidedOptions& options) {
  if (const std::string error = options.Check(); !error.empty()) throw std::invalid_argument(error);
  std::vector<CornerObservation> out;
  // A single-mirror rig has one ring: no other ring to guide into.
  if (!options.enabled || model.params().Paths() < 2) return out;
  cv::Mat raw_grey32;  // CV_32F, made once, when a target is first guided
  for (size_t ti = 0; ti < targets.size(); ++ti) {
    const TargetSpec& target = targets[ti];
    const std::optional<Lattice> lattice = LatticeOf(target);
    if (!lattice) continue;
    // Chessboards of one pattern cannot be told apart (the detector reports the first): the
    // seed's size would be a guess.
    bool unique = true;
    for (size_t tj = 0; tj < targets.size(); ++tj) {
      unique &= tj == ti || targets[tj].type != target.type || target.type != TargetType::kChessboard ||
                targets[tj].rows != target.rows || targets[tj].cols != target.cols;
    }
    if (!unique) continue;
    Seeds ring[2];
    bool repeated = false;  // one target placed twice in an image: whose pose would it be?
    for (const CornerObservation& o : found) {
      if (o.target != static_cast<int>(ti) || !HasCorner(target, o.id)) continue;
      Seeds& s = ring[MirrorIndex(o.mirror) - 1];
      repeated |= std::find(s.ids.begin(), s.ids.end(), o.id) != s.ids.end();
      s.plane.push_back(CornerInTarget(target, o.id));
      s.raw.push_back(o.pixel);
      s.ids.push_back(o.id);
    }
    if (repeated) continue;
    for (int d = 0; d < 2; ++d) {
      const Seeds& source = ring[1 - d];
      if (static_cast<int>(source.ids.size()) < options.min_seed_corners) continue;
      if (static_cast<int>(ring[d].ids.size()) >= CornerCount(target)) continue;
      const Mirror dest = d == 0 ? Mirror::kOne : Mirror::kTwo;
      const Mirror from = d == 0 ? Mirror::kTwo : Mirror::kOne;
      if (raw_grey32.empty()) raw_grey.convertTo(raw_grey32, CV_32F, 1.0 / 255);
      const GuideInputs in{raw_grey, raw_grey32, views, model, target, static_cast<int>(ti), *lattice, source,
                           from, ring[d], dest, options, std::set<int>(ring[d].ids.begin(), ring[d].ids.end())};
      for (CornerObservation& o : GuideTarget(in)) {
        // Not where the ring already has a corner of another target.
        bool taken = false;
        for (const CornerObservation& f : found) {
          taken |= f.mirror == o.mirror && (f.pixel - o.pixel).norm() < 2.0;
        }
        if (!taken) out.push_back(o);
      }
    }
  }
  return out;
}

}  // namespace omni::detectors
