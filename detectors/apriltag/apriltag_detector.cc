#include "detectors/apriltag/apriltag_detector.h"

#include <algorithm>
#include <cmath>
#include <array>
#include <map>
#include <set>
#include <stdexcept>
#include <tuple>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/apriltag/kalibr_detector.h"
#include "detectors/apriltag/tag_pattern_fit.h"
#include "detectors/common/corner_refine.h"
#include "detectors/common/corner_window.h"
#include "detectors/common/option_check.h"
#include "detectors/common/saddle_points.h"

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

// A tag a post hides in part: its place predicted from the tags read in the view (GrowTagGrids),
// its code unreadable. Kalibr: the corners the view shows that refine as X-junctions near the
// prediction (`seen`) are measured as any Kalibr corner is; plain: the corners the view shows,
// measured from their edges near them (PartialPlainCorner).
struct PartialTag {
  ViewTag tag;
  bool seen[4] = {false, false, false, false};
};

// libapriltag's detector for tag36h11, made once per thread: the quick-decode table for codes up
// to 2 bits off is ~400k entries.
struct PlainDetector {
  apriltag_family_t* family = nullptr;
  apriltag_detector_t* detector = nullptr;
  explicit PlainDetector(int max_hamming) {
    family = tag36h11_create();
    detector = apriltag_detector_create();
    apriltag_detector_add_family_bits(detector, family, max_hamming);
    detector->nthreads = 1;
  }
  ~PlainDetector() {
    apriltag_detector_destroy(detector);
    tag36h11_destroy(family);
  }
};

// Plain tags in a view. Exact codes (hamming 0) are taken as libapriltag reads them; in a blurred
// view (blur_sigma set) a code up to max_hamming bits off is taken only if the tag's whole
// blurred pattern reads as that code (ReadTagBlurred): libapriltag thresholds each bit, and bits
// of one bit width blurred to ~40% contrast fall on the wrong side.
std::vector<ViewTag> DetectPlainTags(const cv::Mat& view_grey, int view_index, float decimate,
                                     double blur_sigma, const TagDetectorOptions& options) {
  std::vector<ViewTag> out;
  static thread_local PlainDetector exact(0), tolerant(2);
  const bool blurred = options.plain_max_hamming > 0 && blur_sigma > 0;
  apriltag_detector_t* detector = blurred ? tolerant.detector : exact.detector;
  detector->quad_decimate = decimate;
  image_u8_t im{view_grey.cols, view_grey.rows, static_cast<int32_t>(view_grey.step),
                view_grey.data};
  zarray_t* detections = apriltag_detector_detect(detector, &im);
  for (int i = 0; i < zarray_size(detections); ++i) {
    apriltag_detection_t* det;
    zarray_get(detections, i, &det);
    if (det->hamming > (blurred ? options.plain_max_hamming : 0)) continue;
    ViewTag tag{TargetType::kAprilTagGrid, det->id, {}, view_index};
    // libapriltag puts pixel centres at +0.5; p[k] is our k in an un-mirrored view.
    for (int k = 0; k < 4; ++k) tag.corners[k] = Eigen::Vector2d(det->p[k][0] - 0.5, det->p[k][1] - 0.5);
    if (det->hamming > 0) {
      std::array<cv::Point2f, 4> printed;  // TL, TR, BR, BL = k 3, 2, 1, 0
      for (int j = 0; j < 4; ++j) {
        printed[j] = cv::Point2f(static_cast<float>(tag.corners[3 - j].x()),
                                 static_cast<float>(tag.corners[3 - j].y()));
      }
      const BlurredReading reading =
          ReadTagBlurred(view_grey, printed, PlainTagLayout(), blur_sigma, options.kalibr.blurred);
      if (reading.tag_id != det->id || reading.rotation != 0) continue;
    }
    out.push_back(tag);
  }
  apriltag_detections_destroy(detections);
  return out;
}

// Kalibr AprilGrid tags (kalibr_detector.h), each checked against the other tags of its target
// seen in the same view.
std::vector<ViewTag> DetectKalibrTags(const cv::Mat& view_grey, int view_index,
                                      const std::vector<TargetSpec>& targets,
                                      const KalibrDetectorOptions& options, std::set<int>* unclaimed) {
  std::map<int, std::vector<KalibrViewTag>> by_target;
  for (const KalibrViewTag& t : DetectKalibrTagsInView(view_grey, options)) {
    bool claimed = false;
    for (std::size_t i = 0; i < targets.size() && !claimed; ++i) {
      int row = 0, col = 0;
      if (targets[i].type == TargetType::kKalibrAprilGrid && TagCell(targets[i], t.tag_id, &row, &col)) {
        by_target[static_cast<int>(i)].push_back(t);
        claimed = true;
      }
    }
    if (!claimed && unclaimed) unclaimed->insert(t.tag_id);
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


// The printed TL, TR, BR, BL corners of a view tag (our k 3, 2, 1, 0).
std::array<cv::Point2f, 4> Printed(const Eigen::Vector2d (&corners)[4]) {
  std::array<cv::Point2f, 4> q;
  for (int j = 0; j < 4; ++j) {
    q[j] = cv::Point2f(static_cast<float>(corners[3 - j].x()), static_cast<float>(corners[3 - j].y()));
  }
  return q;
}

// A Kalibr corner fitted as a blurred X-junction (corner_refine.h FitBlurredJunction) from
// `start`, in a window of half `half`: its lines are the tag's edges through the corner,
// continued along the corner square's sides, as the view's map bends them (raw points half a tag
// side either side of `mapped`, the corner's raw pixel). With `across` a line whose one side the
// view does not show (a post covers it) is continued straight across the corner. `start` where
// the lines or the fit fail.
Eigen::Vector2d FitKalibrJunction(const cv::Mat& grey, const RingView& view, const ViewTag& t, int k,
                                  const Eigen::Vector2d& mapped, const Eigen::Vector2d& start,
                                  double half, bool across) {
  const auto line = [&](int other) -> std::optional<LocalLine> {
    const Eigen::Vector2d step = 0.5 * (t.corners[other] - t.corners[k]);
    std::optional<Eigen::Vector2d> back = view.ViewToRaw(t.corners[k] - step);
    std::optional<Eigen::Vector2d> ahead = view.ViewToRaw(t.corners[k] + step);
    if (across && !back && ahead) back = 2 * mapped - *ahead;
    if (across && !ahead && back) ahead = 2 * mapped - *back;
    if (!back || !ahead) return std::nullopt;
    std::vector<std::optional<Eigen::Vector2d>> points = {back, mapped, ahead};
    return LineThroughCorner(points, 1, 3, 1, true);
  };
  const auto row = line((k + 1) % 4), col = line((k + 3) % 4);
  if (!row || !col) return start;
  const auto fit = FitBlurredJunction(grey, start, *row, *col, half);
  return fit ? fit->corner : start;
}

// Target `ti`'s tags read in view `v` (cell (row, col) -> index in `found`): the first target of
// its layout that holds the id, as DetectTagCorners assigns them.
std::map<std::pair<int, int>, int> TagsOfTargetInView(const std::vector<ViewTag>& found, int v,
                                                      const std::vector<TargetSpec>& targets, std::size_t ti) {
  const TargetSpec& target = targets[ti];
  std::map<std::pair<int, int>, int> have;
  for (std::size_t i = 0; i < found.size(); ++i) {
    const ViewTag& t = found[i];
    if (t.view != v || t.layout != target.type) continue;
    int row = 0, col = 0;
    if (!TagCell(target, t.tag_id, &row, &col)) continue;
    bool earlier = false;  // an earlier target of this layout holds the id
    for (std::size_t tj = 0; tj < ti && !earlier; ++tj) {
      int r2 = 0, c2 = 0;
      earlier = targets[tj].type == target.type && TagCell(targets[tj], t.tag_id, &r2, &c2);
    }
    if (!earlier) have[{row, col}] = static_cast<int>(i);
  }
  return have;
}

// The target's plane -> view homography from the corners of the tags accepted so far (`have`).
cv::Mat GridHomography(const TargetSpec& target, const std::vector<ViewTag>& found,
                       const std::map<std::pair<int, int>, int>& have) {
  std::vector<cv::Point2f> plane, in_view;
  for (const auto& [cell, i] : have) {
    const ViewTag& t = found[i];
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d p = CornerInTarget(target, 4 * t.tag_id + k);
      plane.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
      in_view.emplace_back(static_cast<float>(t.corners[k].x()), static_cast<float>(t.corners[k].y()));
    }
  }
  return cv::findHomography(plane, in_view, 0);
}

// The untried cells next (8-neighbourhood) to an accepted tag or a hidden cell.
std::vector<std::pair<int, int>> CellsNextToGrid(const TargetSpec& target,
                                                 const std::map<std::pair<int, int>, int>& have,
                                                 const std::set<std::pair<int, int>>& tried,
                                                 const std::set<std::pair<int, int>>& hidden) {
  std::vector<std::pair<int, int>> next;
  for (int row = 0; row < target.rows; ++row) {
    for (int col = 0; col < target.cols; ++col) {
      if (have.count({row, col}) || tried.count({row, col})) continue;
      bool adjacent = false;
      for (const auto& [cell, i] : have) {
        adjacent |= std::max(std::abs(cell.first - row), std::abs(cell.second - col)) == 1;
      }
      for (const auto& cell : hidden) {
        adjacent |= std::max(std::abs(cell.first - row), std::abs(cell.second - col)) == 1;
      }
      if (adjacent) next.emplace_back(row, col);
    }
  }
  return next;
}

// Whether the view shows a predicted tag whole: its corners, centre and the middles of its
// half-sides all on the view's map (`covered` where one is not: its code cannot be read), and
// `post` where such a point sees the mount's post through the model without its mount.
void TagCoverage(const RingView& view, const RigModel* model, const RigModel* unmounted, const ViewTag& tag,
                 bool* covered, bool* post) {
  std::vector<Eigen::Vector2d> probes(tag.corners, tag.corners + 4);
  const Eigen::Vector2d centre = 0.25 * (tag.corners[0] + tag.corners[1] + tag.corners[2] + tag.corners[3]);
  probes.push_back(centre);
  for (int k = 0; k < 4; ++k) probes.push_back(0.5 * (tag.corners[k] + centre));
  *covered = false;
  *post = false;
  for (const Eigen::Vector2d& p : probes) {
    if (view.ViewToRaw(p)) continue;
    *covered = true;
    if (!unmounted) continue;
    const auto behind = view.ViewToRawExact(*unmounted, p);
    *post = *post || (behind && model->PixelSeesMount(*behind));
  }
}

// A plain tag's predicted corners moved to where the code's pattern fits best, +-0.25 bit in
// steps of 1/16 bit (plain corners are not X-junctions, and the prediction is extrapolated from
// a few tags); returns the code's residual there (`e`: at the prediction).
double ShiftToCode(const cv::Mat& view_grey, const TagLayout& layout, double blur, int tag_id, double side,
                   double e, ViewTag* tag) {
  const double step = side / layout.bits / 16;
  Eigen::Vector2d best_shift = Eigen::Vector2d::Zero();
  for (int pass = 0; pass < 2; ++pass) {
    const Eigen::Vector2d centre = best_shift;
    const double h = pass == 0 ? 4 * step : step;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0) continue;
        const Eigen::Vector2d shift = centre + h * Eigen::Vector2d(dx, dy);
        Eigen::Vector2d moved[4];
        for (int k = 0; k < 4; ++k) moved[k] = tag->corners[k] + shift;
        const double e_shift = TagCodeResidual(view_grey, Printed(moved), layout, blur, tag_id);
        if (e_shift < e) {
          e = e_shift;
          best_shift = shift;
        }
      }
    }
  }
  for (int k = 0; k < 4; ++k) tag->corners[k] += best_shift;
  return e;
}

// The outcome of trying one cell: the tag grown there, or whether the cell is hidden.
enum class CellOutcome { kNone, kHidden, kRead };

// One predicted cell of the grid (homography H: plane -> view) tried: hidden where the view's
// margin holds it but its map does not show it whole (a post's Kalibr tag then gives its seen
// X-junctions in `partial`); read (`tag`) where its corners refine (Kalibr) and its code fits at
// the prediction within grow_max_residual.
CellOutcome TryCell(const cv::Mat& view_grey, const RingView& view, int v, const TargetSpec& target,
                    const std::pair<int, int>& cell, const cv::Mat& H, const TagDetectorOptions& options,
                    const RigModel* model, const RigModel* unmounted, ViewTag* tag_out,
                    std::vector<PartialTag>* partial) {
  const bool kalibr = target.type == TargetType::kKalibrAprilGrid;
  const double blur = view.blur_sigma ? *view.blur_sigma : 0.0;
  const int tag_id = TagIdAt(target, cell.first, cell.second);
  std::vector<cv::Point2f> plane_k, predicted;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d p = CornerInTarget(target, 4 * tag_id + k);
    plane_k.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  }
  cv::perspectiveTransform(plane_k, predicted, H);
  ViewTag tag{target.type, tag_id, {}, v};
  bool ok = true;
  double side = 0;
  for (int k = 0; k < 4; ++k) side += 0.25 * cv::norm(predicted[(k + 1) % 4] - predicted[k]);
  const double margin = 0.3 * side + 3;
  bool in_view = true;
  for (int k = 0; k < 4; ++k) {
    tag.corners[k] = Eigen::Vector2d(predicted[k].x, predicted[k].y);
    in_view = in_view && predicted[k].x >= margin && predicted[k].y >= margin &&
              predicted[k].x < view_grey.cols - margin && predicted[k].y < view_grey.rows - margin;
  }
  bool covered = false, post = false;
  TagCoverage(view, model, unmounted, tag, &covered, &post);
  CellOutcome outcome = CellOutcome::kNone;
  if (in_view && covered) {
    outcome = CellOutcome::kHidden;  // its neighbours are candidates now
    if (post) {
      PartialTag part{tag, {}};
      const int half = TagCornerHalfWindow(side);
      for (int k = 0; k < 4; ++k) {
        // Kalibr: a seen X-junction near the prediction; plain: a corner the view shows, its
        // edges measured near it later (MeasurePartialTags).
        part.seen[k] = view.ViewToRaw(tag.corners[k]).has_value() &&
                       (!kalibr || RefineSaddleCorner(view_grey, tag.corners[k], half, 0.1 * side,
                                                      &part.tag.corners[k]));
      }
      if (std::count(part.seen, part.seen + 4, true) > 0) partial->push_back(part);
    }
  }
  if (!in_view || covered) return outcome;
  if (kalibr) {
    const int half = TagCornerHalfWindow(side);
    for (int k = 0; k < 4 && ok; ++k) {
      ok = RefineSaddleCorner(view_grey, tag.corners[k], half, 0.1 * side, &tag.corners[k]);
    }
    if (!ok) return CellOutcome::kNone;
  }
  const TagLayout layout = kalibr ? KalibrTagLayout() : PlainTagLayout();
  double e = TagCodeResidual(view_grey, Printed(tag.corners), layout, blur, tag_id);
  if (!kalibr) e = ShiftToCode(view_grey, layout, blur, tag_id, side, e, &tag);
  if (!(e <= options.grow_max_residual)) return CellOutcome::kNone;
  *tag_out = tag;
  return CellOutcome::kRead;
}

// One read tag carries its grid: in a view a target is a homography of its plane, so the tags of
// a target read in view `v` predict where its other tags are (nearest first, the homography
// refitted to every tag accepted so far). A predicted tag is taken, with the id its place on the
// target gives, only if its pattern there fits that code's blurred pattern (TagCodeResidual
// <= options.grow_max_residual) and, for Kalibr tags, its corners refine as X-junctions near the
// prediction. A wrong seed cannot carry a grid: its predicted neighbours read as other codes.
// Tags a post hides in part are returned in `partial` (their code cannot be read: the grid alone
// names them, and the grid check judges each of their corners).
// Only tags a post hides are partial: where a tag runs past the view's or the ring's edge, guided
// detection (guided_detection.h) measures its corners beyond it. `unmounted`: the model without
// its mount (nullptr: the rig has none).
void GrowTagGrids(const cv::Mat& view_grey, const RingView& view, int v,
                  const std::vector<TargetSpec>& targets, const TagDetectorOptions& options,
                  const RigModel* model, const RigModel* unmounted, std::vector<ViewTag>* found,
                  std::vector<PartialTag>* partial) {
  for (std::size_t ti = 0; ti < targets.size(); ++ti) {
    const TargetSpec& target = targets[ti];
    if (target.type == TargetType::kChessboard) continue;
    std::map<std::pair<int, int>, int> have = TagsOfTargetInView(*found, v, targets, ti);
    if (have.empty()) continue;
    // Cells whose predicted tag the view does not show whole (a post of the mount, the ring's
    // rim): growth goes on past them, so that a grid cut by a post is read on both sides.
    std::set<std::pair<int, int>> tried, hidden;
    for (;;) {
      const cv::Mat H = GridHomography(target, *found, have);
      if (H.empty()) break;
      const std::vector<std::pair<int, int>> next = CellsNextToGrid(target, have, tried, hidden);
      if (next.empty()) break;
      bool grew = false;
      for (const auto& cell : next) {
        tried.insert(cell);
        ViewTag tag{target.type, -1, {}, v};
        const CellOutcome outcome = TryCell(view_grey, view, v, target, cell, H, options, model, unmounted, &tag,
                                            partial);
        if (outcome == CellOutcome::kHidden) hidden.insert(cell);
        if (outcome == CellOutcome::kRead) {
          have[cell] = static_cast<int>(found->size());
          found->push_back(tag);
        }
        grew |= outcome != CellOutcome::kNone;
      }
      if (!grew) break;
    }
  }
}

double Median(std::vector<double> v) {
  if (v.empty()) return -1;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// One tag edge in the raw image, from corner a towards corner b: t(s) = c0 + c1 s + c2 s^2 is
// the edge's offset along `inward` (towards the tag's inside) at distance s along the chord.
// Quadratic because the mirrors bend the tag's straight edges ([m1], [m2]: a line's image is a
// conic section's arc; over one tag side its cubic term is far below the noise).
struct EdgeCurve {
  Eigen::Vector2d a, along, inward;
  double length = 0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  Eigen::Vector2d Point(double s) const { return a + s * along + (c(0) + c(1) * s + c(2) * s * s) * inward; }
  Eigen::Vector2d Tangent(double s) const { return along + (c(1) + 2 * c(2) * s) * inward; }
};

// Least-squares t = c0 + c1 s + c2 s^2 through (s, t) points, then once more without the points
// farther than 3 rms (and 0.1 px) from the first fit (a data bit's or a neighbour's blur).
// With `c2` finite the quadratic term is held at it (the curvature the model predicts).
bool FitQuadratic(std::vector<Eigen::Vector2d> st, double c2, Eigen::Vector3d* c, double* rms) {
  const bool fixed = std::isfinite(c2);
  for (int pass = 0; pass < 2; ++pass) {
    if (st.size() < 6) return false;
    Eigen::MatrixXd A(st.size(), fixed ? 2 : 3);
    Eigen::VectorXd b(st.size());
    for (std::size_t i = 0; i < st.size(); ++i) {
      const double s = st[i].x();
      if (fixed) {
        A.row(i) << 1, s;
        b(i) = st[i].y() - c2 * s * s;
      } else {
        A.row(i) << 1, s, s * s;
        b(i) = st[i].y();
      }
    }
    const Eigen::VectorXd x = A.colPivHouseholderQr().solve(b);
    *c = fixed ? Eigen::Vector3d(x(0), x(1), c2) : Eigen::Vector3d(x);
    const Eigen::VectorXd r = A * x - b;
    *rms = std::sqrt(r.squaredNorm() / st.size());
    if (pass == 1) break;
    const double limit = std::max(3 * *rms, 0.1);
    std::vector<Eigen::Vector2d> kept;
    for (std::size_t i = 0; i < st.size(); ++i) {
      if (std::abs(r(i)) <= limit) kept.push_back(st[i]);
    }
    st = std::move(kept);
  }
  return c->allFinite();
}

// The data bits just behind one edge's black border (1 white, 0 black) along the edge, as the
// tag's code gives them, and the border's width (raw px). Empty: taken as black (a plain step).
struct EdgeBits {
  std::vector<int> cells;  // along the edge, from its first corner
  double border_px = 0;
  double At(double f) const {
    if (cells.empty()) return 0;
    const int i = std::clamp(static_cast<int>(f * cells.size()), 0, static_cast<int>(cells.size()) - 1);
    return cells[i];
  }
};

// Refines `edge` (its offset c0 and slope c1; the curvature c2 kept) by fitting the raw pixels
// next to it, from reach_out outside to reach_in inside and `margin` clear of both corners, with
// a blurred step: I = white - (white - black) Phi(d / sigma), d the pixel centre's distance inside
// the edge curve; levels and sigma fitted too (Gauss-Newton). The profiles' halfway crossings
// between bilinearly interpolated pixels shift with the edge's phase against the pixel grid
// (sharp renders: up to ~0.1 px), which along a nearly axis-parallel edge turns the fitted line;
// the step model sees each pixel where it is.
bool FitEdgeToPixels(const cv::Mat& grey, double margin, double reach_in, double reach_out,
                     double black, double white, const EdgeBits& bits, EdgeCurve* edge) {
  struct Pixel {
    double s, u, value, bit;
  };
  std::vector<Pixel> pixels;
  const Eigen::Vector2d ends[2] = {edge->a, edge->a + edge->length * edge->along};
  const double pad = reach_out + reach_in + 2;
  const int x0 = static_cast<int>(std::floor(std::min(ends[0].x(), ends[1].x()) - pad));
  const int x1 = static_cast<int>(std::ceil(std::max(ends[0].x(), ends[1].x()) + pad));
  const int y0 = static_cast<int>(std::floor(std::min(ends[0].y(), ends[1].y()) - pad));
  const int y1 = static_cast<int>(std::ceil(std::max(ends[0].y(), ends[1].y()) + pad));
  if (x0 < 0 || y0 < 0 || x1 >= grey.cols || y1 >= grey.rows) return false;
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      const Eigen::Vector2d q = Eigen::Vector2d(x, y) - edge->a;
      const double s = q.dot(edge->along), u = q.dot(edge->inward);
      const double d = u - (edge->c(0) + edge->c(1) * s + edge->c(2) * s * s);
      if (s < margin || s > edge->length - margin || d < -reach_out || d > reach_in) continue;
      pixels.push_back({s, u, grey.at<float>(y, x), bits.At(s / edge->length)});
    }
  }
  if (pixels.size() < 12) return false;
  // Parameters: c0, c1, sigma, black, white.
  Eigen::Matrix<double, 5, 1> p(edge->c(0), edge->c(1), 0.6, black, white);
  for (int it = 0; it < 8; ++it) {
    Eigen::Matrix<double, 5, 5> H = Eigen::Matrix<double, 5, 5>::Zero();
    Eigen::Matrix<double, 5, 1> g = Eigen::Matrix<double, 5, 1>::Zero();
    for (const Pixel& px : pixels) {
      // The border is a bar: behind it (bits.border_px in) a white data bit brings the level
      // back up, which a blur as wide as the border shows at the edge too.
      const double d = px.u - (p(0) + p(1) * px.s + edge->c(2) * px.s * px.s);
      const double x = d / p(2), x2 = (d - bits.border_px) / p(2);
      const double phi1 = std::exp(-0.5 * x * x) / std::sqrt(2 * M_PI);
      const double phi2 = px.bit * std::exp(-0.5 * x2 * x2) / std::sqrt(2 * M_PI);
      const double Phi = 0.5 * std::erfc(-x / std::sqrt(2.0)) -
                         px.bit * 0.5 * std::erfc(-x2 / std::sqrt(2.0));
      const double phi = phi1 - phi2;
      const double r = p(4) - (p(4) - p(3)) * Phi - px.value;
      const double dI_dd = -(p(4) - p(3)) * phi / p(2);
      Eigen::Matrix<double, 5, 1> J;
      J << -dI_dd, -dI_dd * px.s, (p(4) - p(3)) * (phi1 * x - phi2 * x2) / p(2), Phi, 1 - Phi;
      H += J * J.transpose();
      g += J * r;
    }
    const Eigen::Matrix<double, 5, 1> step = H.ldlt().solve(-g);
    if (!step.allFinite()) return false;
    p += step;
    p(2) = std::clamp(p(2), 0.2, 3.0);
    if (step.head<2>().norm() < 1e-6) break;
  }
  if (!(std::abs(p(0) - edge->c(0)) < 1.0 && p(4) - p(3) > 0.1)) return false;
  edge->c(0) = p(0);
  edge->c(1) = p(1);
  return true;
}

// Fits one tag edge (corner a to corner b, raw pixels, both approximate) in the grey CV_32F raw
// image. Along the chord, clear of both corners' blur, each profile across the edge gives the
// sub-pixel point where it crosses halfway between this edge's own black and white: the median
// values at the black border's middle (border_px / 2 inside) and reach_out outside. Halfway
// between the levels that the profile itself reaches is where a symmetric blur puts an ideal
// step's edge, whatever the blur's width (a global min/max level would move it with the noise).
bool FitTagEdge(const cv::Mat& grey, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                const Eigen::Vector2d& tag_centre, double border_px, double reach_out,
                double curvature, const EdgeBits& bits, const TagDetectorOptions& options,
                EdgeCurve* edge) {
  edge->a = a;
  edge->length = (b - a).norm();
  if (!(edge->length >= options.min_edge_px)) return false;
  edge->along = (b - a) / edge->length;
  edge->inward = Eigen::Vector2d(-edge->along.y(), edge->along.x());
  if (edge->inward.dot(tag_centre - a) < 0) edge->inward = -edge->inward;
  const double margin = options.edge_corner_margin_px;
  const double reach_in = std::clamp(0.8 * border_px, 0.8, 3.0);
  std::vector<double> s_values;
  for (double s = margin; s <= edge->length - margin + 1e-9; s += 0.5) s_values.push_back(s);
  if (s_values.size() < 6) return false;
  std::vector<double> blacks, whites;
  for (const double s : s_values) {
    const Eigen::Vector2d base = a + s * edge->along;
    double darkest = 1e9;
    for (double t = 0; t <= reach_in + 1e-9; t += 0.25) {
      const Eigen::Vector2d in = base + t * edge->inward;
      const double value = Bilinear(grey, in.x(), in.y());
      if (value >= 0) darkest = std::min(darkest, value);
    }
    const Eigen::Vector2d out = base - reach_out * edge->inward;
    blacks.push_back(darkest);
    whites.push_back(Bilinear(grey, out.x(), out.y()));
  }
  const double black = Median(blacks), white = Median(whites);
  if (!(black >= 0 && white - black > 0.15)) return false;
  const double half = 0.5 * (black + white);
  constexpr double kStep = 0.1;
  const int n = static_cast<int>((reach_in + reach_out) / kStep) + 1;
  std::vector<Eigen::Vector2d> st;
  std::vector<double> value(n);
  for (const double s : s_values) {
    const Eigen::Vector2d base = a + s * edge->along;
    bool inside_image = true;
    for (int i = 0; i < n && inside_image; ++i) {
      const Eigen::Vector2d p = base + (reach_in - i * kStep) * edge->inward;  // inside to outside
      value[i] = Bilinear(grey, p.x(), p.y());
      inside_image = value[i] >= 0;
    }
    if (!inside_image) continue;
    // The dark-to-bright crossing (going outwards) nearest to the predicted edge t = 0.
    double best_t = 1e9;
    for (int i = 0; i + 1 < n; ++i) {
      const double u = value[i] - half, w = value[i + 1] - half;
      if (u < 0 && w >= 0) {
        const double t = reach_in - (i + u / (u - w)) * kStep;
        if (std::abs(t) < std::abs(best_t)) best_t = t;
      }
    }
    if (best_t < 1e8) st.emplace_back(s, best_t);
  }
  double rms = 0;
  if (st.size() < 0.7 * s_values.size()) return false;
  if (!FitQuadratic(st, curvature, &edge->c, &rms) || rms > options.max_edge_rms_px) return false;
  return !options.fit_edge_pixels ||
         FitEdgeToPixels(grey, margin,
                         bits.cells.empty() || options.edge_fit_reach_in_blurred <= options.edge_fit_reach_in
                             ? std::min(options.edge_fit_reach_in * border_px, reach_in)
                             : options.edge_fit_reach_in_blurred * border_px,
                         reach_out, black, white, bits, edge);
}

// The curvature term c2 (t = c0 + c1 s + c2 s^2 across the raw chord, EdgeCurve) of the raw image
// of the straight view segment from view pixel a to b, t along the normal towards raw pixel
// `inside`: the view's map (ViewToRaw, from the rig model) at 9 points along it, fitted by a
// quadratic. NaN if the segment leaves the view's map.
double EdgeCurvatureFromView(const RingView& view, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                             const Eigen::Vector2d& inside) {
  const auto raw_a = view.ViewToRaw(a), raw_b = view.ViewToRaw(b);
  if (!raw_a || !raw_b || (*raw_b - *raw_a).norm() < 1e-6) return std::nan("");
  const Eigen::Vector2d along = (*raw_b - *raw_a).normalized();
  Eigen::Vector2d normal(-along.y(), along.x());
  if (normal.dot(inside - *raw_a) < 0) normal = -normal;
  std::vector<Eigen::Vector2d> st;
  for (int i = 0; i <= 8; ++i) {
    const auto raw = view.ViewToRaw(a + (i / 8.0) * (b - a));
    if (!raw) return std::nan("");
    st.emplace_back((*raw - *raw_a).dot(along), (*raw - *raw_a).dot(normal));
  }
  Eigen::Vector3d c;
  double rms = 0;
  return FitQuadratic(st, std::nan(""), &c, &rms) ? c(2) : std::nan("");
}

// Where edge `in` (ending at the corner, s near its length) meets edge `out` (starting there):
// Newton on the two curves from the chord ends.
bool IntersectEdges(const EdgeCurve& in, const EdgeCurve& out, Eigen::Vector2d* corner) {
  Eigen::Vector2d s(in.length, 0);
  for (int it = 0; it < 10; ++it) {
    const Eigen::Vector2d r = in.Point(s(0)) - out.Point(s(1));
    Eigen::Matrix2d J;
    J.col(0) = in.Tangent(s(0));
    J.col(1) = -out.Tangent(s(1));
    const Eigen::Vector2d step = J.fullPivLu().solve(-r);
    if (!step.allFinite()) return false;
    s += step;
    if (step.norm() < 1e-9) break;
  }
  *corner = out.Point(s(1));
  return corner->allFinite() && (in.Point(s(0)) - *corner).norm() < 1e-6;
}

// A Kalibr corner that failed the grid check, refined again in its view by the first step's
// cornerSubPix with smaller windows, from where the grid puts it. Its window was cut by the ring's
// edge (the view's black outside the map, or the rim's dark band inside it); a smaller window can
// keep clear of it. Kept only if it then fits the grid tightly: a measurement, not the prediction.
bool RetryKalibrCorner(const cv::Mat& view_grey, const RingView& view, const GridFit& fit,
                       const TagDetectorOptions& options, TagCornerDetection* d) {
  if (view_grey.empty() || fit.residual_px < 0) return false;
  const double first_half = TagCornerHalfWindow(d->side_in_view);
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
    const CornerObservation& o = (*detections)[i].observation;
    groups[{o.target, MirrorIndex(o.mirror)}].push_back(i);
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

bool RefineTagCorners(const cv::Mat& grey, const Eigen::Vector2d (&corners)[4],
                      const double (&curvature)[4], double border_fraction, double spacing,
                      const TagDetectorOptions& options, Eigen::Vector2d (&refined)[4],
                      int tag_id) {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const auto& c : corners) centre += 0.25 * c;
  double side[4];
  for (int j = 0; j < 4; ++j) side[j] = (corners[(j + 1) % 4] - corners[j]).norm();
  EdgeCurve edges[4];
  for (int j = 0; j < 4; ++j) {
    // Edge j runs from corner j to corner j+1; its border is as wide as a bit of the sides
    // across it. Outside, stay within half the gap to the neighbouring tag.
    const double across = 0.5 * (side[(j + 1) % 4] + side[(j + 3) % 4]);
    const double border_px = border_fraction * across;
    if (border_px < options.min_border_px) return false;
    const double reach_out = std::clamp(0.5 * spacing * across, 1.0, 2.5);
    EdgeBits bits;
    bits.border_px = border_px;
    if (tag_id >= 0 && options.edge_bits) {
      // Edge j runs from corner k = j to k = j + 1 (k0 bottom-left, k1 bottom-right, k2
      // top-right, k3 top-left as printed; cells x right, y down from the top-left).
      const TagLayout layout = PlainTagLayout();
      const int n = layout.bits, in = layout.border;
      for (int i = 0; i < n; ++i) {
        int x = 0, y = 0;
        switch (j) {
          case 0: x = i, y = n - 1 - in; break;          // bottom, left to right
          case 1: x = n - 1 - in, y = n - 1 - i; break;  // right, bottom to top
          case 2: x = n - 1 - i, y = in; break;          // top, right to left
          default: x = in, y = i; break;                 // left, top to bottom
        }
        bits.cells.push_back(TagCellValue(tag_id, layout, x, y));
      }
    }
    if (!FitTagEdge(grey, corners[j], corners[(j + 1) % 4], centre, border_px, reach_out,
                    curvature[j], bits, options, &edges[j])) {
      return false;
    }
  }
  for (int k = 0; k < 4; ++k) {
    if (!IntersectEdges(edges[(k + 3) % 4], edges[k], &refined[k]) ||
        (refined[k] - corners[k]).norm() > options.max_refine_shift_px) {
      return false;
    }
  }
  return true;
}

namespace {

// The view's image: the one RenderViews left in it for this raw image, else resampled here.
cv::Mat ViewImage(const cv::Mat& raw_grey8, const RingView& view) {
  cv::Mat view_grey = view.image;
  if (view_grey.empty() || view_grey.cols != view.width || view_grey.rows != view.height) {
    cv::remap(raw_grey8, view_grey, view.map_fixed, view.map_interp, cv::INTER_LINEAR,
              cv::BORDER_CONSTANT, cv::Scalar(0));
  }
  return view_grey;
}

// Plain tags in a crop of view `v` (crop px): libapriltag's, plus in blurred views outlines of
// our own read by their blurred pattern for tags it did not read (libapriltag's quad finder
// misses small blurred tags: realistic_scene's 45 mm tags at 0.3-0.45 m in the inner ring, ~2
// raw px per bit).
std::vector<ViewTag> PlainTagsInCrop(const cv::Mat& crop, const RingView& view, int v, double blur,
                                     const TagDetectorOptions& options) {
  const float decimate = view.mirror == Mirror::kTwo ? options.inner_ring_quad_decimate : options.quad_decimate;
  std::vector<ViewTag> in_crop = DetectPlainTags(crop, v, decimate, blur, options);
  if (options.plain_outline_finder && blur >= options.blurred_view_sigma) {
    for (const KalibrViewTag& t : DetectPlainTagsBlurred(crop, blur, options.kalibr.blurred)) {
      bool known = false;
      for (const ViewTag& u : in_crop) known |= u.tag_id == t.tag_id;
      if (known) continue;
      ViewTag tag{TargetType::kAprilTagGrid, t.tag_id, {}, v};
      for (int k = 0; k < 4; ++k) tag.corners[k] = t.corners[k];
      in_crop.push_back(tag);
    }
  }
  return in_crop;
}

// Kalibr tags in `crop_rect` of view `v` (view px), appended to `found`. Kalibr tag corners are
// X-junctions (kalibr_detector.h): the quad finder (its contours on the 2x enlarged view were
// 135 of 280 ms per calibration_scene_tags image) runs only on the boxes of saddle-point
// clusters (saddle_points.h) within the crop, each with a margin of 2.5 spacings + 8 px around
// its outermost saddles.
void KalibrTagsInView(const cv::Mat& view_grey, const RingView& view, int v, const cv::Rect& crop_rect,
                      double blur, const std::vector<TargetSpec>& targets, const TagDetectorOptions& options,
                      UnclaimedTags* unclaimed, std::vector<ViewTag>* found) {
  RingView rendered = view;  // shallow: the maps are shared
  rendered.image = view_grey;
  std::vector<Region> regions;
  if (options.kalibr_saddle_gate) {
    regions = Regions(SaddlePoints(rendered, options.kalibr_saddles), view_grey.size(), options.kalibr_saddles, view.f);
  } else {
    regions.emplace_back();
    regions.back().rect = crop_rect;
  }
  for (const Region& region : regions) {
    const int pad = static_cast<int>(std::lround(options.kalibr_region_pad_deg * M_PI / 180 * view.f));
    const cv::Rect box = cv::Rect(region.rect.x - pad, region.rect.y - pad, region.rect.width + 2 * pad,
                                  region.rect.height + 2 * pad) &
                         crop_rect;
    if (box.empty()) continue;
    KalibrDetectorOptions kalibr = options.kalibr;
    kalibr.blur_sigma = blur;
    for (ViewTag t : DetectKalibrTags(view_grey(box).clone(), v, targets, kalibr,
                                      unclaimed ? &unclaimed->kalibr : nullptr)) {
      for (auto& c : t.corners) c += Eigen::Vector2d(box.x, box.y);
      found->push_back(t);
    }
  }
}

// The tags read in view `v` (view px), appended to `found`: plain tags first, then Kalibr tags.
// Neighbouring views overlap (views.h: 8 views of 90 degrees per ring): each ring's azimuth is
// searched once by taking only the middle of each view, 360 / views-per-ring degrees plus
// options.view_overlap_deg on each side, so a tag up to that wide lies whole in some crop.
// Cuts the tag detectors' pixels by ~40% (they were ~290 ms of a 1280x960 image's ~390 ms).
void TagsInView(const cv::Mat& view_grey, const RingView& view, int v, int views_per_ring, bool want_plain,
                bool want_kalibr, const std::vector<TargetSpec>& targets, const TagDetectorOptions& options,
                UnclaimedTags* unclaimed, std::vector<ViewTag>* found) {
  const double half_deg = 180.0 / std::max(1, views_per_ring) + options.view_overlap_deg;
  const int half_px = static_cast<int>(std::ceil(view.f * std::tan(half_deg * M_PI / 180)));
  const int x0 = std::max(0, static_cast<int>(view.cx) - half_px);
  const int x1 = std::min(view.width, static_cast<int>(view.cx) + half_px + 2);
  const cv::Mat crop = view_grey.colRange(x0, x1).clone();
  std::vector<ViewTag> in_crop;
  const double blur = view.blur_sigma ? *view.blur_sigma : 0.0;
  if (want_plain) in_crop = PlainTagsInCrop(crop, view, v, blur, options);
  for (ViewTag& t : in_crop) {
    for (auto& c : t.corners) c.x() += x0;
    found->push_back(t);
  }
  if (want_kalibr) {
    KalibrTagsInView(view_grey, view, v, cv::Rect(x0, 0, x1 - x0, view.height), blur, targets, options, unclaimed,
                     found);
  }
}

// One detection per (layout, tag, ring): the one whose corners lie nearest its view's centre
// (pointers into `found`).
std::map<std::tuple<int, int, int>, std::pair<double, const ViewTag*>> NearestToViewCentre(
    const std::vector<ViewTag>& found, const std::vector<RingView>& views) {
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
  return best;
}

// The target a tag id belongs to: the first of the detector's layout that holds it; -1 if none.
int TargetOfTag(const std::vector<TargetSpec>& targets, TargetType layout, int tag_id) {
  int target = -1;
  for (std::size_t i = 0; i < targets.size() && target < 0; ++i) {
    int row = 0, col = 0;
    if (targets[i].type == layout && TagCell(targets[i], tag_id, &row, &col)) target = static_cast<int>(i);
  }
  return target;
}

// A tag's corners mapped from its view to raw (`mapped`); false where one is off the view's map
// or they do not form a convex quadrilateral with the same turning sense all round.
bool MappedConvexQuad(const RingView& view, const ViewTag& t, Eigen::Vector2d (&mapped)[4]) {
  bool ok = true;
  for (int k = 0; k < 4 && ok; ++k) {
    const auto raw = view.ViewToRaw(t.corners[k]);
    ok = raw.has_value();
    if (ok) mapped[k] = *raw;
  }
  if (!ok) return false;
  double sign = 0;
  for (int k = 0; k < 4 && ok; ++k) {
    const Eigen::Vector2d a = mapped[(k + 1) % 4] - mapped[k];
    const Eigen::Vector2d b = mapped[(k + 2) % 4] - mapped[(k + 1) % 4];
    const double cross = a.x() * b.y() - a.y() * b.x();
    if (k == 0) sign = cross;
    ok = cross * sign > 0;
  }
  return ok;
}

// A Kalibr tag's corners in raw: small tags by their whole printed pattern (FitTagPattern),
// else each corner as an X-junction (kalibr_detector.h): saddle refinement in the raw image over
// the 2-bit border around the corner, then the blurred-junction fit, only where the junction is
// whole (`whole[k]`). Corners judged one by one: a tag read exactly in its view next to the
// ring's rim has its corner squares and gaps on that side cut off by the lip band
// (calibration_scene_tags 0016 and 0019, ring 1: 3 tags lost whole); those corners cannot be
// measured and are dropped, the tag's whole X-junctions kept (the grid check judges each).
void RefineKalibrTag(const cv::Mat& raw_grey8, const cv::Mat& grey, const RingView& view, const ViewTag& t,
                     const TargetSpec& target, const Eigen::Vector2d (&mapped)[4],
                     const TagDetectorOptions& options, Eigen::Vector2d (&refined)[4], bool (&whole)[4]) {
  if (options.fit_tag_pattern) {
    double side = 1e9;
    for (int k = 0; k < 4; ++k) side = std::min(side, (mapped[(k + 1) % 4] - mapped[k]).norm());
    if (target.spacing * side < options.kalibr_pattern_below_gap_px) {
      if (const auto fit = FitTagPattern(grey, view, target, t.tag_id, t.corners)) {
        std::copy(fit->corners, fit->corners + 4, refined);
        return;
      }
    }
  }
  for (int k = 0; k < 4; ++k) {
    refined[k] = mapped[k];
    const double side =
        std::min((mapped[(k + 1) % 4] - mapped[k]).norm(), (mapped[(k + 3) % 4] - mapped[k]).norm());
    const Eigen::Vector2d to_next = (mapped[(k + 1) % 4] - mapped[k]).normalized();
    const Eigen::Vector2d to_previous = (mapped[(k + 3) % 4] - mapped[k]).normalized();
    whole[k] = IsKalibrXJunction(raw_grey8, mapped[k], to_next, to_previous, XJunctionProbe(side),
                                 options.kalibr.min_contrast);
    if (whole[k] && options.kalibr_refine_in_raw) {
      whole[k] = RefineSaddleCorner(raw_grey8, mapped[k], TagCornerHalfWindow(side),
                                    options.max_refine_shift_px, &refined[k]);
    }
    if (whole[k] && options.kalibr_fit_junction) {
      refined[k] = FitKalibrJunction(grey, view, t, k, mapped[k], refined[k], options.kalibr_junction_window * side,
                                     false);
    }
  }
}

// Whether the view is blurred enough for the plain tags' blurred-view paths (pattern fit, the
// edge fit's deeper reach inside the border).
bool BlurredView(const RingView& view, const TagDetectorOptions& options) {
  return view.blur_sigma && *view.blur_sigma >= options.blurred_view_sigma;
}

// The options a plain tag's edge fits use in this view: the blurred reach only in blurred views.
TagDetectorOptions EdgeFitOptions(const RingView& view, const TagDetectorOptions& options) {
  TagDetectorOptions edge_options = options;
  if (!BlurredView(view, options)) edge_options.edge_fit_reach_in_blurred = options.edge_fit_reach_in;
  return edge_options;
}

// A plain tag's corners in raw: the whole tag's printed pattern fitted to its raw pixels in
// blurred views (tag_pattern_fit.h), else its four edges fitted in the raw image, the corners
// where they meet. `refined` is left as it is (libapriltag's corners mapped from the view) where
// neither can measure the tag.
void RefinePlainTag(const cv::Mat& grey, const RingView& view, const ViewTag& t, const TargetSpec& target,
                    const Eigen::Vector2d (&mapped)[4], const TagDetectorOptions& options,
                    Eigen::Vector2d (&refined)[4]) {
  const std::optional<TagPatternFit> pattern_fit =
      options.fit_tag_pattern && BlurredView(view, options) ? FitTagPattern(grey, view, target, t.tag_id, t.corners) : std::nullopt;
  if (pattern_fit) {
    std::copy(pattern_fit->corners, pattern_fit->corners + 4, refined);
    return;
  }
  const Eigen::Vector2d centre = 0.25 * (mapped[0] + mapped[1] + mapped[2] + mapped[3]);
  double curvature[4];
  for (int j = 0; j < 4; ++j) {
    curvature[j] = options.curvature_from_view ? EdgeCurvatureFromView(view, t.corners[j], t.corners[(j + 1) % 4], centre)
                                               : std::nan("");
  }
  Eigen::Vector2d fitted[4];
  if (RefineTagCorners(grey, mapped, curvature, BorderFraction(t.layout), target.spacing,
                       EdgeFitOptions(view, options), fitted,
                       t.tag_id)) {
    std::copy(fitted, fitted + 4, refined);
  }
}

// Corner k of tag `t` of target `target` as reported: its raw pixel, the view corner it came from
// and where the view mapped it, and the tag's mean side in the view (for the grid check).
TagCornerDetection CornerDetection(const ViewTag& t, int target, int k, Mirror mirror, const Eigen::Vector2d& pixel,
                                   const Eigen::Vector2d& mapped) {
  TagCornerDetection d;
  d.observation.target = target;
  d.observation.id = 4 * t.tag_id + k;
  d.observation.mirror = mirror;
  d.observation.pixel = pixel;
  d.tag_id = t.tag_id;
  d.mapped = mapped;
  d.view = t.view;
  d.in_view = t.corners[k];
  for (int j = 0; j < 4; ++j) d.side_in_view += 0.25 * (t.corners[(j + 1) % 4] - t.corners[j]).norm();
  return d;
}

// One read tag of target `target` measured in raw, its corners appended to `out`. Plain tags: the
// whole tag or nothing (a half-refined tag is suspect). Kalibr tags: at least
// kalibr_min_whole_corners whole junctions (fewer: the quad itself is doubtful).
void MeasureTag(const cv::Mat& raw_grey8, const cv::Mat& grey, const RingView& view, const ViewTag& t,
                int target, const TargetSpec& spec, const TagDetectorOptions& options,
                std::vector<TagCornerDetection>* out) {
  Eigen::Vector2d mapped[4];
  if (!MappedConvexQuad(view, t, mapped)) return;
  Eigen::Vector2d refined[4];
  bool whole[4] = {true, true, true, true};
  if (t.layout == TargetType::kKalibrAprilGrid) {
    RefineKalibrTag(raw_grey8, grey, view, t, spec, mapped, options, refined, whole);
  } else {
    std::copy(mapped, mapped + 4, refined);
    if (t.layout == TargetType::kAprilTagGrid && options.refine_in_raw) {
      RefinePlainTag(grey, view, t, spec, mapped, options, refined);
    }
  }
  if (std::count(whole, whole + 4, true) < options.kalibr_min_whole_corners) return;
  for (int k = 0; k < 4; ++k) {
    if (whole[k]) out->push_back(CornerDetection(t, target, k, view.mirror, refined[k], mapped[k]));
  }
}

// Corner k of a plain tag a post hides in part (its code unreadable, its place from the grid): its
// two edges fitted near it only, over the part of each within kPartialEdge of the side from the
// corner where the view shows all of it, and intersected (as RefineTagCorners does with whole
// edges; no code bits along them). nullopt where the post is too close or an edge does not fit.
std::optional<Eigen::Vector2d> PartialPlainCorner(const cv::Mat& grey, const RingView& view, const ViewTag& t,
                                                  int k, const TargetSpec& target,
                                                  const TagDetectorOptions& options) {
  constexpr double kPartialEdge = 0.45;
  const Eigen::Vector2d& c = t.corners[k];
  const Eigen::Vector2d to_next = kPartialEdge * (t.corners[(k + 1) % 4] - c);
  const Eigen::Vector2d to_previous = kPartialEdge * (t.corners[(k + 3) % 4] - c);
  for (int i = 0; i <= 8; ++i) {
    if (!view.ViewToRaw(c + i / 8.0 * to_next) || !view.ViewToRaw(c + i / 8.0 * to_previous)) return std::nullopt;
  }
  const Eigen::Vector2d centre = 0.25 * (t.corners[0] + t.corners[1] + t.corners[2] + t.corners[3]);
  const auto raw_c = view.ViewToRaw(c), raw_next = view.ViewToRaw(c + to_next),
             raw_previous = view.ViewToRaw(c + to_previous), inside = view.ViewToRaw(c + 0.2 * (centre - c));
  if (!raw_c || !raw_next || !raw_previous || !inside) return std::nullopt;
  const double side = 0.5 * ((*raw_next - *raw_c).norm() + (*raw_previous - *raw_c).norm()) / kPartialEdge;
  EdgeBits bits;
  bits.border_px = BorderFraction(t.layout) * side;
  if (bits.border_px < options.min_border_px) return std::nullopt;
  const double reach_out = std::clamp(0.5 * target.spacing * side, 1.0, 2.5);
  const TagDetectorOptions edge_options = EdgeFitOptions(view, options);
  const auto curvature = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return options.curvature_from_view ? EdgeCurvatureFromView(view, a, b, *inside) : std::nan("");
  };
  // Edge k - 1 runs from corner k - 1 to k (its part ends at the corner), edge k from k on.
  EdgeCurve into, from;
  if (!FitTagEdge(grey, *raw_previous, *raw_c, *inside, bits.border_px, reach_out,
                  curvature(c + to_previous, c), bits, edge_options, &into) ||
      !FitTagEdge(grey, *raw_c, *raw_next, *inside, bits.border_px, reach_out, curvature(c, c + to_next),
                  bits, edge_options, &from)) {
    return std::nullopt;
  }
  Eigen::Vector2d corner;
  if (!IntersectEdges(into, from, &corner) || (corner - *raw_c).norm() > options.max_refine_shift_px) {
    return std::nullopt;
  }
  return corner;
}

// The seen corners of Kalibr tags hidden in part (GrowTagGrids): where the raw image shows a
// whole X-junction there, measured as read tags' corners are; corners already in `out` are
// kept. The junction's two lines run through the corner: the tag's edges and, beyond the
// corner, its corner square's sides, each taken a quarter side along the edge, or as far the
// other way where the post covers the edge.
void MeasurePartialTags(const cv::Mat& raw_grey8, const cv::Mat& grey, const std::vector<RingView>& views,
                        const std::vector<TargetSpec>& targets, const TagDetectorOptions& options,
                        const std::vector<PartialTag>& partial, std::vector<TagCornerDetection>* out) {
  std::set<std::tuple<int, int, int>> have;  // (target, corner id, ring)
  for (const TagCornerDetection& d : *out) {
    have.insert({d.observation.target, d.observation.id, MirrorIndex(d.observation.mirror)});
  }
  for (const PartialTag& part : partial) {
    const ViewTag& t = part.tag;
    const RingView& view = views[t.view];
    const int target = TargetOfTag(targets, t.layout, t.tag_id);
    if (target < 0) continue;
    for (int k = 0; k < 4; ++k) {
      if (!part.seen[k] || have.count({target, 4 * t.tag_id + k, MirrorIndex(view.mirror)})) continue;
      const Eigen::Vector2d& c = t.corners[k];
      const auto mapped = view.ViewToRaw(c);
      if (!mapped) continue;
      if (t.layout == TargetType::kAprilTagGrid) {
        if (const auto corner = PartialPlainCorner(grey, view, t, k, targets[target], options)) {
          out->push_back(CornerDetection(t, target, k, view.mirror, *corner, *mapped));
          have.insert({target, out->back().observation.id, MirrorIndex(view.mirror)});
        }
        continue;
      }
      const auto along = [&](int other, double fraction) -> std::optional<Eigen::Vector2d> {
        return view.ViewToRaw(c + fraction * (t.corners[other] - c));
      };
      const auto towards = [&](int other) -> std::optional<Eigen::Vector2d> {
        if (const auto p = along(other, 0.25)) return *p - *mapped;
        if (const auto p = along(other, -0.25)) return *mapped - *p;
        return std::nullopt;
      };
      const auto next = towards((k + 1) % 4), previous = towards((k + 3) % 4);
      if (!next || !previous) continue;
      const double side = 4 * std::min(next->norm(), previous->norm());
      if (!IsKalibrXJunction(raw_grey8, *mapped, next->normalized(), previous->normalized(),
                             XJunctionProbe(side), options.kalibr.min_contrast)) {
        continue;
      }
      const Eigen::Vector2d refined =
          options.kalibr_fit_junction
              ? FitKalibrJunction(grey, view, t, k, *mapped, *mapped, options.kalibr_junction_window * side, true)
              : *mapped;
      out->push_back(CornerDetection(t, target, k, view.mirror, refined, *mapped));
      have.insert({target, out->back().observation.id, MirrorIndex(view.mirror)});
    }
  }
}

}  // namespace

std::string TagDetectorOptions::Check() const {
  if (!(quad_decimate >= 1)) return OptionError("quad_decimate", "a decimation >= 1", quad_decimate);
  if (!(inner_ring_quad_decimate >= 1)) {
    return OptionError("inner_ring_quad_decimate", "a decimation >= 1", inner_ring_quad_decimate);
  }
  if (plain_max_hamming < 0) return OptionError("plain_max_hamming", "a bit count >= 0", plain_max_hamming);
  if (!(view_overlap_deg >= 0)) return OptionError("view_overlap_deg", "an angle >= 0 degrees", view_overlap_deg);
  if (!(max_refine_shift_px > 0)) return OptionError("max_refine_shift_px", "a shift > 0 px", max_refine_shift_px);
  if (!(min_edge_px > 0)) return OptionError("min_edge_px", "a length > 0 px", min_edge_px);
  if (!(max_edge_rms_px > 0)) return OptionError("max_edge_rms_px", "a tolerance > 0 px", max_edge_rms_px);
  if (!(edge_corner_margin_px >= 0)) {
    return OptionError("edge_corner_margin_px", "a margin >= 0 px", edge_corner_margin_px);
  }
  if (!(edge_fit_reach_in > 0)) return OptionError("edge_fit_reach_in", "a fraction > 0 of the border", edge_fit_reach_in);
  if (!(edge_fit_reach_in_blurred > 0)) {
    return OptionError("edge_fit_reach_in_blurred", "a fraction > 0 of the border", edge_fit_reach_in_blurred);
  }
  if (!(min_border_px > 0)) return OptionError("min_border_px", "a width > 0 px", min_border_px);
  if (!(kalibr_junction_window > 0)) {
    return OptionError("kalibr_junction_window", "a fraction > 0 of the tag side", kalibr_junction_window);
  }
  if (kalibr_min_whole_corners < 1 || kalibr_min_whole_corners > 4) {
    return OptionError("kalibr_min_whole_corners", "a corner count in [1, 4]", kalibr_min_whole_corners);
  }
  if (!(kalibr_region_pad_deg >= 0)) {
    return OptionError("kalibr_region_pad_deg", "an angle >= 0 degrees", kalibr_region_pad_deg);
  }
  for (double w : kalibr_retry_windows) {
    if (!(w > 0 && w < 1)) return OptionError("kalibr_retry_windows", "fractions in (0, 1)", w);
  }
  if (!(kalibr_retry_max_residual_px > 0)) {
    return OptionError("kalibr_retry_max_residual_px", "a tolerance > 0 px", kalibr_retry_max_residual_px);
  }
  if (const std::string error = NestedOptionError("kalibr_saddles", kalibr_saddles.Check()); !error.empty()) {
    return error;
  }
  if (const std::string error = NestedOptionError("grid_check_options", grid_check_options.Check());
      !error.empty()) {
    return error;
  }
  return NestedOptionError("kalibr", kalibr.Check());
}

std::vector<TagCornerDetection> DetectTagCorners(const cv::Mat& raw_bgr,
                                                 const std::vector<RingView>& views,
                                                 const RigModel& model,
                                                 const std::vector<TargetSpec>& targets,
                                                 const TagDetectorOptions& options,
                                                 UnclaimedTags* unclaimed) {
  if (const std::string error = options.Check(); !error.empty()) throw std::invalid_argument(error);
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

  int views_per_ring = 0;
  for (const RingView& view : views) views_per_ring += view.mirror == views.front().mirror;
  std::vector<ViewTag> found;
  std::vector<cv::Mat> view_images(views.size());  // kept for the grid check's Kalibr retries
  for (std::size_t v = 0; v < views.size(); ++v) {
    view_images[v] = ViewImage(raw_grey8, views[v]);
    TagsInView(view_images[v], views[v], static_cast<int>(v), views_per_ring, want_plain, want_kalibr, targets,
               options, unclaimed, &found);
  }

  std::vector<PartialTag> partial;
  std::optional<RigModel> unmounted;
  if (model.params().mount.present) {
    RigParams bare = model.params();
    bare.mount = Mount();
    unmounted.emplace(bare);
  }
  if (options.grow_grids) {
    for (std::size_t v = 0; v < views.size(); ++v) {
      GrowTagGrids(view_images[v], views[v], static_cast<int>(v), targets, options, &model,
                   unmounted ? &*unmounted : nullptr, &found, &partial);
    }
  }

  for (const auto& [key, entry] : NearestToViewCentre(found, views)) {
    const ViewTag& t = *entry.second;
    const int target = TargetOfTag(targets, t.layout, t.tag_id);
    if (target < 0) {
      if (unclaimed && t.layout == TargetType::kAprilTagGrid) unclaimed->plain.insert(t.tag_id);
      continue;
    }
    MeasureTag(raw_grey8, grey, views[t.view], t, target, targets[target], options, &out);
  }
  MeasurePartialTags(raw_grey8, grey, views, targets, options, partial, &out);
  if (options.grid_check) DropCornersOffTheirTarget(views, view_images, model, targets, options, &out);
  return out;
}

std::vector<CornerObservation> DetectTagGrids(const cv::Mat& raw_bgr,
                                                  const std::vector<RingView>& views,
                                                  const RigModel& model,
                                                  const std::vector<TargetSpec>& targets,
                                                  UnclaimedTags* unclaimed) {
  std::vector<CornerObservation> out;
  for (const TagCornerDetection& d : DetectTagCorners(raw_bgr, views, model, targets, {}, unclaimed)) {
    out.push_back(d.observation);
  }
  return out;
}

}  // namespace omni::detectors
