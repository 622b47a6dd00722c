// The per-frame fast path of DenseStereo::Compute (DisparityRefiner's window moments,
// TriangulateMatch's 4-tangent Jets and LargestEigenvalue) against two oracles, on a small frame
// of the box room (box_room.h) through the misaligned rig:
//  - the first implementation's per-point path (DepthOptions::reference_path: RefineDisparity
//    sample by sample, Jets over the 12 ray coordinates, Eigen's closed-form eigenvalues) on the
//    whole panoramas: the same matches, colours, disparities, points and sigmas to rounding with
//    only the band remapped (full_panoramas = false);
//  - the model's own triangulation (Triangulator::Triangulate: exact ray tracing of the LUT's raw
//    pixels, central differences of the whole chain, no table): the same points and sigmas to
//    the tables' row interpolation, a small fraction of the point's sigma.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <utility>

#include <Eigen/Eigenvalues>

#include "io/model_file.h"
#include "model/triangulation.h"
#include "stereo/dense_stereo.h"
#include "synthetic/scene.h"
#include "tests/stereo/box_room.h"

namespace omni::stereo {
namespace {

const std::string kSampleDir = std::string(OMNI_SOURCE_DIR) + "/sample_configs/";

// A 640x480 frame of the misaligned rig (its model scaled as `render` does), 640-wide panoramas.
struct SmallFrame {
  RigModel model{synthetic::RigAtImageSize(
      io::ReadModelFile(kSampleDir + "big_rig_misaligned.yaml"), 640, 480)};
  cv::Mat image = RenderBox(model, Box());
  PanoramaOptions panorama = [] {
    PanoramaOptions options;
    options.width = 640;
    return options;
  }();
};

const SmallFrame& Frame() {
  static const SmallFrame frame;
  return frame;
}

// The default 5 x 7 refinement window (its SSE2 cross sums, CrossSums7Columns), a 9 x 7 one (the
// same with 9 columns) and a 3 x 5 one (the generic loop).
class DenseFastPathWindow : public ::testing::TestWithParam<std::pair<int, int>> {};

TEST_P(DenseFastPathWindow, SamePointsAndSigmasAsTheReferencePath) {
  const SmallFrame& f = Frame();
  DepthOptions options;
  options.sigma_px = 0.7;
  options.refine_half_width = GetParam().first;
  options.refine_half_height = GetParam().second;
  options.full_panoramas = false;  // as depth --images: only the band remapped
  const DepthFrame fast = DenseStereo(f.model, f.panorama, options).Compute(f.image);
  options.full_panoramas = true;
  options.reference_path = true;
  const DepthFrame reference = DenseStereo(f.model, f.panorama, options).Compute(f.image);
  ASSERT_GT(reference.points.size(), 10000u);
  ASSERT_EQ(fast.points.size(), reference.points.size());
  double max_point = 0, max_sigma = 0, max_disparity = 0;
  for (size_t i = 0; i < fast.points.size(); ++i) {
    const DensePoint& a = fast.points[i];
    const DensePoint& b = reference.points[i];
    ASSERT_EQ(a.u, b.u);
    ASSERT_EQ(a.v, b.v);
    ASSERT_TRUE(std::equal(a.bgr, a.bgr + 3, b.bgr)) << a.u << " " << a.v;  // the band's colours
    max_disparity = std::max(max_disparity, double(std::abs(a.disparity - b.disparity)));
    max_point = std::max(max_point, double((a.point_in_cam - b.point_in_cam).norm() /
                                           b.point_in_cam.norm()));
    max_sigma = std::max(max_sigma, double(std::abs(a.sigma_mm - b.sigma_mm) / b.sigma_mm));
  }
  std::printf("%zu points; fast - reference: max |d| %.2g px, max |point| / range %.2g, "
              "max |sigma| / sigma %.2g\n",
              fast.points.size(), max_disparity, max_point, max_sigma);
  // Float storage rounds at 6e-8 relative; the paths' double sums differ at ~1e-12.
  EXPECT_LT(max_disparity, 1e-5);
  EXPECT_LT(max_point, 1e-6);
  EXPECT_LT(max_sigma, 1e-6);
}
INSTANTIATE_TEST_SUITE_P(Windows, DenseFastPathWindow,
                         ::testing::Values(std::make_pair(2, 3), std::make_pair(4, 3),
                                           std::make_pair(1, 2)));

TEST(DenseFastPath, TablesAgreeWithTheModelTriangulation) {
  const SmallFrame& f = Frame();
  DepthOptions options;
  const DenseStereo dense(f.model, f.panorama, options);
  const DepthFrame frame = dense.Compute(f.image);
  const PanoramaLuts& luts = dense.luts();
  const Triangulator triangulator(f.model);
  // The LUT's raw pixel at column u, sub-pixel row v (linear between rows, as the tables).
  auto raw = [&](int ring, int u, double v) {
    const int v0 = static_cast<int>(std::floor(v));
    const double t = v - v0;
    const cv::Mat &x = luts.map_x[ring], &y = luts.map_y[ring];
    return Eigen::Vector2d((1 - t) * x.at<float>(v0, u) + t * x.at<float>(v0 + 1, u),
                           (1 - t) * y.at<float>(v0, u) + t * y.at<float>(v0 + 1, u));
  };
  int compared = 0;
  double max_point = 0, max_sigma = 0;
  for (size_t i = 0; i < frame.points.size(); i += 37) {
    const DensePoint& p = frame.points[i];
    const auto exact = triangulator.Triangulate(raw(0, p.u, p.v), raw(1, p.u, p.v - p.disparity));
    ASSERT_TRUE(exact.has_value());
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(exact->covariance);
    const double sigma = std::sqrt(eigen.eigenvalues()[2]);
    max_point = std::max(max_point, (p.point_in_cam.cast<double>() - exact->point_in_cam).norm() /
                                        sigma);
    max_sigma = std::max(max_sigma, std::abs(p.sigma_mm - sigma) / sigma);
    ++compared;
  }
  std::printf("%d points vs Triangulator: max |point| / sigma %.2g, max |sigma| / sigma %.2g\n",
              compared, max_point, max_sigma);
  ASSERT_GT(compared, 300);
  EXPECT_LT(max_point, 0.01);
  EXPECT_LT(max_sigma, 0.01);
}

TEST(DenseFastPath, LargestEigenvalueMatchesEigen) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  auto check = [](const Eigen::Matrix3d& m) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(m);  // iterative QR: the oracle
    const double expected = eigen.eigenvalues()[2];
    EXPECT_NEAR(LargestEigenvalue(m), expected, 1e-7 * std::max(expected, 1e-300)) << m;
  };
  for (int i = 0; i < 2000; ++i) {
    // A A^T as the triangulation makes it: 3x4, rows scaled so the ellipsoid is elongated.
    Eigen::Matrix<double, 3, 4> A;
    for (int k = 0; k < 12; ++k) A(k / 4, k % 4) = normal(rng);
    A.row(i % 3) *= std::pow(10.0, 3 * (i % 5) / 4.0);
    check(A * A.transpose());
  }
  check(Eigen::Vector3d(5, 5, 1).asDiagonal());              // double largest root
  check(Eigen::Vector3d(2, 2, 2).asDiagonal());              // triple root
  check(Eigen::Vector3d(1, 2, 3) * Eigen::Vector3d(1, 2, 3).transpose());  // rank 1
  EXPECT_EQ(LargestEigenvalue(Eigen::Matrix3d::Zero()), 0);
}

}  // namespace
}  // namespace omni::stereo
