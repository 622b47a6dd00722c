// 3D sensing speed (issue #7): panorama remap per 1280x960 frame (both rings) and dense depth
// (remap + SGBM + sub-pixel refinement + triangulation) frames per second at panorama width 1280
// on 1 and 2 threads, with and without the sub-pixel refinement (DepthOptions::refine_subpixel).
// The machine may be shared: process_cpu_ms is the CPU time of all threads per frame
// (getrusage), the figure that does not depend on what else runs.
// The paper does not state its panorama size; we use w = 1280 (its image width) and the height
// from [cylinder_height], [panorama_pixel_size] (1280 x 435 for the big rig).
// Input: OMNI_BENCH_IMAGE (e.g. a POV-Ray render of sample_configs/room_scene.yaml through
// OMNI_BENCH_MODEL, default sample_configs/big_rig_misaligned.yaml); without it, blurred noise.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <string>

#include <sys/resource.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "model/io/model_file.h"
#include "model/stereo/dense_stereo.h"

namespace omni::stereo {
namespace {

double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
         1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

const RigModel& Model() {
  static const RigModel model(io::ReadModelFile(
      std::getenv("OMNI_BENCH_MODEL")
          ? std::getenv("OMNI_BENCH_MODEL")
          : std::string(OMNI_SOURCE_DIR) + "/sample_configs/big_rig_misaligned.yaml"));
  return model;
}

const cv::Mat& Image() {
  static const cv::Mat image = [] {
    if (const char* path = std::getenv("OMNI_BENCH_IMAGE")) return cv::imread(path);
    cv::Mat noise(Model().params().image_height, Model().params().image_width, CV_8UC3);
    cv::randu(noise, 0, 255);
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.5);
    return noise;
  }();
  return image;
}

void BM_PanoramaRemapBothRings(benchmark::State& state) {
  cv::setNumThreads(static_cast<int>(state.range(0)));
  PanoramaOptions options;
  options.width = 1280;
  static const PanoramaLuts luts = BuildPanoramaLuts(Model(), options);
  cv::Mat p1, p2;
  const double cpu0 = ProcessCpuSeconds();
  for (auto _ : state) {
    Unwarp(Image(), luts, Mirror::kOne, &p1);
    Unwarp(Image(), luts, Mirror::kTwo, &p2);
    benchmark::DoNotOptimize(p2.data);
  }
  state.counters["frames_per_second"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["process_cpu_ms"] =
      1e3 * (ProcessCpuSeconds() - cpu0) / static_cast<double>(state.iterations());
  state.SetLabel(std::to_string(luts.geometry.width) + "x" +
                 std::to_string(luts.geometry.height) + " x2, threads " +
                 std::to_string(state.range(0)));
}
BENCHMARK(BM_PanoramaRemapBothRings)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_DepthFrame(benchmark::State& state) {
  cv::setNumThreads(static_cast<int>(state.range(0)));
  PanoramaOptions panorama;
  panorama.width = 1280;
  DepthOptions refined, sgbm_only;
  sgbm_only.refine_subpixel = false;
  static const DenseStereo dense_refined(Model(), panorama, refined);
  static const DenseStereo dense_sgbm(Model(), panorama, sgbm_only);
  const DenseStereo& dense = state.range(1) ? dense_refined : dense_sgbm;
  double sgbm = 0, tri = 0, remap = 0;
  size_t points = 0;
  const double cpu0 = ProcessCpuSeconds();
  for (auto _ : state) {
    const DepthFrame frame = dense.Compute(Image());
    sgbm += frame.seconds_sgbm;
    tri += frame.seconds_triangulation;
    remap += frame.seconds_remap;
    points = frame.points.size();
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["frames_per_second"] = benchmark::Counter(n, benchmark::Counter::kIsRate);
  state.counters["remap_ms"] = 1e3 * remap / n;
  state.counters["sgbm_ms"] = 1e3 * sgbm / n;
  state.counters["triangulation_ms"] = 1e3 * tri / n;
  state.counters["points"] = static_cast<double>(points);
  state.counters["process_cpu_ms"] = 1e3 * (ProcessCpuSeconds() - cpu0) / n;
  state.SetLabel("threads " + std::to_string(state.range(0)) +
                 (state.range(1) ? ", refined sub-pixel" : ", SGBM sub-pixel"));
}
BENCHMARK(BM_DepthFrame)
    ->Args({1, 1})->Args({2, 1})->Args({2, 0})
    ->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace omni::stereo

BENCHMARK_MAIN();
