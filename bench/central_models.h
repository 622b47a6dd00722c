// Central single-viewpoint camera models used as BASELINES for our non-central model
// (bench/central_baselines.cc): the figures a user would get from the usual tools on the same
// corners, fitted on training photos and scored on held-out photos with only the board poses
// re-estimated (model fixed), as BabelCalib and mrcal report them.
//
// Two models, each ONE templated projection (double and ceres::Jet) over a raw parameter array:
//  - Unified (Mei 2007, as cv::omnidir implements it): params[10] =
//      fx, fy, s, cx, cy, xi, k1, k2, p1, p2.
//    Xs = P / |P|; m = (Xs.x, Xs.y) / (Xs.z + xi); m_d = radial-tangential(m; k1, k2, p1, p2);
//    u = fx m_d.x + s m_d.y + cx, v = fy m_d.y + cy. Valid where Xs.z + xi > 0 (and |P| > 0).
//  - Polynomial (Scaramuzza 2006, OCamCalib): params[9] = cx, cy, c, d, e, a0, a2, a3, a4.
//    A pixel's centred, de-affined coordinates (u', v') with rho = |(u', v')| see the ray
//    (u', v', f(rho)), f(rho) = a0 + a2 rho^2 + a3 rho^3 + a4 rho^4 (no rho^1 term: f'(0) = 0);
//    u = c u' + d v' + cx, v = e u' + v' + cy. Forward: rho is the smallest positive root of
//    Z rho - r f(rho) = 0 (r = |(X, Y)|), found in double, then ONE Newton step in T so a Jet
//    carries the implicit derivative. Valid where such a root exists and the step is regular.
//
// The board is planar (z = 0 in its frame); poses are cam_from_board as angle-axis + translation
// (metres or whatever unit the board points use).
#ifndef OMNI_BENCH_CENTRAL_MODELS_H_
#define OMNI_BENCH_CENTRAL_MODELS_H_

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <ceres/jet.h>

namespace omni::central {

enum class ModelKind { kUnified, kPolynomial };
constexpr int kUnifiedParams = 10;
constexpr int kPolynomialParams = 9;
int NumParams(ModelKind kind);
const char* ModelName(ModelKind kind);
// Parameter names in array order (for reports).
std::vector<std::string> ParamNames(ModelKind kind);

// One photo's corners: board points (z = 0) and their measured pixels, in the same order.
struct BoardView {
  std::string name;
  std::vector<Eigen::Vector3d> points_in_board;
  std::vector<Eigen::Vector2d> pixels;
};

// cam_from_board: rotation as angle-axis, then translation.
struct Pose {
  double angle_axis_translation[6] = {0, 0, 0, 0, 0, 0};
};

inline double ScalarValue(double x) { return x; }
template <typename T, int N>
double ScalarValue(const ceres::Jet<T, N>& x) { return ScalarValue(x.a); }

template <typename T>
bool UnifiedProject(const T* params, const T* point_in_cam, T* pixel) {
  using std::sqrt;
  const T& fx = params[0]; const T& fy = params[1]; const T& s = params[2];
  const T& cx = params[3]; const T& cy = params[4]; const T& xi = params[5];
  const T& k1 = params[6]; const T& k2 = params[7]; const T& p1 = params[8]; const T& p2 = params[9];
  const T norm = sqrt(point_in_cam[0] * point_in_cam[0] + point_in_cam[1] * point_in_cam[1] +
                      point_in_cam[2] * point_in_cam[2]);
  if (!(ScalarValue(norm) > 0)) return false;
  const T denom = point_in_cam[2] / norm + xi;
  if (!(ScalarValue(denom) > 1e-9)) return false;
  const T x = point_in_cam[0] / norm / denom;
  const T y = point_in_cam[1] / norm / denom;
  const T r2 = x * x + y * y;
  const T radial = T(1) + k1 * r2 + k2 * r2 * r2;
  const T xd = x * radial + T(2) * p1 * x * y + p2 * (r2 + T(2) * x * x);
  const T yd = y * radial + p1 * (r2 + T(2) * y * y) + T(2) * p2 * x * y;
  pixel[0] = fx * xd + s * yd + cx;
  pixel[1] = fy * yd + cy;
  return true;
}

// The smallest positive real root of sum_k coeffs[k] rho^k (coeffs in increasing order), if any.
std::optional<double> SmallestPositiveRoot(const std::vector<double>& coeffs);

template <typename T>
bool PolynomialProject(const T* params, const T* point_in_cam, T* pixel) {
  using std::sqrt;
  const T& cx = params[0]; const T& cy = params[1];
  const T& c = params[2]; const T& d = params[3]; const T& e = params[4];
  const T& a0 = params[5]; const T& a2 = params[6]; const T& a3 = params[7]; const T& a4 = params[8];
  const T& X = point_in_cam[0]; const T& Y = point_in_cam[1]; const T& Z = point_in_cam[2];
  const T r = sqrt(X * X + Y * Y);
  const double r0 = ScalarValue(r);
  if (!(r0 > 1e-12)) return false;  // on the axis: the direction X / r is undefined
  // g(rho) = Z rho - r f(rho).
  const std::vector<double> g = {-r0 * ScalarValue(a0), ScalarValue(Z), -r0 * ScalarValue(a2),
                                 -r0 * ScalarValue(a3), -r0 * ScalarValue(a4)};
  const std::optional<double> root = SmallestPositiveRoot(g);
  if (!root) return false;
  const T rho0(*root);
  const T g_value = Z * rho0 - r * (a0 + a2 * rho0 * rho0 + a3 * rho0 * rho0 * rho0 +
                                    a4 * rho0 * rho0 * rho0 * rho0);
  const T g_slope = Z - r * (T(2) * a2 * rho0 + T(3) * a3 * rho0 * rho0 +
                             T(4) * a4 * rho0 * rho0 * rho0);
  if (!(std::abs(ScalarValue(g_slope)) > 1e-12)) return false;
  const T rho = rho0 - g_value / g_slope;
  const T up = rho * X / r;
  const T vp = rho * Y / r;
  pixel[0] = c * up + d * vp + cx;
  pixel[1] = e * up + vp + cy;
  return true;
}

template <typename T>
bool Project(ModelKind kind, const T* params, const T* point_in_cam, T* pixel) {
  return kind == ModelKind::kUnified ? UnifiedProject(params, point_in_cam, pixel)
                                     : PolynomialProject(params, point_in_cam, pixel);
}

// The unit ray of a pixel (the inverse of Project up to scale); nullopt where the model has none.
std::optional<Eigen::Vector3d> Unproject(ModelKind kind, const std::vector<double>& params,
                                         const Eigen::Vector2d& pixel);

// Pixels of a view's board points under a pose; invalid projections give nullopt.
std::vector<std::optional<Eigen::Vector2d>> ProjectView(ModelKind kind,
                                                        const std::vector<double>& params,
                                                        const Pose& pose, const BoardView& view);

// Per-corner 2D reprojection error |projected - measured| (px); an invalid projection counts as
// a miss (returned in *invalid, not in the errors).
std::vector<double> CornerErrors(ModelKind kind, const std::vector<double>& params,
                                 const Pose& pose, const BoardView& view, int* invalid = nullptr);
// sqrt(mean of squared 2D errors): "RMS per corner", px.
double Rms(const std::vector<double>& errors);

// Initial cam_from_board from the model's rays: DLT homography board plane -> rays (rays as
// projective points, so boards beside or behind the camera work), decomposed and orthonormalised.
std::optional<Pose> InitialPoseFromRays(ModelKind kind, const std::vector<double>& params,
                                        const BoardView& view);

// Board pose with the model FIXED (Ceres, squared pixel residuals); from InitialPoseFromRays
// unless `start` is given. nullopt where no start pose exists or the solve fails.
std::optional<Pose> FitPose(ModelKind kind, const std::vector<double>& params,
                            const BoardView& view, const std::optional<Pose>& start = {});

struct FitResult {
  bool ok = false;
  std::string message;              // why not, when !ok
  std::vector<double> params;       // the model (NumParams)
  std::vector<int> used;            // indices of the views the fit used
  std::vector<Pose> poses;          // one per `used`
  double tool_rms = 0;              // the fitting tool's own figure (omnidir's return value)
};

// cv::omnidir::calibrate on the views (skew fixed unless flags say otherwise). It silently drops
// views whose initialisation fails: `used` says which it kept.
FitResult FitUnifiedOmnidir(const std::vector<BoardView>& views, int width, int height,
                            int omnidir_flags);

// Scaramuzza's linear estimate (centre at (cx0, cy0), affine identity): per view the 6 pose terms
// without the z row, r31 / r32 from orthonormality, then a0, a2..a4 and each view's t_z jointly.
// Views whose linear step fails are dropped (reported in `used`).
FitResult LinearPolynomialInit(const std::vector<BoardView>& views, double cx0, double cy0);

// The linear estimate, then every parameter and pose refined by Ceres (reprojection error).
FitResult FitPolynomial(const std::vector<BoardView>& views, int width, int height);

}  // namespace omni::central

#endif  // OMNI_BENCH_CENTRAL_MODELS_H_
