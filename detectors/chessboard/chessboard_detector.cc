#include "detectors/chessboard/chessboard_detector.h"

#include "detectors/chessboard/chessboard_trace.h"
#include "detectors/chessboard/grid_check.h"
#include "detectors/chessboard/junction_board.h"
#include "detectors/chessboard/junction_grid.h"
#include "detectors/chessboard/region_crop.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <optional>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/common/board_junction_fit.h"
#include "detectors/common/corner_refine.h"
#include "detectors/common/corner_window.h"
#include "detectors/common/option_check.h"
#include "detectors/common/saddle_points.h"

namespace omni::detectors {
namespace {

SaddleOptions Saddles(const ChessboardOptions& o) {
  SaddleOptions s;
  s.sigma = o.saddle_sigma;
  s.min_contrast = o.saddle_min_contrast;
  s.balance = o.saddle_balance;
  s.relative_contrast = o.saddle_relative_contrast;
  s.min_contrast_floor = o.saddle_contrast_floor;
  s.merge_sigmas = o.saddle_merge_sigmas;
  s.min_saddles = o.min_saddles;
  return s;
}

// Index permutations of a rows x cols grid that a board's symmetry allows: 180-degree turns,
// and for square boards 90-degree turns and transposes; mirror images are filtered later by
// handedness. perm[new_id] = old index.
std::vector<std::vector<int>> Relabellings(int rows, int cols) {
  std::vector<std::vector<int>> out;
  for (int transpose = 0; transpose < (rows == cols ? 2 : 1); ++transpose) {
    for (int flip_r = 0; flip_r < 2; ++flip_r) {
      for (int flip_c = 0; flip_c < 2; ++flip_c) {
        std::vector<int> perm(rows * cols);
        for (int r = 0; r < rows; ++r) {
          for (int c = 0; c < cols; ++c) {
            int rr = flip_r ? rows - 1 - r : r, cc = flip_c ? cols - 1 - c : c;
            if (transpose) std::swap(rr, cc);
            perm[r * cols + c] = rr * cols + cc;
          }
        }
        out.push_back(perm);
      }
    }
  }
  return out;
}

// Chooses ids for corners found as a rows x cols grid in a view (see the header's rule: +x to
// the viewer's left, i.e. view -x; +y up, i.e. view -y; proper handedness).
// Returns perm with oriented[id] = found[perm[id]]; empty if no relabelling is proper.
std::vector<int> Orient(const std::vector<cv::Point2f>& found, int rows, int cols) {
  std::vector<int> best;
  double best_score = -1e9;
  for (const auto& perm : Relabellings(rows, cols)) {
    Eigen::Vector2d dc = Eigen::Vector2d::Zero(), dr = Eigen::Vector2d::Zero();
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c + 1 < cols; ++c) {
        const cv::Point2f d = found[perm[r * cols + c + 1]] - found[perm[r * cols + c]];
        dc += Eigen::Vector2d(d.x, d.y);
      }
    }
    for (int r = 0; r + 1 < rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        const cv::Point2f d = found[perm[(r + 1) * cols + c]] - found[perm[r * cols + c]];
        dr += Eigen::Vector2d(d.x, d.y);
      }
    }
    if (dc.x() * dr.y() - dc.y() * dr.x() <= 0) continue;  // a mirror image
    const double score = -dc.normalized().x() - dr.normalized().y();
    if (score > best_score) {
      best_score = score;
      best = perm;
    }
  }
  return best;
}

// True if the region lies more centrally in the neighbouring view (views of one ring are evenly
// spaced in azimuth and overlap) and fits whole in it: it is then searched there only.
bool BetterInNeighbour(const RingView& view, const cv::Rect& rect, size_t sectors) {
  const double step = 2 * M_PI / sectors;
  const double half_fov = std::atan(0.5 * view.width / view.f);
  // The region's azimuth range from its two sides: the middle of its pixel columns lies farther
  // from the view's centre than the middle of its angles (tan), and a board midway between two
  // views then looked better in the other one from both sides (detector_eval_scene 0006: three
  // inner-ring boards at 3.5 m never searched). Near a tie both views search it (kTie); the
  // duplicate is removed later.
  // Taken on the region's middle row: the views look up or down at their ring's elevation, so
  // a column is not one azimuth, and at the view's middle row a region near the ring's edge
  // looked farther out than it is in both neighbouring views (realistic_scene 0002: a 5x6
  // board in ring 2 at the tie between two views was searched in neither).
  const double row = rect.y + 0.5 * rect.height;
  const auto azimuth_at = [&](double x) {
    const Eigen::Vector3d ray = view.RayInCam(Eigen::Vector2d(x, row));
    return std::atan2(ray.y(), ray.x());
  };
  const double left = azimuth_at(rect.x), right = azimuth_at(rect.x + rect.width);
  const double span = std::remainder(right - left, 2 * M_PI);
  const double offset =
      std::abs(std::remainder(left + 0.5 * span - view.azimuth, 2 * M_PI));
  constexpr double kTie = 0.02;
  return offset > 0.5 * step + kTie && (step - offset) + 0.5 * std::abs(span) < half_fov - 0.02;
}

// The view's pixels inside the ring (`edge_margin_rad` = 0) or at least `edge_margin_rad` from
// its edges. Ring 1's images end in a dark rim band inside the ring's modelled edge (5-7 view
// pixels = 0.02 rad wide in the calibration_scene_tags renders, ring 2 none): a board square's
// corner next to it reads as an X-junction like the dark invalid area would (image 0015: three
// "junctions" read on the rim beyond the top side of a 6x7 board in ring 1 made the
// whole-board test refuse it; 0 of 42 corners found). So the whole-board test, where a false
// junction refuses a whole board, reads only the pixels away from the edge; the junction grid,
// where a junction by the edge is a corner to report, reads all of the ring (with the margin
// there the demo's board 0008/2, cut by the ring's edge, lost 3 of its 40 corners).
cv::Mat RingPixels(const RingView& view, double edge_margin_rad) {
  cv::Mat trusted = view.map_x >= 0;
  const int margin = static_cast<int>(std::ceil(edge_margin_rad * view.f));
  if (margin > 0) {
    cv::erode(trusted, trusted, cv::getStructuringElement(cv::MORPH_RECT, {2 * margin + 1, 2 * margin + 1}),
              cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(255));
  }
  return trusted;
}

// True if a grid of rows x cols corners found in a view (`corners` row-major in view pixels) is
// a whole board and not part of a larger one: one grid step beyond each side lies the board's
// outer square corners, which must not be X-junctions: where most of a side's extrapolated
// points that the view sees are X-junctions, the grid goes on (the corner finders, the sector
// one especially, accept a sub-grid of a larger board, which would give a smaller target's ids
// to another board's corners). Points outside the ring or the view are unknown (a board whose
// outer squares are cut by a ring boundary is still found).
bool GridIsWholeBoard(const RingView& view, const cv::Mat& trusted,
                      const std::vector<cv::Point2f>& corners, int rows,
                      int cols, double min_contrast) {
  if (rows < 2 || cols < 2) return true;
  const auto at = [&](int r, int c) { return corners[r * cols + c]; };
  // Each side: (edge corner, its inner neighbour) pairs.
  std::vector<std::vector<std::pair<cv::Point2f, cv::Point2f>>> sides(4);
  for (int c = 0; c < cols; ++c) {
    sides[0].emplace_back(at(0, c), at(1, c));
    sides[1].emplace_back(at(rows - 1, c), at(rows - 2, c));
  }
  for (int r = 0; r < rows; ++r) {
    sides[2].emplace_back(at(r, 0), at(r, 1));
    sides[3].emplace_back(at(r, cols - 1), at(r, cols - 2));
  }
  for (const auto& side : sides) {
    int junctions = 0, seen = 0;
    for (const auto& [edge, inner] : side) {
      const std::optional<bool> x =
          IsXJunction(view, trusted, 2 * edge - inner, 0.35 * cv::norm(edge - inner), min_contrast, true);
      if (!x) continue;  // beyond the ring or the view: unknown
      ++seen;
      junctions += *x ? 1 : 0;
    }
    // A lone junction beyond a side is no evidence of a larger board: the ring's dark rim next
    // to a square's corner passes the circle test too (calibration_scene_tags image 0003).
    if (junctions >= 2 && 2 * junctions > seen) return false;
  }
  return true;
}

// One rows x cols grid in a crop by finder 0 or 1. The classic finder (quadrilaterals of a
// thresholded image) is fast but loses boards whose squares merge with a busy background in the
// threshold; the sector-based finder (findChessboardCornersSB, a Radon-like corner response and
// grid growing) finds those at about ten times the cost, so it only runs where the classic one
// failed or its grid was refused.
bool FindGrid(const cv::Mat& crop, const TargetSpec& spec, int finder,
              std::vector<cv::Point2f>* corners) {
  const cv::Size pattern(spec.cols, spec.rows);
  const size_t n = static_cast<size_t>(spec.rows * spec.cols);
  corners->clear();
  const bool found = finder == 0
      ? cv::findChessboardCorners(crop, pattern, *corners,
                                  cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)
      : cv::findChessboardCornersSB(crop, pattern, *corners,
                                    cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE);
  return found && corners->size() == n;
}

// A grid found in a region's crop made into a board: refined in the view, checked to be a whole
// board, labelled by the id rule, mapped to the raw image, refined there, checked against the
// board's homography. nullopt if any check refuses it. `filled` (empty: none) marks grid points
// that the ring or view hides (GridFromJunctions): they take part in the whole-board test and
// the orientation only.
}  // namespace

RawRefinement RefineBoardInRaw(const cv::Mat& raw_grey, const RigModel& model, const TargetSpec& spec,
                               const std::vector<std::optional<Eigen::Vector2d>>& raw,
                               double blur_px, const ChessboardOptions& options) {
  const size_t n = raw.size();
  RawRefinement out;
  std::vector<std::optional<Eigen::Vector2d>>& refined = out.refined;
  refined.resize(n);
  std::vector<int> halves(n, 1);
  std::vector<double> sides(n, 0);
  int& refused_refine = out.refused_refine;
  int& refused_shift = out.refused_shift;
  for (size_t i = 0; i < n; ++i) {
    if (!raw[i]) continue;
    Eigen::Vector2d pixel = *raw[i];
    if (options.refine_in_raw) {
      // The local square side in the raw image from the grid neighbours.
      const int r = static_cast<int>(i) / spec.cols, c = static_cast<int>(i) % spec.cols;
      double side = 1e9;
      for (auto [dr, dc] : {std::pair{0, 1}, {0, -1}, {1, 0}, {-1, 0}}) {
        const int rr = r + dr, cc = c + dc;
        if (rr < 0 || cc < 0 || rr >= spec.rows || cc >= spec.cols) continue;
        const auto& q = raw[rr * spec.cols + cc];
        if (q) side = std::min(side, (*q - *raw[i]).norm());
      }
      // A window of 0.55 squares (half-width, corner_window.h): the more of the four squares' edges it holds, the
      // less the demosaicing's phase-dependent errors and the noise move the corner
      // (realistic_scene ring 2 chessboards: 0.4 squares 0.140 px mean, 0.55: 0.099; clean
      // 0.058 -> 0.049; 0.7 reaches the next corners: 0.17). 3x3 on squares under 3 px (the inner
      // ring near 2 m at 960x720): a 5x5 one there spans neighbouring corners and pulled a third
      // of them about 1 px off (demo image 0007), which the grid check then refused; at 3-3.75 px
      // (inner-ring near boards, radially squeezed) 5x5 keeps them (realistic_scene 0011).
      const int raw_half = ChessboardHalfWindow(side, CameraPixelsPerDegree(model.params()));
      const Eigen::Vector2d before = pixel;
      if (!RefineCornerInRaw(raw_grey, raw_half, &pixel)) {
        ++refused_refine;
        continue;
      }
      // The views are exact only for points at their distance_mm: on the non-central rig a
      // near board's mapped corner is off by a few pixels (1.5-3 px measured in ring 1 at
      // 0.6 m), while a wrong saddle would be a whole square away.
      const double max_shift =
          std::max(options.max_refine_shift_px, options.max_refine_shift_squares * side);
      if ((pixel - before).norm() > max_shift) {
        trace::Line("   corner %zu: refinement moved it %.2f px (max %.2f, half %d)", i,
                    (pixel - before).norm(), max_shift, raw_half);
        ++refused_shift;
        continue;
      }
      halves[i] = raw_half;
      sides[i] = side;
    }
    refined[i] = pixel;
  }
  // Windows that reach past the corner's own four squares (a board cut by the ring's rim or
  // lip, its sheet's edge) pulled whole edge rows 0.5-0.9 px off, coherently, which the grid
  // check cannot see: such corners are refined again in a window that leaves the foreign edge
  // out, or dropped.
  const std::vector<int> start_halves = halves;
  if (options.refine_in_raw && options.clean_windows) {
    out.refused_window = KeepWindowsOnTheirSquares(raw_grey, spec.rows, spec.cols, sides,
                                                   options.min_clean_half, &halves, &refined,
                                                   blur_px, options.foreign_edge_slope);
  }
  // The board's lines from its refined corners, before any is corrected.
  if (options.refine_in_raw && options.fit_junctions) {
    FitBoardJunctions(raw_grey, spec.rows, spec.cols, sides, halves, options.junction_window_squares,
                      &refined);
    // Squares small against the blur: fitted again as the blurred board, as guided detection's
    // (board_junction_fit.h).
    double side_sum = 0;
    int side_count = 0;
    for (size_t i = 0; i < refined.size(); ++i) {
      if (refined[i]) side_sum += sides[i], ++side_count;
    }
    if (side_count && blur_px > kBlurredBoardFraction * side_sum / side_count) {
      FitBlurredBoard(raw_grey, spec.rows, spec.cols, sides, start_halves, halves,
                      kBlurredBoardWindowSquares, blur_px, &refined);
    }
  } else if (options.refine_in_raw && options.remove_curvature_bias) {
    RemoveCurvatureBias(spec.rows, spec.cols, halves, &refined);
  }
  return out;
}

namespace {

std::optional<BoardDetection> MakeBoard(const cv::Mat& raw_grey, const RingView& view,
                                        const cv::Mat& trusted,
                                        const RigModel& model, const TargetSpec& spec,
                                        const Region& region, std::vector<cv::Point2f> corners,
                                        std::vector<bool> filled, const ChessboardOptions& options) {
  filled.resize(corners.size(), false);
  const cv::Point2f origin(static_cast<float>(region.full.x), static_cast<float>(region.full.y));
  BoardDetection board;
  // A window of about a third of a square: the corner finders' initial corners are up to a
  // few view pixels off in the blurrier (upsampled) inner-ring views, beyond the reach of a
  // fixed 5x5 window.
  const int half = std::clamp(static_cast<int>(0.35 * region.spacing), 2, 8);
  std::vector<cv::Point2f> seen;
  for (size_t i = 0; i < corners.size(); ++i) {
    cv::Point2f& c = corners[i];
    c += origin;
    if (filled[i]) continue;
    if (c.x < half + 1 || c.y < half + 1 || c.x > view.width - half - 2 || c.y > view.height - half - 2) {
      trace::Line("  refused: a corner at the view's border");
      return std::nullopt;
    }
    seen.push_back(c);
  }
  cv::cornerSubPix(view.image, seen, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 20, 1e-3));
  for (size_t i = 0, k = 0; i < corners.size(); ++i) {
    if (!filled[i]) corners[i] = seen[k++];
  }
  if (!GridIsWholeBoard(view, trusted, corners, spec.rows, spec.cols, options.saddle_contrast_floor)) {
    trace::Line("  refused: not a whole board");
    return std::nullopt;
  }
  const std::vector<int> perm = Orient(corners, spec.rows, spec.cols);
  if (perm.empty()) {
    trace::Line("  refused: no proper orientation");
    return std::nullopt;
  }
  std::vector<cv::Point2f> oriented(perm.size());
  for (size_t i = 0; i < perm.size(); ++i) oriented[i] = corners[perm[i]];
  board.mirror = view.mirror;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  std::vector<std::optional<Eigen::Vector2d>> raw(oriented.size());
  for (size_t i = 0; i < oriented.size(); ++i) {
    const Eigen::Vector2d vp(oriented[i].x, oriented[i].y);
    centre += vp / oriented.size();
    if (!filled[perm[i]]) raw[i] = view.ViewToRawExact(model, vp);
  }
  board.off_centre = (centre - Eigen::Vector2d(view.cx, view.cy)).norm();
  const RawRefinement refinement =
      RefineBoardInRaw(raw_grey, model, spec, raw, view.RawBlurAt(centre), options);
  const std::vector<std::optional<Eigen::Vector2d>>& refined = refinement.refined;
  trace::Line("   raw refinement refused %d, moved too far %d, window not on its squares %d",
              refinement.refused_refine, refinement.refused_shift, refinement.refused_window);
  for (size_t i = 0; i < oriented.size(); ++i) {
    if (!refined[i]) continue;
    board.ids.push_back(static_cast<int>(i));
    board.view_pixels.emplace_back(oriented[i].x, oriented[i].y);
    board.raw_pixels.push_back(*refined[i]);
  }
  const size_t refined_count = board.ids.size();
  if (!GridFitsBoard(view, model, spec.cols, options, &board)) {
    trace::Line("  refused: grid check (%zu of %zu corners refined)", refined_count, oriented.size());
    return std::nullopt;
  }
  trace::Line("  board: %zu corners (%zu refined)", board.ids.size(), refined_count);
  return board;
}

// The boards in one region of a view. The patterns whose rows x cols match the extent of the
// region's X-junction grid are searched first (the board's outer square corners pass the saddle
// test but are not X-junctions), then those that can hold the grid, nearest first: a grid with
// an extra row and column of junk junctions can match another pattern exactly (the field
// photo's 5x7 board read as an 8x6 grid, the session's 6x8 pattern; only 6x8 was searched).
// Pass 0 runs the fast classic finder, pass 1 the junction grid, pass 2 the sector finder where
// the region's saddle points allow more boards than were found (a failed sector search costs
// ~60-80 ms, a failed classic one ~10 ms, a successful one 2-20 ms: measured on the demo's
// 960x720 renders).
std::vector<BoardDetection> SearchRegion(const cv::Mat& raw_grey, const RingView& view,
                                         const cv::Mat& in_ring, const cv::Mat& trusted,
                                         const RigModel& model, const std::vector<TargetSpec>& targets,
                                         const std::vector<int>& patterns, const Region& region,
                                         const std::vector<cv::Point2f>& view_saddles,
                                         size_t sectors, const ChessboardOptions& options,
                                         int view_index) {
  std::vector<cv::Point2f> junctions;
  for (const auto& q : region.points) {
    if (IsJunctionNearEdge(view, in_ring, trusted, q, region.spacing, options.saddle_contrast_floor)) {
      junctions.push_back(q);
    }
  }
  const GridExtent grid = MeasureGrid(view.image, junctions, region.spacing, options.saddle_contrast_floor);
  trace::Junctions(view_index, junctions);
  trace::Grid(view_index, grid.points, grid.coords);
  trace::Line(" region %d,%d %dx%d: %d saddles, spacing %.1f, %zu junctions, grid %dx%d (%d)",
              region.rect.x, region.rect.y, region.rect.width, region.rect.height, region.saddles,
              region.spacing, junctions.size(), grid.a, grid.b, grid.count);
  // The view's X-junctions outside the grid, for the junction grid across gaps (a post's band
  // splits a board's junctions into two grids, often two regions): computed once, when needed.
  std::optional<JunctionGaps> gaps;
  const auto junction_gaps = [&]() -> const JunctionGaps* {
    if (gaps) return &*gaps;
    gaps.emplace();
    gaps->min_contrast = options.saddle_contrast_floor;
    for (const cv::Point2f& q : view_saddles) {
      const bool in_grid = std::any_of(grid.points.begin(), grid.points.end(),
                                       [&](const cv::Point2f& g) { return cv::norm(g - q) < 0.5; });
      if (!in_grid && IsJunctionNearEdge(view, in_ring, trusted, q, region.spacing, options.saddle_contrast_floor)) {
        gaps->loose.push_back(q);
      }
    }
    return &*gaps;
  };
  // Whether a grid point lies within 1.5 squares of pixels the view does not trust (a post's
  // band, the ring's edge): only such a grid may be one side of a board crossed by a post.
  std::optional<bool> by_gap;
  const auto grid_by_gap = [&]() {
    if (!by_gap) {
      by_gap = std::any_of(grid.points.begin(), grid.points.end(), [&](const cv::Point2f& p) {
        return !IsXJunction(view, trusted, p, 1.5 * region.spacing, 0).has_value();
      });
    }
    return *by_gap;
  };
  std::vector<BoardDetection> found;
  // A board cut by the view's side lies whole in the neighbouring view and is searched there
  // (the region's box may be too large to tell, when background saddles join it; the grid's
  // box tells).
  if (2 * grid.count > region.saddles && BetterInNeighbour(view, grid.box, sectors)) {
    trace::Line("  left to the neighbouring view");
    return found;
  }
  const auto near = [&](int t, int tolerance) {
    return GridNearPattern(grid, targets[t].rows, targets[t].cols, tolerance);
  };
  const auto matches = [&](int t) { return near(t, 0); };
  // At most two junk rows or columns (GridFitsInPattern); the whole-board test decides.
  const auto holds = [&](int t) { return GridFitsInPattern(grid, targets[t].rows, targets[t].cols, 2); };
  // The patterns nearest the grid's extent go first (larger first among equals, as
  // `patterns`): a failed classic search costs 10-25 ms per pattern.
  std::vector<int> order = patterns;
  const auto distance = [&](int t) { return PatternDistance(grid, targets[t].rows, targets[t].cols); };
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return distance(a) < distance(b); });
  cv::Mat crop = RegionCrop(view, region.full);
  int found_here = 0;
  // The searches, cheapest first: per pattern the classic finder, then the region's own
  // X-junction grid (~1 ms; it finds the boards cut by a ring's edge that both OpenCV finders
  // lose: calibration_scene_tags 0006, where the failed sector searches and classic ones for
  // the other patterns cost 160 ms before it); the sector-based finder after all of them.
  // Last, the junction grid across gaps (GridFromJunctions with JunctionGaps: a board crossed by
  // a post, or cut by a ring's edge by more than a row or column), only where no finder found a
  // board in the region: the boards the others find keep their corners as they were.
  enum Finder { kClassic, kJunctions, kSector, kAcross };
  std::vector<std::pair<Finder, int>> searches;
  for (int t : order) {
    searches.emplace_back(kClassic, t);
    if (options.sector_fallback) searches.emplace_back(kJunctions, t);
  }
  for (int t : order) {
    if (options.sector_fallback) searches.emplace_back(kSector, t);
  }
  for (int t : order) {
    if (options.sector_fallback) searches.emplace_back(kAcross, t);
  }
  for (const auto& [finder, t] : searches) {
    {
      const TargetSpec& spec = targets[t];
      const int n = spec.rows * spec.cols;
      // Patterns the grid does not match: not where the junction grid holds under half their
      // corners (tag grids' bits make saddle regions too: searching them cost ~500 ms per
      // 1280x960 image) or more rows or columns than the pattern has (plus two), and the sector
      // finder only for patterns within two rows or columns of the grid (some junctions missed,
      // or extra ones from the background, see `holds`).
      // Across gaps on a rig with posts, a grid under half the pattern may be one side of a
      // post's band (the rest beyond it, often another region): GridFromJunctions asks for half
      // in plain sight after taking the junctions across. (On the demo's rig without posts this
      // found a ring-2 board directly that guided detection gave before, one corner apart.)
      const bool beside_posts = finder == kAcross && model.params().mount.present && grid_by_gap();
      if (!matches(t) && ((!beside_posts && 2 * grid.count < n) || !holds(t))) continue;
      if (finder == kSector && !matches(t) && !near(t, 2)) continue;
      // Too few saddles for the pattern, unless half its junctions already form a grid it holds
      // (an underexposed, vignetted board loses a third of its saddles under the threshold:
      // the harsh preset's 0.55 m board at 1280x960; the classic finder reads its squares).
      if (!beside_posts && n > 1.3 * region.saddles + 2 && 2 * grid.count < n) continue;
      // Stop at the number of boards the region's saddle points allow (boards bring some extra
      // saddles at their sheet edges).
      const int expected = std::clamp(static_cast<int>(region.saddles / (1.5 * n) + 0.5), 1,
                                      options.max_boards_per_region);
      trace::Line("  search %s %dx%d",
                  finder == kClassic     ? "classic"
                  : finder == kJunctions ? "junctions"
                  : finder == kSector    ? "sector"
                                         : "junctions across gaps",
                  spec.rows, spec.cols);
      while (found_here < expected) {
        std::vector<cv::Point2f> corners;
        std::vector<bool> filled;
        if (finder == kJunctions) {
          // Junctions are in view pixels; the crop's origin is added back in MakeBoard.
          if (found_here > 0 ||
              !GridFromJunctions(view, trusted, grid, region.spacing, spec.rows, spec.cols, nullptr, &corners,
                                 &filled)) {
            break;
          }
          for (auto& c : corners) c -= cv::Point2f(region.full.tl());
        } else if (finder == kAcross) {
          // A grid larger than the pattern: without its points on the ring's rim band (a junk row).
          const bool fits = GridFitsInPattern(grid, spec.rows, spec.cols, 0);
          const GridExtent placed = fits ? grid : TrustedPart(view, trusted, grid, region.spacing);
          if (found_here > 0 || (fits && grid.count >= n) ||
              !GridFromJunctions(view, trusted, placed, region.spacing, spec.rows, spec.cols, junction_gaps(),
                                 &corners, &filled)) {
            break;
          }
          // With its rows or columns hidden, the grid may be part of another of the session's
          // patterns just as well (a 3x6 grid: a 3x8 board two columns short, a 5x6 one two rows
          // short; post_sessions' 1mp_webcam_plain_4light 0002 took the 3x8 board's corners as the
          // 5x6's): ambiguous, refused.
          const bool elsewhere = std::any_of(patterns.begin(), patterns.end(), [&](int p) {
            const TargetSpec& other = targets[p];
            if (other.rows == spec.rows && other.cols == spec.cols) return false;
            std::vector<cv::Point2f> other_corners;
            std::vector<bool> other_filled;
            int held = 0;
            const bool fits_other = GridFitsInPattern(grid, other.rows, other.cols, 0);
            GridFromJunctions(view, trusted, fits_other ? grid : TrustedPart(view, trusted, grid, region.spacing),
                              region.spacing, other.rows, other.cols, junction_gaps(), &other_corners,
                              &other_filled, &held);
            return held > 0;
          });
          if (elsewhere) {
            trace::Line("   the grid fits another pattern too: ambiguous");
            break;
          }
          for (auto& c : corners) c -= cv::Point2f(region.full.tl());
        } else if (!FindGrid(crop, spec, finder == kClassic ? 0 : 1, &corners)) {
          trace::Line("   the finder found no grid in the %dx%d crop", crop.cols, crop.rows);
          break;
        }
        std::optional<BoardDetection> board =
            MakeBoard(raw_grey, view, trusted, model, spec, region, corners, filled, options);
        // A grid the classic finder or the junctions got wrong (refused: mis-ordered, not a
        // whole board) is left for the next finder; one the sector finder got wrong is hidden
        // and counted so that it is not found again.
        if (!board && finder != kSector) break;
        ++found_here;
        // Hide this grid from the next search in the region.
        std::vector<cv::Point> pts, hull;
        for (const auto& c : corners) pts.emplace_back(cvRound(c.x), cvRound(c.y));
        cv::convexHull(pts, hull);
        cv::fillConvexPoly(crop, hull, cv::Scalar(128));
        cv::polylines(crop, hull, true, cv::Scalar(128),
                      std::max(3, static_cast<int>(2.5 * region.spacing)));
        if (!board) continue;
        board->target = t;
        found.push_back(std::move(*board));
      }
    }
  }
  return found;
}

}  // namespace

std::vector<BoardDetection> DropRepeatedPlacements(std::vector<BoardDetection> kept,
                                                   const std::vector<TargetSpec>& targets,
                                                   std::vector<int>* repeated_sheets) {
  // A sheet shows each of its corners once per ring: a smaller placement that repeats ids of a
  // larger one, beyond the number of sheets printed with the pattern, is a false board (a partial
  // grid of junctions on a Kalibr grid's corner squares next to the true board: hid3 0003, 4
  // corners 60-100 px off). Parts of one board with no id in common (an occluder between them)
  // both stay.
  std::stable_sort(kept.begin(), kept.end(), [](const BoardDetection& a, const BoardDetection& b) {
    return a.ids.size() > b.ids.size();
  });
  std::vector<BoardDetection> placed;
  for (auto& b : kept) {
    int sheets = 0, repeated = 0;
    for (const TargetSpec& t : targets) {
      sheets += t.type == TargetType::kChessboard && t.rows == targets[b.target].rows &&
                t.cols == targets[b.target].cols;
    }
    for (const auto& k : placed) {
      if (k.target != b.target || k.mirror != b.mirror) continue;
      repeated += std::any_of(b.ids.begin(), b.ids.end(), [&](int id) {
        return std::find(k.ids.begin(), k.ids.end(), id) != k.ids.end();
      });
    }
    if (repeated < sheets) {
      placed.push_back(std::move(b));
    } else if (repeated_sheets &&
               2 * b.ids.size() >= static_cast<size_t>(targets[b.target].rows * targets[b.target].cols)) {
      repeated_sheets->push_back(b.target);
    }
  }
  return placed;
}

void SpreadCopiesOverTheirTargets(const RigModel& model, const std::vector<TargetSpec>& targets,
                                  std::vector<BoardDetection>* boards) {
  // The azimuth (about C's z) of a copy's mean ray direction; NaN where no corner unprojects.
  const auto azimuth = [&](const BoardDetection& b) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Eigen::Vector2d& px : b.raw_pixels) {
      if (const auto ray = model.Unproject(px)) sum += ray->ray.direction;
    }
    return sum.head<2>().norm() > 0 ? std::atan2(sum.y(), sum.x()) : std::nan("");
  };
  const auto angle_between = [](double a, double b) {
    return std::abs(std::remainder(a - b, 2 * M_PI));
  };
  for (size_t first = 0; first < targets.size(); ++first) {
    const TargetSpec& spec = targets[first];
    if (spec.type != TargetType::kChessboard) continue;
    std::vector<int> siblings;  // the targets printed with this pattern, the first first
    for (size_t t = 0; t < targets.size(); ++t) {
      if (targets[t].type == TargetType::kChessboard && targets[t].rows == spec.rows &&
          targets[t].cols == spec.cols) {
        siblings.push_back(static_cast<int>(t));
      }
    }
    if (siblings.size() < 2 || siblings[0] != static_cast<int>(first)) continue;
    // Ring 1's copies in order of azimuth take the siblings in turn; each of ring 2's copies
    // takes the target of ring 1's copy nearest in azimuth not yet paired, else the next free.
    std::vector<std::pair<double, BoardDetection*>> ring[2];
    for (BoardDetection& b : *boards) {
      if (b.target == static_cast<int>(first)) ring[MirrorIndex(b.mirror) - 1].emplace_back(azimuth(b), &b);
    }
    std::sort(ring[0].begin(), ring[0].end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    size_t next = 0;
    std::vector<std::pair<double, int>> taken;  // (azimuth, target) of ring 1's copies
    for (auto& [az, b] : ring[0]) {
      if (next >= siblings.size()) break;
      b->target = siblings[next++];
      taken.emplace_back(az, b->target);
    }
    std::vector<bool> paired(taken.size(), false);
    for (auto& [az, b] : ring[1]) {
      int best = -1;
      for (size_t k = 0; k < taken.size(); ++k) {
        if (paired[k] || std::isnan(az) || std::isnan(taken[k].first)) continue;
        if (best < 0 || angle_between(az, taken[k].first) < angle_between(az, taken[best].first)) {
          best = static_cast<int>(k);
        }
      }
      if (best >= 0) {
        paired[best] = true;
        b->target = taken[best].second;
      } else if (next < siblings.size()) {
        b->target = siblings[next++];
      }
    }
  }
}

std::string ChessboardOptions::Check() const {
  if (!(saddle_sigma > 0)) return OptionError("saddle_sigma", "a smoothing > 0 view px", saddle_sigma);
  if (!(saddle_balance > 0)) return OptionError("saddle_balance", "a ratio > 0", saddle_balance);
  if (!(saddle_relative_contrast >= 0)) {
    return OptionError("saddle_relative_contrast", "a fraction >= 0", saddle_relative_contrast);
  }
  if (!(saddle_contrast_floor > 0)) return OptionError("saddle_contrast_floor", "grey levels > 0", saddle_contrast_floor);
  if (min_saddles < 1) return OptionError("min_saddles", "at least 1", min_saddles);
  if (max_boards_per_region < 1) return OptionError("max_boards_per_region", "at least 1", max_boards_per_region);
  if (!(edge_margin_rad >= 0)) return OptionError("edge_margin_rad", "an angle >= 0 rad", edge_margin_rad);
  if (min_clean_half < 1) return OptionError("min_clean_half", "a half-window of at least 1 px", min_clean_half);
  if (!(foreign_edge_slope > 0 && foreign_edge_slope <= 1)) {
    return OptionError("foreign_edge_slope", "a fraction in (0, 1]", foreign_edge_slope);
  }
  if (!(junction_window_squares > 0)) {
    return OptionError("junction_window_squares", "a half-window > 0 squares", junction_window_squares);
  }
  if (!(max_refine_shift_px > 0)) return OptionError("max_refine_shift_px", "a shift > 0 px", max_refine_shift_px);
  if (!(max_refine_shift_squares > 0)) {
    return OptionError("max_refine_shift_squares", "a shift > 0 squares", max_refine_shift_squares);
  }
  if (!(max_grid_ransac_squares > 0)) {
    return OptionError("max_grid_ransac_squares", "a tolerance > 0 squares", max_grid_ransac_squares);
  }
  if (!(max_grid_residual_squares >= 0)) {
    return OptionError("max_grid_residual_squares", "a tolerance >= 0 squares", max_grid_residual_squares);
  }
  if (!(max_grid_residual_px > 0)) {
    return OptionError("max_grid_residual_px", "a tolerance > 0 px", max_grid_residual_px);
  }
  if (!(min_grid_inlier_fraction >= 0 && min_grid_inlier_fraction <= 1)) {
    return OptionError("min_grid_inlier_fraction", "a fraction in [0, 1]", min_grid_inlier_fraction);
  }
  return "";
}

std::vector<BoardDetection> DetectChessboardBoards(const cv::Mat& raw_grey,
                                                   const std::vector<RingView>& views,
                                                   const RigModel& model,
                                                   const std::vector<TargetSpec>& targets,
                                                   const ChessboardOptions& options,
                                                   std::vector<int>* repeated) {
  if (const std::string error = options.Check(); !error.empty()) throw std::invalid_argument(error);
  // Distinct patterns, larger first (a smaller pattern must not claim part of a larger board).
  std::vector<int> patterns;
  for (size_t t = 0; t < targets.size(); ++t) {
    if (targets[t].type != TargetType::kChessboard) continue;
    bool seen = false;
    for (int p : patterns) {
      seen = seen || (targets[p].rows == targets[t].rows && targets[p].cols == targets[t].cols);
    }
    if (!seen) patterns.push_back(static_cast<int>(t));
  }
  std::sort(patterns.begin(), patterns.end(), [&](int a, int b) {
    return targets[a].rows * targets[a].cols > targets[b].rows * targets[b].cols;
  });
  std::vector<BoardDetection> boards;
  if (patterns.empty()) return boards;

  trace::NextImage();
  for (size_t vi = 0; vi < views.size(); ++vi) {
    const RingView& view = views[vi];
    const cv::Mat in_ring = RingPixels(view, 0), trusted = RingPixels(view, options.edge_margin_rad);
    const std::vector<cv::Point2f> saddles = SaddlePoints(view, Saddles(options));
    const std::vector<Region> regions = Regions(saddles, view.image.size(), Saddles(options), view.f);
    if (trace::On()) {
      std::vector<cv::Rect> boxes;
      for (const Region& r : regions) boxes.push_back(r.rect);
      trace::Line("view %zu (ring %d, azimuth %.0f deg, %dx%d, blur %.2f): %zu saddles, %zu regions", vi,
                  MirrorIndex(view.mirror), view.azimuth * 180 / M_PI, view.width, view.height,
                  view.blur_sigma.value_or(-1), saddles.size(), regions.size());
      trace::View(static_cast<int>(vi), view.image, saddles, boxes);
    }
    for (const Region& region : regions) {
      if (BetterInNeighbour(view, region.rect, view.sectors)) {
        trace::Line(" region %d,%d %dx%d: better in the neighbouring view", region.rect.x, region.rect.y,
                    region.rect.width, region.rect.height);
        continue;
      }
      for (BoardDetection& board : SearchRegion(raw_grey, view, in_ring, trusted, model, targets, patterns, region, saddles,
                                                view.sectors, options, static_cast<int>(vi))) {
        board.view = static_cast<int>(vi);
        boards.push_back(std::move(board));
      }
    }
  }

  // One board seen in two overlapping views: keep the view it is most central in. A smaller
  // pattern found on corners of a larger one (a sub-grid, e.g. where the larger board runs out
  // of one view) is dropped whatever its view: larger patterns first.
  std::sort(boards.begin(), boards.end(), [&](const BoardDetection& a, const BoardDetection& b) {
    const size_t na = a.ids.size() > 0 ? targets[a.target].rows * targets[a.target].cols : 0;
    const size_t nb = b.ids.size() > 0 ? targets[b.target].rows * targets[b.target].cols : 0;
    return na != nb ? na > nb : a.off_centre < b.off_centre;
  });
  std::vector<BoardDetection> kept;
  for (auto& b : boards) {
    bool duplicate = false;
    for (const auto& k : kept) {
      if (k.mirror != b.mirror) continue;
      for (size_t i = 0; i < b.ids.size() && !duplicate; ++i) {
        for (size_t j = 0; j < k.ids.size(); ++j) {
          if ((b.raw_pixels[i] - k.raw_pixels[j]).norm() < 2.0) {
            duplicate = true;
            break;
          }
        }
      }
      if (duplicate) break;
    }
    if (!duplicate) kept.push_back(std::move(b));
  }
  std::vector<BoardDetection> placed = DropRepeatedPlacements(std::move(kept), targets, repeated);
  SpreadCopiesOverTheirTargets(model, targets, &placed);
  return placed;
}

std::vector<CornerObservation> DetectChessboards(const cv::Mat& raw_grey,
                                                     const std::vector<RingView>& views,
                                                     const RigModel& model,
                                                     const std::vector<TargetSpec>& targets,
                                                     const ChessboardOptions& options,
                                                     std::vector<int>* repeated) {
  std::vector<CornerObservation> out;
  for (const BoardDetection& b :
       DetectChessboardBoards(raw_grey, views, model, targets, options, repeated)) {
    for (size_t i = 0; i < b.ids.size(); ++i) {
      CornerObservation o;
      o.target = b.target;
      o.id = b.ids[i];
      o.mirror = b.mirror;
      o.pixel = b.raw_pixels[i];
      out.push_back(o);
    }
  }
  return out;
}

}  // namespace omni::detectors



