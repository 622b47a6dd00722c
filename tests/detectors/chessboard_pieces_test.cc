// Pieces of the chessboard detector on drawn boards whose corners are known: the region's crop
// (region_crop.h: padded with the paper's white, never the finders' binarisation level), the
// pattern gate (junction_grid.h: a 6x8 board read with junk rows and columns is still searched
// as 6x8), a narrow board one row short, a board crossed by a post's band, an ambiguous
// partial grid, a grid two patterns hold and a junk row on the rim band (junction_board.h
// GridFromJunctions, TrustedPart).
#include <algorithm>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/chessboard/junction_board.h"
#include "detectors/chessboard/junction_grid.h"
#include "detectors/chessboard/region_crop.h"

namespace omni::detectors {
namespace {

// An axis-aligned rows x cols inner-corner board (first inner corner at `first`, squares of
// `side` px, squares 30 / 220) on a sheet with a `margin` px white border, `background` beyond;
// 4 x 4 samples per pixel, then a 0.7 px blur. The inner corners are returned row-major.
cv::Mat DrawBoard(cv::Size size, int rows, int cols, cv::Point2f first, float side, float margin, int background,
                  std::vector<cv::Point2f>* corners) {
  const auto value = [&](float x, float y) {
    const float a = (x - first.x) / side + 1, b = (y - first.y) / side + 1;  // square coordinates
    const float m = margin / side;
    if (a < -m || b < -m || a > cols + 1 + m || b > rows + 1 + m) return static_cast<float>(background);
    if (a < 0 || b < 0 || a > cols + 1 || b > rows + 1) return 220.f;
    return (static_cast<int>(a) + static_cast<int>(b)) % 2 == 0 ? 30.f : 220.f;
  };
  cv::Mat image(size, CV_32F);
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      float sum = 0;
      for (int j = 0; j < 4; ++j) {
        for (int i = 0; i < 4; ++i) sum += value(x - 0.375f + 0.25f * i, y - 0.375f + 0.25f * j);
      }
      image.at<float>(y, x) = sum / 16;
    }
  }
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.7);
  cv::Mat out;
  image.convertTo(out, CV_8U);
  corners->clear();
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) corners->push_back(first + cv::Point2f(c * side, r * side));
  }
  return out;
}

// A view of the drawn image whose ring ends at column `ring_end` (the map is -1 beyond, the
// view's pixels black there, as RenderViews leaves them).
RingView ViewOf(const cv::Mat& image, int ring_end) {
  RingView view;
  view.width = image.cols;
  view.height = image.rows;
  view.image = image.clone();
  view.map_x.create(image.size(), CV_32F);
  view.map_y.create(image.size(), CV_32F);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const bool in = x < ring_end;
      view.map_x.at<float>(y, x) = in ? static_cast<float>(x) : -1.f;
      view.map_y.at<float>(y, x) = in ? static_cast<float>(y) : -1.f;
      if (!in) view.image.at<uchar>(y, x) = 0;
    }
  }
  return view;
}

// The region's box runs off the view (top and right) and the ring's edge cuts the sheet's white
// margin: every pixel the crop adds or replaces is the paper's white (220 drawn), not mid grey,
// and the classic finder reads the board in the crop at its drawn corners.
TEST(RegionCropTest, PaddedWithThePapersWhite) {
  std::vector<cv::Point2f> corners;
  const cv::Mat image = DrawBoard({160, 120}, 4, 5, {46, 42}, 12, 6, 60, &corners);
  const int ring_end = 113;  // the sheet's right margin spans 106-118
  const RingView view = ViewOf(image, ring_end);
  const cv::Rect full(20, -12, 150, 130);
  const cv::Mat crop = RegionCrop(view, full);
  ASSERT_EQ(crop.size(), full.size());
  int padded = 0;
  for (int y = 0; y < crop.rows; ++y) {
    for (int x = 0; x < crop.cols; ++x) {
      const int vx = x + full.x, vy = y + full.y;
      const bool outside = vx < 0 || vy < 0 || vx >= view.width || vy >= view.height || vx >= ring_end;
      if (!outside) {
        EXPECT_EQ(crop.at<uchar>(y, x), view.image.at<uchar>(vy, vx));
        continue;
      }
      ++padded;
      ASSERT_NEAR(crop.at<uchar>(y, x), 220, 3) << "at view " << vx << "," << vy;
    }
  }
  EXPECT_GT(padded, 2000);
  std::vector<cv::Point2f> found;
  ASSERT_TRUE(cv::findChessboardCorners(crop, cv::Size(5, 4), found,
                                        cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE));
  for (const cv::Point2f& f : found) {
    double nearest = 1e9;
    for (const cv::Point2f& c : corners) nearest = std::min(nearest, cv::norm(f + cv::Point2f(full.tl()) - c));
    EXPECT_LT(nearest, 0.6);
  }
}

// X-junctions among the lattice points of a drawn board, one step beyond each side included.
std::vector<cv::Point2f> Junctions(const RingView& view, const cv::Mat& in_ring, int rows, int cols,
                                   cv::Point2f first, float side) {
  std::vector<cv::Point2f> out;
  for (int r = -1; r <= rows; ++r) {
    for (int c = -1; c <= cols; ++c) {
      const cv::Point2f p = first + cv::Point2f(c * side, r * side);
      if (IsXJunction(view, in_ring, p, 0.35 * side, 10).value_or(false)) out.push_back(p);
    }
  }
  return out;
}

// A 6x8 board on a sheet with a narrow white margin (0.2 squares) against a dark background: its
// outer squares' corners read as X-junctions, so its junction grid has junk rows and columns
// beyond the board (Mei's photo 1: 8x10). The gate still searches the 6x8 pattern in it, and
// would not a pattern the grid cannot be (two rows or columns short).
TEST(PatternGateTest, AGridWithJunkRowsStillSearchesItsPattern) {
  std::vector<cv::Point2f> corners;
  const float side = 14;
  const cv::Point2f first(40, 36);
  const cv::Mat image = DrawBoard({200, 160}, 6, 8, first, side, 0.2f * side, 20, &corners);
  const RingView view = ViewOf(image, image.cols);
  const cv::Mat in_ring(image.size(), CV_8U, cv::Scalar(255));
  const std::vector<cv::Point2f> junctions = Junctions(view, in_ring, 6, 8, first, side);
  const GridExtent grid = MeasureGrid(image, junctions, side, 10);
  // The drawing reproduces the junk: more than the board's 48 junctions, and a grid larger than
  // 6x8 that holds every inner corner.
  ASSERT_GT(static_cast<int>(junctions.size()), 48);
  ASSERT_GT(grid.a * grid.b, 48) << grid.a << "x" << grid.b;
  for (const cv::Point2f& c : corners) {
    EXPECT_TRUE(std::any_of(grid.points.begin(), grid.points.end(),
                            [&](const cv::Point2f& p) { return cv::norm(p - c) < 0.01; }));
  }
  EXPECT_FALSE(GridNearPattern(grid, 6, 8, 0));
  EXPECT_TRUE(GridFitsInPattern(grid, 6, 8, 2)) << grid.a << "x" << grid.b;
  EXPECT_TRUE(GridFitsInPattern(grid, 8, 6, 2));  // either way round
  EXPECT_FALSE(GridFitsInPattern(grid, 4, 6, 2));
  EXPECT_LE(PatternDistance(grid, 6, 8), 4);
  std::printf("%zu junctions, grid %dx%d (%d)\n", junctions.size(), grid.a, grid.b, grid.count);
}

// A 3x10 board whose top row of corners lies on the ring's edge: 20 of its 30 junctions, the
// missing row hidden (its circles leave the trusted pixels). It is taken as the board (all but
// its longest row), the hidden row filled at the homography's prediction of the drawn corners.
TEST(GridFromJunctionsTest, ANarrowBoardOneRowShort) {
  std::vector<cv::Point2f> corners;
  const float side = 14;
  const cv::Point2f first(30, 20);
  const cv::Mat image = DrawBoard({220, 120}, 3, 10, first, side, 6, 90, &corners);
  // Trusted pixels: below the first row (y = 20) by 3 px only.
  cv::Mat trusted(image.size(), CV_8U, cv::Scalar(255));
  trusted.rowRange(0, 23).setTo(0);
  const RingView view = ViewOf(image, image.cols);
  std::vector<cv::Point2f> seen;
  for (int k = 10; k < 30; ++k) seen.push_back(corners[k]);
  const GridExtent grid = MeasureGrid(image, seen, side, 10);
  ASSERT_EQ(grid.count, 20);
  std::vector<cv::Point2f> out;
  std::vector<bool> filled;
  ASSERT_TRUE(GridFromJunctions(view, trusted, grid, side, 3, 10, nullptr, &out, &filled));
  ASSERT_EQ(out.size(), 30u);
  EXPECT_EQ(std::count(filled.begin(), filled.end(), true), 10);
  // The grid's order is its own (ids are Orient's); each point must be a drawn corner.
  for (const cv::Point2f& p : out) {
    double nearest = 1e9;
    for (const cv::Point2f& c : corners) nearest = std::min(nearest, cv::norm(p - c));
    EXPECT_LT(nearest, 0.05);
  }
  // Shown whole (the ring not cutting it), the missing row is in plain sight: refused. Across
  // gaps (JunctionGaps), its corners are X-junctions at their predictions: taken, none filled;
  // hidden by an occluder instead (a grey patch over the row) it is refused there too.
  const cv::Mat all(image.size(), CV_8U, cv::Scalar(255));
  EXPECT_FALSE(GridFromJunctions(view, all, grid, side, 3, 10, nullptr, &out, &filled));
  const JunctionGaps gaps;
  ASSERT_TRUE(GridFromJunctions(view, all, grid, side, 3, 10, &gaps, &out, &filled));
  EXPECT_EQ(std::count(filled.begin(), filled.end(), true), 0);
  RingView occluded = view;
  occluded.image = view.image.clone();
  occluded.image(cv::Rect(0, 10, image.cols, 17)).setTo(128);
  EXPECT_FALSE(GridFromJunctions(occluded, all, grid, side, 3, 10, &gaps, &out, &filled));
}

// A post of the mount crossing a 3x8 board: the view's map is -1 over the post's band (as
// RigModel's projection blocks a path through a post), columns 2-3 of the corners lie in it and
// column 1's circles reach its margin. The junctions right of the band form the grid (3x4);
// column 0's three, left of it, are loose. The one placement whose missing corners are all hidden
// takes the loose junctions across the band (at the homography's prediction): 15 corners at the
// drawn ones, the 9 of columns 1-3 filled (never reported).
TEST(GridFromJunctionsTest, ABoardCrossedByAPostIsFitAcrossTheBand) {
  std::vector<cv::Point2f> corners;
  const float side = 14;
  const cv::Point2f first(30, 30);
  cv::Mat image = DrawBoard({200, 100}, 3, 8, first, side, 6, 90, &corners);
  // The band: x in [first.x + 1.5 side, first.x + 3.5 side) = [51, 79), black like RenderViews
  // leaves invalid pixels; trusted pixels 3 px clear of it (the edge margin). Corners: x = 30 + 14 col.
  RingView view = ViewOf(image, image.cols);
  cv::Mat trusted(image.size(), CV_8U, cv::Scalar(255));
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 51; x < 79; ++x) {
      view.map_x.at<float>(y, x) = view.map_y.at<float>(y, x) = -1.f;
      view.image.at<uchar>(y, x) = 0;
    }
  }
  trusted.colRange(48, 82).setTo(0);
  std::vector<cv::Point2f> right, left;
  for (int k = 0; k < 24; ++k) {
    if (k % 8 >= 4) right.push_back(corners[k]);
    if (k % 8 == 0) left.push_back(corners[k]);
  }
  const GridExtent grid = MeasureGrid(view.image, right, side, 10);
  ASSERT_EQ(grid.count, 12);
  std::vector<cv::Point2f> out;
  std::vector<bool> filled;
  JunctionGaps gaps;
  gaps.loose = left;
  // One column short at most, without gaps: refused.
  EXPECT_FALSE(GridFromJunctions(view, trusted, grid, side, 3, 8, nullptr, &out, &filled));
  ASSERT_TRUE(GridFromJunctions(view, trusted, grid, side, 3, 8, &gaps, &out, &filled));
  ASSERT_EQ(out.size(), 24u);
  int seen = 0;
  for (size_t k = 0; k < out.size(); ++k) {
    double nearest = 1e9;
    int at = -1;
    for (size_t c = 0; c < corners.size(); ++c) {
      if (cv::norm(out[k] - corners[c]) < nearest) {
        nearest = cv::norm(out[k] - corners[c]);
        at = static_cast<int>(c);
      }
    }
    EXPECT_LT(nearest, 0.05) << k;
    const bool in_band = at % 8 == 1 || at % 8 == 2 || at % 8 == 3;
    // Column 1 (x = 44) is 7 px from the band: its 0.35-square circle reaches the margin, hidden
    // like the band's own columns.
    EXPECT_EQ(filled[k], in_band) << "corner " << at;
    seen += filled[k] ? 0 : 1;
  }
  EXPECT_EQ(seen, 15);
  // Column 0 covered (an occluder, not the post: a grey patch): in plain sight with no junction,
  // the board is refused.
  RingView occluded = view;
  occluded.image = view.image.clone();
  occluded.image(cv::Rect(22, 0, 16, image.rows)).setTo(128);
  const JunctionGaps no_loose;  // the saddle detector would not find column 0 there either
  EXPECT_FALSE(GridFromJunctions(occluded, trusted, grid, side, 3, 8, &no_loose, &out, &filled));
}

// A 3x10 board whose two end columns on each side are hidden (the trusted pixels stop short of
// columns 2 and 7): the 3x6 grid of its middle fits the pattern in five places whose missing
// corners are all hidden, so its ids are ambiguous and it is refused.
TEST(GridFromJunctionsTest, AGridThatFitsSeveralWaysIsRefused) {
  std::vector<cv::Point2f> corners;
  const float side = 14;
  const cv::Point2f first(30, 30);
  const cv::Mat image = DrawBoard({220, 100}, 3, 10, first, side, 6, 90, &corners);
  const RingView view = ViewOf(image, image.cols);
  cv::Mat trusted(image.size(), CV_8U, cv::Scalar(255));
  // Corners at x = 30 + 14 col, circles of 4.9 px: columns 0-1 and 8-9 (and beyond) hidden.
  trusted.colRange(0, 68).setTo(0);
  trusted.colRange(140, 220).setTo(0);
  std::vector<cv::Point2f> middle;
  for (int k = 0; k < 30; ++k) {
    if (k % 10 >= 2 && k % 10 <= 7) middle.push_back(corners[k]);
  }
  const GridExtent grid = MeasureGrid(image, middle, side, 10);
  ASSERT_EQ(grid.count, 18);
  std::vector<cv::Point2f> out;
  std::vector<bool> filled;
  const JunctionGaps gaps;
  EXPECT_FALSE(GridFromJunctions(view, trusted, grid, side, 3, 10, &gaps, &out, &filled));
  // One end in plain sight (the right one trusted): one placement, the board is taken.
  cv::Mat one_end = trusted.clone();
  one_end.colRange(140, 220).setTo(255);
  std::vector<cv::Point2f> with_right = middle;
  for (int k = 0; k < 30; ++k) {
    if (k % 10 >= 8) with_right.push_back(corners[k]);
  }
  ASSERT_TRUE(GridFromJunctions(view, one_end, MeasureGrid(image, with_right, side, 10), side, 3, 10, &gaps,
                                &out, &filled));
  EXPECT_EQ(std::count(filled.begin(), filled.end(), true), 6);
}

// A 3x10 board whose squares touch the ring's dark rim band above its first row: the band beside
// those squares reads as a junk row of X-junctions, and the grid (10x4) fits no placement in
// the pattern. Its trusted part (TrustedPart: circles inside the trusted pixels) drops the junk
// row and the first row, whose circles reach the band too; across gaps the two rows left are
// placed where the missing row is hidden: the board, its first row filled.
TEST(GridFromJunctionsTest, AJunkRowOnTheRimBandIsLeftOut) {
  std::vector<cv::Point2f> corners;
  const float side = 14;
  const cv::Point2f first(30, 20);
  const cv::Mat image = DrawBoard({220, 120}, 3, 10, first, side, 6, 90, &corners);
  cv::Mat trusted(image.size(), CV_8U, cv::Scalar(255));
  trusted.rowRange(0, 23).setTo(0);
  const RingView view = ViewOf(image, image.cols);
  GridExtent grid;
  grid.a = 10;
  grid.b = 4;
  for (int c = 0; c < 10; ++c) {  // the junk row, one step above the first
    grid.points.push_back(corners[c] - cv::Point2f(0, side));
    grid.coords.emplace_back(c, 0);
  }
  for (int k = 0; k < 30; ++k) {
    grid.points.push_back(corners[k]);
    grid.coords.emplace_back(k % 10, k / 10 + 1);
  }
  grid.count = static_cast<int>(grid.points.size());
  std::vector<cv::Point2f> out;
  std::vector<bool> filled;
  const JunctionGaps gaps;
  EXPECT_FALSE(GridFromJunctions(view, trusted, grid, side, 3, 10, &gaps, &out, &filled));
  const GridExtent part = TrustedPart(view, trusted, grid, side);
  ASSERT_EQ(part.count, 20);
  EXPECT_EQ(part.a, 10);
  EXPECT_EQ(part.b, 2);
  ASSERT_TRUE(GridFromJunctions(view, trusted, part, side, 3, 10, &gaps, &out, &filled));
  ASSERT_EQ(out.size(), 30u);
  for (size_t k = 0; k < out.size(); ++k) {
    EXPECT_LT(cv::norm(out[k] - corners[k]), 0.05) << k;
    EXPECT_EQ(filled[k], k < 10) << k;
  }
}

// A 3x8 board whose two right columns are hidden and whose top lies at the ring's edge: its
// 3x6 grid holds one placement in the 3x8 pattern (the two columns hidden) and one in a 5x6
// pattern (two rows hidden above it). In a session with both patterns the detector refuses such
// a grid (chessboard_detector.cc, the search across gaps): GridFromJunctions counts the
// placements each pattern holds.
TEST(GridFromJunctionsTest, AGridTwoPatternsHoldCountsForBoth) {
  std::vector<cv::Point2f> corners;
  const float side = 14;
  const cv::Mat image = DrawBoard({220, 120}, 3, 8, {30, 50}, side, 6, 90, &corners);
  const RingView view = ViewOf(image, image.cols);
  cv::Mat trusted(image.size(), CV_8U, cv::Scalar(255));
  trusted.rowRange(0, 45).setTo(0);     // rows above y = 50 hidden
  trusted.colRange(110, 220).setTo(0);  // columns 6-7 (x = 114, 128) hidden
  std::vector<cv::Point2f> seen;
  for (int k = 0; k < 24; ++k) {
    if (k % 8 <= 5) seen.push_back(corners[k]);
  }
  const GridExtent grid = MeasureGrid(image, seen, side, 10);
  ASSERT_EQ(grid.count, 18);
  std::vector<cv::Point2f> out;
  std::vector<bool> filled;
  const JunctionGaps gaps;
  int placements = 0;
  EXPECT_TRUE(GridFromJunctions(view, trusted, grid, side, 3, 8, &gaps, &out, &filled, &placements));
  EXPECT_EQ(placements, 1);
  EXPECT_TRUE(GridFromJunctions(view, trusted, grid, side, 5, 6, &gaps, &out, &filled, &placements));
  EXPECT_EQ(placements, 1);
  // With the rows above in plain sight, the 5x6 pattern holds none.
  trusted.rowRange(0, 45).setTo(255);
  EXPECT_FALSE(GridFromJunctions(view, trusted, grid, side, 5, 6, &gaps, &out, &filled, &placements));
  EXPECT_EQ(placements, 0);
}

}  // namespace
}  // namespace omni::detectors
