// 3D sensing speed: dense depth per frame (remap, SGBM, sub-pixel refinement + triangulation),
// set-up excluded (DenseStereo built once), in four configurations, on 1 and 2 threads:
//   BM_DepthFrame/0: a 1280x960 frame, 1280-wide panoramas (1280 x 435), 64 disparities;
//   BM_DepthFrame/1: the same frame, 2048-wide panoramas, 64 disparities;
//   BM_DepthFrame/2: a 5 MP webcam frame (2592x1944) at its full angular resolution (2592-wide
//                    panoramas), 128 disparities.
//   BM_DepthFrame/3: the same 5 MP frame on the CLI's defaults, `depth --images ... --panorama_width
//                    2592` (DepthOptions{} and PanoramaOptions{} but the width: 64 disparities).
// The panoramas are remapped over the rows matching reads only, as `depth --images` does
// (DepthOptions::full_panoramas = false; before 2026-11-28 the whole panoramas, ~2.5x the remap).
// Counters: remap_ms, sgbm_ms, triangulation_ms (refinement included) as DepthFrame times them,
// frames_per_second (wall), points, and process_cpu_ms: the CPU time of all threads per frame
// (getrusage), the figure that does not depend on what else runs on a shared machine.
// Inputs: OMNI_BENCH_MODEL (default sample_configs/big_rig_misaligned.yaml; the 5 MP model is
// the same rig at 2592x1944, synthetic::RigAtImageSize, as `omnistereo render` makes it),
// OMNI_BENCH_IMAGE (1280x960) and OMNI_BENCH_IMAGE_5MP (2592x1944), e.g. POV-Ray renders of
// sample_configs/room_scene.yaml (for 5 MP, the same scene with `image: {width: 2592, height:
// 1944}`); without them, blurred noise (SGBM then matches far fewer points: not comparable).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <stdexcept>
#include <string>

#include <sys/resource.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/model_file.h"
#include "stereo/dense_stereo.h"
#include "synthetic/scene.h"

namespace omni::stereo {
namespace {

double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
         1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

const RigParams& Rig1280() {
  static const RigParams rig = io::ReadModelFile(
      std::getenv("OMNI_BENCH_MODEL")
          ? std::getenv("OMNI_BENCH_MODEL")
          : std::string(OMNI_SOURCE_DIR) + "/sample_configs/big_rig_misaligned.yaml");
  return rig;
}

cv::Mat LoadOrNoise(const char* env, int width, int height) {
  if (const char* path = std::getenv(env)) {
    cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
    if (image.cols != width || image.rows != height) {
      throw std::runtime_error(std::string(env) + "=" + path + ": expected a readable " +
                               std::to_string(width) + "x" + std::to_string(height) + " image");
    }
    return image;
  }
  cv::Mat noise(height, width, CV_8UC3);
  cv::randu(noise, 0, 255);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.5);
  return noise;
}

struct Config {
  RigModel model;
  cv::Mat image;
  PanoramaOptions panorama;
  DepthOptions depth;
};

const Config& GetConfig(int index) {
  static const Config configs[4] = {
      [] {
        const RigParams& rig = Rig1280();
        Config c{RigModel(rig), LoadOrNoise("OMNI_BENCH_IMAGE", rig.image_width, rig.image_height),
                 {}, {}};
        c.panorama.width = 1280;
        return c;
      }(),
      [] {
        const RigParams& rig = Rig1280();
        Config c{RigModel(rig), LoadOrNoise("OMNI_BENCH_IMAGE", rig.image_width, rig.image_height),
                 {}, {}};
        c.panorama.width = 2048;
        return c;
      }(),
      [] {
        const RigParams rig = synthetic::RigAtImageSize(Rig1280(), 2592, 1944);
        Config c{RigModel(rig), LoadOrNoise("OMNI_BENCH_IMAGE_5MP", 2592, 1944), {}, {}};
        c.panorama.width = 2592;
        c.depth.num_disparities = 128;
        return c;
      }(),
      [] {
        const RigParams rig = synthetic::RigAtImageSize(Rig1280(), 2592, 1944);
        Config c{RigModel(rig), LoadOrNoise("OMNI_BENCH_IMAGE_5MP", 2592, 1944), {}, {}};
        c.panorama.width = 2592;  // the CLI's other defaults (apps/cmd_depth.cc's flags)
        return c;
      }(),
  };
  return configs[index];
}

void BM_DepthFrame(benchmark::State& state) {
  const int index = static_cast<int>(state.range(0));
  cv::setNumThreads(static_cast<int>(state.range(1)));
  const Config& config = GetConfig(index);
  static const DenseStereo* dense[4] = {nullptr, nullptr, nullptr, nullptr};  // set-up: once, not timed
  if (!dense[index]) {
    DepthOptions options = config.depth;
    options.full_panoramas = false;  // as `depth --images` (the points do not depend on it)
    dense[index] = new DenseStereo(config.model, config.panorama, options);
  }
  double sgbm = 0, tri = 0, remap = 0;
  size_t points = 0;
  const double cpu0 = ProcessCpuSeconds();
  for (auto _ : state) {
    const DepthFrame frame = dense[index]->Compute(config.image);
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
  state.SetLabel(std::to_string(config.image.cols) + "x" + std::to_string(config.image.rows) +
                 ", panoramas " + std::to_string(dense[index]->luts().geometry.width) + "x" +
                 std::to_string(dense[index]->luts().geometry.height) + ", " +
                 std::to_string(config.depth.num_disparities) + " disparities, threads " +
                 std::to_string(state.range(1)));
}
BENCHMARK(BM_DepthFrame)
    ->ArgNames({"config", "threads"})
    ->Args({0, 1})->Args({0, 2})->Args({1, 2})->Args({2, 1})->Args({2, 2})
    ->Args({3, 1})->Args({3, 2})
    ->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace omni::stereo

BENCHMARK_MAIN();
