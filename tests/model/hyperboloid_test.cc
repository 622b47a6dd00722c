#include "model/hyperboloid.h"

#include <gtest/gtest.h>

#include <random>

#include "tests/model/test_rigs.h"

namespace omni {
namespace {

TEST(Hyperboloid, FociAndVertexOfBothMirrors) {
  const auto d = testing::BigRigDesign();
  const auto m1 = HyperboloidSheet<double>::Mirror1(d.c1, d.k1);
  const auto m2 = HyperboloidSheet<double>::Mirror2(d.c2, d.k2, d.d);
  EXPECT_NEAR(m1.PrimaryFocusZ(), d.c1, 1e-12);
  EXPECT_NEAR(m1.SecondaryFocusZ(), 0.0, 1e-12);
  EXPECT_NEAR(m2.PrimaryFocusZ(), d.d - d.c2, 1e-12);
  EXPECT_NEAR(m2.SecondaryFocusZ(), d.d, 1e-12);
  // A hyperboloid's defining property: | |P - F| - |P - F'| | = 2a on the surface.
  for (double r : {0.0, 5.0, 17.0, 37.0}) {
    for (const auto* m : {&m1, &m2}) {
      const Eigen::Vector3d p(r, 0, m->Z(r));
      const double df = (p - Eigen::Vector3d(0, 0, m->PrimaryFocusZ())).norm() -
                        (p - Eigen::Vector3d(0, 0, m->SecondaryFocusZ())).norm();
      EXPECT_NEAR(std::abs(df), 2 * m->a, 1e-9);
      EXPECT_NEAR(m->Implicit(p), 0.0, 1e-12);
    }
  }
}

TEST(Hyperboloid, FuncZAndFuncRAreInverse) {
  const auto d = testing::BigRigDesign();
  for (const auto& m : {HyperboloidSheet<double>::Mirror1(d.c1, d.k1),
                        HyperboloidSheet<double>::Mirror2(d.c2, d.k2, d.d)}) {
    for (double r = 0.5; r < 60; r += 0.5) {
      double back = -1;
      ASSERT_TRUE(m.R(m.Z(r), &back));
      EXPECT_NEAR(back, r, 1e-9 * (1 + r));
    }
    // A plane between the sheets misses this sheet.
    double r = 0;
    EXPECT_FALSE(m.R(m.z0, &r));
  }
}

TEST(Hyperboloid, RayIntersectionMatchesMarchingAndNormalMatchesSlope) {
  const auto d = testing::BigRigDesign();
  const auto m1 = HyperboloidSheet<double>::Mirror1(d.c1, d.k1);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ang(-0.3, 0.3);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d dir = Eigen::Vector3d(ang(rng), ang(rng), 1).normalized();
    double t = 0;
    ASSERT_TRUE(m1.IntersectRay(Eigen::Vector3d::Zero(), dir, &t));
    const Eigen::Vector3d p = t * dir;
    EXPECT_GT(p.z(), m1.z0);  // upper sheet, not the lower one the ray crosses first
    EXPECT_NEAR(m1.Implicit(p), 0.0, 1e-10);
    // Marching oracle: first upper-sheet sign change of F along the ray.
    double prev = m1.Implicit(Eigen::Vector3d::Zero()), s_hit = -1;
    for (double s = 0.01; s < 400; s += 0.01) {
      const Eigen::Vector3d q = s * dir;
      const double f = m1.Implicit(q);
      if (q.z() > m1.z0 && (f > 0) != (prev > 0)) {
        s_hit = s;
        break;
      }
      prev = f;
    }
    EXPECT_NEAR(s_hit, t, 0.011);
    // The normal is perpendicular to the profile's tangent (1, dz/dr) in the azimuth plane.
    const double r = std::hypot(p.x(), p.y());
    const Eigen::Vector3d tangent(p.x() / r, p.y() / r, m1.Slope(r));
    EXPECT_NEAR(m1.Normal(p).dot(tangent), 0.0, 1e-12);
  }
}

}  // namespace
}  // namespace omni
