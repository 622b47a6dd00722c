// The ray gap of a match and a lip point's residual (health/consistency.h) against brute force.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "health/consistency.h"
#include "io/model_file.h"
#include "model/lip.h"

namespace omni::health {
namespace {

const std::string kSampleDir = std::string(OMNI_SOURCE_DIR) + "/sample_configs/";

// Distance from `pixel` to the polyline of ring-2 images of pixel1's ray sampled finely in
// inverse range (the slow oracle).
double BruteForceGap(const RigModel& model, const Eigen::Vector2d& pixel1,
                     const Eigen::Vector2d& pixel) {
  const Ray ray = model.Unproject(pixel1)->ray;
  double best = 1e9;
  std::optional<Eigen::Vector2d> previous;
  for (int k = 1; k <= 40000; ++k) {
    const double w = k * (1.0 / 200.0) / 40000;  // ranges 200 mm .. 8 km
    const auto p = model.Project(ray.origin + ray.direction / w, Mirror::kTwo);
    if (p && previous) {
      const Eigen::Vector2d a = *previous, b = *p;
      const double t = std::clamp((pixel - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      best = std::min(best, (pixel - (a + t * (b - a))).norm());
    }
    previous = p;
  }
  return best;
}

TEST(EpipolarGap, ZeroForAPointSeenInBothRingsAndTheBruteForceDistanceOtherwise) {
  const RigModel model(io::ReadModelFile(kSampleDir + "big_rig_misaligned.yaml"));
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> azimuth(0, 2 * M_PI), range(500, 4000),
      height(-300, 600), offset(-2, 2);
  int tested = 0;
  for (int i = 0; i < 200 && tested < 12; ++i) {
    const double a = azimuth(rng), r = range(rng);
    const Eigen::Vector3d point(r * std::cos(a), r * std::sin(a), height(rng));
    const auto p1 = model.Project(point, Mirror::kOne), p2 = model.Project(point, Mirror::kTwo);
    if (!p1 || !p2) continue;
    ++tested;
    const auto zero = EpipolarGap(model, *p1, *p2);
    ASSERT_TRUE(zero.has_value());
    EXPECT_LT(std::abs(*zero), 1e-5);
    // Off the curve by up to 2 px in any direction: |gap| is the distance to the curve.
    const Eigen::Vector2d moved = *p2 + Eigen::Vector2d(offset(rng), offset(rng));
    const auto gap = EpipolarGap(model, *p1, moved);
    ASSERT_TRUE(gap.has_value());
    EXPECT_NEAR(std::abs(*gap), BruteForceGap(model, *p1, moved), 2e-3);
  }
  EXPECT_EQ(tested, 12);
}

// The gap's sign keeps one sense of azimuth all around the ring: a pixel turned about the
// principal point by a small angle gets the same sign everywhere.
TEST(EpipolarGap, SignIsOneSenseOfAzimuthAllAround) {
  const RigModel model(io::ReadModelFile(kSampleDir + "big_rig_misaligned.yaml"));
  const Eigen::Vector2d centre(model.params().camera[kCx], model.params().camera[kCy]);
  int positive = 0, negative = 0;
  for (int k = 0; k < 36; ++k) {
    const double a = k * 2 * M_PI / 36;
    const Eigen::Vector3d point(2000 * std::cos(a), 2000 * std::sin(a), 200);
    const auto p1 = model.Project(point, Mirror::kOne), p2 = model.Project(point, Mirror::kTwo);
    ASSERT_TRUE(p1 && p2);
    const Eigen::Vector2d radial = *p2 - centre;
    const Eigen::Vector2d turned = centre + Eigen::Rotation2Dd(0.01) * radial;
    const auto gap = EpipolarGap(model, *p1, turned);
    ASSERT_TRUE(gap.has_value());
    (*gap > 0 ? positive : negative)++;
  }
  EXPECT_TRUE(positive == 36 || negative == 36) << positive << " / " << negative;
}

TEST(LipResidual, SignedDistanceAcrossTheEdge) {
  const RigModel model(io::ReadModelFile(kSampleDir + "big_rig_misaligned.yaml"));
  const Eigen::Vector2d centre(model.params().camera[kCx], model.params().camera[kCy]);
  int tested = 0;
  for (LipPath path : {LipPath::kDirect, LipPath::kViaMirror1, LipPath::kViaMirror2}) {
    for (double phi : {0.3, 2.0, 4.4}) {
      const auto on = ProjectLipPoint(model, path, LipCircle::kOuter, phi);
      if (!on) continue;  // via_mirror2: the reflex disc hides part of the band
      ++tested;
      const Eigen::Vector2d out = (*on - centre).normalized();
      const auto r = LipResidual(model, path, LipCircle::kOuter, *on + 0.3 * out);
      ASSERT_TRUE(r.has_value());
      EXPECT_NEAR(r->value, 0.3, 0.01) << LipPathName(path);
      // The first-order residual under the same model agrees.
      EXPECT_NEAR(*LipResidualUnder(model, *r), r->value, 1e-3);
    }
  }
  EXPECT_GE(tested, 7);
}

}  // namespace
}  // namespace omni::health
