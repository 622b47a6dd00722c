// Accuracy and speed of the detectors on a rendered synthetic session (`omnistereo render`), a
// timed run against the exact ground truth (ComputeTruth): per ring and per horizontal range of
// the corner from the axis, the corner error (mean, 99th percentile), the fraction of truly
// visible corners found, wrong ids, and the time per image on one core.
//   eval_detectors MODEL SCENE RENDER_DIR [NOMINAL]
// Images are RENDER_DIR/NNNN.png or .jpg; with EVAL_CAMERA=PRESET (or a camera_effects map in
// YAML) the camera is applied to the kept linear renders RENDER_DIR/NNNN.pinhole.png instead
// (render --keep_pinhole), to measure presets and single effects on the same renders.
// Corners found by guided detection across rings (detectors/guided_detection.h) are also
// tabulated on their own (EVAL_GUIDED=0 turns it off). EVAL_DETECT_MODEL=FILE detects with that
// model (e.g. the ideal design a user starts from) while the truth comes from MODEL.
// On colour renders it also fits the lip-only intrinsics (InitialIntrinsicsFromLips) from the
// NOMINAL model (default: MODEL) and compares the principal point it gives with the true one and
// with the image points that the mirror bodies' poses fix. The evaluation itself is
// detectors/detector_evaluation.h; EVAL_DETECTORS_CSV=FILE writes every matched corner and every
// missed visible one; EVAL_SAVE_DIR=DIR the images as EVAL_CAMERA's camera wrote them.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include <malloc.h>

#include <opencv2/core/utility.hpp>

#include "detectors/detect_image.h"
#include "detectors/detector_evaluation.h"
#include "detectors/lip_guide.h"
#include "io/model_file.h"
#include "synthetic/camera_effects.h"
#include "synthetic/rendered_image.h"
#include "synthetic/scene.h"
#include "synthetic/scene_file.h"

using namespace omni;

int main(int argc, char** argv) {
  if (argc != 4 && argc != 5) {
    std::fprintf(stderr, "usage: eval_detectors MODEL SCENE RENDER_DIR [NOMINAL]\n");
    return 2;
  }
  cv::setNumThreads(1);
  // The allocator as `omnistereo` sets it (apps/main.cc): image buffers kept on the heap for the
  // next image, so that the time per image is the command's.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
  const RigParams rig = io::ReadModelFile(argv[1]);
  const RigModel model(rig);
  const RigParams nominal = argc == 5 ? io::ReadModelFile(argv[4]) : rig;
  const synthetic::Scene scene = synthetic::ReadSceneFile(argv[2], model);
  std::optional<synthetic::CameraEffects> camera;
  if (const char* text = std::getenv("EVAL_CAMERA")) {
    camera = synthetic::ParseCameraEffects(text, "EVAL_CAMERA");
    std::printf("camera: %s\n", camera->Summary().c_str());
  }
  const auto t_ctx = std::chrono::steady_clock::now();
  const char* detect_model = std::getenv("EVAL_DETECT_MODEL");
  detectors::DetectorContext ctx(detect_model ? io::ReadModelFile(detect_model) : rig, scene.targets);
  if (const char* g = std::getenv("EVAL_GUIDED")) ctx.guided.enabled = std::string(g) != "0";
  if (detect_model) std::printf("detecting with %s\n", detect_model);
  // The images are encoded as the camera wrote them (raw mosaics are linear).
  const synthetic::CameraEffects& effects = camera ? *camera : scene.camera;
  ctx.tone = effects.raw_mosaic ? io::ToneCurve::kLinear : effects.tone;
  const double ctx_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_ctx).count();
  std::FILE* csv = nullptr;
  if (const char* csv_path = std::getenv("EVAL_DETECTORS_CSV")) {
    csv = std::fopen(csv_path, "w");
    if (csv) std::fputs(detectors::DetectorEvaluation::CsvHeader(), csv);
  }
  const char* save_dir = std::getenv("EVAL_SAVE_DIR");
  auto load = [&](size_t index) {  // one image as the detector gets it; ctx's JPEG luma set
    synthetic::RenderedImage r = synthetic::ReadRenderedImage(
        argv[3], scene.images[index].name, rig, camera ? &*camera : nullptr,
        scene.noise_seed + index, save_dir ? save_dir : "");
    ctx.chroma_halved = r.chroma_halved;
    ctx.luma = r.luma;
    if (r.image.empty()) std::fprintf(stderr, "skipping %s (cannot read)\n", r.path.c_str());
    return r.image;
  };
  // The lip guide, as detect and calibrate run it (EVAL_LIP_GUIDE=0: the model as it is).
  const char* lip_guide = std::getenv("EVAL_LIP_GUIDE");
  if (!lip_guide || std::string(lip_guide) != "0") {
    std::vector<detectors::GuideImage> guide_images;
    for (size_t i : detectors::LipGuideImages(scene.images.size())) {
      const cv::Mat raw = load(i);
      guide_images.push_back({raw, ctx.chroma_halved, ctx.luma.clone()});
    }
    std::printf("%s\n", detectors::Describe(detectors::GuideByLips(guide_images, &ctx)).c_str());
  }
  detectors::DetectorEvaluation evaluation(scene.targets);
  std::array<std::vector<double>, 2> view_blur;  // per ring, every image's measured view blur
  std::vector<double> times_ms, cpu_ms;  // wall clock, process CPU time (one thread)
  std::vector<LipEdgeObservation> all_lips;  // every image's labelled lip edges, for one pooled fit
  int lip_images = 0;
  for (size_t i = 0; i < scene.images.size(); ++i) {
    const cv::Mat raw = load(i);
    if (raw.empty()) continue;
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    std::vector<bool> guided;
    const ImageObservations det = detectors::DetectImage(raw, &ctx, nullptr, &guided);
    for (const detectors::RingView& v : ctx.views) {
      if (v.blur_sigma) view_blur[MirrorIndex(v.mirror) - 1].push_back(*v.blur_sigma);
    }
    cpu_ms.push_back(1000.0 * (std::clock() - c0) / CLOCKS_PER_SEC);
    times_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    if (!det.lips.empty()) {
      ++lip_images;
      all_lips.insert(all_lips.end(), det.lips.begin(), det.lips.end());
    }
    const std::string& name = scene.images[i].name;
    std::string rows;
    for (const std::string& line :
         evaluation.AddImage(name, det, guided, synthetic::ComputeTruth(model, scene, scene.images[i]),
                             csv ? &rows : nullptr)) {
      std::fprintf(stderr, "%s\n", line.c_str());
    }
    if (csv) std::fputs(rows.c_str(), csv);
    std::fprintf(stderr, "%s: %zu corners in %.1f ms\n", name.c_str(), det.corners.size(),
                 times_ms.back());
  }
  std::printf("views and layout built once in %.0f ms\n", ctx_ms);
  for (int ring = 0; ring < 2; ++ring) {
    for (const detectors::RingView& v : ctx.views) {
      if (MirrorIndex(v.mirror) != ring + 1) continue;
      std::printf("ring %d views: %d x %d px, f %.0f px/rad, measured blur sigma median %.2f view px\n",
                  ring + 1, v.width, v.height, v.f, detectors::Percentile(view_blur[ring], 0.5));
      break;
    }
  }
  std::printf("%s", evaluation.Tables().c_str());
  if (!times_ms.empty()) {
    const auto sum = [](const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0); };
    std::printf("time per %dx%d image on one core: mean %.1f ms, max %.1f ms (%zu images)\n",
                rig.image_width, rig.image_height, sum(times_ms) / times_ms.size(),
                detectors::Percentile(times_ms, 1.0), times_ms.size());
    std::printf("CPU time per image (independent of other load): mean %.1f ms, max %.1f ms\n",
                sum(cpu_ms) / cpu_ms.size(), detectors::Percentile(cpu_ms, 1.0));
  }
  if (!all_lips.empty()) {
    std::printf("%s", detectors::LipIntrinsicsAgainstTruth(rig, nominal, all_lips, lip_images).c_str());
  }
  return 0;
}
