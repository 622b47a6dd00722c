// ComputeRigCovariance against dense brute force on a random linear least-squares problem with
// the calibration's structure (rig columns, considered columns, one 6-column block per pose):
//  - the noise covariance is the rig block of the inverse of the full normal matrix;
//  - the considered share is what re-solving the whole problem (rig + poses, considered held)
//    for a unit error in each considered value says: dx = sensitivity * dc.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <Eigen/SparseCore>

#include "calib/covariance.h"

namespace omni::calib {
namespace {

struct ArrowProblem {
  int n_rig = 4, n_considered = 2, n_poses = 3, rows_per_pose = 40;
  Eigen::MatrixXd dense;  // rows x (n_rig + n_considered + 6 n_poses)
};

ArrowProblem MakeProblem(unsigned seed) {
  ArrowProblem p;
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  const int cols = p.n_rig + p.n_considered + 6 * p.n_poses;
  p.dense = Eigen::MatrixXd::Zero(p.n_poses * p.rows_per_pose, cols);
  for (int k = 0; k < p.n_poses; ++k) {
    for (int r = 0; r < p.rows_per_pose; ++r) {
      const int row = k * p.rows_per_pose + r;
      for (int c = 0; c < p.n_rig + p.n_considered; ++c) p.dense(row, c) = g(rng);
      // A considered column that trades with rig column 0 (like the tangential distortion with
      // the camera-rotation valley).
      p.dense(row, p.n_rig) += 0.8 * p.dense(row, 0);
      for (int c = 0; c < 6; ++c) p.dense(row, p.n_rig + p.n_considered + 6 * k + c) = g(rng);
    }
  }
  return p;
}

Eigen::SparseMatrix<double, Eigen::RowMajor> Sparse(const Eigen::MatrixXd& m) {
  return m.sparseView();
}

TEST(RigCovariance, NoiseAndConsideredShareMatchDenseBruteForce) {
  const ArrowProblem p = MakeProblem(5);
  RigCovarianceOptions options;
  options.variance_factor = 0.7;
  options.considered_sigma = {0.3, 0.05};
  const RigCovariance cov = ComputeRigCovariance(Sparse(p.dense), p.n_rig, options);
  ASSERT_EQ(cov.observable.size(), static_cast<size_t>(p.n_rig));

  // Estimated columns: rig + poses (the considered ones are held).
  std::vector<int> estimated;
  for (int c = 0; c < p.n_rig; ++c) estimated.push_back(c);
  for (int c = p.n_rig + p.n_considered; c < p.dense.cols(); ++c) estimated.push_back(c);
  Eigen::MatrixXd j_est(p.dense.rows(), estimated.size());
  for (size_t i = 0; i < estimated.size(); ++i) j_est.col(i) = p.dense.col(estimated[i]);
  const Eigen::MatrixXd normal_inverse = (j_est.transpose() * j_est).inverse();
  const Eigen::MatrixXd noise = options.variance_factor * normal_inverse.topLeftCorner(p.n_rig, p.n_rig);
  EXPECT_LT((cov.noise_covariance - noise).norm(), 1e-9 * noise.norm());

  // A held value off by dc adds J_c dc to the data; the re-solved rig parameters move by dx.
  Eigen::MatrixXd sensitivity(p.n_rig, p.n_considered);
  for (int c = 0; c < p.n_considered; ++c) {
    const Eigen::VectorXd shift = p.dense.col(p.n_rig + c);
    const Eigen::VectorXd dx = j_est.colPivHouseholderQr().solve(shift);
    sensitivity.col(c) = dx.head(p.n_rig);
  }
  Eigen::Vector2d var(0.3 * 0.3, 0.05 * 0.05);
  const Eigen::MatrixXd share = sensitivity * var.asDiagonal() * sensitivity.transpose();
  EXPECT_GT(share(0, 0), 0.1 * noise(0, 0));  // the test means something: the share is sizable
  EXPECT_LT((cov.covariance - noise - share).norm(), 1e-9 * (noise + share).norm());
}

TEST(RigCovariance, NoConsideredColumnsGivesTheNoiseCovariance) {
  ArrowProblem p = MakeProblem(9);
  // Drop the considered columns: the layout is then rig + poses only.
  Eigen::MatrixXd j(p.dense.rows(), p.dense.cols() - p.n_considered);
  j << p.dense.leftCols(p.n_rig), p.dense.rightCols(6 * p.n_poses);
  const RigCovariance cov = ComputeRigCovariance(Sparse(j), p.n_rig, RigCovarianceOptions{});
  EXPECT_EQ((cov.covariance - cov.noise_covariance).norm(), 0.0);
  const Eigen::MatrixXd normal_inverse = (j.transpose() * j).inverse();
  EXPECT_LT((cov.covariance - normal_inverse.topLeftCorner(p.n_rig, p.n_rig)).norm(),
            1e-9 * cov.covariance.norm());
}

// Considered columns whose assumed sigma is updated by the data (a profile held for want of
// evidence): the covariance is the rig block of the full problem's inverse with those columns
// freed under a prior of that sigma (their prior rows added), i.e. what freeing them would
// report, while the estimate holds them; the other considered column keeps its plain share.
TEST(RigCovariance, UpdatedConsideredColumnsGiveTheFreedMarginalCovariance) {
  ArrowProblem p = MakeProblem(7);
  p.n_considered = 2;
  RigCovarianceOptions options;
  options.variance_factor = 0.7;
  options.considered_sigma = {0.3, 0.05};
  options.updated_considered = {0};  // column 0 trades with rig column 0 (MakeProblem)
  const RigCovariance cov = ComputeRigCovariance(Sparse(p.dense), p.n_rig, options);
  ASSERT_EQ(cov.observable.size(), static_cast<size_t>(p.n_rig));

  // Freed with a prior: the considered column 0 estimated, with a prior row of weight
  // sqrt(vf) / sigma (the data's rows have unit weight up to the variance factor vf).
  const int n = static_cast<int>(p.dense.cols());
  Eigen::MatrixXd normal = p.dense.transpose() * p.dense;
  normal(p.n_rig, p.n_rig) += options.variance_factor / (0.3 * 0.3);
  std::vector<int> estimated;  // rig, considered 0, poses
  for (int c = 0; c <= p.n_rig; ++c) estimated.push_back(c);
  for (int c = p.n_rig + p.n_considered; c < n; ++c) estimated.push_back(c);
  Eigen::MatrixXd n_est(estimated.size(), estimated.size());
  for (size_t a = 0; a < estimated.size(); ++a) {
    for (size_t b = 0; b < estimated.size(); ++b) n_est(a, b) = normal(estimated[a], estimated[b]);
  }
  const Eigen::MatrixXd freed =
      options.variance_factor * n_est.inverse().topLeftCorner(p.n_rig, p.n_rig);

  // The other considered column (held, plain share) is in both: take it out of ours by its
  // column, and compare with the freed marginal.
  const Eigen::VectorXd s1 = cov.considered_sensitivity.col(1) * cov.considered_column_sigma(1);
  EXPECT_DOUBLE_EQ(cov.considered_column_sigma(1), 0.05);
  const Eigen::MatrixXd ours = cov.covariance - s1 * s1.transpose();
  // The test means something: updating narrows the plain consider share of column 0.
  const Eigen::MatrixXd held_share = cov.covariance - cov.noise_covariance;
  EXPECT_LT(ours(0, 0), cov.noise_covariance(0, 0) + held_share(0, 0));
  EXPECT_GT(ours(0, 0), 1.2 * cov.noise_covariance(0, 0));
  // Column 1's sensitivity was taken with column 0 held; freed, it would differ, so compare the
  // covariance without column 1 against the freed problem without it.
  EXPECT_LT((ours - freed).norm(), 1e-9 * freed.norm()) << ours << "\n\n" << freed;
  // The updated column is a unit combination of the considered coordinates (here column 0).
  EXPECT_NEAR(std::abs(cov.considered_column_mix(0, 0)), 1.0, 1e-12);
  EXPECT_LT(cov.considered_column_sigma(0), 0.3);

  // "Not determined" asks what the data determine with the held values as they are: a bound
  // between rig 0's sigma without the updated column's share and with it keeps it observable
  // (it is in the sigma, not in the test); a bound below the rest names it.
  const double without = std::sqrt(cov.covariance(0, 0) -
                                   std::pow(cov.considered_sensitivity(0, 0) *
                                                cov.considered_column_sigma(0), 2));
  ASSERT_LT(without, 0.9 * std::sqrt(cov.covariance(0, 0)));
  options.nearly_unobservable_sigma = {0.5 * (without + std::sqrt(cov.covariance(0, 0))), 0, 0, 0};
  EXPECT_EQ(ComputeRigCovariance(Sparse(p.dense), p.n_rig, options).observable.size(),
            static_cast<size_t>(p.n_rig));
  options.nearly_unobservable_sigma[0] = 0.9 * without;
  EXPECT_EQ(ComputeRigCovariance(Sparse(p.dense), p.n_rig, options).unobservable,
            std::vector<int>{0});
}

// A nuisance parameter shared by everything (a single mirror's edge circle radius) eliminated
// last, densely: the remaining block's inverse is the full inverse's block, and the parameter's
// variance from the coupling is the full inverse's diagonal entry.
TEST(RigCovariance, ASharedNuisanceColumnEliminatedLastMatchesTheFullInverse) {
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = 6;
  Eigen::MatrixXd j(60, n + 1);
  for (int r = 0; r < j.rows(); ++r) {
    for (int c = 0; c <= n; ++c) j(r, c) = g(rng);
    j(r, n) += 0.7 * j(r, 0) - 0.4 * j(r, 3);  // coupled with the others
  }
  const Eigen::MatrixXd full = j.transpose() * j;
  Eigen::VectorXd coupling;
  double information = 0;
  const Eigen::MatrixXd reduced = EliminateLastColumn(full, &coupling, &information);
  const Eigen::MatrixXd full_inverse = full.inverse();
  const Eigen::MatrixXd cov = reduced.inverse();
  EXPECT_LT((cov - full_inverse.topLeftCorner(n, n)).norm(), 1e-12 * full_inverse.norm());
  const double variance = 1.0 / information + coupling.dot(cov * coupling);
  EXPECT_NEAR(variance, full_inverse(n, n), 1e-12 * full_inverse(n, n));
}

}  // namespace
}  // namespace omni::calib
