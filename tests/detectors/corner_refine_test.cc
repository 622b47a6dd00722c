// The curvature-bias correction of the raw corner refinement (detectors/common/corner_refine.h) against
// an independent oracle: chessboards seen through a strong analytic radial warp (their rows and
// columns image as curves, as through the mirrors), every pixel box-filtered exactly (8 x 8
// sub-pixel samples of the warp where an edge crosses it), the true corners by Newton's method
// on the warp. Plain cornerSubPix shows the outward shift away from the centres of curvature;
// the corrected corners must not.
#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/common/corner_refine.h"
#include "io/image_file.h"

namespace omni::detectors {
namespace {

constexpr int kRows = 6, kCols = 7;
constexpr double kSide = 10.0;  // px, about the square side of the rig's rings at 1-1.5 m

// Board coordinates (squares; corner (r, c) at (c, r)) <-> pixels by a polar warp: the board,
// turned by `angle` about its middle, is wrapped around the image centre with its middle at
// radius kRadius (its local x along the circle, y outwards, scale kept there), so that its rows
// and columns image as spirals with radii of curvature ~kRadius and more, as through the
// mirrors (the inner ring's lines have radii of the order of 150-400 px).
constexpr double kRadius = 150.0;  // px
struct Warp {
  Eigen::Vector2d centre{320, 240};
  double angle = 0, azimuth = 0;
  double side = kSide;  // px
  bool curved = true;  // false: the same board placed by a rotation only (straight lines)
  Eigen::Vector2d middle{(kCols - 1) / 2.0, (kRows - 1) / 2.0};

  Eigen::Vector2d BoardOf(const Eigen::Vector2d& pixel) const {
    const Eigen::Vector2d d = pixel - centre;
    if (!curved) {
      const Eigen::Vector2d local = Eigen::Rotation2Dd(-azimuth) * d - Eigen::Vector2d(kRadius, 0);
      return Eigen::Rotation2Dd(-angle) * Eigen::Vector2d(local.y(), local.x()) / side + middle;
    }
    const double phi = std::remainder(std::atan2(d.y(), d.x()) - azimuth, 2 * M_PI);
    const Eigen::Vector2d local(phi * kRadius / side, (d.norm() - kRadius) / side);
    return Eigen::Rotation2Dd(-angle) * local + middle;
  }
  Eigen::Vector2d PixelOf(const Eigen::Vector2d& board) const {
    const Eigen::Vector2d local = Eigen::Rotation2Dd(angle) * (board - middle);
    if (!curved) {
      return centre + Eigen::Rotation2Dd(azimuth) * (Eigen::Vector2d(kRadius, 0) + side * Eigen::Vector2d(local.y(), local.x()));
    }
    const double rho = kRadius + local.y() * side, phi = azimuth + local.x() * side / kRadius;
    return centre + rho * Eigen::Vector2d(std::cos(phi), std::sin(phi));
  }
};

// Exact box-filtered checkerboard (the board's squares from -1 to kCols x kRows, white around).
void DrawBoard(const Warp& warp, cv::Mat* image) {
  const auto value = [&](const Eigen::Vector2d& p) {
    const Eigen::Vector2d b = warp.BoardOf(p);
    if (b.x() < -1 || b.y() < -1 || b.x() > kCols || b.y() > kRows) return 1;
    return static_cast<int>((static_cast<long>(std::floor(b.x())) + static_cast<long>(std::floor(b.y()))) & 1);
  };
  for (int v = 0; v < image->rows; ++v) {
    for (int u = 0; u < image->cols; ++u) {
      const Eigen::Vector2d b = warp.BoardOf(Eigen::Vector2d(u, v));
      if (b.x() < -2 || b.y() < -2 || b.x() > kCols + 1 || b.y() > kRows + 1) continue;
      // Far from any grid line (in pixels): one colour.
      const double fx = std::abs(b.x() - std::round(b.x())), fy = std::abs(b.y() - std::round(b.y()));
      if (std::min(fx, fy) * warp.side * 0.6 > 1.0) {  // the warp scales squares by 0.7-1.3
        image->at<float>(v, u) = 255.f * value(Eigen::Vector2d(u, v));
        continue;
      }
      int sum = 0;
      for (int a = 0; a < 8; ++a) {
        for (int c = 0; c < 8; ++c) sum += value(Eigen::Vector2d(u - 0.5 + (a + 0.5) / 8, v - 0.5 + (c + 0.5) / 8));
      }
      image->at<float>(v, u) = 255.f * sum / 64;
    }
  }
}

struct Stats {
  double radial = 0, rms = 0;
  int n = 0;
};

// Eight boards around the centre, curved or straight; corners refined from 0.3 px off the truth with
// the detector's window (half = round(0.4 x the local square side)); returns plain and corrected
// statistics, radial taken from the warp's centre.
void Measure(bool curved, Stats* plain, Stats* corrected) {
  for (int k = 0; k < 8; ++k) {
    Warp warp;
    warp.angle = 0.35 + 0.7 * k;
    warp.azimuth = M_PI / 4 * k;
    warp.curved = curved;
    cv::Mat image(480, 640, CV_32F, cv::Scalar(0));
    DrawBoard(warp, &image);
    std::vector<std::optional<Eigen::Vector2d>> refined(kRows * kCols);
    std::vector<Eigen::Vector2d> truth(kRows * kCols);
    for (int id = 0; id < kRows * kCols; ++id) truth[id] = warp.PixelOf(Eigen::Vector2d(id % kCols, id / kCols));
    std::vector<int> halves(kRows * kCols);
    for (int id = 0; id < kRows * kCols; ++id) {
      const int r = id / kCols, c = id % kCols;
      double side = 1e9;
      if (c > 0) side = std::min(side, (truth[id] - truth[id - 1]).norm());
      if (c + 1 < kCols) side = std::min(side, (truth[id] - truth[id + 1]).norm());
      if (r > 0) side = std::min(side, (truth[id] - truth[id - kCols]).norm());
      if (r + 1 < kRows) side = std::min(side, (truth[id] - truth[id + kCols]).norm());
      halves[id] = std::clamp(static_cast<int>(std::lround(0.4 * side)), 1, 6);
      Eigen::Vector2d p = truth[id] + Eigen::Vector2d(0.3, -0.2);
      ASSERT_TRUE(RefineCornerInRaw(image, halves[id], &p));
      refined[id] = p;
    }
    std::vector<std::optional<Eigen::Vector2d>> fixed = refined;
    RemoveCurvatureBias(kRows, kCols, halves, &fixed);
    for (int id = 0; id < kRows * kCols; ++id) {
      const Eigen::Vector2d outward = (truth[id] - warp.centre).normalized();  // from the centres of curvature
      for (auto [stats, p] : {std::pair{plain, refined[id]}, std::pair{corrected, fixed[id]}}) {
        const Eigen::Vector2d e = *p - truth[id];
        stats->radial += e.dot(outward);
        stats->rms += e.squaredNorm();
        ++stats->n;
      }
    }
  }
  for (Stats* s : {plain, corrected}) {
    s->radial /= s->n;
    s->rms = std::sqrt(s->rms / s->n);
  }
}

TEST(CornerRefine, CurvatureBiasRemovedOnCurvedBoards) {
  Stats plain, corrected;
  Measure(true, &plain, &corrected);
  RecordProperty("plain_radial", std::to_string(plain.radial));
  RecordProperty("corrected_radial", std::to_string(corrected.radial));
  std::printf("curved: plain radial %+.4f rms %.4f; corrected radial %+.4f rms %.4f (%d corners)\n",
              plain.radial, plain.rms, corrected.radial, corrected.rms, plain.n);
  // The bias this corrects must be there (else the test could not fail) ...
  EXPECT_GT(std::abs(plain.radial), 0.012);
  // ... and be gone, without scattering the corners more.
  EXPECT_LT(std::abs(corrected.radial), 0.004);
  EXPECT_LT(corrected.rms, plain.rms);
}

// What a colour camera makes of the inner ring's small squares: the exact box-filtered board
// (5 px squares, as ring 2's boards at 0.3-0.45 m and 2-2.5 m), a Gaussian defocus, the RGGB
// mosaic of the neutral board demosaiced edge-aware as the camera's processor does
// (io::DemosaicImage, OpenCV's), back to grey.
cv::Mat CameraImage(const cv::Mat& exact, double blur) {
  cv::Mat blurred, mosaic, grey;
  cv::GaussianBlur(exact, blurred, cv::Size(0, 0), blur);
  blurred.convertTo(mosaic, CV_16U, 257.0);  // a neutral board: every channel alike
  cv::cvtColor(io::DemosaicImage(mosaic, io::BayerPattern::kRGGB, io::Demosaic::kEdgeAware), grey,
               cv::COLOR_BGR2GRAY);
  grey.convertTo(grey, CV_32F, 1.0 / 257.0);
  return grey;
}

// Corners of eight curved boards of `side` px squares refined as the chessboard detector does
// (cornerSubPix, half-window 0.55 squares, from 0.3 px off), then either corrected for the
// curvature bias (RemoveCurvatureBias) or fitted as blurred junctions (FitBoardJunctions).
void MeasureOnCamera(double side, double blur, bool camera, Stats* corrected, Stats* fitted) {
  for (int k = 0; k < 8; ++k) {
    Warp warp;
    warp.angle = 0.35 + 0.7 * k;
    warp.azimuth = M_PI / 4 * k;
    warp.side = side;
    cv::Mat image(480, 640, CV_32F, cv::Scalar(0));
    DrawBoard(warp, &image);
    if (camera) image = CameraImage(image, blur);
    std::vector<Eigen::Vector2d> truth(kRows * kCols);
    for (int id = 0; id < kRows * kCols; ++id) truth[id] = warp.PixelOf(Eigen::Vector2d(id % kCols, id / kCols));
    std::vector<std::optional<Eigen::Vector2d>> refined(kRows * kCols);
    std::vector<int> halves(kRows * kCols);
    std::vector<double> sides(kRows * kCols, 1e9);
    for (int id = 0; id < kRows * kCols; ++id) {
      const int r = id / kCols, c = id % kCols;
      for (auto [dr, dc] : {std::pair{0, 1}, {0, -1}, {1, 0}, {-1, 0}}) {
        if (r + dr < 0 || c + dc < 0 || r + dr >= kRows || c + dc >= kCols) continue;
        sides[id] = std::min(sides[id], (truth[id] - truth[(r + dr) * kCols + c + dc]).norm());
      }
      halves[id] = std::clamp(static_cast<int>(std::lround(0.55 * sides[id])), 2, 8);
      Eigen::Vector2d p = truth[id] + Eigen::Vector2d(0.3, -0.2);
      ASSERT_TRUE(RefineCornerInRaw(image, halves[id], &p));
      refined[id] = p;
    }
    std::vector<std::optional<Eigen::Vector2d>> fixed = refined, fits = refined;
    RemoveCurvatureBias(kRows, kCols, halves, &fixed);
    EXPECT_GE(FitBoardJunctions(image, kRows, kCols, sides, halves, 0.55, &fits), kRows * kCols - 2);
    for (int id = 0; id < kRows * kCols; ++id) {
      // cornerSubPix lost the board's corner corners here (1.2 px, the board's rim in its
      // window): the detector's grid check drops such corners, and neither way can mend them.
      if ((*refined[id] - truth[id]).norm() > 0.5) continue;
      const Eigen::Vector2d outward = (truth[id] - warp.centre).normalized();
      for (auto [stats, p] : {std::pair{corrected, fixed[id]}, std::pair{fitted, fits[id]}}) {
        const Eigen::Vector2d e = *p - truth[id];
        stats->radial += e.dot(outward);
        stats->rms += e.squaredNorm();
        ++stats->n;
      }
    }
  }
  for (Stats* s : {corrected, fitted}) {
    s->radial /= s->n;
    s->rms = std::sqrt(s->rms / s->n);
  }
}

// The inner ring on a realistic camera's images: cornerSubPix reads every gradient's direction,
// and in 5 px squares the demosaicing's errors along the edges and the blur of the neighbouring
// edges turn them (realistic_scene ring 2 chessboards: 0.099 px mean, p99 0.40). The junction
// fit reads the levels.
TEST(CornerRefine, BlurredJunctionFitOnSmallDemosaicedSquares) {
  Stats corrected, fitted;
  MeasureOnCamera(5.0, 1.0, true, &corrected, &fitted);
  std::printf("5 px squares, blur 1 px, RGGB edge-aware: cornerSubPix + curvature radial %+.4f "
              "rms %.4f; junction fit radial %+.4f rms %.4f (%d corners)\n", corrected.radial,
              corrected.rms, fitted.radial, fitted.rms, fitted.n);
  EXPECT_GT(corrected.rms, 0.08);  // what the fit replaces (else the test could not fail)
  EXPECT_LT(fitted.rms, 0.04);
  EXPECT_LT(std::abs(fitted.radial), 0.008);
}

// Sharp exact boards of 10 px squares (the outer ring at 1-1.5 m, clean renders): the fit
// carries the lines' curvature as the correction does and is no worse.
TEST(CornerRefine, BlurredJunctionFitOnSharpCurvedBoards) {
  Stats corrected, fitted;
  MeasureOnCamera(kSide, 0.0, false, &corrected, &fitted);
  std::printf("10 px squares, exact: cornerSubPix + curvature radial %+.4f rms %.4f; junction "
              "fit radial %+.4f rms %.4f\n", corrected.radial, corrected.rms, fitted.radial,
              fitted.rms);
  EXPECT_LT(std::abs(fitted.radial), 0.004);
  EXPECT_LT(fitted.rms, corrected.rms);
}

TEST(CornerRefine, StraightBoardsAreLeftAlone) {
  Stats plain, corrected;
  Measure(false, &plain, &corrected);
  std::printf("straight: plain radial %+.4f rms %.4f; corrected radial %+.4f rms %.4f\n", plain.radial,
              plain.rms, corrected.radial, corrected.rms);
  EXPECT_LT(std::abs(plain.radial), 0.004);
  EXPECT_LT(std::abs(corrected.radial), 0.004);
  EXPECT_LT(corrected.rms, plain.rms + 0.002);
}

TEST(CornerRefine, LinesFromNeighbours) {
  // A circle of radius 200 px through three corners: curvature 1/200 towards its centre, at the
  // middle corner and (one-sided triple) at an end one; a lone neighbour gives a straight line.
  const Eigen::Vector2d centre(100, 50);
  std::vector<std::optional<Eigen::Vector2d>> corners(3);
  for (int c = 0; c < 3; ++c) {
    const double a = 0.05 * (c - 1);
    corners[c] = centre + 200.0 * Eigen::Vector2d(std::sin(a), -std::cos(a));
  }
  // Centred: second-order accurate (chord vs arc); at the end corner the parabola through the
  // triple: first-order.
  for (auto [id, tolerance] : {std::pair{1, 1e-5}, std::pair{0, 5e-5}}) {
    const auto line = LineThroughCorner(corners, 1, 3, id, true);
    ASSERT_TRUE(line);
    EXPECT_NEAR(line->curvature.norm(), 1.0 / 200, tolerance);
    EXPECT_GT(line->curvature.dot(centre - *corners[id]), 0);
    EXPECT_NEAR(std::abs(line->tangent.dot((centre - *corners[id]).normalized())), 0.0, 2e-3);
  }
  corners[2].reset();
  const auto pair = LineThroughCorner(corners, 1, 3, 0, true);
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->curvature.norm(), 0.0);
  EXPECT_FALSE(LineThroughCorner(corners, 1, 3, 0, false));  // no neighbour along a column
}

// A board cut by a ring's edge: the same exact boards (straight and curved), everything beyond
// a line 0.3 squares past the board's last inner row dark (the ring's lip or the invalid area:
// its outer squares are cut there). Refined with the detector's window from 0.3 px off the
// truth, the last row's windows take in that edge and are pulled towards it; after
// KeepWindowsOnTheirSquares every corner left is on its truth, few are dropped, and on the
// uncut board nothing changes.
TEST(CornerRefine, WindowsKeepToTheirOwnSquares) {
  int pulled = 0, dropped = 0, kept = 0;
  double worst_plain = 0, worst_kept = 0;
  for (bool curved : {false, true}) {
    for (int k = 0; k < 4; ++k) {
      Warp warp;
      warp.angle = 0.35 + 0.7 * k;  // never axis-aligned (cornerSubPix errs more there)
      warp.azimuth = M_PI / 2 * k;
      warp.curved = curved;
      for (bool cut : {false, true}) {
        cv::Mat image(480, 640, CV_32F, cv::Scalar(0));
        DrawBoard(warp, &image);
        if (cut) {
          for (int v = 0; v < image.rows; ++v) {
            for (int u = 0; u < image.cols; ++u) {
              // Beyond board row kRows - 1 + 0.3, box-filtered along v (8 samples).
              int beyond = 0;
              for (int a = 0; a < 8; ++a) {
                beyond += warp.BoardOf(Eigen::Vector2d(u, v - 0.5 + (a + 0.5) / 8)).y() > kRows - 0.7;
              }
              float& px = image.at<float>(v, u);
              px = px * (8 - beyond) / 8 + 30.f * beyond / 8;
            }
          }
        }
        std::vector<Eigen::Vector2d> truth(kRows * kCols);
        for (int id = 0; id < kRows * kCols; ++id) truth[id] = warp.PixelOf(Eigen::Vector2d(id % kCols, id / kCols));
        std::vector<std::optional<Eigen::Vector2d>> refined(kRows * kCols);
        std::vector<int> halves(kRows * kCols);
        std::vector<double> sides(kRows * kCols, 1e9);
        for (int id = 0; id < kRows * kCols; ++id) {
          const int r = id / kCols, c = id % kCols;
          for (auto [dr, dc] : {std::pair{0, 1}, {0, -1}, {1, 0}, {-1, 0}}) {
            if (r + dr < 0 || c + dc < 0 || r + dr >= kRows || c + dc >= kCols) continue;
            sides[id] = std::min(sides[id], (truth[id] - truth[(r + dr) * kCols + c + dc]).norm());
          }
          halves[id] = std::clamp(static_cast<int>(std::lround(0.4 * sides[id])), 1, 6);
          Eigen::Vector2d p = truth[id] + Eigen::Vector2d(0.3, -0.2);
          ASSERT_TRUE(RefineCornerInRaw(image, halves[id], &p));
          refined[id] = p;
        }
        const std::vector<std::optional<Eigen::Vector2d>> plain = refined;
        const std::vector<int> plain_halves = halves;
        const int lost = KeepWindowsOnTheirSquares(image, kRows, kCols, sides, 2, &halves, &refined);
        for (int id = 0; id < kRows * kCols; ++id) {
          const double e_plain = (*plain[id] - truth[id]).norm();
          if (!cut) {  // nothing to find: the same corners, the same windows
            EXPECT_EQ(halves[id], plain_halves[id]) << "id " << id;
            ASSERT_TRUE(refined[id]);
            EXPECT_EQ(*refined[id], *plain[id]) << "id " << id;
            continue;
          }
          worst_plain = std::max(worst_plain, e_plain);
          pulled += e_plain > 0.3;
          if (!refined[id]) continue;
          ++kept;
          worst_kept = std::max(worst_kept, (*refined[id] - truth[id]).norm());
        }
        if (cut) dropped += lost;
      }
    }
  }
  std::printf("cut boards: %d of %d plain corners > 0.3 px off (worst %.3f px); kept %d (worst "
              "%.3f px), dropped %d\n", pulled, 8 * kRows * kCols, worst_plain, kept, worst_kept, dropped);
  EXPECT_GE(pulled, 8);  // the edge pulls the last row (else the test could not fail)
  // cornerSubPix's own error on these exact boards, from 0.3 px off, reaches 0.15 px (plain
  // rms 0.07 px above); a smaller window adds some.
  EXPECT_LT(worst_kept, 0.2);
  EXPECT_LE(dropped, 8 * kCols);  // at most the last row
  EXPECT_EQ(kept + dropped, 8 * kRows * kCols);
}

// A 5-megapixel webcam's boards: 24 px squares (the inner ring's boards near 1 m at 2592x1944)
// under a 2.6 px Gaussian defocus. Nothing foreign is in any window, so KeepWindowsOnTheirSquares
// given the blur keeps every corner as refined; told the image is sharp (the 1.5 px edge band it
// had before the blur was passed), some of the corners' own blurred edges look foreign and it
// drops them (84 or more of the 336 before the slope test, 12 with it: the edges' flanks off
// their level are also on a slope under 0.7 of the edges' own there).
TEST(CornerRefine, BlurredBoardsKeepTheirWindows) {
  constexpr double kBlur = 2.6;
  int dropped_with_blur = 0, dropped_as_sharp = 0, corners = 0, narrowed = 0;
  for (bool curved : {false, true}) {
    for (int k = 0; k < 4; ++k) {
      Warp warp;
      warp.angle = 0.35 + 0.7 * k;
      warp.azimuth = M_PI / 2 * k;
      warp.curved = curved;
      warp.side = 24;
      warp.centre = Eigen::Vector2d(400, 400);
      cv::Mat exact(800, 800, CV_32F, cv::Scalar(0)), image;
      DrawBoard(warp, &exact);
      cv::GaussianBlur(exact, image, cv::Size(0, 0), kBlur);
      std::vector<std::optional<Eigen::Vector2d>> refined(kRows * kCols);
      std::vector<int> halves(kRows * kCols);
      std::vector<double> sides(kRows * kCols, 1e9);
      for (int id = 0; id < kRows * kCols; ++id) {
        const Eigen::Vector2d truth = warp.PixelOf(Eigen::Vector2d(id % kCols, id / kCols));
        const int r = id / kCols, c = id % kCols;
        for (auto [dr, dc] : {std::pair{0, 1}, {0, -1}, {1, 0}, {-1, 0}}) {
          if (r + dr < 0 || c + dc < 0 || r + dr >= kRows || c + dc >= kCols) continue;
          sides[id] = std::min(sides[id], (truth - warp.PixelOf(Eigen::Vector2d(c + dc, r + dr))).norm());
        }
        halves[id] = std::clamp(static_cast<int>(std::lround(0.55 * sides[id])), 2, 8);  // MakeBoard's
        Eigen::Vector2d p = truth + Eigen::Vector2d(0.3, -0.2);
        ASSERT_TRUE(RefineCornerInRaw(image, halves[id], &p));
        refined[id] = p;
      }
      auto with_blur = refined, as_sharp = refined;
      auto halves_with_blur = halves, halves_as_sharp = halves;
      dropped_with_blur +=
          KeepWindowsOnTheirSquares(image, kRows, kCols, sides, 2, &halves_with_blur, &with_blur, kBlur);
      dropped_as_sharp += KeepWindowsOnTheirSquares(image, kRows, kCols, sides, 2, &halves_as_sharp, &as_sharp);
      for (int id = 0; id < kRows * kCols; ++id) {
        ++corners;
        ASSERT_TRUE(with_blur[id]) << "id " << id;
        narrowed += halves_with_blur[id] != halves[id];
      }
    }
  }
  std::printf("blurred boards: %d corners; with the blur given %d dropped, %d windows narrowed; "
              "as if sharp %d dropped\n", corners, dropped_with_blur, narrowed, dropped_as_sharp);
  EXPECT_EQ(dropped_with_blur, 0);
  // The curved boards' corners nearest the warp's centre (lines curved with a radius of 3
  // squares, far more than any ring's) may see their neighbours' edges bend into the window.
  EXPECT_LE(narrowed, corners / 50);
  EXPECT_GT(dropped_as_sharp, 0);  // what the test guards against
}

// A glossy board's sheen in linear light (Mei's photo 10): the bright squares' level varies by
// +-45% over a square (a smooth wave along the board, 1.3 squares long), far beyond the 35% of the
// contrast a foreign edge's level is told by, but at under half the edges' slope. No corner is
// dropped, few windows narrowed; the same boards cut as in WindowsKeepToTheirOwnSquares (the sheen on too)
// still lose or narrow their last row's windows. (Such sheen pulls cornerSubPix itself, in
// windows of half a square, by up to 0.8 px here, and a narrowed window's corner moves by up to
// 0.6 px: a limit of the refinement under sheen, which this step does not judge.)
TEST(CornerRefine, SheenIsNoForeignEdge) {
  int dropped = 0, narrowed = 0, corners = 0, cut_caught = 0;
  double worst = 0;
  for (int k = 0; k < 4; ++k) {
    Warp warp;
    warp.angle = 0.35 + 0.7 * k;
    warp.azimuth = M_PI / 2 * k;
    warp.side = 16;
    warp.centre = Eigen::Vector2d(400, 400);
    for (bool cut : {false, true}) {
      cv::Mat image(800, 800, CV_32F, cv::Scalar(0));
      DrawBoard(warp, &image);
      for (int v = 0; v < image.rows; ++v) {
        for (int u = 0; u < image.cols; ++u) {
          const Eigen::Vector2d b = warp.BoardOf(Eigen::Vector2d(u, v));
          float& px = image.at<float>(v, u);
          if (cut && b.y() > kRows - 0.7) px = 30;
          // Shading multiplies the light (dark squares stay near black, as in linear light).
          px = 20 + px * static_cast<float>(0.6 + 0.27 * std::sin(2 * M_PI * (b.x() + 0.5 * b.y()) / 1.3));
        }
      }
      cv::GaussianBlur(image, image, cv::Size(0, 0), 0.8);
      std::vector<std::optional<Eigen::Vector2d>> refined(kRows * kCols);
      std::vector<int> halves(kRows * kCols);
      std::vector<double> sides(kRows * kCols, 1e9);
      for (int id = 0; id < kRows * kCols; ++id) {
        const Eigen::Vector2d truth = warp.PixelOf(Eigen::Vector2d(id % kCols, id / kCols));
        const int r = id / kCols, c = id % kCols;
        for (auto [dr, dc] : {std::pair{0, 1}, {0, -1}, {1, 0}, {-1, 0}}) {
          if (r + dr < 0 || c + dc < 0 || r + dr >= kRows || c + dc >= kCols) continue;
          sides[id] = std::min(sides[id], (truth - warp.PixelOf(Eigen::Vector2d(c + dc, r + dr))).norm());
        }
        halves[id] = std::clamp(static_cast<int>(std::lround(0.55 * sides[id])), 2, 8);  // MakeBoard's
        Eigen::Vector2d p = truth + Eigen::Vector2d(0.3, -0.2);
        ASSERT_TRUE(RefineCornerInRaw(image, halves[id], &p));
        refined[id] = p;
      }
      const auto plain = refined;
      const auto plain_halves = halves;
      const int lost = KeepWindowsOnTheirSquares(image, kRows, kCols, sides, 2, &halves, &refined, 0.8, 0.7);
      if (cut) {
        for (int id = (kRows - 1) * kCols; id < kRows * kCols; ++id) cut_caught += !refined[id] || halves[id] < plain_halves[id];
        continue;
      }
      dropped += lost;
      for (int id = 0; id < kRows * kCols; ++id) {
        ++corners;
        if (!refined[id]) continue;
        narrowed += halves[id] != plain_halves[id];
        worst = std::max(worst, (*refined[id] - *plain[id]).norm());
      }
    }
  }
  std::printf("sheen: %d corners, %d dropped, %d windows narrowed (moved up to %.3f px); cut: "
              "%d of %d last-row corners dropped or narrowed\n", corners, dropped, narrowed, worst, cut_caught,
              4 * kCols);
  // The bright squares span 88-244 over a contrast of ~150 (dark 20): +-51% of it, so the level
  // test alone would take most windows for foreign.
  EXPECT_EQ(dropped, 0);
  EXPECT_LE(narrowed, corners / 10);
  EXPECT_GE(cut_caught, 3 * kCols);  // a step is still one, sheen or not
}

// RefineFromStarts: each start refined with its window onto the junction, a start whose window
// comes within 3 px of the border left out, and the result in the corners' order.
TEST(RefineFromStarts, RefinesEachStartAndLeavesOutWindowsAtTheBorder) {
  // One X-junction between pixels: the quadrants meet at (39.5, 29.5).
  cv::Mat grey(60, 80, CV_8U, cv::Scalar(0));
  grey(cv::Rect(40, 0, 40, 30)).setTo(255);
  grey(cv::Rect(0, 30, 40, 30)).setTo(255);
  cv::GaussianBlur(grey, grey, cv::Size(0, 0), 1.0);
  const std::vector<CornerStart> corners = {{0, 1, Eigen::Vector2d(41.2, 28.4), 5},
                                            {0, 0, Eigen::Vector2d(3, 29), 5}};
  const auto refined = RefineFromStarts(grey, {{1, 2}}, corners, false);
  ASSERT_EQ(refined.size(), 2u);
  ASSERT_TRUE(refined[0]);
  EXPECT_LT((*refined[0] - Eigen::Vector2d(39.5, 29.5)).norm(), 0.02) << refined[0]->transpose();
  EXPECT_FALSE(refined[1]);
}

}  // namespace
}  // namespace omni::detectors
