#include "bench/central_models.h"

#include <algorithm>
#include <cstdio>
#include <limits>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/ccalib/omnidir.hpp>
#include <opencv2/core.hpp>
#include <unsupported/Eigen/Polynomials>

namespace omni::central {
namespace {

// One corner's pixel residual for a model block and a cam_from_board block (Snavely-style).
template <ModelKind kKind>
struct ReprojectionError {
  ReprojectionError(const Eigen::Vector2d& observed, const Eigen::Vector3d& point_in_board)
      : observed_(observed), point_in_board_(point_in_board) {}

  template <typename T>
  bool operator()(const T* model, const T* cam_from_board, T* residual) const {
    const T point[3] = {T(point_in_board_.x()), T(point_in_board_.y()), T(point_in_board_.z())};
    T point_in_cam[3];
    ceres::AngleAxisRotatePoint(cam_from_board, point, point_in_cam);
    for (int i = 0; i < 3; ++i) point_in_cam[i] += cam_from_board[3 + i];
    T pixel[2];
    if (!Project(kKind, model, point_in_cam, pixel)) return false;
    residual[0] = pixel[0] - T(observed_.x());
    residual[1] = pixel[1] - T(observed_.y());
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& observed,
                                     const Eigen::Vector3d& point_in_board) {
    constexpr int kN = kKind == ModelKind::kUnified ? kUnifiedParams : kPolynomialParams;
    return new ceres::AutoDiffCostFunction<ReprojectionError, 2, kN, 6>(
        new ReprojectionError(observed, point_in_board));
  }

  Eigen::Vector2d observed_;
  Eigen::Vector3d point_in_board_;
};

ceres::CostFunction* MakeCost(ModelKind kind, const Eigen::Vector2d& observed,
                              const Eigen::Vector3d& point_in_board) {
  return kind == ModelKind::kUnified
             ? ReprojectionError<ModelKind::kUnified>::Create(observed, point_in_board)
             : ReprojectionError<ModelKind::kPolynomial>::Create(observed, point_in_board);
}

ceres::Solver::Options SolverOptions(int max_iterations) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = max_iterations;
  options.num_threads = 1;  // deterministic sums
  options.function_tolerance = 1e-12;
  options.gradient_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  options.logging_type = ceres::SILENT;
  return options;
}

Pose PoseFromRotationTranslation(const Eigen::Matrix3d& cam_from_board_rotation,
                                 const Eigen::Vector3d& translation) {
  const Eigen::AngleAxisd angle_axis(cam_from_board_rotation);
  const Eigen::Vector3d rotation_vector = angle_axis.angle() * angle_axis.axis();
  Pose pose;
  for (int i = 0; i < 3; ++i) {
    pose.angle_axis_translation[i] = rotation_vector[i];
    pose.angle_axis_translation[3 + i] = translation[i];
  }
  return pose;
}

// The rotation nearest (Frobenius) to m.
Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& m) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) d(2, 2) = -1;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

}  // namespace

int NumParams(ModelKind kind) {
  return kind == ModelKind::kUnified ? kUnifiedParams : kPolynomialParams;
}

const char* ModelName(ModelKind kind) {
  return kind == ModelKind::kUnified ? "unified (cv::omnidir)" : "polynomial (OCamCalib-style)";
}

std::vector<std::string> ParamNames(ModelKind kind) {
  if (kind == ModelKind::kUnified)
    return {"fx", "fy", "s", "cx", "cy", "xi", "k1", "k2", "p1", "p2"};
  return {"cx", "cy", "c", "d", "e", "a0", "a2", "a3", "a4"};
}

std::optional<double> SmallestPositiveRoot(const std::vector<double>& coeffs) {
  int degree = static_cast<int>(coeffs.size()) - 1;
  double scale = 0;
  for (double c : coeffs) scale = std::max(scale, std::abs(c));
  if (!(scale > 0)) return std::nullopt;
  // Leading terms that vanish would make the companion matrix singular: drop them.
  while (degree > 0 && std::abs(coeffs[degree]) <= 1e-300) --degree;
  if (degree == 0) return std::nullopt;
  if (degree == 1) {
    const double root = -coeffs[0] / coeffs[1];
    if (root > 0) return root;
    return std::nullopt;
  }
  Eigen::VectorXd poly(degree + 1);
  for (int k = 0; k <= degree; ++k) poly[k] = coeffs[k];
  Eigen::PolynomialSolver<double, Eigen::Dynamic> solver(poly);
  std::optional<double> best;
  for (int i = 0; i < solver.roots().size(); ++i) {
    const std::complex<double> root = solver.roots()[i];
    if (std::abs(root.imag()) > 1e-8 * std::max(1.0, std::abs(root.real()))) continue;
    if (root.real() <= 0) continue;
    if (!best || root.real() < *best) best = root.real();
  }
  return best;
}

std::optional<Eigen::Vector3d> Unproject(ModelKind kind, const std::vector<double>& params,
                                         const Eigen::Vector2d& pixel) {
  if (kind == ModelKind::kUnified) {
    const double fx = params[0], fy = params[1], s = params[2], cx = params[3], cy = params[4];
    const double xi = params[5], k1 = params[6], k2 = params[7], p1 = params[8], p2 = params[9];
    const double yd = (pixel.y() - cy) / fy;
    const double xd = (pixel.x() - cx - s * yd) / fx;
    // Undistort by fixed-point iteration (as cv::undistortPoints does).
    double x = xd, y = yd;
    for (int it = 0; it < 50; ++it) {
      const double r2 = x * x + y * y;
      const double radial = 1 + k1 * r2 + k2 * r2 * r2;
      const double dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
      const double dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
      x = (xd - dx) / radial;
      y = (yd - dy) / radial;
    }
    // Lift onto the unit sphere: the inverse of m = Xs.xy / (Xs.z + xi).
    const double r2 = x * x + y * y;
    const double discriminant = 1 + (1 - xi * xi) * r2;
    if (discriminant < 0) return std::nullopt;
    const double factor = (xi + std::sqrt(discriminant)) / (r2 + 1);
    return Eigen::Vector3d(factor * x, factor * y, factor - xi).normalized();
  }
  const double cx = params[0], cy = params[1], c = params[2], d = params[3], e = params[4];
  const double a0 = params[5], a2 = params[6], a3 = params[7], a4 = params[8];
  // [u - cx; v - cy] = [c d; e 1] [u'; v'].
  const double det = c - d * e;
  if (std::abs(det) < 1e-12) return std::nullopt;
  const double du = pixel.x() - cx, dv = pixel.y() - cy;
  const double up = (du - d * dv) / det;
  const double vp = (c * dv - e * du) / det;
  const double rho = std::hypot(up, vp);
  const double f = a0 + a2 * rho * rho + a3 * rho * rho * rho + a4 * rho * rho * rho * rho;
  return Eigen::Vector3d(up, vp, f).normalized();
}

std::vector<std::optional<Eigen::Vector2d>> ProjectView(ModelKind kind,
                                                        const std::vector<double>& params,
                                                        const Pose& pose, const BoardView& view) {
  std::vector<std::optional<Eigen::Vector2d>> out;
  out.reserve(view.points_in_board.size());
  for (const Eigen::Vector3d& point : view.points_in_board) {
    double point_in_cam[3];
    ceres::AngleAxisRotatePoint(pose.angle_axis_translation, point.data(), point_in_cam);
    for (int i = 0; i < 3; ++i) point_in_cam[i] += pose.angle_axis_translation[3 + i];
    Eigen::Vector2d pixel;
    if (Project(kind, params.data(), point_in_cam, pixel.data()))
      out.push_back(pixel);
    else
      out.push_back(std::nullopt);
  }
  return out;
}

std::vector<double> CornerErrors(ModelKind kind, const std::vector<double>& params,
                                 const Pose& pose, const BoardView& view, int* invalid) {
  const std::vector<std::optional<Eigen::Vector2d>> projected =
      ProjectView(kind, params, pose, view);
  std::vector<double> errors;
  int misses = 0;
  for (size_t i = 0; i < projected.size(); ++i) {
    if (projected[i])
      errors.push_back((*projected[i] - view.pixels[i]).norm());
    else
      ++misses;
  }
  if (invalid) *invalid = misses;
  return errors;
}

double Rms(const std::vector<double>& errors) {
  if (errors.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0;
  for (double e : errors) sum += e * e;
  return std::sqrt(sum / errors.size());
}

std::optional<Pose> InitialPoseFromRays(ModelKind kind, const std::vector<double>& params,
                                        const BoardView& view) {
  const int n = static_cast<int>(view.points_in_board.size());
  if (n < 4) return std::nullopt;
  std::vector<Eigen::Vector3d> rays;
  std::vector<Eigen::Vector3d> plane_points;  // (X, Y, 1)
  for (int i = 0; i < n; ++i) {
    const std::optional<Eigen::Vector3d> ray = Unproject(kind, params, view.pixels[i]);
    if (!ray) continue;
    rays.push_back(*ray);
    plane_points.emplace_back(view.points_in_board[i].x(), view.points_in_board[i].y(), 1.0);
  }
  if (rays.size() < 4) return std::nullopt;
  // ray x (H p) = 0, all three rows (rank 2): with only two, rays near z = 0 lose a constraint.
  Eigen::MatrixXd a(3 * rays.size(), 9);
  a.setZero();
  for (size_t i = 0; i < rays.size(); ++i) {
    const Eigen::Vector3d& b = rays[i];
    const Eigen::RowVector3d p = plane_points[i].transpose();
    a.block<1, 3>(3 * i, 3) = -b.z() * p;
    a.block<1, 3>(3 * i, 6) = b.y() * p;
    a.block<1, 3>(3 * i + 1, 0) = b.z() * p;
    a.block<1, 3>(3 * i + 1, 6) = -b.x() * p;
    a.block<1, 3>(3 * i + 2, 0) = -b.y() * p;
    a.block<1, 3>(3 * i + 2, 3) = b.x() * p;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Eigen::Matrix3d homography;
  homography << h.segment<3>(0).transpose(), h.segment<3>(3).transpose(), h.segment<3>(6).transpose();
  double agreement = 0;
  for (size_t i = 0; i < rays.size(); ++i) agreement += rays[i].dot(homography * plane_points[i]);
  const double scale = (agreement >= 0 ? 2.0 : -2.0) /
                       (homography.col(0).norm() + homography.col(1).norm());
  homography *= scale;
  Eigen::Matrix3d rotation;
  rotation.col(0) = homography.col(0);
  rotation.col(1) = homography.col(1);
  rotation.col(2) = homography.col(0).cross(homography.col(1));
  return PoseFromRotationTranslation(NearestRotation(rotation), homography.col(2));
}

std::optional<Pose> FitPose(ModelKind kind, const std::vector<double>& params,
                            const BoardView& view, const std::optional<Pose>& start) {
  std::optional<Pose> pose = start ? start : InitialPoseFromRays(kind, params, view);
  if (!pose) return std::nullopt;
  std::vector<double> model = params;
  ceres::Problem problem;
  for (size_t i = 0; i < view.pixels.size(); ++i)
    problem.AddResidualBlock(MakeCost(kind, view.pixels[i], view.points_in_board[i]), nullptr,
                             model.data(), pose->angle_axis_translation);
  problem.SetParameterBlockConstant(model.data());
  ceres::Solver::Summary summary;
  ceres::Solve(SolverOptions(100), &problem, &summary);
  if (!summary.IsSolutionUsable()) return std::nullopt;
  return pose;
}

FitResult FitUnifiedOmnidir(const std::vector<BoardView>& views, int width, int height,
                            int omnidir_flags) {
  FitResult result;
  std::vector<cv::Mat> object_points, image_points;
  for (const BoardView& view : views) {
    cv::Mat object(1, static_cast<int>(view.points_in_board.size()), CV_64FC3);
    cv::Mat image(1, static_cast<int>(view.pixels.size()), CV_64FC2);
    for (size_t i = 0; i < view.pixels.size(); ++i) {
      object.at<cv::Vec3d>(0, i) = cv::Vec3d(view.points_in_board[i].x(),
                                             view.points_in_board[i].y(),
                                             view.points_in_board[i].z());
      image.at<cv::Vec2d>(0, i) = cv::Vec2d(view.pixels[i].x(), view.pixels[i].y());
    }
    object_points.push_back(object);
    image_points.push_back(image);
  }
  cv::Mat camera_matrix, xi, distortion, idx;
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    result.tool_rms = cv::omnidir::calibrate(
        object_points, image_points, cv::Size(width, height), camera_matrix, xi, distortion, rvecs,
        tvecs, omnidir_flags,
        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 300, 1e-10), idx);
  } catch (const cv::Exception& e) {
    result.message = std::string("cv::omnidir::calibrate failed: ") + e.what();
    return result;
  }
  if (idx.empty() || rvecs.empty()) {
    result.message = "cv::omnidir::calibrate kept no view";
    return result;
  }
  cv::Mat idx_int;
  idx.convertTo(idx_int, CV_32S);
  for (int i = 0; i < static_cast<int>(idx_int.total()); ++i)
    result.used.push_back(idx_int.ptr<int>()[i]);
  std::sort(result.used.begin(), result.used.end());
  // rvecs/tvecs follow idx's order; re-read them per used view in our sorted order.
  std::vector<Pose> poses_by_view(views.size());
  for (int i = 0; i < static_cast<int>(idx_int.total()); ++i) {
    const int view = idx_int.ptr<int>()[i];
    cv::Mat r, t;
    rvecs[i].convertTo(r, CV_64F);
    tvecs[i].convertTo(t, CV_64F);
    for (int k = 0; k < 3; ++k) {
      poses_by_view[view].angle_axis_translation[k] = r.ptr<double>()[k];
      poses_by_view[view].angle_axis_translation[3 + k] = t.ptr<double>()[k];
    }
  }
  for (int view : result.used) result.poses.push_back(poses_by_view[view]);
  cv::Mat k64, d64, xi64;
  camera_matrix.convertTo(k64, CV_64F);
  distortion.convertTo(d64, CV_64F);
  xi.convertTo(xi64, CV_64F);
  result.params = {k64.at<double>(0, 0), k64.at<double>(1, 1), k64.at<double>(0, 1),
                   k64.at<double>(0, 2), k64.at<double>(1, 2), xi64.ptr<double>()[0],
                   d64.ptr<double>()[0], d64.ptr<double>()[1], d64.ptr<double>()[2],
                   d64.ptr<double>()[3]};
  result.ok = true;
  return result;
}

FitResult LinearPolynomialInit(const std::vector<BoardView>& views, double cx0, double cy0) {
  FitResult result;
  struct ViewTerms {
    int view;
    Eigen::Vector2d r1_xy, r2_xy, t_xy;  // rows 1-2 of r1, r2, t
    double r31, r32;
  };
  // Step 1 per view: u' (r21 X + r22 Y + t2) - v' (r11 X + r12 Y + t1) = 0 has no f in it.
  std::vector<std::vector<ViewTerms>> candidates(views.size());
  double rho_max = 1;
  for (size_t v = 0; v < views.size(); ++v) {
    const BoardView& view = views[v];
    const int n = static_cast<int>(view.pixels.size());
    if (n < 6) continue;
    Eigen::MatrixXd m(n, 6);
    for (int i = 0; i < n; ++i) {
      const double up = view.pixels[i].x() - cx0, vp = view.pixels[i].y() - cy0;
      const double x = view.points_in_board[i].x(), y = view.points_in_board[i].y();
      rho_max = std::max(rho_max, std::hypot(up, vp));
      m.row(i) << -vp * x, -vp * y, up * x, up * y, -vp, up;
    }
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(m, Eigen::ComputeFullV);
    Eigen::VectorXd h = svd.matrixV().col(5);  // r11 r12 r21 r22 t1 t2
    // lambda > 0: (u', v') points the same way as the board point's (x, y) in the camera.
    double agreement = 0;
    for (int i = 0; i < n; ++i) {
      const double up = view.pixels[i].x() - cx0, vp = view.pixels[i].y() - cy0;
      const double x = view.points_in_board[i].x(), y = view.points_in_board[i].y();
      agreement += up * (h[0] * x + h[1] * y + h[4]) + vp * (h[2] * x + h[3] * y + h[5]);
    }
    if (agreement < 0) h = -h;
    // r1 . r2 = 0 and |r1| = |r2| give r31, r32 up to a common sign.
    const double b = -(h[0] * h[1] + h[2] * h[3]);
    const double c = h[0] * h[0] + h[2] * h[2] - h[1] * h[1] - h[3] * h[3];
    const double r31_sq = (-c + std::sqrt(c * c + 4 * b * b)) / 2;
    double r31, r32;
    if (r31_sq > 1e-14 * (h[0] * h[0] + h[2] * h[2])) {
      r31 = std::sqrt(r31_sq);
      r32 = b / r31;
    } else {
      r31 = 0;
      r32 = std::sqrt(std::max(c, 0.0));
    }
    for (double sign : {1.0, -1.0}) {
      const double norm = std::sqrt(h[0] * h[0] + h[2] * h[2] + r31 * r31);
      ViewTerms terms;
      terms.view = static_cast<int>(v);
      terms.r1_xy = Eigen::Vector2d(h[0], h[2]) / norm;
      terms.r2_xy = Eigen::Vector2d(h[1], h[3]) / norm;
      terms.t_xy = Eigen::Vector2d(h[4], h[5]) / norm;
      terms.r31 = sign * r31 / norm;
      terms.r32 = sign * r32 / norm;
      candidates[v].push_back(terms);
    }
  }
  // Step 2: a0, a2, a3, a4 (in rho / rho_max units) and t3 per view, from the two rows with f.
  auto solve_step2 = [&](const std::vector<ViewTerms>& chosen, Eigen::VectorXd* solution) {
    int rows = 0;
    for (const ViewTerms& t : chosen) rows += 2 * static_cast<int>(views[t.view].pixels.size());
    const int unknowns = 4 + static_cast<int>(chosen.size());
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(rows, unknowns);
    Eigen::VectorXd rhs(rows);
    int row = 0;
    for (size_t k = 0; k < chosen.size(); ++k) {
      const ViewTerms& t = chosen[k];
      const BoardView& view = views[t.view];
      for (size_t i = 0; i < view.pixels.size(); ++i) {
        const double up = view.pixels[i].x() - cx0, vp = view.pixels[i].y() - cy0;
        const double x = view.points_in_board[i].x(), y = view.points_in_board[i].y();
        const double rho = std::hypot(up, vp) / rho_max;
        const Eigen::RowVector4d powers(1, rho * rho, rho * rho * rho, rho * rho * rho * rho);
        const double a_term = t.r1_xy[1] * x + t.r2_xy[1] * y + t.t_xy[1];  // camera y
        const double c_term = t.r1_xy[0] * x + t.r2_xy[0] * y + t.t_xy[0];  // camera x
        const double d_term = t.r31 * x + t.r32 * y;                         // camera z - t3
        // v' (D + t3) - f A = 0 and f C - u' (D + t3) = 0.
        a.block<1, 4>(row, 0) = -a_term * powers;
        a(row, 4 + k) = vp;
        rhs[row++] = -vp * d_term;
        a.block<1, 4>(row, 0) = c_term * powers;
        a(row, 4 + k) = -up;
        rhs[row++] = up * d_term;
      }
    }
    *solution = a.colPivHouseholderQr().solve(rhs);
    return (a * *solution - rhs).norm();
  };
  std::vector<ViewTerms> chosen;
  for (size_t v = 0; v < views.size(); ++v) {
    std::optional<ViewTerms> best;
    double best_residual = 0;
    // The two candidates mirror the board in the camera's xy plane (f -> -f, t3 -> -t3): keep
    // the one with a0 > 0, which puts the image centre's ray on +z as the unified model does.
    for (const ViewTerms& candidate : candidates[v]) {
      Eigen::VectorXd solution;
      const double residual = solve_step2({candidate}, &solution);
      if (!(solution[0] > 0) || !std::isfinite(residual)) continue;
      if (!best || residual < best_residual) {
        best = candidate;
        best_residual = residual;
      }
    }
    if (best) chosen.push_back(*best);
  }
  if (chosen.size() < 2) {
    result.message = "the linear polynomial estimate kept fewer than 2 views";
    return result;
  }
  Eigen::VectorXd solution;
  solve_step2(chosen, &solution);
  result.params = {cx0, cy0, 1, 0, 0, solution[0], solution[1] / std::pow(rho_max, 2),
                   solution[2] / std::pow(rho_max, 3), solution[3] / std::pow(rho_max, 4)};
  for (size_t k = 0; k < chosen.size(); ++k) {
    const ViewTerms& t = chosen[k];
    const Eigen::Vector3d r1(t.r1_xy[0], t.r1_xy[1], t.r31);
    const Eigen::Vector3d r2(t.r2_xy[0], t.r2_xy[1], t.r32);
    Eigen::Matrix3d rotation;
    rotation << r1, r2, r1.cross(r2);
    result.used.push_back(t.view);
    result.poses.push_back(PoseFromRotationTranslation(
        NearestRotation(rotation), Eigen::Vector3d(t.t_xy[0], t.t_xy[1], solution[4 + k])));
  }
  result.ok = true;
  return result;
}

FitResult FitPolynomial(const std::vector<BoardView>& views, int width, int height) {
  FitResult result = LinearPolynomialInit(views, width / 2.0, height / 2.0);
  if (!result.ok) return result;
  ceres::Problem problem;
  for (size_t k = 0; k < result.used.size(); ++k) {
    const BoardView& view = views[result.used[k]];
    for (size_t i = 0; i < view.pixels.size(); ++i)
      problem.AddResidualBlock(
          MakeCost(ModelKind::kPolynomial, view.pixels[i], view.points_in_board[i]), nullptr,
          result.params.data(), result.poses[k].angle_axis_translation);
  }
  ceres::Solver::Summary summary;
  ceres::Solve(SolverOptions(500), &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    result.ok = false;
    result.message = "the polynomial refinement failed: " + summary.message;
    return result;
  }
  result.tool_rms = std::sqrt(2 * summary.final_cost / std::max<int>(1, summary.num_residuals / 2));
  return result;
}

}  // namespace omni::central
