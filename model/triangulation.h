// Triangulation of a pixel pair (one pixel in each ring) for any rig model, with its covariance
// (docs/design.md, Conventions, the paper's section "Range from Triangulation").
//
//  - MidpointOnCommonPerpendicular: the midpoint of the common perpendicular of two (skew) rays
//    [midpoint_on_common_perpendicular] ([linear_system_common_perpendicular] solved in closed
//    form); templated so that Jets differentiate it.
//  - Triangulator::Triangulate: back-projects both pixels with RigModel::Unproject (the exact,
//    non-central rays, origin = reflection point), takes the midpoint and, optionally, refines it
//    to the reprojection-optimal point (Gauss-Newton on both rings' projections, Jacobians by
//    ceres::Jet through the same templated ProjectViaMirror1/2 code that calibration uses).
//  - Covariance by first-order propagation [uncertainty_propagation]:
//      Sigma = A (sigma_px^2 I_4 + Sigma_model) A^T,   A = d point / d (u1, v1, u2, v2)
//    [jacobian_matrix_triangulation_function], [pixel_covariance_matrix]. For the midpoint, A is
//    the central difference of the whole Unproject -> midpoint chain (step 1e-3 px: Unproject is
//    exact ray tracing, smooth to rounding, so the truncation error is ~(1e-3 / 10 px)^2 relative
//    and the rounding error ~1e-13 / 1e-3); for the refined point A = (J^T J)^-1 J^T with
//    J = d pixels / d point.
//    Sigma_model (optional, a calibrated model only) is the parameter covariance of the model's
//    `calibration:` section mapped to pixels, J_theta Sigma_theta J_theta^T with J_theta = d pixels
//    / d parameters of the projections of the triangulated point: to first order, changing the
//    model by d theta moves the point exactly as moving the pixels by -J_theta d theta does
//    (the rays still meet at the same point), so d point / d theta = -A J_theta.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include "model/rig_model.h"
#include "model/rig_parameters.h"
#include "model/types.h"

namespace omni {

// [midpoint_on_common_perpendicular]: rays o_i + lambda_i d_i (d_i need not be unit). The
// closest points G1 = o1 + lambda1 d1, G2 = o2 + lambda2 d2 solve the 2x2 normal equations of
// [linear_system_common_perpendicular]; the midpoint is (G1 + G2) / 2. False if the rays are
// parallel to rounding (|d1 x d2|^2 <= 1e-24 |d1|^2 |d2|^2).
template <typename T>
bool MidpointOnCommonPerpendicular(const Vec3<T>& o1, const Vec3<T>& d1, const Vec3<T>& o2,
                                   const Vec3<T>& d2, Vec3<T>* midpoint, T* lambda1 = nullptr,
                                   T* lambda2 = nullptr) {
  const Vec3<T> w = o1 - o2;
  const T a = d1.dot(d1), b = d1.dot(d2), c = d2.dot(d2);
  const T d = d1.dot(w), e = d2.dot(w);
  const T den = a * c - b * b;  // = |d1 x d2|^2
  if (!(den > T(1e-24) * a * c)) return false;
  const T l1 = (b * e - c * d) / den;
  const T l2 = (a * e - b * d) / den;
  *midpoint = T(0.5) * (o1 + l1 * d1 + o2 + l2 * d2);
  if (lambda1) *lambda1 = l1;
  if (lambda2) *lambda2 = l2;
  return true;
}

enum class TriangulationMethod {
  kMidpoint,      // [midpoint_on_common_perpendicular] of the back-projected rays
  kReprojection,  // the midpoint refined to minimise the reprojection error in both rings
};

// The body that the model part of a point's covariance holds the point fixed to. kCam: the
// camera frame C. kMirror1: mirror 1's body M1 (reflex disc included). A calibration fixes the
// mirror bodies relative to each other and to the scene much better than the camera frame's
// orientation: a lens's tangential distortion (dist_p1, dist_p2, held at 0) images nearly like a
// rotation of the camera against the bodies, so the calibrated C may be turned by up to ~0.1 deg
// (the tilts' sigma) while M1 is not (see docs/design.md, Calibration). Points measured relative
// to M1 carry only the bodies' own uncertainty.
enum class ReferenceBody { kCam, kMirror1 };

struct TriangulationOptions {
  TriangulationMethod method = TriangulationMethod::kMidpoint;
  ReferenceBody reference = ReferenceBody::kCam;  // for the model part of the covariance
  double sigma_px = 1.0;          // [pixel_covariance_matrix]; the paper assumes 1 px
  // Ring 2's (inner ring's) pixel sigma if > 0, else sigma_px: the two rings' corner errors differ
  // (the inner ring is upsampled and blurrier), so Omega = diag(s1^2, s1^2, s2^2, s2^2). The
  // refined point then minimises the reprojection error weighted by 1 / sigma^2 (maximum
  // likelihood under that noise).
  double sigma_px_ring2 = 0.0;
  bool model_covariance = false;  // add the calibration's parameter covariance (if any)
  double jacobian_step_px = 1e-3; // central differences of the midpoint (see the file comment)
  int max_iterations = 10;        // Gauss-Newton of the reprojection-optimal point
};

struct TriangulatedPoint {
  Eigen::Vector3d point_in_cam = Eigen::Vector3d::Zero();  // mm
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();    // mm^2, pixel + model parts
  // The model part alone, A Sigma_model_px A^T (zero unless options.model_covariance and the
  // model carries a covariance), so a caller can re-weight the pixel part.
  Eigen::Matrix3d model_covariance = Eigen::Matrix3d::Zero();
  Eigen::Matrix<double, 3, 4> jacobian_px;                 // d point / d (u1, v1, u2, v2)
  double gap_mm = 0;                // length of the common perpendicular of the two rays
  double reprojection_rms_px = 0;   // of the returned point in both rings (kReprojection only)
  int iterations = 0;               // Gauss-Newton iterations (kReprojection only)
};

// A calibration covariance's parameter (FindRigParameter's spellings) in the flat order of
// model/rig_parameters.h (its `flat`); -1 for an unknown name.
constexpr int kNumModelParameters = kRigParameterCount;
int ModelParameterIndex(const std::string& name);

// The diagonal of [pixel_covariance_matrix] Omega for (u1, v1, u2, v2) under these options.
Eigen::Vector4d PixelCovariance(const TriangulationOptions& options);

struct TriangulatorJetPaths;  // the Jet paths (triangulation.cc)

class Triangulator {
 public:
  // Keeps a copy of the model. If the model has a `calibration:` section, its covariance is
  // mapped to the flat parameter order; names that ModelParameterIndex does not know are listed
  // by unknown_parameters() (their rows and columns are then ignored).
  explicit Triangulator(const RigModel& model);

  // pixel1 must back-project via mirror 1 (outer ring), pixel2 via mirror 2 (inner ring), and the
  // point must lie in front of both rays; otherwise nullopt.
  std::optional<TriangulatedPoint> Triangulate(const Eigen::Vector2d& pixel1,
                                               const Eigen::Vector2d& pixel2,
                                               const TriangulationOptions& options = {}) const;

  // The midpoint of the rays of two pixels, without covariance; nullopt as above.
  std::optional<Eigen::Vector3d> Midpoint(const Eigen::Vector2d& pixel1,
                                          const Eigen::Vector2d& pixel2,
                                          double* gap_mm = nullptr) const;

  // Both projections of point_in_cam (u1, v1, u2, v2) and their 4x3 Jacobian w.r.t. the point
  // (Jets through Mirror1Path / Mirror2Path). False if either projection is invalid.
  bool ProjectBoth(const Eigen::Vector3d& point_in_cam, Eigen::Vector4d* pixels,
                   Eigen::Matrix<double, 4, 3>* jacobian) const;

  // The 4x4 pixel covariance that the model's parameter covariance induces at point_in_cam
  // (J_theta Sigma_theta J_theta^T) for a point held fixed to `reference` while the parameters
  // vary; zero if the model carries no covariance. False if either projection is invalid.
  bool ModelPixelCovariance(const Eigen::Vector3d& point_in_cam, Eigen::Matrix4d* covariance,
                            ReferenceBody reference = ReferenceBody::kCam) const;

  bool has_model_covariance() const { return has_model_covariance_; }
  const std::vector<std::string>& unknown_parameters() const { return unknown_parameters_; }
  const RigModel& model() const { return model_; }

 private:
  std::optional<TriangulatedPoint> Refine(const Eigen::Vector2d& pixel1,
                                          const Eigen::Vector2d& pixel2,
                                          const TriangulatedPoint& start,
                                          const TriangulationOptions& options) const;

  RigModel model_;
  std::shared_ptr<const TriangulatorJetPaths> jet_paths_;
  bool has_model_covariance_ = false;
  Eigen::Matrix<double, kNumModelParameters, kNumModelParameters> model_covariance_;
  std::vector<std::string> unknown_parameters_;
};

}  // namespace omni
