// Triangulation of pixel pairs (model/triangulation.h) against independent oracles: exact points
// projected by the model, the paper's closed-form SVP triangulation, and Monte Carlo for the
// covariance (pixel noise and model-parameter noise).
#include "model/triangulation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>

#include "io/model_file.h"
#include "model/ideal_analysis.h"
#include "tests/model/rig_test_util.h"

namespace omni {
namespace {

const std::string kMisalignedRig =
    std::string(OMNI_SOURCE_DIR) + "/sample_configs/big_rig_misaligned.yaml";

// A point at horizontal range rho and azimuth az in the middle fraction `frac` of the ideal
// stereo band at that range (as the paper's RMSE scene places its boards).
Eigen::Vector3d StereoPoint(const RigParams& rig, double rho, double az, double height01) {
  const IdealModel ideal = rig.Ideal();
  const FieldOfView fov = ComputeFieldOfView(rig.Design(), rig.r_ref, rig.r_cam);
  const double z_f1 = ideal.c1, z_f2 = ideal.d - ideal.c2;
  const double z_lo = std::max(z_f1 + rho * std::tan(fov.theta1_min),
                               z_f2 + rho * std::tan(fov.theta2_min));
  const double z_hi = std::min(z_f1 + rho * std::tan(fov.theta1_max),
                               z_f2 + rho * std::tan(fov.theta2_max));
  const double z = z_lo + (0.2 + 0.6 * height01) * (z_hi - z_lo);
  return Eigen::Vector3d(rho * std::cos(az), rho * std::sin(az), z);
}

struct Sample {
  Eigen::Vector3d point;
  Eigen::Vector2d px1, px2;
};

std::vector<Sample> StereoSamples(const RigModel& model, const std::vector<double>& ranges,
                                  int per_range, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<Sample> samples;
  for (double rho : ranges) {
    for (int k = 0; k < per_range; ++k) {
      const Eigen::Vector3d p = StereoPoint(model.params(), rho, 2 * M_PI * u01(rng), u01(rng));
      const auto px1 = model.Project(p, Mirror::kOne);
      const auto px2 = model.Project(p, Mirror::kTwo);
      if (px1 && px2) samples.push_back({p, *px1, *px2});
    }
  }
  return samples;
}

Eigen::Matrix3d SampleCovariance(const std::vector<Eigen::Vector3d>& xs) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& x : xs) mean += x;
  mean /= xs.size();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& x : xs) cov += (x - mean) * (x - mean).transpose();
  return cov / (xs.size() - 1);
}

// Largest relative difference of the standard deviations along the predicted covariance's
// principal axes (the covariance is strongly elongated along the range, so compare per axis).
double WorstAxisSigmaRatioError(const Eigen::Matrix3d& predicted, const Eigen::Matrix3d& sample) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(predicted);
  double worst = 0;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d axis = eig.eigenvectors().col(i);
    const double s_pred = std::sqrt(axis.dot(predicted * axis));
    const double s_mc = std::sqrt(axis.dot(sample * axis));
    worst = std::max(worst, std::abs(s_mc / s_pred - 1.0));
  }
  return worst;
}

TEST(Triangulation, MidpointOfSkewRaysIsExact) {
  // Two skew lines with a known common perpendicular: x-axis through (0,0,-1) and y-axis
  // through (5,0,1): closest points (5,0,-1) and (5,0,1), midpoint (5,0,0).
  Eigen::Vector3d mid;
  double l1 = 0, l2 = 0;
  ASSERT_TRUE(MidpointOnCommonPerpendicular<double>({-3, 0, -1}, {2, 0, 0}, {5, 7, 1}, {0, -1, 0},
                                                    &mid, &l1, &l2));
  EXPECT_NEAR((mid - Eigen::Vector3d(5, 0, 0)).norm(), 0, 1e-14);
  EXPECT_NEAR(l1, 4.0, 1e-14);
  EXPECT_NEAR(l2, 7.0, 1e-14);
  EXPECT_FALSE(MidpointOnCommonPerpendicular<double>({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-2, 0, 0},
                                                     &mid));
}

// Noise-free pixels of known points through the misaligned rig: the rays meet exactly, so the
// midpoint (and the refined point) is the point to rounding.
TEST(Triangulation, NoiseFreePixelsGiveTheExactPointOnTheMisalignedRig) {
  const RigModel model(io::ReadModelFile(kMisalignedRig));
  const Triangulator triangulator(model);
  const auto samples =
      StereoSamples(model, {250, 500, 1000, 2000, 4000, 8000}, 40, /*seed=*/3);
  ASSERT_GT(samples.size(), 200u);
  double worst_mid = 0, worst_ref = 0, worst_gap = 0;
  for (const auto& s : samples) {
    const auto mid = triangulator.Triangulate(s.px1, s.px2);
    ASSERT_TRUE(mid.has_value());
    worst_mid = std::max(worst_mid, (mid->point_in_cam - s.point).norm());
    worst_gap = std::max(worst_gap, mid->gap_mm);
    TriangulationOptions refine;
    refine.method = TriangulationMethod::kReprojection;
    const auto ref = triangulator.Triangulate(s.px1, s.px2, refine);
    ASSERT_TRUE(ref.has_value());
    worst_ref = std::max(worst_ref, (ref->point_in_cam - s.point).norm());
    EXPECT_LT(ref->reprojection_rms_px, 1e-9);
  }
  std::printf("noise-free: worst midpoint error %.3g mm, refined %.3g mm, gap %.3g mm (%zu points)\n",
              worst_mid, worst_ref, worst_gap, samples.size());
  EXPECT_LT(worst_mid, 1e-6);
  EXPECT_LT(worst_ref, 1e-6);
}

// The ideal rig: the midpoint equals the paper's closed form [depth_from_triangulation],
// [pw_from_triangulation] from the elevations of the two rays (coplanar rays through F1, F2).
TEST(Triangulation, IdealRigMatchesThePapersClosedForm) {
  const RigParams rig = testing::BigRigParams();
  const RigModel model(rig);
  const Triangulator triangulator(model);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 2.0);
  int n = 0;
  for (const auto& s : StereoSamples(model, {300, 1000, 3000}, 20, 9)) {
    // Move the inner-ring pixel radially only (ideal rig: it stays in the plane of the outer
    // ray, so the rays remain coplanar) to test away from the exact point too.
    const Eigen::Vector2d centre(rig.camera[kCx], rig.camera[kCy]);
    const Eigen::Vector2d radial = (s.px2 - centre).normalized();
    const Eigen::Vector2d px2 = s.px2 + noise(rng) * radial;
    const auto ray1 = model.Unproject(s.px1);
    const auto ray2 = model.Unproject(px2);
    ASSERT_TRUE(ray1 && ray2);
    const Eigen::Vector3d& d1 = ray1->ray.direction;
    const Eigen::Vector3d& d2 = ray2->ray.direction;
    const double theta1 = std::atan2(d1.z(), d1.head<2>().norm());
    const double theta2 = std::atan2(d2.z(), d2.head<2>().norm());
    const double psi = std::atan2(d1.y(), d1.x());
    Eigen::Vector3d closed_form;
    if (!TriangulateElevations(rig.Design(), theta1, theta2, psi, &closed_form)) continue;
    const auto mid = triangulator.Triangulate(s.px1, px2);
    ASSERT_TRUE(mid.has_value());
    EXPECT_LT((mid->point_in_cam - closed_form).norm(), 1e-9 * closed_form.norm())
        << closed_form.transpose();
    EXPECT_LT(mid->gap_mm, 1e-8);
    ++n;
  }
  EXPECT_GT(n, 40);
}

// Covariance by first-order propagation vs the spread of 2000 noisy pixel pairs, and the mean
// normalised estimation error squared (NEES) near 3.
TEST(Triangulation, CovarianceMatchesMonteCarloAndNeesIsThree) {
  const RigModel model(io::ReadModelFile(kMisalignedRig));
  const Triangulator triangulator(model);
  const double sigma_px = 0.5;
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, sigma_px);
  for (double rho : {500.0, 2000.0}) {
    for (auto method : {TriangulationMethod::kMidpoint, TriangulationMethod::kReprojection}) {
      TriangulationOptions options;
      options.sigma_px = sigma_px;
      options.method = method;
      const Eigen::Vector3d truth = StereoPoint(model.params(), rho, 0.7, 0.5);
      const auto px1 = model.Project(truth, Mirror::kOne);
      const auto px2 = model.Project(truth, Mirror::kTwo);
      ASSERT_TRUE(px1 && px2);
      const auto predicted = triangulator.Triangulate(*px1, *px2, options);
      ASSERT_TRUE(predicted.has_value());
      std::vector<Eigen::Vector3d> estimates;
      double nees = 0;
      for (int i = 0; i < 2000; ++i) {
        const Eigen::Vector2d n1(noise(rng), noise(rng)), n2(noise(rng), noise(rng));
        const auto est = triangulator.Triangulate(*px1 + n1, *px2 + n2, options);
        ASSERT_TRUE(est.has_value());
        estimates.push_back(est->point_in_cam);
        const Eigen::Vector3d e = est->point_in_cam - truth;
        nees += e.dot(est->covariance.ldlt().solve(e));
      }
      nees /= estimates.size();
      const double axis_error =
          WorstAxisSigmaRatioError(predicted->covariance, SampleCovariance(estimates));
      std::printf("rho %.0f mm %s: sigma (sqrt eig max) %.3f mm, worst axis sigma error %.1f%%, "
                  "mean NEES %.3f\n",
                  rho, method == TriangulationMethod::kMidpoint ? "midpoint" : "refined",
                  std::sqrt(predicted->covariance.eigenvalues().real().maxCoeff()),
                  100 * axis_error, nees);
      // Sample sigma of 2000 draws: ~1.6% standard error; 10% is well beyond it.
      EXPECT_LT(axis_error, 0.10);
      // Mean of 2000 chi^2(3) draws: standard error sqrt(6 / 2000) = 0.055.
      EXPECT_NEAR(nees, 3.0, 0.25);
    }
  }
}

// The model's own parameter covariance: triangulating exact pixels with models drawn from that
// covariance spreads the point as the propagated covariance says.
// The parameter a calibration's name addresses, written out here independently of
// ModelParameterIndex (model/rig_params.h: poses are rx, ry (rad), tx, ty, tz (mm); reflex rx, ry
// (rad), dz (mm)); nullptr for a name the test does not know.
double* ParameterByName(RigParams* rig, const std::string& name) {
  const std::vector<std::pair<std::string, double*>> table = {
      {"fx", &rig->camera[kFx]}, {"fy", &rig->camera[kFy]}, {"cx", &rig->camera[kCx]},
      {"cy", &rig->camera[kCy]}, {"skew", &rig->camera[kSkew]}, {"dist_k1", &rig->distortion[kDistK1]},
      {"dist_k2", &rig->distortion[kDistK2]}, {"dist_p1", &rig->distortion[kDistP1]},
      {"dist_p2", &rig->distortion[kDistP2]}, {"dist_k3", &rig->distortion[kDistK3]},
      {"c1", &rig->mirror1_shape[kShapeC]}, {"k1", &rig->mirror1_shape[kShapeK]},
      {"c2", &rig->mirror2_shape[kShapeC]}, {"k2", &rig->mirror2_shape[kShapeK]},
      {"mirror1.rx", &rig->mirror1_pose[kRx]}, {"mirror1.ry", &rig->mirror1_pose[kRy]},
      {"mirror1.tx", &rig->mirror1_pose[kTx]}, {"mirror1.ty", &rig->mirror1_pose[kTy]},
      {"mirror1.tz", &rig->mirror1_pose[kTz]}, {"mirror2.rx", &rig->mirror2_pose[kRx]},
      {"mirror2.ry", &rig->mirror2_pose[kRy]}, {"mirror2.tx", &rig->mirror2_pose[kTx]},
      {"mirror2.ty", &rig->mirror2_pose[kTy]}, {"mirror2.tz", &rig->mirror2_pose[kTz]},
      {"reflex.rx", &rig->reflex[kReflexRx]}, {"reflex.ry", &rig->reflex[kReflexRy]}, {"reflex.dz", &rig->reflex[kReflexDz]}};
  for (const auto& [key, ptr] : table) {
    if (key == name) return ptr;
  }
  return nullptr;
}

// The model part of a triangulated point's covariance against Monte Carlo over models drawn
// from a calibration covariance (subset of the parameters, one correlation), the point held
// fixed to `reference`: in C the estimates are compared as they are, relative to mirror 1's body
// each is taken into its own model's M1 (and the prediction into the nominal M1's axes).
// Returns the worst axis sigma error.
double ModelCovarianceVsMonteCarlo(ReferenceBody reference, ReferenceBody compared_in,
                                   const std::vector<std::string>& names,
                                   const std::vector<double>& sigma, double correlation_1_4) {
  const RigParams truth_rig = io::ReadModelFile(kMisalignedRig);
  const RigModel truth_model(truth_rig);
  const size_t n = names.size();
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(n, n);
  for (size_t i = 0; i < n; ++i) cov(i, i) = sigma[i] * sigma[i];
  if (n > 4) cov(1, 4) = cov(4, 1) = correlation_1_4 * sigma[1] * sigma[4];
  RigParams calibrated = truth_rig;
  CalibrationInfo info;
  info.parameters = names;
  info.sigma = sigma;
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j) info.covariance.push_back(cov(i, j));
  }
  calibrated.calibration = info;
  const Triangulator triangulator{RigModel(calibrated)};
  EXPECT_TRUE(triangulator.has_model_covariance());
  EXPECT_TRUE(triangulator.unknown_parameters().empty());

  const Eigen::Vector3d point = StereoPoint(truth_rig, 1500, 2.1, 0.4);
  const auto px1 = truth_model.Project(point, Mirror::kOne);
  const auto px2 = truth_model.Project(point, Mirror::kTwo);
  if (!px1 || !px2) return 1e9;
  TriangulationOptions options;
  options.sigma_px = 0;  // the model's uncertainty alone
  options.model_covariance = true;
  options.reference = reference;
  const auto predicted = triangulator.Triangulate(*px1, *px2, options);
  if (!predicted) return 1e9;
  const bool in_m1 = compared_in == ReferenceBody::kMirror1;
  const Eigen::Matrix3d mirror1_from_cam =
      in_m1 ? PoseFromBlock(truth_rig.mirror1_pose.data()).Inverse().rotation
            : Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d predicted_cov =
      mirror1_from_cam * predicted->covariance * mirror1_from_cam.transpose();

  const Eigen::MatrixXd chol = cov.llt().matrixL();
  std::mt19937 rng(21);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Eigen::Vector3d> estimates;
  for (int k = 0; k < 1500; ++k) {
    Eigen::VectorXd z(n);
    for (size_t i = 0; i < n; ++i) z[i] = normal(rng);
    const Eigen::VectorXd delta = chol * z;
    RigParams sample = truth_rig;
    for (size_t i = 0; i < n; ++i) *ParameterByName(&sample, names[i]) += delta[i];
    const Triangulator perturbed{RigModel(sample)};
    const auto est = perturbed.Midpoint(*px1, *px2);
    if (!est) return 1e9;
    estimates.push_back(in_m1 ? PoseFromBlock(sample.mirror1_pose.data()).Inverse() * *est : *est);
  }
  const double axis_error = WorstAxisSigmaRatioError(predicted_cov, SampleCovariance(estimates));
  std::printf("model covariance at 1.5 m (held in %s, compared in %s): sigma max %.3f mm, "
              "worst axis sigma error %.1f%%\n",
              reference == ReferenceBody::kMirror1 ? "M1" : "C", in_m1 ? "M1" : "C",
              std::sqrt(predicted_cov.eigenvalues().real().maxCoeff()), 100 * axis_error);
  return axis_error;
}

TEST(Triangulation, ModelCovarianceMatchesMonteCarloOverModels) {
  const std::vector<std::string> names = {"fx", "cx", "cy", "dist_k1", "mirror1.tx", "mirror1.rx",
                                          "mirror2.tz", "mirror2.ry", "reflex.rx", "c1"};
  const std::vector<double> sigma = {0.8, 0.4, 0.4, 2e-4, 0.03, 3e-4, 0.05, 4e-4, 2e-4, 0.02};
  EXPECT_LT(ModelCovarianceVsMonteCarlo(ReferenceBody::kCam, ReferenceBody::kCam, names, sigma, 0.6),
            0.10);
}

// Relative to mirror 1's body: with the uncertainty all in mirror 1's pose, a point held in C
// and one held in M1 spread differently (in M1 the body's tilt no longer turns the point about
// the pinhole), and each prediction must match its own Monte Carlo and not the other's.
TEST(Triangulation, ModelCovarianceRelativeToMirror1MatchesMonteCarlo) {
  const std::vector<std::string> names = {"mirror1.rx", "mirror1.ry", "mirror1.tx", "mirror1.ty",
                                          "mirror1.tz"};
  const std::vector<double> sigma = {2e-4, 2e-4, 0.02, 0.02, 0.02};
  const auto m1 = ReferenceBody::kMirror1, cam = ReferenceBody::kCam;
  EXPECT_LT(ModelCovarianceVsMonteCarlo(m1, m1, names, sigma, 0.0), 0.10);
  EXPECT_LT(ModelCovarianceVsMonteCarlo(cam, cam, names, sigma, 0.0), 0.10);
  // Measured 1.6% in each own frame, 19% for C held but compared in M1: the oracle tells.
  EXPECT_GT(ModelCovarianceVsMonteCarlo(cam, m1, names, sigma, 0.0), 0.15);
}

// A model file written by a real calibration (`omnistereo calibrate` of a rendered session of
// big_rig_misaligned at 1280x960, started from big_rig_ideal; see scripts/rmse_table.sh): its
// `calibration:` section names, values and covariance must address the model's own parameters in
// the model's units (values equal to the parameters: radians, not degrees), and triangulating
// exact pixels with models drawn from that covariance must spread the point as the propagated
// model covariance says (the full 18 x 18 matrix with its strong fx-fy-tz correlations).
TEST(Triangulation, CalibratedModelFileCovarianceMatchesMonteCarloOverModels) {
  const RigParams calibrated = io::ReadModelFile(std::string(OMNI_SOURCE_DIR) +
                                                 "/tests/model/data/calibrated_big_rig.yaml");
  ASSERT_TRUE(calibrated.calibration.has_value());
  const CalibrationInfo& info = *calibrated.calibration;
  const size_t n = info.parameters.size();
  ASSERT_EQ(info.values.size(), n);
  ASSERT_EQ(info.covariance.size(), n * n);
  RigParams copy = calibrated;
  for (size_t i = 0; i < n; ++i) {
    const double* p = ParameterByName(&copy, info.parameters[i]);
    ASSERT_NE(p, nullptr) << info.parameters[i];
    EXPECT_NEAR(*p, info.values[i], 1e-9 * (1 + std::abs(*p))) << info.parameters[i];
    EXPECT_NEAR(std::sqrt(info.covariance[i * n + i]), info.sigma[i], 1e-9 * info.sigma[i])
        << info.parameters[i];
  }
  const RigModel model(calibrated);
  const Triangulator triangulator(model);
  ASSERT_TRUE(triangulator.has_model_covariance());
  ASSERT_TRUE(triangulator.unknown_parameters().empty());

  Eigen::MatrixXd cov(n, n);
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j) cov(i, j) = info.covariance[i * n + j];
  }
  // Draws by the symmetric square root (the matrix is nearly singular along fx-fy).
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(cov);
  const Eigen::MatrixXd root = eig.eigenvectors() *
                               eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (double rho : {1000.0, 4000.0}) {
    const Eigen::Vector3d point = StereoPoint(calibrated, rho, 0.9, 0.5);
    const auto px1 = model.Project(point, Mirror::kOne);
    const auto px2 = model.Project(point, Mirror::kTwo);
    ASSERT_TRUE(px1 && px2);
    TriangulationOptions options;
    options.sigma_px = 0;  // the model's uncertainty alone
    options.model_covariance = true;
    const auto predicted = triangulator.Triangulate(*px1, *px2, options);
    ASSERT_TRUE(predicted.has_value());
    EXPECT_TRUE(predicted->covariance.isApprox(predicted->model_covariance));
    std::vector<Eigen::Vector3d> estimates;
    for (int k = 0; k < 1500; ++k) {
      Eigen::VectorXd z(n);
      for (size_t i = 0; i < n; ++i) z[i] = normal(rng);
      const Eigen::VectorXd delta = root * z;
      RigParams sample = calibrated;
      sample.calibration.reset();
      for (size_t i = 0; i < n; ++i) *ParameterByName(&sample, info.parameters[i]) += delta[i];
      const auto est = Triangulator{RigModel(sample)}.Midpoint(*px1, *px2);
      ASSERT_TRUE(est.has_value());
      estimates.push_back(*est);
    }
    const double axis_error =
        WorstAxisSigmaRatioError(predicted->covariance, SampleCovariance(estimates));
    std::printf("calibrated model covariance at %.0f m: sigma max %.3f mm, worst axis sigma "
                "error %.1f%%\n", rho / 1000,
                std::sqrt(predicted->covariance.eigenvalues().real().maxCoeff()), 100 * axis_error);
    // 1500 draws: ~1.8% standard error of a sigma; 10% is well beyond it.
    EXPECT_LT(axis_error, 0.10);
  }
}

TEST(Triangulation, RejectsPixelsOfTheWrongRingOrInTheHole) {
  const RigModel model(io::ReadModelFile(kMisalignedRig));
  const Triangulator triangulator(model);
  const auto s = StereoSamples(model, {1000}, 1, 1).at(0);
  EXPECT_FALSE(triangulator.Triangulate(s.px2, s.px1).has_value());  // rings swapped
  EXPECT_FALSE(triangulator.Triangulate(s.px1, s.px1).has_value());  // both outer
  const Eigen::Vector2d centre(model.params().camera[kCx], model.params().camera[kCy]);
  EXPECT_FALSE(triangulator.Triangulate(s.px1, centre).has_value());  // through the hole
  EXPECT_EQ(ModelParameterIndex("mirror1.tx"), 16);
  EXPECT_EQ(ModelParameterIndex("camera.fx"), 0);
  EXPECT_EQ(ModelParameterIndex("mirror2.k2"), 13);
  EXPECT_EQ(ModelParameterIndex("nonsense"), -1);
}

}  // namespace
}  // namespace omni
