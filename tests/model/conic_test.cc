// The optics-convention conic (model/conic.h) against independent closed forms: the paper's
// hyperboloid sheets (hyperboloid.h), a sphere, a paraboloid and an ellipsoid given by their
// semi-axes; its slope against finite differences.
#include "model/conic.h"

#include <gtest/gtest.h>

#include <cmath>

#include "model/hyperboloid.h"

namespace omni {
namespace {

// The big rig's mirrors (sample_configs/big_rig_design.yaml) and a flatter and a steeper shape.
struct FocalShape {
  double c, k;
};
constexpr FocalShape kShapes[] = {{123.8, 6.2}, {241.5, 5.3}, {60.0, 2.5}, {300.0, 20.0}};

TEST(Conic, EqualsThePapersHyperboloidSheetsAndTheirFoci) {
  for (const FocalShape& f : kShapes) {
    const Conic<double> conic = Conic<double>::FromFocalSeparation(f.c, f.k);
    EXPECT_LT(conic.K, -1);
    EXPECT_EQ(KindOfConic(conic.K), ConicKind::kHyperboloid);
    const auto upper = HyperboloidSheet<double>::Mirror1(f.c, f.k);      // opens towards +z
    const auto lower = HyperboloidSheet<double>::Mirror2(f.c, f.k, 50);  // opens towards -z
    for (double r = 0; r <= 80; r += 2.5) {
      const double s = conic.Sag(r * r);
      EXPECT_NEAR(upper.Z(r) - upper.VertexZ(), s, 1e-10 * (1 + s)) << f.c << " " << f.k << " " << r;
      EXPECT_NEAR(lower.VertexZ() - lower.Z(r), s, 1e-10 * (1 + s));
    }
    double near = 0, far = 0;
    ASSERT_TRUE(conic.NearFocus(&near));
    ASSERT_TRUE(conic.FarFocus(&far));
    EXPECT_NEAR(upper.PrimaryFocusZ() - upper.VertexZ(), near, 1e-9);
    EXPECT_NEAR(upper.SecondaryFocusZ() - upper.VertexZ(), far, 1e-9);
    EXPECT_NEAR(near - far, f.c, 1e-9);  // the focal separation
    double c = 0, k = 0;
    ASSERT_TRUE(conic.ToFocalSeparation(&c, &k));
    EXPECT_NEAR(c, f.c, 1e-9);
    EXPECT_NEAR(k, f.k, 1e-12);
  }
}

TEST(Conic, SphereParaboloidAndEllipsoidClosedForms) {
  const double R = 40;
  const Conic<double> sphere{R, 0}, paraboloid{R, -1};
  EXPECT_EQ(KindOfConic(sphere.K), ConicKind::kSphere);
  EXPECT_EQ(KindOfConic(paraboloid.K), ConicKind::kParaboloid);
  for (double r = 0; r <= R; r += 2) {
    EXPECT_NEAR(sphere.Sag(r * r), R - std::sqrt(R * R - r * r), 1e-12);
    EXPECT_NEAR(paraboloid.Sag(r * r), r * r / (2 * R), 1e-12);
  }
  EXPECT_FALSE(sphere.Covers((R + 0.1) * (R + 0.1)));
  EXPECT_TRUE(paraboloid.Covers(1e6));
  double s = 0;
  ASSERT_TRUE(paraboloid.NearFocus(&s));
  EXPECT_NEAR(s, R / 2, 1e-12);  // a paraboloid's focus
  EXPECT_FALSE(paraboloid.FarFocus(&s));
  ASSERT_TRUE(sphere.NearFocus(&s));
  EXPECT_NEAR(s, R, 1e-12);  // the centre

  // A prolate ellipsoid of axial semi-axis A and radial B, vertex at s = 0:
  // r^2 / B^2 + (s - A)^2 / A^2 = 1, foci at A -+ sqrt(A^2 - B^2).
  const double A = 50, B = 30;
  const Conic<double> ellipsoid{B * B / A, B * B / (A * A) - 1};
  EXPECT_EQ(KindOfConic(ellipsoid.K), ConicKind::kEllipsoid);
  for (double r = 0; r < B; r += 1.5) {
    EXPECT_NEAR(ellipsoid.Sag(r * r), A - A * std::sqrt(1 - r * r / (B * B)), 1e-10);
  }
  EXPECT_FALSE(ellipsoid.Covers((B + 0.01) * (B + 0.01)));
  double far = 0;
  ASSERT_TRUE(ellipsoid.NearFocus(&s));
  ASSERT_TRUE(ellipsoid.FarFocus(&far));
  EXPECT_NEAR(s, A - std::sqrt(A * A - B * B), 1e-10);
  EXPECT_NEAR(far, A + std::sqrt(A * A - B * B), 1e-10);
  EXPECT_FALSE(Conic<double>({40, 0.5}).NearFocus(&s));  // oblate: no focus on the axis
}

TEST(Conic, SlopeMatchesFiniteDifferences) {
  const Conic<double> conics[] = {Conic<double>::FromFocalSeparation(123.8, 6.2), {40, -1},
                                  {40, 0}, {18, -0.64}};
  for (const Conic<double>& conic : conics) {
    EXPECT_NEAR(conic.SlopeOverRadius(0), 1 / conic.R, 1e-15);
    for (double r = 0.5; r < 17; r += 1.5) {
      const double h = 1e-5;
      const double fd = (conic.Sag((r + h) * (r + h)) - conic.Sag((r - h) * (r - h))) / (2 * h);
      EXPECT_NEAR(conic.SlopeOverRadius(r * r) * r, fd, 1e-8) << conic.R << " " << conic.K;
    }
  }
}

}  // namespace
}  // namespace omni
