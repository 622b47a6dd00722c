#include "model/ideal_model.h"

#include <gtest/gtest.h>

#include <cmath>

#include "model/ideal_analysis.h"
#include "tests/model/test_rigs.h"

namespace omni {
namespace {

constexpr double kDeg = M_PI / 180.0;

// World points spread over mirror i's field of view: directions from F_i at elevations strictly
// inside (theta_min, theta_max), all azimuths, ranges 0.3 m to 20 m.
std::vector<Eigen::Vector3d> PointsInFov(const IdealModel& m, Mirror mirror) {
  const auto fov = ComputeFieldOfView(DesignParams{m.c1, m.c2, m.k1, m.k2, m.d, m.r_sys}, m.r_ref,
                                      m.r_cam);
  const double lo = mirror == Mirror::kOne ? fov.theta1_min : fov.theta2_min;
  const double hi = mirror == Mirror::kOne ? fov.theta1_max : fov.theta2_max;
  const Eigen::Vector3d focus = mirror == Mirror::kOne ? m.Focus1() : m.Focus2();
  std::vector<Eigen::Vector3d> points;
  for (int ie = 1; ie < 20; ++ie) {
    const double el = lo + (hi - lo) * ie / 20.0;
    for (int ia = 0; ia < 36; ++ia) {
      const double az = ia * 10 * kDeg + 0.1;
      for (double range : {300.0, 1000.0, 20000.0}) {
        points.push_back(focus + range * Eigen::Vector3d(std::cos(el) * std::cos(az),
                                                         std::cos(el) * std::sin(az),
                                                         std::sin(el)));
      }
    }
  }
  return points;
}

TEST(IdealModel, ForwardThenBackProjectionRoundTrip) {
  const IdealModel m = testing::BigRig();
  for (Mirror mirror : {Mirror::kOne, Mirror::kTwo}) {
    int n = 0;
    for (const auto& p : PointsInFov(m, mirror)) {
      Eigen::Vector2d px;
      ASSERT_TRUE(m.Project(p, mirror, &px)) << p.transpose();
      const auto ray = Unproject(m, px);
      ASSERT_TRUE(ray.has_value()) << px.transpose();
      ASSERT_EQ(ray->mirror, mirror) << "pixel landed in the other ring: " << px.transpose();
      const Eigen::Vector3d expected = (p - ray->ray.origin).normalized();
      const double angle = std::atan2(expected.cross(ray->ray.direction).norm(),
                                      expected.dot(ray->ray.direction));
      EXPECT_LT(angle, 1e-9) << p.transpose();
      ++n;
    }
    EXPECT_GT(n, 2000);
  }
}

TEST(IdealModel, RingsAreDisjointAndOrdered) {
  // Mirror 2 (through the reflex disc) gives the inner ring, mirror 1 the outer ring; by the h1
  // equality the inner ring's outer edge is the outer ring's inner edge (~214 px at fx = 1450).
  const IdealModel m = testing::BigRig();
  double max2 = 0, min1 = 1e9;
  for (Mirror mirror : {Mirror::kOne, Mirror::kTwo}) {
    for (const auto& p : PointsInFov(m, mirror)) {
      Eigen::Vector2d px;
      ASSERT_TRUE(m.Project(p, mirror, &px));
      const double radius = (px - Eigen::Vector2d(m.cam.cx, m.cam.cy)).norm();
      if (mirror == Mirror::kOne) min1 = std::min(min1, radius);
      else max2 = std::max(max2, radius);
    }
  }
  EXPECT_LE(max2, min1);
  // The edges themselves: mirror 2's rim through the reflex disc, and the reflex disc's edge.
  const double edge2 = m.cam.fx * m.r_sys / (m.d - m.Mirror2().Z(m.r_sys));
  const double edge1 = m.cam.fx * m.r_ref / (m.d / 2);
  EXPECT_NEAR(edge2, edge1, 0.01);
  EXPECT_NEAR(edge2, 213.8, 0.1);
  EXPECT_LT(edge2, min1);
  EXPECT_GT(edge2, max2);
}

// ---- Brute-force oracle: trace camera rays by marching to the surface and reflecting by the law
// of reflection (normals from the implicit function's gradient); none of [lambda_i], [t_i] used.
struct Traced {
  Eigen::Vector3d origin, direction;
};

bool MarchToSheet(const HyperboloidSheet<double>& sheet, const Eigen::Vector3d& o,
                  const Eigen::Vector3d& dir, Eigen::Vector3d* hit) {
  double prev = sheet.Implicit(o);
  double s_prev = 0;
  for (double s = 0.05; s < 1000; s += 0.05) {
    const Eigen::Vector3d q = o + s * dir;
    const double f = sheet.Implicit(q);
    if ((f > 0) != (prev > 0) && sheet.sheet * (q.z() - sheet.z0) > 0) {
      double lo = s_prev, hi = s;
      for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        ((sheet.Implicit(o + mid * dir) > 0) == (prev > 0) ? lo : hi) = mid;
      }
      *hit = o + 0.5 * (lo + hi) * dir;
      return true;
    }
    prev = f;
    s_prev = s;
  }
  return false;
}

bool Trace(const IdealModel& m, Mirror mirror, const Eigen::Vector2d& px, Traced* out) {
  const Eigen::Vector2d q = m.cam.NormalizedFromPixel(px);
  Eigen::Vector3d o = Eigen::Vector3d::Zero();
  Eigen::Vector3d dir = Eigen::Vector3d(q.x(), q.y(), 1).normalized();
  const auto sheet = mirror == Mirror::kOne ? m.Mirror1() : m.Mirror2();
  if (mirror == Mirror::kTwo) {  // reflect in the plane z = d/2
    o = dir * (m.d / 2 / dir.z());
    dir.z() = -dir.z();
  }
  Eigen::Vector3d hit;
  if (!MarchToSheet(sheet, o, dir, &hit)) return false;
  const double f2 = (hit.z() - sheet.z0) / (sheet.a * sheet.a);
  const Eigen::Vector3d grad(-hit.x() / (sheet.b * sheet.b), -hit.y() / (sheet.b * sheet.b), f2);
  const Eigen::Vector3d n = grad.normalized();
  out->origin = hit;
  out->direction = dir - 2 * dir.dot(n) * n;
  return true;
}

// Pixel of world point p via the mirror: bisection on the pixel radius along the point's azimuth
// (the rig is coaxial) for the reflected ray to pass through p.
bool OracleProject(const IdealModel& m, Mirror mirror, const Eigen::Vector3d& p,
                   Eigen::Vector2d* px) {
  const double az = std::atan2(p.y(), p.x());
  const Eigen::Vector3d e_perp(-std::sin(az), std::cos(az), 0);
  const Eigen::Vector2d c(m.cam.cx, m.cam.cy), u(std::cos(az), std::sin(az));
  auto miss = [&](double rho, bool* ok) {
    Traced t;
    *ok = Trace(m, mirror, c + rho * u, &t);
    return *ok ? (p - t.origin).cross(t.direction).dot(e_perp) : 0.0;
  };
  const double lo_px = mirror == Mirror::kOne ? 214 : 1, hi_px = mirror == Mirror::kOne ? 420 : 214;
  bool ok_prev = false;
  double f_prev = miss(lo_px, &ok_prev), r_prev = lo_px;
  for (double rho = lo_px + 0.5; rho <= hi_px; rho += 0.5) {
    bool ok = false;
    const double f = miss(rho, &ok);
    if (ok && ok_prev && (f > 0) != (f_prev > 0)) {
      double lo = r_prev, hi = rho;
      for (int i = 0; i < 100; ++i) {
        const double mid = 0.5 * (lo + hi);
        bool ok_mid = false;
        ((miss(mid, &ok_mid) > 0) == (f_prev > 0) ? lo : hi) = mid;
      }
      *px = c + 0.5 * (lo + hi) * u;
      return true;
    }
    ok_prev = ok;
    f_prev = f;
    r_prev = rho;
  }
  return false;
}

TEST(IdealModel, ForwardProjectionMatchesBruteForceRayTrace) {
  const IdealModel m = testing::BigRig();
  int checked = 0;
  double worst = 0;
  for (Mirror mirror : {Mirror::kOne, Mirror::kTwo}) {
    const auto points = PointsInFov(m, mirror);
    for (size_t i = 0; i < points.size(); i += 37) {
      Eigen::Vector2d px, oracle;
      ASSERT_TRUE(m.Project(points[i], mirror, &px));
      ASSERT_TRUE(OracleProject(m, mirror, points[i], &oracle)) << points[i].transpose();
      worst = std::max(worst, (px - oracle).norm());
      EXPECT_LT((px - oracle).norm(), 1e-6) << points[i].transpose();
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
  std::printf("brute-force oracle: %d points, worst difference %.3g px\n", checked, worst);
}

TEST(IdealModel, InvalidCasesAreRejected) {
  const IdealModel m = testing::BigRig();
  Eigen::Vector2d px(-1, -1);
  // Straight up and straight down: outside both mirrors' fields of view.
  EXPECT_FALSE(m.Project(Eigen::Vector3d(0, 0, 5000), Mirror::kOne, &px));
  EXPECT_FALSE(m.Project(Eigen::Vector3d(0, 0, 5000), Mirror::kTwo, &px));
  EXPECT_FALSE(m.Project(Eigen::Vector3d(1, 0, -5000), Mirror::kOne, &px));
  EXPECT_FALSE(m.Project(Eigen::Vector3d(1, 0, -5000), Mirror::kTwo, &px));
  // Inside mirror 1's body (between the focus and the surface).
  EXPECT_FALSE(m.Project(Eigen::Vector3d(10, 0, m.c1), Mirror::kOne, &px));
  // Just above mirror 1's field of view (elevation 15 deg > theta_1,max = 14 deg).
  const Eigen::Vector3d above = m.Focus1() + 1000 * Eigen::Vector3d(std::cos(15 * kDeg), 0,
                                                                    std::sin(15 * kDeg));
  EXPECT_FALSE(m.Project(above, Mirror::kOne, &px));
  // Through the hole: the centre pixel sees the camera's own reflection, no mirror.
  EXPECT_FALSE(Unproject(m, Eigen::Vector2d(m.cam.cx, m.cam.cy)).has_value());
  // Outside both rings (image corner).
  EXPECT_FALSE(Unproject(m, Eigen::Vector2d(0, 0)).has_value());
}

}  // namespace
}  // namespace omni
