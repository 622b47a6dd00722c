// Lip detection on rendered images against the exact images of the lips' 3D circles, and the
// lip-only intrinsics from them (a timed run):
//   eval_lips MODEL RENDER_DIR [TONE [NOMINAL]]
// Images are RENDER_DIR/NNNN.png or .jpg (not the kept *.pinhole.png); TONE (srgb | linear;
// default srgb for JPEG, linear for PNG) says how they encode light: they are decoded to 16-bit
// linear before detection, as DetectImage does (EVAL_LIPS_BITS=8: then scaled to 8 bit); JPEGs
// come with their own luma plane (EVAL_LIPS_NO_LUMA=1: without); EVAL_LIPS_COLOUR=1 places every
// point on the colour (no luma placement), EVAL_LIPS_LUMA=1 on the luma even for an image with
// full chroma (a PNG: Y' from its colours), to tell the placements' own biases apart. With
// EVAL_CAMERA, EVAL_LIPS_EXACT=colour takes the colours from the camera's image before its JPEG
// (the luma still the file's), EVAL_LIPS_EXACT=luma the luma (the colours the file's). The
// detector's prior is NOMINAL (default MODEL). EVAL_CAMERA=PRESET (or a camera_effects map in
// YAML): the camera applied to the kept linear renders RENDER_DIR/NNNN.pinhole.png (render
// --keep_pinhole) instead, as eval_detectors does; EVAL_LIPS_POINTS=1 prints every point.
// Reports per edge (mirror, side, circle, path) the points kept, their mean / p95 / max distance
// to the image of their labelled circle in MODEL (DistanceToLipCircleImage; `outward`: the mean
// signed, + away from the principal point; `no_truth`: points where MODEL images no such circle
// point, left out of the distances; `edge_mn` / `edge_p95`: the distance to the band edge with
// the occlusion followed, ProjectLipEdge, over every point; `on_rim`: points whose edge there is
// the reflex disc's rim; `curve_mn` / `curve_p95`: the edge as a curve, per point the mean
// signed distance of the image's points within +-2.5 deg of its azimuth; `fit_mn` / `fit_p95`: the
// edge as the detector's ellipse fit of the image gives it, its distance from the truth at each
// point's azimuth), the band's paint likeness, colour contrast and noise
// (LipEdgeFit, 8-bit linear levels), the lip-only fit of f and the principal point
// (InitialIntrinsicsFromLips from NOMINAL and from MODEL) and the CPU time of DetectLipEdges.
// The evaluation itself is detectors/lip_evaluation.h.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/lip_evaluation.h"
#include "detectors/lips/lip_detector.h"
#include "io/image_file.h"
#include "io/model_file.h"
#include "synthetic/camera_effects.h"
#include "synthetic/rendered_image.h"
#include "synthetic/scene_file.h"

using namespace omni;

int main(int argc, char** argv) {
  if (argc < 3 || argc > 5) {
    std::fprintf(stderr, "usage: eval_lips MODEL RENDER_DIR [srgb|linear [NOMINAL]]\n");
    return 2;
  }
  cv::setNumThreads(1);
  const RigParams truth_params = io::ReadModelFile(argv[1]);
  const RigModel truth(truth_params);
  const RigModel nominal(argc == 5 ? io::ReadModelFile(argv[4]) : truth_params);
  const char* bits_env = std::getenv("EVAL_LIPS_BITS");
  const bool eight_bit = bits_env && std::string(bits_env) == "8";
  const std::optional<synthetic::CameraEffects> camera =
      synthetic::CameraFromEnvironment("EVAL_CAMERA");
  if (camera) std::printf("camera: %s\n", camera->Summary().c_str());
  const std::vector<std::string> files = synthetic::NumberedRenders(argv[2], camera.has_value());
  std::printf("lips: %s %s, %s / %s, %zu images, fed %s linear\n", truth_params.lip1.color.c_str(),
              truth_params.lip2.color.c_str(), argv[1], argv[2], files.size(),
              eight_bit ? "8-bit" : "16-bit");
  detectors::LipEvaluation evaluation(truth);
  const bool print_points = std::getenv("EVAL_LIPS_POINTS") != nullptr;
  for (const std::string& file : files) {
    cv::Mat image = cv::imread(file, cv::IMREAD_COLOR | cv::IMREAD_ANYDEPTH);
    if (image.empty()) continue;
    bool srgb = argc >= 4 ? std::string(argv[3]) == "srgb"
                          : std::filesystem::path(file).extension() == ".jpg";
    detectors::LipDetectorOptions options;
    options.chroma_halved = io::HasHalvedChroma(file);
    options.luma = io::ReadStoredLuma(file);
    if (camera) {  // the camera on the linear render, and its file as the camera writes it
      image = synthetic::ApplyCamera(image, truth_params, *camera, 1 + (&file - &files[0]));
      std::vector<uchar> bytes;
      synthetic::EncodeCameraImage(image, *camera, &bytes);
      options.chroma_halved = io::HasHalvedChroma(bytes);
      options.luma = io::ReadStoredLuma(bytes);
      const cv::Mat before_file = image;
      image = cv::imdecode(bytes, cv::IMREAD_COLOR | cv::IMREAD_ANYDEPTH);
      // Which of the JPEG's two parts moves the edges: its colours or its luma.
      const char* exact = std::getenv("EVAL_LIPS_EXACT");
      if (exact && std::string(exact) == "colour") image = before_file;
      if (exact && std::string(exact) == "luma" && before_file.depth() == CV_8U) {
        cv::cvtColor(before_file, options.luma, cv::COLOR_BGR2GRAY);  // Rec. 601, as JPEG's Y'
      }
      srgb = camera->tone == synthetic::ToneCurve::kSrgb;
    }
    cv::Mat linear = io::LinearImage(image, srgb ? io::ToneCurve::kSrgb : io::ToneCurve::kLinear);
    if (eight_bit) linear.convertTo(linear, CV_8U, 1.0 / 257.0);
    if (std::getenv("EVAL_LIPS_NO_LUMA")) options.luma = cv::Mat();
    if (std::getenv("EVAL_LIPS_COLOUR")) options.chroma_halved = false;
    if (std::getenv("EVAL_LIPS_LUMA")) options.chroma_halved = true;
    std::string points;
    evaluation.DetectAndAdd(linear, nominal, options, print_points ? &points : nullptr);
    std::printf("%s", points.c_str());
  }
  std::printf("%s", evaluation.Report(nominal).c_str());
  return 0;
}
