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
// Readable corners (DetectorEvaluation's Readability) are judged at the camera's defocus per ring
// with the pixel's box (variance 1/12 px^2) added; EVAL_READABLE_MODULATION=F sets the threshold.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include <malloc.h>

#include <opencv2/core/utility.hpp>

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
  // The allocator as `omnistereo` sets it (apps/main.cc), so that the time per image is its.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
  const RigParams rig = io::ReadModelFile(argv[1]);
  const RigModel model(rig);
  const RigParams nominal = argc == 5 ? io::ReadModelFile(argv[4]) : rig;
  const synthetic::Scene scene = synthetic::ReadSceneFile(argv[2], model);
  const std::optional<synthetic::CameraEffects> camera =
      synthetic::CameraFromEnvironment("EVAL_CAMERA");
  if (camera) std::printf("camera: %s\n", camera->Summary().c_str());
  const auto t_ctx = std::chrono::steady_clock::now();
  const char* detect_model = std::getenv("EVAL_DETECT_MODEL");
  detectors::DetectorContext ctx(detect_model ? io::ReadModelFile(detect_model) : rig, scene.targets);
  if (const char* g = std::getenv("EVAL_GUIDED")) ctx.guided.enabled = std::string(g) != "0";
  if (detect_model) std::printf("detecting with %s\n", detect_model);
  ctx.tone = (camera ? *camera : scene.camera).FileTone();  // as the camera wrote the images
  const double ctx_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_ctx).count();
  const char* csv_path = std::getenv("EVAL_DETECTORS_CSV");
  std::FILE* csv = csv_path ? std::fopen(csv_path, "w") : nullptr;
  if (csv) std::fputs(detectors::DetectorEvaluation::CsvHeader(), csv);
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
    const detectors::LipGuide guide = detectors::GuideByLipsOf(
        scene.images.size(),
        [&](size_t i) { return detectors::GuideImage{load(i), ctx.chroma_halved, ctx.luma.clone()}; },
        &ctx);
    std::printf("%s\n", detectors::Describe(guide).c_str());
  }
  detectors::Readability readability;
  const synthetic::CameraEffects& wrote = camera ? *camera : scene.camera;
  for (int r = 0; r < 2; ++r) {
    readability.blur_sigma_px[r] = std::sqrt(std::pow(wrote.defocus_sigma_px[r], 2) + 1.0 / 12);
  }
  if (const char* m = std::getenv("EVAL_READABLE_MODULATION")) readability.min_modulation = std::atof(m);
  detectors::DetectorEvaluation evaluation(scene.targets, readability);
  detectors::DetectionRun run;
  for (size_t i = 0; i < scene.images.size(); ++i) {
    const cv::Mat raw = load(i);
    if (raw.empty()) continue;
    std::string rows;
    for (const std::string& line : detectors::DetectAndEvaluate(
             raw, scene.images[i].name, synthetic::ComputeTruth(model, scene, scene.images[i]),
             &ctx, &evaluation, &run, csv ? &rows : nullptr)) {
      std::fprintf(stderr, "%s\n", line.c_str());
    }
    if (csv) std::fputs(rows.c_str(), csv);
  }
  std::printf("%s",
              detectors::DetectionRunReport(run, ctx, evaluation, rig, nominal, ctx_ms).c_str());
  return 0;
}
