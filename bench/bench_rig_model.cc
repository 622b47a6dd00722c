// Non-central rig model throughput on a misaligned big rig (1 mm / 1 deg, distortion), with the
// ideal closed form on the same points for the ratio.
// Targets (non-central model issue): >= 3 million double projections per second on one thread;
// one evaluation of 100k residuals with Jacobians (ceres::Problem::Evaluate) < 0.5 s on 2 cores.
#include <benchmark/benchmark.h>
#include <ceres/ceres.h>

#include <memory>
#include <random>
#include <vector>

#include "model/rig_model.h"
#include "model/rig_parameters.h"
#include "model/rig_params.h"

namespace omni {
namespace {

constexpr double kDeg = M_PI / 180.0;

RigParams MisalignedRig() {
  RigParams rig = MakeIdealRig(DesignParams{123.488, 241.803, 5.7319, 9.7443, 233.684, 37.0}, 7.0,
                               Pinhole<double>{1450, 1450, 639.5, 479.5, 0}, 1280, 960);
  rig.kind = ModelKind::kNoncentral;
  rig.camera[kCx] += 3.2;
  rig.camera[kCy] -= 2.1;
  rig.distortion = {-0.06, 0.012, 1e-4, -1e-4, -0.002};
  rig.mirror1_pose = {0.7 * kDeg, -0.4 * kDeg, 0.6, -0.8, 0.9};
  rig.mirror2_pose = {-0.9 * kDeg, 0.5 * kDeg, -0.7, 0.4, -0.6};
  rig.reflex = {0.6 * kDeg, 0.8 * kDeg, 0.5};
  return rig;
}

struct Sample {
  Mirror mirror;
  Eigen::Vector3d point;
  Eigen::Vector2d pixel;
};

// Valid points of both rings (from random pixels at depths 0.3-5 m), mixed in image order.
std::vector<Sample> Samples(const RigModel& model, int n) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Sample> samples;
  while (static_cast<int>(samples.size()) < n) {
    const Eigen::Vector2d px(u(rng) * 1280, u(rng) * 960);
    const auto ray = model.Unproject(px);
    if (!ray) continue;
    samples.push_back({ray->mirror, ray->ray.origin + (300 + 4700 * u(rng)) * ray->ray.direction, px});
  }
  return samples;
}

void BM_RigProjectDouble(benchmark::State& state) {
  const RigModel model(MisalignedRig());
  const auto samples = Samples(model, 4096);
  for (auto _ : state) {
    for (const auto& s : samples) benchmark::DoNotOptimize(model.Project(s.point, s.mirror));
  }
  state.SetItemsProcessed(state.iterations() * samples.size());
}
BENCHMARK(BM_RigProjectDouble);

// Machined mirrors: every profile term and a ripple on both mirrors. Target: >= 1 M
// projections / s per core.
RigParams ProfiledRig() {
  RigParams rig = MisalignedRig();
  rig.profile1 = DefaultProfileShape(rig, Mirror::kOne);
  rig.profile2 = DefaultProfileShape(rig, Mirror::kTwo);
  rig.mirror1_profile = {0.005, -0.001, 0.0005, 0.0002, 0.0005, -0.0003};
  rig.mirror2_profile = {0.004, 0.001, -0.0005, 0.0001, -0.0004, 0.0005};
  rig.profile1.ripple_amplitude = 0.002;
  rig.profile1.ripple_period = 6;
  return rig;
}

void BM_RigProjectProfiledDouble(benchmark::State& state) {
  const RigModel model(ProfiledRig());
  const auto samples = Samples(model, 4096);
  for (auto _ : state) {
    for (const auto& s : samples) benchmark::DoNotOptimize(model.Project(s.point, s.mirror));
  }
  state.SetItemsProcessed(state.iterations() * samples.size());
}
BENCHMARK(BM_RigProjectProfiledDouble);

void BM_RigUnprojectProfiled(benchmark::State& state) {
  const RigModel model(ProfiledRig());
  const auto samples = Samples(model, 4096);
  for (auto _ : state) {
    for (const auto& s : samples) benchmark::DoNotOptimize(model.Unproject(s.pixel));
  }
  state.SetItemsProcessed(state.iterations() * samples.size());
}
BENCHMARK(BM_RigUnprojectProfiled);

// The free functions straight from the parameter blocks (poses rebuilt per call, as in a cost
// function), double.
void BM_RigProjectFromBlocksDouble(benchmark::State& state) {
  const RigParams rig = MisalignedRig();
  const RigModel model(rig);
  const RigFixed fixed = FixedOf(rig);
  const auto samples = Samples(model, 4096);
  Eigen::Vector2d px;
  for (auto _ : state) {
    for (const auto& s : samples) {
      const bool ok =
          s.mirror == Mirror::kOne
              ? ProjectViaMirror1(RigBlocksOf(rig), fixed, s.point, &px)
              : ProjectViaMirror2(RigBlocksOf(rig), fixed, s.point, &px);
      benchmark::DoNotOptimize(ok);
      benchmark::DoNotOptimize(px);
    }
  }
  state.SetItemsProcessed(state.iterations() * samples.size());
}
BENCHMARK(BM_RigProjectFromBlocksDouble);

// Jets with every parameter block and the point as derivative dimensions (30).
void BM_RigProjectJet(benchmark::State& state) {
  using J = ceres::Jet<double, 30>;
  const RigParams rig = MisalignedRig();
  const RigModel model(rig);
  const RigFixed fixed = FixedOf(rig);
  const auto samples = Samples(model, 1024);
  std::vector<J> x(27);
  int k = 3;
  auto fill = [&](const auto& block) {
    for (double v : block) {
      x[k - 3] = J(v, k);
      ++k;
    }
  };
  fill(rig.camera);         // x[0..4]
  fill(rig.distortion);     // x[5..9]
  fill(rig.mirror1_shape);  // x[10..11]
  fill(rig.mirror2_shape);  // x[12..13]
  fill(rig.mirror1_pose);   // x[14..18]
  fill(rig.mirror2_pose);   // x[19..23]
  fill(rig.reflex);         // x[24..26]
  RigBlocks<J> blocks;  // the profile blocks nullptr: exact conics
  for (RigBlockId b : {kCameraBlock, kDistortionBlock, kShape1Block, kShape2Block, kPose1Block,
                       kPose2Block, kReflexBlock}) {
    blocks[b] = &x[BlockOffset(b)];
  }
  Vec2<J> px;
  for (auto _ : state) {
    for (const auto& s : samples) {
      const Vec3<J> p(J(s.point.x(), 0), J(s.point.y(), 1), J(s.point.z(), 2));
      const bool ok = s.mirror == Mirror::kOne
                          ? ProjectViaMirror1(blocks, fixed, p, &px)
                          : ProjectViaMirror2(blocks, fixed, p, &px);
      benchmark::DoNotOptimize(ok);
      benchmark::DoNotOptimize(px);
    }
  }
  state.SetItemsProcessed(state.iterations() * samples.size());
}
BENCHMARK(BM_RigProjectJet);

void BM_RigUnproject(benchmark::State& state) {
  const RigModel model(MisalignedRig());
  const auto samples = Samples(model, 4096);
  for (auto _ : state) {
    for (const auto& s : samples) benchmark::DoNotOptimize(model.Unproject(s.pixel));
  }
  state.SetItemsProcessed(state.iterations() * samples.size());
}
BENCHMARK(BM_RigUnproject);

void BM_IdealProjectSamePoints(benchmark::State& state) {
  const RigParams rig = MisalignedRig();
  const RigModel model(rig);
  const IdealModel ideal = rig.Ideal();
  const auto samples = Samples(model, 4096);
  Eigen::Vector2d px;
  for (auto _ : state) {
    for (const auto& s : samples) {
      benchmark::DoNotOptimize(ideal.Project(s.point, s.mirror, &px));
      benchmark::DoNotOptimize(px);
    }
  }
  state.SetItemsProcessed(state.iterations() * samples.size());
}
BENCHMARK(BM_IdealProjectSamePoints);

void BM_IdealUnprojectSamePixels(benchmark::State& state) {
  const RigParams rig = MisalignedRig();
  const RigModel model(rig);
  const IdealModel ideal = rig.Ideal();
  const auto samples = Samples(model, 4096);
  for (auto _ : state) {
    for (const auto& s : samples) benchmark::DoNotOptimize(Unproject(ideal, s.pixel));
  }
  state.SetItemsProcessed(state.iterations() * samples.size());
}
BENCHMARK(BM_IdealUnprojectSamePixels);

// Reprojection residuals as a calibration would write them (one per observation, the point a
// parameter block of its own), evaluated with Jacobians by ceres::Problem::Evaluate.
struct Mirror1Residual {
  static constexpr std::array<RigBlockId, 5> kBlocks = {kCameraBlock, kDistortionBlock,
                                                        kShape1Block, kPose1Block, kReflexBlock};
  Eigen::Vector2d observed;
  RigFixed fixed;
  template <typename T>
  bool operator()(const T* camera, const T* distortion, const T* shape, const T* pose,
                  const T* reflex, const T* point, T* residual) const {
    Vec2<T> px;
    const T* blocks[] = {camera, distortion, shape, pose, reflex};
    if (!ProjectViaMirror1(RigBlocks<T>(kBlocks, blocks), fixed,
                           Vec3<T>(point[0], point[1], point[2]), &px)) {
      return false;
    }
    residual[0] = px(0) - observed(0);
    residual[1] = px(1) - observed(1);
    return true;
  }
};
struct Mirror2Residual {
  static constexpr std::array<RigBlockId, 6> kBlocks = {
      kCameraBlock, kDistortionBlock, kPose1Block, kReflexBlock, kShape2Block, kPose2Block};
  Eigen::Vector2d observed;
  RigFixed fixed;
  template <typename T>
  bool operator()(const T* camera, const T* distortion, const T* pose1, const T* reflex,
                  const T* shape, const T* pose2, const T* point, T* residual) const {
    Vec2<T> px;
    const T* blocks[] = {camera, distortion, pose1, reflex, shape, pose2};
    if (!ProjectViaMirror2(RigBlocks<T>(kBlocks, blocks), fixed,
                           Vec3<T>(point[0], point[1], point[2]), &px)) {
      return false;
    }
    residual[0] = px(0) - observed(0);
    residual[1] = px(1) - observed(1);
    return true;
  }
};

void BM_CeresEvaluate100kResidualsWithJacobians(benchmark::State& state) {
  RigParams rig = MisalignedRig();
  const RigModel model(rig);
  const RigFixed fixed = FixedOf(rig);
  const auto samples = Samples(model, 100000);
  std::vector<std::array<double, 3>> points(samples.size());
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (size_t i = 0; i < samples.size(); ++i) {
    points[i] = {samples[i].point.x(), samples[i].point.y(), samples[i].point.z()};
    if (samples[i].mirror == Mirror::kOne) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<Mirror1Residual, 2, 5, 5, 2, 5, 3, 3>(
              new Mirror1Residual{samples[i].pixel, fixed}),
          nullptr, rig.camera.data(), rig.distortion.data(), rig.mirror1_shape.data(),
          rig.mirror1_pose.data(), rig.reflex.data(), points[i].data());
    } else {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<Mirror2Residual, 2, 5, 5, 5, 3, 2, 5, 3>(
              new Mirror2Residual{samples[i].pixel, fixed}),
          nullptr, rig.camera.data(), rig.distortion.data(), rig.mirror1_pose.data(),
          rig.reflex.data(), rig.mirror2_shape.data(), rig.mirror2_pose.data(), points[i].data());
    }
  }
  ceres::Problem::EvaluateOptions options;
  options.num_threads = static_cast<int>(state.range(0));
  double cost = 0;
  std::vector<double> residuals;
  ceres::CRSMatrix jacobian;
  for (auto _ : state) {
    if (!problem.Evaluate(options, &cost, &residuals, nullptr, &jacobian)) {
      state.SkipWithError("Evaluate failed");
      break;
    }
    benchmark::DoNotOptimize(cost);
  }
  state.counters["residuals"] = static_cast<double>(samples.size());
  state.counters["rms_px"] = std::sqrt(2 * cost / residuals.size());
  state.SetItemsProcessed(state.iterations() * samples.size());
}
BENCHMARK(BM_CeresEvaluate100kResidualsWithJacobians)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace omni
BENCHMARK_MAIN();
