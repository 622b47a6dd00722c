#include "detectors/lips/lip_intrinsics.h"

#include <cmath>

#include <ceres/ceres.h>

#include "model/lip.h"
#include "model/rig_frames.h"
#include "model/rig_parameters.h"

namespace omni::detectors {
namespace {

constexpr double kMaxInnerOffsetMm = 5.0;

// Residual of one edge point (model/lip.h LipEdgeResidual, as in the calibration) with camera =
// (f, f, cx, cy, 0), the inner ring's (the reflex plane's tilt rx, ry and mirror 2's axial offset
// tz) and every other block at the nominal values.
struct LipPointResidual {
  LipPointResidual(const RigModel* model, LipPath path, double radius, const Eigen::Vector2d& pixel)
      : model(model), path(path), radius(radius), pixel(pixel) {}

  template <typename T>
  bool operator()(const T* intrinsics, const T* inner, const T* phi, T* residual) const {
    const RigParams& rig = model->params();
    // Every block at its nominal value (constants), then the coordinates refined here.
    T flat[kRigParameterCount];
    RigBlocks<T> blocks;
    for (int b = 0; b < kRigBlockCount; ++b) {
      const RigBlockId id = static_cast<RigBlockId>(b);
      T* block = flat + BlockOffset(id);
      for (int i = 0; i < kRigBlocks[id].size; ++i) block[i] = T(BlockIn(rig, id)[i]);
      blocks[id] = block;
    }
    T* camera = flat + BlockOffset(kCameraBlock);
    camera[kFx] = camera[kFy] = intrinsics[0];
    camera[kCx] = intrinsics[1];
    camera[kCy] = intrinsics[2];
    camera[kSkew] = T(0);
    T* reflex = flat + BlockOffset(kReflexBlock);
    reflex[kReflexRx] = inner[0];
    reflex[kReflexRy] = inner[1];
    flat[BlockOffset(kPose2Block) + kTz] = inner[2];
    return LipEdgeResidual(blocks, model->fixed(), path, T(radius), T(LipOf(rig, path).z), phi[0],
                           model->fixed().r_ref, pixel, residual);
  }

  const RigModel* model;
  LipPath path;
  double radius;
  Eigen::Vector2d pixel;
};

// Distortion-free pinhole pixel of a point or direction (z > 0) in C.
Eigen::Vector2d Pinhole(const RigParams& rig, const Eigen::Vector3d& p) {
  const auto& c = rig.camera;
  return Eigen::Vector2d(c[kFx] * p.x() / p.z() + c[kSkew] * p.y() / p.z() + c[kCx],
                         c[kFy] * p.y() / p.z() + c[kCy]);
}

}  // namespace

LipReferencePoints LipReferencePointsOf(const RigParams& rig) {
  const Pose<double> cam_from_m1 = PoseFromBlock(rig.mirror1_pose.data());
  const Pose<double> cam_from_m2 = PoseFromBlock(rig.mirror2_pose.data());
  const Eigen::Vector3d ez(0, 0, 1);
  const Plane<double> reflex_in_cam =
      ReflexPlaneInCam(rig.mirror1_pose.data(), rig.reflex.data(), rig.d);
  const Eigen::Vector3d n = reflex_in_cam.normal;
  // Mirror 2's axis direction towards -z (from the reflex disc to mirror 2) mirrored in the plane.
  const Eigen::Vector3d axis2_down = -cam_from_m2.Rotate(ez);
  LipReferencePoints out;
  out.axis1 = Pinhole(rig, cam_from_m1.Rotate(ez));
  out.axis2 = Pinhole(rig, cam_from_m2.Rotate(ez));
  out.lip1_centre = Pinhole(rig, cam_from_m1 * Eigen::Vector3d(0, 0, rig.lip1.z));
  out.lip2_centre_in_reflex =
      Pinhole(rig, MirrorPoint(reflex_in_cam, cam_from_m2 * Eigen::Vector3d(0, 0, rig.lip2.z)));
  out.axis2_in_reflex = Pinhole(rig, axis2_down - 2 * axis2_down.dot(n) * n);
  return out;
}

std::optional<LipIntrinsics> InitialIntrinsicsFromLipsOf(const Observations& detections,
                                                       const RigModel& nominal) {
  std::vector<LipEdgeObservation> edges;
  for (const auto& image : detections.images) {
    edges.insert(edges.end(), image.lips.begin(), image.lips.end());
  }
  return InitialIntrinsicsFromLips(edges, nominal);
}

std::optional<LipIntrinsics> InitialIntrinsicsFromLips(const std::vector<LipEdgeObservation>& edges,
                                                       const RigModel& nominal,
                                                       bool fit_reflex_tilt) {
  const RigParams& rig = nominal.params();
  double intrinsics[3] = {0.5 * (rig.camera[kFx] + rig.camera[kFy]), rig.camera[kCx],
                          rig.camera[kCy]};
  // The inner ring's place and scale against the outer: the reflex tilt, mirror 2's axial offset.
  double inner[3] = {rig.reflex[kReflexRx], rig.reflex[kReflexRy], rig.mirror2_pose[kTz]};
  struct Point {
    LipPath path;
    double radius;
    Eigen::Vector2d pixel;
  };
  std::vector<Point> points;
  for (const LipEdgeObservation& edge : edges) {
    if (!edge.path || !edge.circle || LipOwner(*edge.path) != edge.mirror) continue;
    const LipPath path = *edge.path;
    const LipCircle circle = *edge.circle;
    const Lip& lip = LipOf(rig, path);
    const double radius = circle == LipCircle::kInner ? lip.r_inner : lip.r_outer;
    for (const Eigen::Vector2d& p : edge.points) points.push_back(Point{path, radius, p});
  }
  if (points.size() < 20) return std::nullopt;

  // Azimuths: the image azimuth about the principal point is close to the lip point's azimuth
  // on a nearly coaxial rig (every path reflects in planes through the axis); a scan around it
  // (+-0.12 rad: every 0.01, then every 0.002 around the nearest; 36 projections instead of 121
  // at 0.002 throughout, which were 3/4 of the fit's time) finds a valid start where the point's
  // image is nearest, the solve then refines it. Points whose circle image is nowhere near
  // (> 20 px) are left out.
  constexpr double kCoarseStep = 0.01, kFineStep = 0.002, kMaxStart = 20.0;
  constexpr int kCoarseHalf = 12, kFineHalf = 5;
  std::vector<double> phi;
  std::vector<Point> used;
  for (const Point& p : points) {
    double best = HUGE_VAL, best_phi = 0;
    const auto scan = [&](double from, double step, int half) {
      for (int k = -half; k <= half; ++k) {
        Eigen::Vector2d q;
        const double a = from + k * step;
        if (!ProjectLipEdge(RigBlocksOf(rig), nominal.fixed(), p.path, p.radius,
                            LipOf(rig, p.path).z, a, nominal.fixed().r_ref, &q)) {
          continue;
        }
        const double dist = (q - p.pixel).norm();
        if (dist < best) {
          best = dist;
          best_phi = a;
        }
      }
    };
    scan(std::atan2(p.pixel.y() - intrinsics[2], p.pixel.x() - intrinsics[1]), kCoarseStep,
         kCoarseHalf);
    if (best == HUGE_VAL) continue;
    scan(best_phi, kFineStep, kFineHalf);
    if (best < kMaxStart) {
      used.push_back(p);
      phi.push_back(best_phi);
    }
  }
  if (used.size() < 20) return std::nullopt;
  points.swap(used);
  // The reflex tilt only moves the via_mirror2 edge: its centre against the mirror-1 edges'; mirror
  // 2's axial offset its radius (the inner ring's scale). Each stands for every misalignment that
  // moves (scales) the inner ring against the outer: a design's via_mirror2 edge is otherwise off by
  // ~1 px on a misaligned rig at 1280x960 (docs/experiments.md, 2026-11-29: every post found).
  int via_mirror2 = 0;
  for (const Point& p : points) via_mirror2 += p.path == LipPath::kViaMirror2;
  const bool fit_tilt = fit_reflex_tilt && via_mirror2 >= 20;
  ceres::Problem problem;
  for (std::size_t i = 0; i < points.size(); ++i) {
    auto* cost = new ceres::AutoDiffCostFunction<LipPointResidual, 2, 3, 3, 1>(
        new LipPointResidual(&nominal, points[i].path, points[i].radius, points[i].pixel));
    problem.AddResidualBlock(cost, new ceres::HuberLoss(1.0), intrinsics, inner, &phi[i]);
  }
  if (!fit_tilt) {
    problem.SetParameterBlockConstant(inner);
  } else {
    // A stand-in, bounded to what a built rig's inner ring could need (a few mm of offset).
    problem.SetParameterLowerBound(inner, 2, rig.mirror2_pose[kTz] - kMaxInnerOffsetMm);
    problem.SetParameterUpperBound(inner, 2, rig.mirror2_pose[kTz] + kMaxInnerOffsetMm);
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = 50;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (summary.termination_type != ceres::CONVERGENCE) return std::nullopt;

  LipIntrinsics out;
  out.f = intrinsics[0];
  out.cx = intrinsics[1];
  out.cy = intrinsics[2];
  if (fit_tilt) {
    out.reflex_tilt = Eigen::Vector2d(inner[0], inner[1]);
    out.mirror2_tz = inner[2];
  }
  out.n_points = static_cast<int>(points.size());
  // Residual spread and the intrinsics' standard deviations from the Gauss-Newton normal
  // equations, the per-azimuth unknowns eliminated (Ceres' covariance of the 3-block).
  double sum2 = 0;
  std::vector<double> residuals;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), nullptr, &residuals, nullptr, nullptr);
  for (double r : residuals) sum2 += r * r;
  const int dof = std::max<int>(1, static_cast<int>(residuals.size()) - 3 -
                                        (fit_tilt ? 3 : 0) -
                                        static_cast<int>(points.size()));
  out.rms_px = std::sqrt(sum2 / points.size());
  ceres::Covariance::Options cov_options;
  cov_options.num_threads = 1;
  ceres::Covariance covariance(cov_options);
  std::vector<std::pair<const double*, const double*>> blocks = {{intrinsics, intrinsics}};
  if (covariance.Compute(blocks, &problem)) {
    double c[9];
    covariance.GetCovarianceBlock(intrinsics, intrinsics, c);
    const double s2 = sum2 / dof;  // unit-weight variance (the Huber loss is ~quadratic here)
    out.sigma_f = std::sqrt(std::max(0.0, c[0] * s2));
    out.sigma_cx = std::sqrt(std::max(0.0, c[4] * s2));
    out.sigma_cy = std::sqrt(std::max(0.0, c[8] * s2));
  }
  return out;
}

}  // namespace omni::detectors
