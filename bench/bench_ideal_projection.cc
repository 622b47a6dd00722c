// Ideal (SVP) closed-form forward and back projection throughput on one thread.
// Target (foundation issue): >= 20 million projections per second.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "model/ideal_model.h"

namespace omni {
namespace {

IdealModel BigRig() {
  return MakeIdealModel(DesignParams{123.488, 241.803, 5.7319, 9.7443, 233.684, 37.0}, 7.0,
                        Pinhole<double>{1450, 1450, 639.5, 479.5, 0});
}

std::vector<Eigen::Vector3d> Points(int n) {
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < n; ++i) {
    const double az = 0.0061 * i, el = -0.2 + 0.4 * ((i * 7919) % 1000) / 1000.0;
    const double range = 500 + (i % 17) * 300;
    pts.emplace_back(range * std::cos(el) * std::cos(az), range * std::cos(el) * std::sin(az),
                     60 + range * std::sin(el));
  }
  return pts;
}

void BM_IdealProject(benchmark::State& state) {
  const IdealModel m = BigRig();
  const auto pts = Points(4096);
  const Mirror mirror = state.range(0) == 1 ? Mirror::kOne : Mirror::kTwo;
  Eigen::Vector2d px;
  for (auto _ : state) {
    for (const auto& p : pts) {
      benchmark::DoNotOptimize(m.Project(p, mirror, &px));
      benchmark::DoNotOptimize(px);
    }
  }
  state.SetItemsProcessed(state.iterations() * pts.size());
}
BENCHMARK(BM_IdealProject)->Arg(1)->Arg(2);

void BM_IdealUnproject(benchmark::State& state) {
  const IdealModel m = BigRig();
  std::vector<Eigen::Vector2d> pixels;
  for (const auto& p : Points(4096)) {
    Eigen::Vector2d px;
    if (m.Project(p, Mirror::kOne, &px)) pixels.push_back(px);
    if (m.Project(p, Mirror::kTwo, &px)) pixels.push_back(px);
  }
  for (auto _ : state) {
    for (const auto& px : pixels) benchmark::DoNotOptimize(Unproject(m, px));
  }
  state.SetItemsProcessed(state.iterations() * pixels.size());
}
BENCHMARK(BM_IdealUnproject);

}  // namespace
}  // namespace omni

BENCHMARK_MAIN();
