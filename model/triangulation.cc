// The heavy Jet instantiations of triangulation (the reprojection-optimal refinement and the
// model-covariance Jacobian) live in this one file. ceres/jet.h is header-only: model/ still
// links no Ceres library.
#include "model/triangulation.h"

#include <array>
#include <cmath>
#include <map>

#include <Eigen/Cholesky>
#include <ceres/jet.h>

namespace omni {
namespace {

using Jet3 = ceres::Jet<double, 3>;
using JetP = ceres::Jet<double, kNumModelParameters>;

std::array<double, kNumModelParameters> FlatParameters(const RigParams& p) {
  std::array<double, kNumModelParameters> flat{};
  for (int b = 0; b < kRigBlockCount; ++b) {
    const double* block = BlockIn(p, static_cast<RigBlockId>(b));
    for (int i = 0; i < kRigBlocks[b].size; ++i) flat[kRigBlocks[b].offset + i] = block[i];
  }
  return flat;
}

// The flat parameters as Jets: constants (seed = false) or seeded with their own index.
template <typename J>
std::array<J, kNumModelParameters> JetParameters(const RigParams& p, bool seed) {
  const auto flat = FlatParameters(p);
  std::array<J, kNumModelParameters> jets;
  for (int i = 0; i < kNumModelParameters; ++i) {
    jets[i] = J(flat[i]);
    if (seed) jets[i].v[i] = 1.0;
  }
  return jets;
}

template <typename J>
RigBlocks<J> BlocksOf(const std::array<J, kNumModelParameters>& x) {
  RigBlocks<J> blocks;
  for (int b = 0; b < kRigBlockCount; ++b) {
    blocks[static_cast<RigBlockId>(b)] = &x[BlockOffset(static_cast<RigBlockId>(b))];
  }
  return blocks;
}

template <typename J>
Mirror1Path<J> Path1(const std::array<J, kNumModelParameters>& x, const RigFixed& fixed) {
  return Mirror1Path<J>::FromBlocks(BlocksOf(x), fixed);
}

template <typename J>
Mirror2Path<J> Path2(const std::array<J, kNumModelParameters>& x, const RigFixed& fixed) {
  return Mirror2Path<J>::FromBlocks(BlocksOf(x), fixed);
}

}  // namespace

Eigen::Vector4d PixelCovariance(const TriangulationOptions& options) {
  const double s1 = options.sigma_px;
  const double s2 = options.sigma_px_ring2 > 0 ? options.sigma_px_ring2 : options.sigma_px;
  return Eigen::Vector4d(s1 * s1, s1 * s1, s2 * s2, s2 * s2);
}

// The Jet (d/d point) paths, built once per Triangulator.
struct TriangulatorJetPaths {
  Mirror1Path<Jet3> path1;
  Mirror2Path<Jet3> path2;
};

int ModelParameterIndex(const std::string& name) {
  const RigParameter* p = FindRigParameter(name);
  return p ? p->flat : -1;
}

Triangulator::Triangulator(const RigModel& model)
    : model_(model), model_covariance_(decltype(model_covariance_)::Zero()) {
  const auto constants = JetParameters<Jet3>(model_.params(), /*seed=*/false);
  jet_paths_ = std::make_shared<const TriangulatorJetPaths>(
      TriangulatorJetPaths{Path1(constants, model_.fixed()), Path2(constants, model_.fixed())});
  const auto& cal = model_.params().calibration;
  if (!cal) return;
  const size_t n = cal->parameters.size();
  if (cal->covariance.size() != n * n) return;
  std::vector<int> index(n);
  for (size_t i = 0; i < n; ++i) {
    index[i] = ModelParameterIndex(cal->parameters[i]);
    if (index[i] < 0) unknown_parameters_.push_back(cal->parameters[i]);
  }
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j) {
      if (index[i] >= 0 && index[j] >= 0) {
        model_covariance_(index[i], index[j]) = cal->covariance[i * n + j];
      }
    }
  }
  has_model_covariance_ = n > unknown_parameters_.size();
}

std::optional<Eigen::Vector3d> Triangulator::Midpoint(const Eigen::Vector2d& pixel1,
                                                      const Eigen::Vector2d& pixel2,
                                                      double* gap_mm) const {
  const auto ray1 = model_.Unproject(pixel1);
  const auto ray2 = model_.Unproject(pixel2);
  if (!ray1 || !ray2 || ray1->mirror != Mirror::kOne || ray2->mirror != Mirror::kTwo) {
    return std::nullopt;
  }
  Eigen::Vector3d midpoint;
  double lambda1 = 0, lambda2 = 0;
  if (!MidpointOnCommonPerpendicular<double>(ray1->ray.origin, ray1->ray.direction,
                                             ray2->ray.origin, ray2->ray.direction, &midpoint,
                                             &lambda1, &lambda2)) {
    return std::nullopt;
  }
  if (!(lambda1 > 0) || !(lambda2 > 0) || !midpoint.allFinite()) return std::nullopt;
  if (gap_mm) {
    *gap_mm = ((ray1->ray.origin + lambda1 * ray1->ray.direction) -
               (ray2->ray.origin + lambda2 * ray2->ray.direction))
                  .norm();
  }
  return midpoint;
}

std::optional<TriangulatedPoint> Triangulator::Triangulate(
    const Eigen::Vector2d& pixel1, const Eigen::Vector2d& pixel2,
    const TriangulationOptions& options) const {
  TriangulatedPoint out;
  const auto midpoint = Midpoint(pixel1, pixel2, &out.gap_mm);
  if (!midpoint) return std::nullopt;
  out.point_in_cam = *midpoint;

  if (options.method == TriangulationMethod::kReprojection) {
    auto refined = Refine(pixel1, pixel2, out, options);
    if (!refined) return std::nullopt;
    out = *refined;
  } else {
    // A = d midpoint / d pixels by central differences (one-sided at a ring's edge).
    const double h = options.jacobian_step_px;
    const Eigen::Vector4d m(pixel1.x(), pixel1.y(), pixel2.x(), pixel2.y());
    for (int k = 0; k < 4; ++k) {
      auto at = [&](double step) {
        Eigen::Vector4d q = m;
        q[k] += step;
        return Midpoint(q.head<2>(), q.tail<2>());
      };
      const auto plus = at(h), minus = at(-h);
      if (plus && minus) {
        out.jacobian_px.col(k) = (*plus - *minus) / (2 * h);
      } else if (plus) {
        out.jacobian_px.col(k) = (*plus - out.point_in_cam) / h;
      } else if (minus) {
        out.jacobian_px.col(k) = (out.point_in_cam - *minus) / h;
      } else {
        return std::nullopt;
      }
    }
  }

  // [uncertainty_propagation]: Sigma = A Omega A^T with Omega = sigma_px^2 I_4
  // [pixel_covariance_matrix], plus the model's own uncertainty mapped to pixels.
  out.covariance = out.jacobian_px * PixelCovariance(options).asDiagonal() *
                   out.jacobian_px.transpose();
  if (options.model_covariance && has_model_covariance_) {
    Eigen::Matrix4d model_px;
    if (!ModelPixelCovariance(out.point_in_cam, &model_px, options.reference)) return std::nullopt;
    out.model_covariance = out.jacobian_px * model_px * out.jacobian_px.transpose();
    out.covariance += out.model_covariance;
  }
  return out;
}

bool Triangulator::ProjectBoth(const Eigen::Vector3d& point_in_cam, Eigen::Vector4d* pixels,
                               Eigen::Matrix<double, 4, 3>* jacobian) const {
  Vec3<Jet3> point;
  for (int i = 0; i < 3; ++i) point[i] = Jet3(point_in_cam[i], i);
  Vec2<Jet3> px[2];
  if (!jet_paths_->path1.Project(model_.fixed(), point, &px[0])) return false;
  if (!jet_paths_->path2.Project(model_.fixed(), point, &px[1])) return false;
  for (int r = 0; r < 4; ++r) {
    const Jet3& value = px[r / 2][r % 2];
    (*pixels)[r] = value.a;
    if (jacobian) jacobian->row(r) = value.v.transpose();
  }
  return pixels->allFinite();
}

bool Triangulator::ModelPixelCovariance(const Eigen::Vector3d& point_in_cam,
                                        Eigen::Matrix4d* covariance,
                                        ReferenceBody reference) const {
  covariance->setZero();
  const auto x = JetParameters<JetP>(model_.params(), /*seed=*/true);
  Vec3<JetP> point = point_in_cam.cast<JetP>();
  if (reference == ReferenceBody::kMirror1) {
    // The point fixed in M1: its place in C moves with mirror 1's pose parameters.
    const Pose<double> cam_from_mirror1 = PoseFromBlock(model_.params().mirror1_pose.data());
    const Eigen::Vector3d point_in_mirror1 = cam_from_mirror1.Inverse() * point_in_cam;
    point = PoseFromBlock(&x[BlockOffset(kPose1Block)]) * point_in_mirror1.cast<JetP>();
  }
  Vec2<JetP> px[2];
  if (!Path1(x, model_.fixed()).Project(model_.fixed(), point, &px[0])) return false;
  if (!Path2(x, model_.fixed()).Project(model_.fixed(), point, &px[1])) return false;
  if (!has_model_covariance_) return true;
  Eigen::Matrix<double, 4, kNumModelParameters> j_theta;
  for (int r = 0; r < 4; ++r) j_theta.row(r) = px[r / 2][r % 2].v.transpose();
  *covariance = j_theta * model_covariance_ * j_theta.transpose();
  return covariance->allFinite();
}

std::optional<TriangulatedPoint> Triangulator::Refine(const Eigen::Vector2d& pixel1,
                                                      const Eigen::Vector2d& pixel2,
                                                      const TriangulatedPoint& start,
                                                      const TriangulationOptions& options) const {
  // Gauss-Newton on 0.5 (m - proj(P))^T W (m - proj(P)), W = Omega^-1 (per-ring weights; all 1
  // for equal sigmas), from the midpoint, halving a step that leaves a ring or does not decrease
  // the cost. At the optimum d P / d m = (J^T W J)^-1 J^T W.
  const Eigen::Vector4d m(pixel1.x(), pixel1.y(), pixel2.x(), pixel2.y());
  const Eigen::Vector4d omega = PixelCovariance(options);
  const Eigen::Vector4d w = omega.maxCoeff() > 0 ? Eigen::Vector4d(omega.minCoeff() * omega.cwiseInverse())
                                                 : Eigen::Vector4d::Ones();  // scale-free
  auto weighted_cost = [&](const Eigen::Vector4d& r) { return r.dot(w.asDiagonal() * r); };
  TriangulatedPoint out = start;
  Eigen::Vector4d px;
  Eigen::Matrix<double, 4, 3> J;
  if (!ProjectBoth(out.point_in_cam, &px, &J)) return std::nullopt;
  double cost = weighted_cost(m - px);
  int it = 0;
  for (; it < options.max_iterations; ++it) {
    const Eigen::Matrix3d normal = J.transpose() * w.asDiagonal() * J;
    const Eigen::Vector3d step = normal.ldlt().solve(J.transpose() * w.asDiagonal() * (m - px));
    if (!step.allFinite()) return std::nullopt;
    double scale = 1.0;
    bool accepted = false;
    for (int halving = 0; halving < 20; ++halving) {
      const Eigen::Vector3d trial = out.point_in_cam + scale * step;
      Eigen::Vector4d trial_px;
      Eigen::Matrix<double, 4, 3> trial_J;
      if (ProjectBoth(trial, &trial_px, &trial_J) && weighted_cost(m - trial_px) <= cost) {
        out.point_in_cam = trial;
        px = trial_px;
        J = trial_J;
        cost = weighted_cost(m - trial_px);
        accepted = true;
        break;
      }
      scale *= 0.5;
    }
    if (!accepted || step.norm() * scale <= 1e-12 * (1.0 + out.point_in_cam.norm())) break;
  }
  const Eigen::Matrix3d normal = J.transpose() * w.asDiagonal() * J;
  const Eigen::Matrix3d normal_inv = normal.inverse();
  if (!normal_inv.allFinite()) return std::nullopt;
  out.jacobian_px = normal_inv * J.transpose() * w.asDiagonal();
  out.reprojection_rms_px = std::sqrt((m - px).squaredNorm() / 4.0);
  out.iterations = it;
  return out;
}

}  // namespace omni
