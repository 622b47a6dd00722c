#include "stereo/dense_triangulation.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <ceres/jet.h>
#include <opencv2/core/utility.hpp>

#include "model/triangulation.h"

namespace omni::stereo {

void RayTable::Build(const RigModel& model, Mirror mirror, const cv::Mat& map_x,
                     const cv::Mat& map_y, int begin, int end) {
  width = map_x.cols;
  row_begin = begin;
  row_end = end;
  const size_t n = static_cast<size_t>(end - begin) * width;
  ray.assign(6 * n, 0.0);
  jacobian.assign(12 * n, 0.f);
  valid.assign(n, 0);
  constexpr double h = 1e-3;  // px; see triangulation.h on the step
  auto unproject = [&](const Eigen::Vector2d& px, Eigen::Matrix<double, 6, 1>* out) {
    const auto r = model.Unproject(px);
    if (!r || r->mirror != mirror) return false;
    out->head<3>() = r->ray.origin;
    out->tail<3>() = r->ray.direction;
    return true;
  };
  cv::parallel_for_(cv::Range(begin, end), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      for (int u = 0; u < width; ++u) {
        const Eigen::Vector2d px(map_x.at<float>(v, u), map_y.at<float>(v, u));
        if (px.x() < 0) continue;
        Eigen::Matrix<double, 6, 1> centre, plus, minus;
        if (!unproject(px, &centre)) continue;
        Eigen::Matrix<double, 6, 2> J;
        bool ok = true;
        for (int k = 0; k < 2 && ok; ++k) {
          Eigen::Vector2d step = Eigen::Vector2d::Zero();
          step[k] = h;
          const bool p = unproject(px + step, &plus), m = unproject(px - step, &minus);
          if (p && m) J.col(k) = (plus - minus) / (2 * h);
          else if (p) J.col(k) = (plus - centre) / h;
          else if (m) J.col(k) = (centre - minus) / h;
          else ok = false;
        }
        if (!ok) continue;
        const size_t i = Index(u, v);
        for (int r = 0; r < 6; ++r) {
          ray[6 * i + r] = centre[r];
          for (int c = 0; c < 2; ++c) jacobian[12 * i + 2 * r + c] = static_cast<float>(J(r, c));
        }
        valid[i] = 1;
      }
    }
  });
}

bool RayTable::At(int u, double v, Eigen::Matrix<double, 6, 1>* r,
                  Eigen::Matrix<double, 6, 2>* J) const {
  const int v0 = static_cast<int>(std::floor(v));
  const double t = v - v0;
  const int v1 = t > 0 ? v0 + 1 : v0;
  if (v0 < row_begin || v1 >= row_end) return false;
  const size_t i0 = Index(u, v0), i1 = Index(u, v1);
  if (!valid[i0] || !valid[i1]) return false;
  if (t == 0) {  // a whole row (ring 1 always): the entry itself, as the blend would give
    for (int k = 0; k < 6; ++k) {
      (*r)[k] = ray[6 * i0 + k];
      for (int c = 0; c < 2; ++c) (*J)(k, c) = jacobian[12 * i0 + 2 * k + c];
    }
    return true;
  }
  for (int k = 0; k < 6; ++k) {
    (*r)[k] = (1 - t) * ray[6 * i0 + k] + t * ray[6 * i1 + k];
    for (int c = 0; c < 2; ++c) {
      (*J)(k, c) = (1 - t) * jacobian[12 * i0 + 2 * k + c] + t * jacobian[12 * i1 + 2 * k + c];
    }
  }
  return true;
}

double LargestEigenvalue(const Eigen::Matrix3d& m) {
  // Shifted by the mean eigenvalue q (as Eigen's closed form is), B = m - q I has trace 0 and the
  // characteristic polynomial l^3 - p l - det(B), p = tr(B^2) / 2; its roots are
  // 2 sqrt(p / 3) cos(.), so Newton starts at 2 sqrt(p / 3) >= the largest, where the cubic is
  // increasing and convex. Working on B keeps the error relative to the eigenvalues' spread: an
  // isotropic m is exact, an elongated one (the triangulation's) starts on the root.
  const double q = m.trace() / 3;
  const double a = m(0, 0) - q, b = m(1, 1) - q, c = m(2, 2) - q;
  const double xy = m(0, 1), xz = m(0, 2), yz = m(1, 2);
  const double p = 0.5 * (a * a + b * b + c * c) + xy * xy + xz * xz + yz * yz;
  if (!(p > 0)) return q;
  const double det = a * (b * c - yz * yz) - xy * (xy * c - yz * xz) + xz * (xy * yz - b * xz);
  double lambda = 2 * std::sqrt(p / 3);
  for (int i = 0; i < 200; ++i) {
    const double f = (lambda * lambda - p) * lambda - det;
    const double slope = 3 * lambda * lambda - p;
    if (!(f > 0) || !(slope > 0)) break;  // on the root to rounding
    const double step = f / slope;
    lambda -= step;
    // Quadratic convergence: after a step of 1e-10 the error is ~1e-20 (a double root, linear:
    // ~1e-10), far below the float the sigma is stored in.
    if (step <= 1e-10 * (std::abs(q) + lambda)) break;
  }
  return q + lambda;
}

bool TriangulateMatch(const RayTable& ring1, const RayTable& ring2, int u, int v, double d,
                      double sigma_px, MatchPoint* out) {
  using Jet4 = ceres::Jet<double, 4>;  // tangents along u1, v1, u2, v2
  Eigen::Matrix<double, 6, 1> r1, r2;
  Eigen::Matrix<double, 6, 2> J1, J2;
  if (!ring1.At(u, v, &r1, &J1) || !ring2.At(u, v - d, &r2, &J2)) return false;
  Vec3<Jet4> o1, d1, o2, d2, mid;
  for (int k = 0; k < 3; ++k) {
    o1[k] = Jet4(r1[k]);
    o1[k].v << J1(k, 0), J1(k, 1), 0, 0;
    d1[k] = Jet4(r1[3 + k]);
    d1[k].v << J1(3 + k, 0), J1(3 + k, 1), 0, 0;
    o2[k] = Jet4(r2[k]);
    o2[k].v << 0, 0, J2(k, 0), J2(k, 1);
    d2[k] = Jet4(r2[3 + k]);
    d2[k].v << 0, 0, J2(3 + k, 0), J2(3 + k, 1);
  }
  Jet4 l1, l2;
  if (!MidpointOnCommonPerpendicular(o1, d1, o2, d2, &mid, &l1, &l2)) return false;
  if (!(l1.a > 0) || !(l2.a > 0)) return false;
  Eigen::Matrix<double, 3, 4> A;
  for (int k = 0; k < 3; ++k) A.row(k) = mid[k].v.transpose();
  const Eigen::Matrix3d cov = (sigma_px * sigma_px) * (A * A.transpose());
  out->point_in_cam = Eigen::Vector3d(mid[0].a, mid[1].a, mid[2].a);
  out->sigma_mm = std::sqrt(std::max(0.0, LargestEigenvalue(cov)));
  return true;
}

bool TriangulateMatchReference(const RayTable& ring1, const RayTable& ring2, int u, int v,
                               double d, double sigma_px, MatchPoint* out) {
  using Jet12 = ceres::Jet<double, 12>;  // over (o1, d1, o2, d2)
  Eigen::Matrix<double, 6, 1> r1, r2;
  Eigen::Matrix<double, 6, 2> J1, J2;
  if (!ring1.At(u, v, &r1, &J1) || !ring2.At(u, v - d, &r2, &J2)) return false;
  Vec3<Jet12> o1, d1, o2, d2, mid;
  for (int k = 0; k < 3; ++k) {
    o1[k] = Jet12(r1[k], k);
    d1[k] = Jet12(r1[3 + k], 3 + k);
    o2[k] = Jet12(r2[k], 6 + k);
    d2[k] = Jet12(r2[3 + k], 9 + k);
  }
  Jet12 l1, l2;
  if (!MidpointOnCommonPerpendicular(o1, d1, o2, d2, &mid, &l1, &l2)) return false;
  if (!(l1.a > 0) || !(l2.a > 0)) return false;
  Eigen::Matrix<double, 3, 12> dmid_drays;
  for (int k = 0; k < 3; ++k) dmid_drays.row(k) = mid[k].v.transpose();
  // A = d point / d (u1, v1, u2, v2) = d point / d rays * d rays / d pixels.
  const Eigen::Matrix<double, 3, 2> A1 = dmid_drays.leftCols<6>() * J1;
  const Eigen::Matrix<double, 3, 2> A2 = dmid_drays.rightCols<6>() * J2;
  const Eigen::Matrix3d cov =
      (sigma_px * sigma_px) * (A1 * A1.transpose() + A2 * A2.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
  eigen.computeDirect(cov, Eigen::EigenvaluesOnly);
  out->point_in_cam = Eigen::Vector3d(mid[0].a, mid[1].a, mid[2].a);
  out->sigma_mm = std::sqrt(std::max(0.0, eigen.eigenvalues()[2]));
  return true;
}

}  // namespace omni::stereo
