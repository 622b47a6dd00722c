#include "calib/projection_uncertainty.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <optional>

#include "model/model_compare.h"
#include "model/rig_frames.h"
#include "model/rig_model.h"
#include "model/rig_parameters.h"

namespace omni::calib {
namespace {

// Every 4th stereo-band point of model_compare.h (~500 at 1 m): the figure is an RMS over a
// smooth field, so a quarter of the points gives it to ~1%.
constexpr int kPointStride = 4;

// The band's points in C and in M1 (at `rig`), and their pixels' derivatives with respect to
// the parameters `names` (central differences of step `steps`), per ring: rows 2 per usable
// point. A point counts where every perturbed model projects it in both rings.
struct BandJacobian {
  Eigen::MatrixXd in_mirror1[2], in_cam[2];
  std::vector<BandPoint> points;  // the usable points, in row order
};

BandJacobian Jacobians(const RigParams& rig, const std::vector<std::string>& names,
                       const std::vector<double>& steps, double range_mm) {
  const RigModel model(rig);
  const int rings = rig.Paths();
  std::vector<BandPoint> band = StereoBandPoints(model, range_mm);
  std::vector<Eigen::Vector3d> in_cam, in_mirror1;
  const Pose<double> cam_from_mirror1 = PoseFromBlock(rig.mirror1_pose.data());
  const Pose<double> mirror1_from_cam = cam_from_mirror1.Inverse();
  for (size_t i = 0; i < band.size(); i += kPointStride) {
    in_cam.push_back(band[i].point_in_cam);
    in_mirror1.push_back(mirror1_from_cam * band[i].point_in_cam);
  }
  const int n_points = static_cast<int>(in_cam.size());
  const int n = static_cast<int>(names.size());
  // pixels[frame][ring][param][sign] per point.
  std::vector<std::optional<Eigen::Vector2d>> px[2][2][2];
  Eigen::MatrixXd d[2][2];
  for (int f = 0; f < 2; ++f) {
    for (int m = 0; m < 2; ++m) d[f][m] = Eigen::MatrixXd::Zero(2 * n_points, n);
  }
  std::vector<bool> ok(n_points, true);
  for (int j = 0; j < n; ++j) {
    for (int sign = 0; sign < 2; ++sign) {
      RigParams perturbed = rig;
      *ParameterOf(&perturbed, names[j]) += (sign ? 1 : -1) * steps[j];
      const RigModel other(perturbed);
      const Pose<double> other_cam_from_mirror1 = PoseFromBlock(perturbed.mirror1_pose.data());
      for (int p = 0; p < n_points; ++p) {
        for (int f = 0; f < 2; ++f) {
          const Eigen::Vector3d point = f == 0 ? other_cam_from_mirror1 * in_mirror1[p] : in_cam[p];
          for (int m = 0; m < rings; ++m) {
            const auto pixel = other.Project(point, m == 0 ? Mirror::kOne : Mirror::kTwo);
            if (!pixel) {
              ok[p] = false;
              continue;
            }
            const Eigen::Vector2d v = (sign ? 0.5 : -0.5) * *pixel / steps[j];
            d[f][m].block<2, 1>(2 * p, j) += v;
          }
        }
      }
    }
  }
  BandJacobian out;
  int kept = 0;
  for (int p = 0; p < n_points; ++p) {
    if (!ok[p]) continue;
    ++kept;
    out.points.push_back(band[p * kPointStride]);
  }
  for (int f = 0; f < 2; ++f) {
    for (int m = 0; m < rings; ++m) {
      Eigen::MatrixXd& target = f == 0 ? out.in_mirror1[m] : out.in_cam[m];
      target.resize(2 * kept, n);
      int row = 0;
      for (int p = 0; p < n_points; ++p) {
        if (!ok[p]) continue;
        target.middleRows(row, 2) = d[f][m].middleRows(2 * p, 2);
        row += 2;
      }
    }
  }
  return out;
}

double Step(const std::string& name, double sigma) {
  // A tenth of a sigma where it is known (the pixels are linear far beyond that); otherwise a
  // small fixed step in the parameter's unit: 1e-5 for a body's pose, the reflex plane and the
  // profiles (rad, mm), 1e-4 for the camera, the distortion and the shapes.
  if (sigma > 0) return 0.1 * sigma;
  const RigParameter* p = FindRigParameter(name);
  return p && BlockOf(*p) >= kPose1Block ? 1e-5 : 1e-4;
}

}  // namespace

std::vector<PointUncertainty> ProjectionUncertaintyMap(const CalibrationResult& result,
                                                       double range_mm) {
  std::vector<PointUncertainty> out;
  const int n = static_cast<int>(result.estimate.names.size());
  if (n == 0) return out;
  // Columns: the refined parameters, then the named considered ones (their direct effect).
  std::vector<std::string> names = result.estimate.names;
  std::vector<double> steps;
  for (int i = 0; i < n; ++i) steps.push_back(Step(names[i], result.uncertainty.sigma(i)));
  for (const auto& c : result.uncertainty.considered) {
    names.push_back(c.name);
    steps.push_back(Step(c.name, c.sigma));
  }
  const BandJacobian jac = Jacobians(result.estimate.rig, names, steps, range_mm);
  out.resize(jac.points.size());
  for (size_t p = 0; p < jac.points.size(); ++p) {
    out[p].point_in_cam = jac.points[p].point_in_cam;
    out[p].pixel[0] = jac.points[p].pixel[0];
    out[p].pixel[1] = jac.points[p].pixel[1];
  }
  const int n_named = static_cast<int>(result.uncertainty.considered.size());
  const int n_columns = static_cast<int>(result.uncertainty.considered_column_sigma.size());
  const bool considered =
      result.uncertainty.considered_sensitivity.cols() == n_columns && n_columns > 0;
  // Covariance without the considered share, rebuilt from the sensitivity.
  Eigen::MatrixXd noise = result.uncertainty.covariance;
  for (int c = 0; considered && c < n_columns; ++c) {
    const Eigen::VectorXd s = result.uncertainty.considered_sensitivity.col(c);
    noise -= result.uncertainty.considered_column_sigma(c) *
             result.uncertainty.considered_column_sigma(c) * s * s.transpose();
  }
  for (int f = 0; f < 2; ++f) {
    for (int m = 0; m < 2; ++m) {
      const Eigen::MatrixXd& j_all = f == 0 ? jac.in_mirror1[m] : jac.in_cam[m];
      if (j_all.rows() == 0) continue;
      const Eigen::MatrixXd j = j_all.leftCols(n);
      // Pixel noise: J C J^T per row; each considered column: its direct effect plus the
      // estimate's response to it, times its sigma.
      Eigen::VectorXd variance = (j * noise).cwiseProduct(j).rowwise().sum();
      for (size_t p = 0; p < out.size(); ++p) {
        const double v = std::max(variance(2 * p) + variance(2 * p + 1), 0.0);
        (f == 0 ? out[p].noise_in_mirror1_px : out[p].noise_in_cam_px)[m] = std::sqrt(v);
      }
      for (int c = 0; considered && c < n_columns; ++c) {
        Eigen::VectorXd effect = j * result.uncertainty.considered_sensitivity.col(c);
        const Eigen::MatrixXd& mix = result.uncertainty.considered_column_mix;
        if (mix.rows() == n_columns && mix.cols() == n_columns) {
          // A combination of held coordinates (a held profile's updated tolerance): its direct
          // effect is the same combination of theirs.
          if (n_named > 0) effect += j_all.middleCols(n, n_named) * mix.col(c).head(n_named);
        } else if (c < n_named) {
          effect += j_all.col(n + c);
        }
        variance += result.uncertainty.considered_column_sigma(c) *
                    result.uncertainty.considered_column_sigma(c) * effect.cwiseAbs2();
      }
      for (size_t p = 0; p < out.size(); ++p) {
        const double v = std::max(variance(2 * p) + variance(2 * p + 1), 0.0);
        (f == 0 ? out[p].in_mirror1_px : out[p].in_cam_px)[m] = std::sqrt(v);
      }
    }
  }
  return out;
}

ProjectionUncertainty RmsOf(const std::vector<PointUncertainty>& map) {
  ProjectionUncertainty out;
  if (map.empty()) return out;
  for (int m = 0; m < 2; ++m) {
    double sum_mirror1 = 0, sum_cam = 0;
    for (const PointUncertainty& p : map) {
      sum_mirror1 += p.in_mirror1_px[m] * p.in_mirror1_px[m];
      sum_cam += p.in_cam_px[m] * p.in_cam_px[m];
    }
    out.in_mirror1_px[m] = std::sqrt(sum_mirror1 / map.size());
    out.in_cam_px[m] = std::sqrt(sum_cam / map.size());
  }
  out.points = static_cast<int>(map.size());
  return out;
}

ProjectionUncertainty PredictProjectionUncertainty(const CalibrationResult& result,
                                                   double range_mm) {
  return RmsOf(ProjectionUncertaintyMap(result, range_mm));
}

ProjectionErrorShare ShareOfProjectionError(const CalibrationResult& result,
                                            const RigParams& truth, double range_mm) {
  ProjectionErrorShare out;
  const int n = static_cast<int>(result.estimate.names.size());
  if (n == 0) return out;
  std::vector<double> steps;
  Eigen::VectorXd error(n);
  for (int i = 0; i < n; ++i) {
    steps.push_back(Step(result.estimate.names[i], result.uncertainty.sigma(i)));
    error(i) = result.estimate.values(i) - *ParameterOf(truth, result.estimate.names[i]);
  }
  const BandJacobian jac = Jacobians(result.estimate.rig, result.estimate.names, steps, range_mm);
  // The table's groups (RigBlock::group) in its order.
  for (const RigBlock& b : kRigBlocks) {
    if (std::find(out.groups.begin(), out.groups.end(), b.group) == out.groups.end()) {
      out.groups.push_back(b.group);
    }
  }
  auto group_of = [&out](const std::string& name) {
    const RigParameter* p = FindRigParameter(name);
    const auto it = std::find(out.groups.begin(), out.groups.end(), p ? GroupOf(*p) : "");
    return it == out.groups.end() ? 0 : static_cast<int>(it - out.groups.begin());
  };
  out.group_px.assign(out.groups.size(), {0, 0});
  for (int m = 0; m < 2; ++m) {
    const Eigen::MatrixXd& j = jac.in_mirror1[m];
    const double points = j.rows() / 2;
    if (points == 0) continue;
    out.total_px[m] = std::sqrt((j * error).squaredNorm() / points);
    for (size_t g = 0; g < out.groups.size(); ++g) {
      Eigen::VectorXd part = Eigen::VectorXd::Zero(n);
      for (int i = 0; i < n; ++i) {
        if (group_of(result.estimate.names[i]) == static_cast<int>(g)) part(i) = error(i);
      }
      out.group_px[g][m] = std::sqrt((j * part).squaredNorm() / points);
    }
  }
  // Mahalanobis distance over the observable parameters, on the correlation matrix (Jacobi
  // scaled: px, rad and mm compare) with a pseudo-inverse (the camera-rotation valley makes it
  // nearly singular).
  const Eigen::VectorXd scale =
      result.uncertainty.covariance.diagonal().cwiseMax(1e-300).cwiseSqrt();
  const Eigen::MatrixXd correlation = scale.cwiseInverse().asDiagonal() *
                                      result.uncertainty.covariance *
                                      scale.cwiseInverse().asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(correlation);
  const Eigen::VectorXd projected =
      eig.eigenvectors().transpose() * error.cwiseQuotient(scale);
  out.chi2 = 0;
  for (int k = 0; k < n; ++k) {
    if (eig.eigenvalues()(k) > 1e-10 * eig.eigenvalues().maxCoeff()) {
      out.chi2 += projected(k) * projected(k) / eig.eigenvalues()(k);
    }
  }
  out.dof = n;
  return out;
}

}  // namespace omni::calib
