// (d) Jacobians of ProjectViaMirror1/2 with ceres::Jet (one Newton step in T at the converged
// reflection point) against central finite differences of the double code.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "model/rig_model.h"
#include "tests/model/rig_test_util.h"

namespace omni {
namespace {

// All inputs in one flat vector: point(3) camera(5) distortion(5) mirror1_shape(2)
// mirror2_shape(2) mirror1_pose(5) mirror2_pose(5) reflex(3) mirror1_profile(6)
// mirror2_profile(6).
constexpr int kNumInputs = 42;
struct Block {
  const char* name;
  int offset, size;
  double step;  // finite-difference step
};
constexpr Block kBlocks[] = {
    {"point", 0, 3, 1e-3},         {"camera", 3, 5, 1e-3},        {"distortion", 8, 5, 1e-6},
    {"mirror1_shape", 13, 2, 1e-5}, {"mirror2_shape", 15, 2, 1e-5}, {"mirror1_pose", 17, 5, 1e-5},
    {"mirror2_pose", 22, 5, 1e-5}, {"reflex", 27, 3, 1e-5},   {"mirror1_profile", 30, 6, 1e-5},
    {"mirror2_profile", 36, 6, 1e-5},
};
constexpr int kNumBlocks = sizeof(kBlocks) / sizeof(kBlocks[0]);

template <typename T>
bool Evaluate(Mirror mirror, const T* x, const RigFixed& fixed, Vec2<T>* pixel) {
  const Vec3<T> point(x[0], x[1], x[2]);
  RigBlocks<T> blocks;  // after the point, the blocks in the table's flat order (kBlocks)
  for (int b = 0; b < kRigBlockCount; ++b) {
    blocks[static_cast<RigBlockId>(b)] = x + 3 + BlockOffset(static_cast<RigBlockId>(b));
  }
  return mirror == Mirror::kOne ? ProjectViaMirror1(blocks, fixed, point, pixel)
                                : ProjectViaMirror2(blocks, fixed, point, pixel);
}

std::array<double, kNumInputs> Flatten(const RigParams& rig, const Eigen::Vector3d& p) {
  std::array<double, kNumInputs> x{};
  int i = 0;
  for (int k = 0; k < 3; ++k) x[i++] = p(k);
  for (double v : rig.camera) x[i++] = v;
  for (double v : rig.distortion) x[i++] = v;
  for (double v : rig.mirror1_shape) x[i++] = v;
  for (double v : rig.mirror2_shape) x[i++] = v;
  for (double v : rig.mirror1_pose) x[i++] = v;
  for (double v : rig.mirror2_pose) x[i++] = v;
  for (double v : rig.reflex) x[i++] = v;
  for (double v : rig.mirror1_profile) x[i++] = v;
  for (double v : rig.mirror2_profile) x[i++] = v;
  return x;
}

struct JacobianStats {
  double max_rel[kNumBlocks] = {0};
  double max_value_diff = 0;
  int n = 0;
};

void CheckPoint(const RigParams& rig, Mirror mirror, const Eigen::Vector3d& p,
                JacobianStats* stats) {
  using J = ceres::Jet<double, kNumInputs>;
  const RigFixed fixed = FixedOf(rig);
  const auto x = Flatten(rig, p);
  J xj[kNumInputs];
  for (int i = 0; i < kNumInputs; ++i) xj[i] = J(x[i], i);
  Vec2<J> pixel_jet;
  ASSERT_TRUE(Evaluate(mirror, xj, fixed, &pixel_jet));
  Vec2<double> pixel;
  ASSERT_TRUE(Evaluate(mirror, x.data(), fixed, &pixel));
  stats->max_value_diff =
      std::max(stats->max_value_diff, (Eigen::Vector2d(pixel_jet(0).a, pixel_jet(1).a) - pixel).norm());

  for (int b = 0; b < kNumBlocks; ++b) {
    const Block& block = kBlocks[b];
    Eigen::MatrixXd jet(2, block.size), fd(2, block.size);
    for (int k = 0; k < block.size; ++k) {
      const int i = block.offset + k;
      jet(0, k) = pixel_jet(0).v(i);
      jet(1, k) = pixel_jet(1).v(i);
      // Fourth-order central difference.
      Eigen::Vector2d f[4];
      const double offsets[4] = {-2, -1, 1, 2};
      for (int s = 0; s < 4; ++s) {
        auto xs = x;
        xs[i] += offsets[s] * block.step;
        ASSERT_TRUE(Evaluate(mirror, xs.data(), fixed, &f[s]))
            << block.name << "[" << k << "] step invalidates the point";
      }
      fd.col(k) = (f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * block.step);
    }
    const double scale = jet.norm();
    const double err = (jet - fd).norm();
    const double rel = scale > 1e-9 ? err / scale : err;  // absolute where the block is unused
    EXPECT_LT(rel, 1e-6) << "mirror " << MirrorIndex(mirror) << " block " << block.name
                         << "\njet\n" << jet << "\nfd\n" << fd;
    stats->max_rel[b] = std::max(stats->max_rel[b], rel);
  }
  ++stats->n;
}

void RunJacobianCheck(const RigParams& rig, const char* label, int per_mirror) {
  const RigModel model(rig);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  JacobianStats stats[3];
  int attempts = 0;
  while ((stats[1].n < per_mirror || stats[2].n < per_mirror) && ++attempts < 100000) {
    const Eigen::Vector2d px(u(rng) * rig.image_width, u(rng) * rig.image_height);
    const auto ray = model.Unproject(px);
    if (!ray) continue;
    const int m = MirrorIndex(ray->mirror);
    if (stats[m].n >= per_mirror) continue;
    const Eigen::Vector3d p = ray->ray.origin + (300 + 3000 * u(rng)) * ray->ray.direction;
    // Keep away from the validity boundaries so the finite-difference steps stay valid.
    bool inside = true;
    for (const auto& dp : {Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d(0, 0.5, 0),
                           Eigen::Vector3d(0, 0, 0.5), Eigen::Vector3d(-0.5, -0.5, -0.5)}) {
      inside = inside && model.Project(p + dp, ray->mirror).has_value();
    }
    if (!inside) continue;
    CheckPoint(rig, ray->mirror, p, &stats[m]);
    if (::testing::Test::HasFatalFailure()) return;
  }
  for (int m : {1, 2}) {
    std::string line;
    for (int b = 0; b < kNumBlocks; ++b) {
      char buf[64];
      std::snprintf(buf, sizeof(buf), " %s %.1e", kBlocks[b].name, stats[m].max_rel[b]);
      line += buf;
    }
    std::printf("%s mirror %d: %d points, jet value vs double %.1e px; max rel. error:%s\n", label,
                m, stats[m].n, stats[m].max_value_diff, line.c_str());
    EXPECT_EQ(stats[m].n, per_mirror);
    EXPECT_LT(stats[m].max_value_diff, 1e-10);
  }
}

TEST(RigModelJacobian, JetsMatchFiniteDifferencesMisaligned) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 2; ++trial) {
    RunJacobianCheck(testing::MisalignedBigRig(&rng, 1.0, 1.0, true), "misaligned", 40);
  }
}

// Machined mirrors (issue 40): every profile term, a ripple, on a misaligned rig.
TEST(RigModelJacobian, JetsMatchFiniteDifferencesWithProfiles) {
  std::mt19937 rng(17);
  RigParams rig = testing::MisalignedBigRig(&rng, 1.0, 1.0, true);
  rig.profile1 = DefaultProfileShape(rig, Mirror::kOne);
  rig.profile2 = DefaultProfileShape(rig, Mirror::kTwo);
  rig.profile1.ripple_amplitude = 0.002;
  rig.profile1.ripple_period = 6.0;
  rig.profile1.ripple_phase = 0.3;
  rig.mirror1_profile = {0.005, -0.003, 0.002, 0.001, 0.002, -0.0015};
  rig.mirror2_profile = {-0.004, 0.002, 0.0015, -0.001, -0.001, 0.002};
  RunJacobianCheck(rig, "profiled", 40);
}

TEST(RigModelJacobian, JetsMatchFiniteDifferencesAtZeroMisalignment) {
  RunJacobianCheck(testing::BigRigParams(), "ideal", 40);
}

}  // namespace
}  // namespace omni
