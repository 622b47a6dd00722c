// The central baseline models (bench/central_models.h) against independent oracles:
// cv::omnidir::projectPoints for the unified projection, numeric differentiation for the
// polynomial model's implicit (root-finding) derivative, and a board seen through a KNOWN unified
// camera with 0.3 px noise per coordinate for both fits and their held-out scoring.
#include "bench/central_models.h"

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <gtest/gtest.h>
#include <opencv2/ccalib/omnidir.hpp>

namespace omni::central {
namespace {

constexpr int kWidth = 1280, kHeight = 1024;
constexpr double kNoise = 0.3;  // px per coordinate: 2D RMS per corner sqrt(2) * 0.3

// A 6 x 8 inner-corner board of 42 mm squares, in metres.
std::vector<Eigen::Vector3d> BoardPoints() {
  std::vector<Eigen::Vector3d> points;
  for (int row = 0; row < 6; ++row)
    for (int col = 0; col < 8; ++col) points.emplace_back(col * 0.042, row * 0.042, 0.0);
  return points;
}

struct Scene {
  std::vector<double> truth;  // unified params
  std::vector<BoardView> views;
  std::vector<Pose> poses;
};

// Boards around the camera at 45..100 deg from its axis, facing it with a tilt, all corners
// inside the image; noise from a fixed seed.
Scene MakeScene(double xi, int num_views, unsigned seed) {
  Scene scene;
  scene.truth = {280, 282, 0, 645, 508, xi, 0, 0, 0, 0};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0, 1);
  std::normal_distribution<double> noise(0, kNoise);
  const std::vector<Eigen::Vector3d> board = BoardPoints();
  const Eigen::Vector3d board_middle(3.5 * 0.042, 2.5 * 0.042, 0);
  while (static_cast<int>(scene.views.size()) < num_views) {
    const double theta = (45 + 55 * uniform(rng)) * M_PI / 180;
    const double phi = 2 * M_PI * (scene.views.size() + 0.5 * uniform(rng)) / num_views;
    const double distance = 0.45 + 0.3 * uniform(rng);
    const Eigen::Vector3d centre =
        distance * Eigen::Vector3d(std::sin(theta) * std::cos(phi),
                                   std::sin(theta) * std::sin(phi), std::cos(theta));
    // Board z towards the camera, tilted up to 25 deg, spun about its normal.
    Eigen::Vector3d normal = -centre.normalized();
    const Eigen::Vector3d tilt_axis = normal.unitOrthogonal();
    normal = Eigen::AngleAxisd(25 * M_PI / 180 * (2 * uniform(rng) - 1),
                               Eigen::AngleAxisd(2 * M_PI * uniform(rng), normal) * tilt_axis) *
             normal;
    Eigen::Vector3d x_axis = normal.unitOrthogonal();
    x_axis = Eigen::AngleAxisd(2 * M_PI * uniform(rng), normal) * x_axis;
    Eigen::Matrix3d rotation;
    rotation << x_axis, normal.cross(x_axis), normal;
    const Eigen::Vector3d translation = centre - rotation * board_middle;
    BoardView view;
    view.name = "synthetic_" + std::to_string(scene.views.size());
    bool inside = true;
    for (const Eigen::Vector3d& point : board) {
      const Eigen::Vector3d point_in_cam = rotation * point + translation;
      Eigen::Vector2d pixel;
      if (!UnifiedProject(scene.truth.data(), point_in_cam.data(), pixel.data()) ||
          pixel.x() < 5 || pixel.y() < 5 || pixel.x() > kWidth - 5 || pixel.y() > kHeight - 5) {
        inside = false;
        break;
      }
      view.points_in_board.push_back(point);
      view.pixels.push_back(pixel + Eigen::Vector2d(noise(rng), noise(rng)));
    }
    if (!inside) continue;
    const Eigen::AngleAxisd angle_axis(rotation);
    Pose pose;
    for (int i = 0; i < 3; ++i) {
      pose.angle_axis_translation[i] = angle_axis.angle() * angle_axis.axis()[i];
      pose.angle_axis_translation[3 + i] = translation[i];
    }
    scene.views.push_back(view);
    scene.poses.push_back(pose);
  }
  return scene;
}

TEST(CentralModels, UnifiedProjectionIsOmnidirs) {
  const std::vector<double> params = {300, 310, 0.5, 640, 500, 0.85, -0.12, 0.03, 0.002, -0.001};
  const cv::Matx33d k(params[0], params[2], params[3], 0, params[1], params[4], 0, 0, 1);
  const cv::Vec4d d(params[6], params[7], params[8], params[9]);
  std::vector<cv::Vec3d> points = {{0.3, -0.2, 0.5}, {-0.4, 0.1, 0.1}, {0.2, 0.5, -0.1},
                                   {0.01, 0.02, 1.0}, {-0.6, -0.3, -0.2}};
  std::vector<cv::Vec2d> expected;
  cv::omnidir::projectPoints(points, expected, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k,
                             params[5], d);
  for (size_t i = 0; i < points.size(); ++i) {
    const double point[3] = {points[i][0], points[i][1], points[i][2]};
    double pixel[2];
    ASSERT_TRUE(UnifiedProject(params.data(), point, pixel));
    EXPECT_NEAR(pixel[0], expected[i][0], 1e-9);
    EXPECT_NEAR(pixel[1], expected[i][1], 1e-9);
  }
}

TEST(CentralModels, UnprojectInvertsProject) {
  const std::vector<double> unified = {300, 310, 0.5, 640, 500, 0.85, -0.05, 0.01, 0.001, -0.001};
  const std::vector<double> polynomial = {641, 509, 1.002, 0.001, -0.002, 250, -1.6e-3, 2e-7, -1e-10};
  for (ModelKind kind : {ModelKind::kUnified, ModelKind::kPolynomial}) {
    const std::vector<double>& params = kind == ModelKind::kUnified ? unified : polynomial;
    for (const Eigen::Vector3d& point : {Eigen::Vector3d(0.3, -0.2, 0.5),
                                         Eigen::Vector3d(-0.4, 0.1, 0.1),
                                         Eigen::Vector3d(0.2, 0.5, -0.1)}) {
      Eigen::Vector2d pixel;
      ASSERT_TRUE(Project(kind, params.data(), point.data(), pixel.data())) << ModelName(kind);
      const std::optional<Eigen::Vector3d> ray = Unproject(kind, params, pixel);
      ASSERT_TRUE(ray.has_value());
      EXPECT_NEAR((*ray - point.normalized()).norm(), 0, 1e-9) << ModelName(kind);
    }
  }
}

struct PolynomialProjectFunctor {
  template <typename T>
  bool operator()(const T* params, const T* point, T* pixel) const {
    return PolynomialProject(params, point, pixel);
  }
};

// The one Newton step in T must carry the exact derivative of the root-found rho.
TEST(CentralModels, PolynomialJetDerivativeMatchesNumeric) {
  const double params[kPolynomialParams] = {641, 509, 1.002, 0.001, -0.002, 250, -1.6e-3, 2e-7,
                                             -1e-10};
  const double point[3] = {0.3, -0.2, 0.05};
  const double* blocks[2] = {params, point};
  ceres::AutoDiffCostFunction<PolynomialProjectFunctor, 2, kPolynomialParams, 3> autodiff(
      new PolynomialProjectFunctor);
  double pixel[2], jac_params[2 * kPolynomialParams], jac_point[6];
  double* jacobians[2] = {jac_params, jac_point};
  ASSERT_TRUE(autodiff.Evaluate(blocks, pixel, jacobians));
  // Central differences with a step of 1e-6 of each value: compared as the pixel change that step
  // causes, which must agree to 1e-6 of itself (the truncation error at this step is ~1e-12).
  auto check_block = [&](const double* values, int size, const double* jacobian, int block) {
    for (int j = 0; j < size; ++j) {
      const double step = values[j] != 0 ? 1e-6 * std::abs(values[j]) : 1e-9;
      double plus[kPolynomialParams], minus[kPolynomialParams], pixel_plus[2], pixel_minus[2];
      std::copy(values, values + size, plus);
      std::copy(values, values + size, minus);
      plus[j] += step;
      minus[j] -= step;
      const double* p_plus = block == 0 ? plus : params;
      const double* p_minus = block == 0 ? minus : params;
      const double* x_plus = block == 1 ? plus : point;
      const double* x_minus = block == 1 ? minus : point;
      ASSERT_TRUE(PolynomialProject(p_plus, x_plus, pixel_plus));
      ASSERT_TRUE(PolynomialProject(p_minus, x_minus, pixel_minus));
      for (int r = 0; r < 2; ++r) {
        const double numeric_change = (pixel_plus[r] - pixel_minus[r]) / 2;
        EXPECT_NEAR(jacobian[r * size + j] * step, numeric_change,
                    1e-6 * std::abs(numeric_change) + 1e-10)
            << "block " << block << " row " << r << " column " << j;
      }
    }
  };
  check_block(params, kPolynomialParams, jac_params, 0);
  check_block(point, 3, jac_point, 1);
}

struct Split {
  std::vector<BoardView> train, held_out;
};
Split EveryThirdHeldOut(const std::vector<BoardView>& views) {
  Split split;
  for (size_t i = 0; i < views.size(); ++i)
    (i % 3 == 2 ? split.held_out : split.train).push_back(views[i]);
  return split;
}

double TrainingRms(ModelKind kind, const FitResult& fit, const std::vector<BoardView>& train) {
  std::vector<double> errors;
  for (size_t k = 0; k < fit.used.size(); ++k) {
    const std::vector<double> e = CornerErrors(kind, fit.params, fit.poses[k], train[fit.used[k]]);
    errors.insert(errors.end(), e.begin(), e.end());
  }
  return Rms(errors);
}

double HeldOutRms(ModelKind kind, const FitResult& fit, const std::vector<BoardView>& held_out) {
  std::vector<double> errors;
  for (const BoardView& view : held_out) {
    const std::optional<Pose> pose = FitPose(kind, fit.params, view);
    if (!pose) return 1e9;
    int invalid = 0;
    const std::vector<double> e = CornerErrors(kind, fit.params, *pose, view, &invalid);
    if (invalid) return 1e9;
    errors.insert(errors.end(), e.begin(), e.end());
  }
  return Rms(errors);
}

class CentralFitTest : public ::testing::TestWithParam<double> {};

TEST_P(CentralFitTest, BothModelsFitAKnownUnifiedCamera) {
  const double xi = GetParam();
  const Scene scene = MakeScene(xi, 15, 7);
  const Split split = EveryThirdHeldOut(scene.views);
  const double noise_rms = std::sqrt(2.0) * kNoise;

  // Parameters: with the distortion fixed at the truth's zero (free, xi trades against k1 and
  // fx: at xi = 0.8 a fit lands near xi 0.92, fx +6% with the same RMS).
  namespace omnidir = cv::omnidir;
  const FitResult recovery = FitUnifiedOmnidir(
      split.train, kWidth, kHeight,
      omnidir::CALIB_FIX_SKEW | omnidir::CALIB_FIX_K1 | omnidir::CALIB_FIX_K2 |
          omnidir::CALIB_FIX_P1 | omnidir::CALIB_FIX_P2);
  ASSERT_TRUE(recovery.ok) << recovery.message;
  EXPECT_EQ(recovery.used.size(), split.train.size());
  EXPECT_NEAR(recovery.params[0] / scene.truth[0], 1, 0.01);
  EXPECT_NEAR(recovery.params[1] / scene.truth[1], 1, 0.01);
  EXPECT_NEAR(recovery.params[3], scene.truth[3], 1.5);
  EXPECT_NEAR(recovery.params[4], scene.truth[4], 1.5);
  EXPECT_NEAR(recovery.params[5], xi, 0.01);

  // Figures: the bench's fit (skew fixed, distortion free).
  const FitResult unified =
      FitUnifiedOmnidir(split.train, kWidth, kHeight, omnidir::CALIB_FIX_SKEW);
  ASSERT_TRUE(unified.ok) << unified.message;
  EXPECT_EQ(unified.used.size(), split.train.size());
  const double unified_train = TrainingRms(ModelKind::kUnified, unified, split.train);
  const double unified_held = HeldOutRms(ModelKind::kUnified, unified, split.held_out);
  EXPECT_GT(unified_train, 0.85 * noise_rms);
  EXPECT_LT(unified_train, 1.05 * noise_rms);
  EXPECT_GT(unified_held, 0.85 * noise_rms);
  EXPECT_LT(unified_held, 1.15 * noise_rms);

  // With the truth's parameters, the held-out pose fit alone reaches the noise.
  const FitResult truth_fit{true, "", scene.truth, {}, {}, 0};
  EXPECT_LT(HeldOutRms(ModelKind::kUnified, truth_fit, split.held_out), 1.1 * noise_rms);

  const FitResult polynomial = FitPolynomial(split.train, kWidth, kHeight);
  ASSERT_TRUE(polynomial.ok) << polynomial.message;
  EXPECT_EQ(polynomial.used.size(), split.train.size());
  EXPECT_NEAR(polynomial.params[0], scene.truth[3], 2.0);
  EXPECT_NEAR(polynomial.params[1], scene.truth[4], 2.0);
  const double polynomial_train = TrainingRms(ModelKind::kPolynomial, polynomial, split.train);
  const double polynomial_held = HeldOutRms(ModelKind::kPolynomial, polynomial, split.held_out);
  EXPECT_LT(polynomial_train, 1.1 * noise_rms);
  EXPECT_LT(polynomial_held, 1.25 * noise_rms);
  std::printf("xi %.2f: unified train %.3f held-out %.3f (xi %.4f fx %.2f; distortion fixed: xi %.4f fx %.2f); polynomial train %.3f "
              "held-out %.3f; noise 2D RMS %.3f\n",
              xi, unified_train, unified_held, unified.params[5], unified.params[0], recovery.params[5], recovery.params[0],
              polynomial_train, polynomial_held, noise_rms);
}

INSTANTIATE_TEST_SUITE_P(Xi, CentralFitTest, ::testing::Values(0.8, 1.0));

}  // namespace
}  // namespace omni::central
