// Lip detection on rendered images against the exact images of the lips' 3D circles, and the
// lip-only intrinsics from them (a timed run):
//   eval_lips MODEL RENDER_DIR [TONE [NOMINAL]]
// Images are RENDER_DIR/NNNN.png or .jpg (not the kept *.pinhole.png); TONE (srgb | linear;
// default srgb for JPEG, linear for PNG) says how they encode light: they are decoded to 16-bit
// linear before detection, as DetectImage does (EVAL_LIPS_BITS=8: then scaled to 8 bit); JPEGs
// come with their own luma plane (EVAL_LIPS_NO_LUMA=1: without). The
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
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "detectors/lips/lip_detector.h"
#include "detectors/lips/lip_intrinsics.h"
#include "io/image_file.h"
#include "io/model_file.h"
#include "model/lip.h"
#include "synthetic/camera_effects.h"
#include "synthetic/scene_file.h"

using namespace omni;

namespace {

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

struct EdgeStats {
  std::vector<double> distances, band, contrast, noise;
  std::vector<double> edge_distances;  // to the band edge with the occlusion followed
  // The edge as a curve: per point, the mean signed distance of the points within +-kCurveDeg
  // of its azimuth (about the principal point) in the same image, what a local fit of the edge
  // there would be off by (the points' own scatter averages out, their common offset stays).
  std::vector<double> curve_offsets;
  std::vector<double> fit_distances;  // the fitted ellipse at each point, from the truth
  int on_rim = 0;                      // points whose band edge is the reflex disc's rim
  double signed_sum = 0;
  int images = 0;
  int no_truth = 0;  // points where the true rig images no point of their circle
};

}  // namespace

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
  std::optional<synthetic::CameraEffects> camera;
  if (const char* text = std::getenv("EVAL_CAMERA")) {
    camera = synthetic::ParseCameraEffects(text, "EVAL_CAMERA");
    std::printf("camera: %s\n", camera->Summary().c_str());
  }
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(argv[2])) {
    const std::string ext = entry.path().extension().string();
    std::string stem = entry.path().stem().string();
    if (camera) {
      if (ext != ".png" || stem.size() < 8 || stem.substr(stem.size() - 8) != ".pinhole") continue;
      stem = stem.substr(0, stem.size() - 8);
    } else if (ext != ".png" && ext != ".jpg") {
      continue;
    }
    if (!stem.empty() &&
        std::all_of(stem.begin(), stem.end(), [](char c) { return std::isdigit(c); })) {
      files.push_back(entry.path().string());
    }
  }
  std::sort(files.begin(), files.end());
  std::printf("lips: %s %s, %s / %s, %zu images, fed %s linear\n", truth_params.lip1.color.c_str(),
              truth_params.lip2.color.c_str(), argv[1], argv[2], files.size(),
              eight_bit ? "8-bit" : "16-bit");
  std::map<std::tuple<int, std::string, std::string, std::string>, EdgeStats> stats;
  std::vector<LipEdgeObservation> all_edges;
  std::vector<double> cpu_ms;
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
      image = cv::imdecode(bytes, cv::IMREAD_COLOR | cv::IMREAD_ANYDEPTH);
      srgb = camera->tone == synthetic::ToneCurve::kSrgb;
    }
    cv::Mat linear = io::LinearImage(image, srgb ? io::ToneCurve::kSrgb : io::ToneCurve::kLinear);
    if (eight_bit) linear.convertTo(linear, CV_8U, 1.0 / 257.0);
    if (std::getenv("EVAL_LIPS_NO_LUMA")) options.luma = cv::Mat();
    const std::clock_t c0 = std::clock();
    const std::vector<detectors::LipEdgeFit> fits = detectors::DetectLipEdges(linear, nominal, options);
    cpu_ms.push_back(1000.0 * (std::clock() - c0) / CLOCKS_PER_SEC);
    for (const detectors::LipEdgeFit& fit : fits) {
      EdgeStats& s = stats[{MirrorIndex(fit.edge.mirror), BandEdgeName(fit.edge.edge),
                             LipCircleName(*fit.edge.circle), LipPathName(*fit.edge.path)}];
      ++s.images;
      std::vector<std::pair<double, double>> azimuth_signed;  // this image's points of the edge
      for (const Eigen::Vector2d& p : fit.edge.points) {
        // Signed: + where the point lies farther from the principal point than the truth.
        Eigen::Vector2d q;
        const double d = DistanceToLipCircleImage(truth, *fit.edge.path, *fit.edge.circle, p, &q);
        LipBound bound = LipBound::kCircle;
        s.edge_distances.push_back(
            DistanceToLipEdgeImage(truth, *fit.edge.path, *fit.edge.circle, p, nullptr, &bound));
        if (bound == LipBound::kReflexRim) ++s.on_rim;
        {
          // The fitted ellipse at this point (one Newton step onto the conic from p), against
          // the truth: the edge as the ellipse fit gives it.
          const auto& c = fit.ellipse.conic;
          const double value = c[0] * p.x() * p.x() + c[1] * p.x() * p.y() + c[2] * p.y() * p.y() +
                               c[3] * p.x() + c[4] * p.y() + c[5];
          const Eigen::Vector2d grad(2 * c[0] * p.x() + c[1] * p.y() + c[3],
                                     c[1] * p.x() + 2 * c[2] * p.y() + c[4]);
          const Eigen::Vector2d foot = p - value * grad / grad.squaredNorm();
          const double d_fit = DistanceToLipCircleImage(truth, *fit.edge.path, *fit.edge.circle, foot);
          if (d_fit < 1e8) s.fit_distances.push_back(d_fit);
        }
        if (d > 1e8) {
          ++s.no_truth;
          continue;
        }
        const Eigen::Vector2d pp(truth_params.camera[kCx], truth_params.camera[kCy]);
        s.distances.push_back(d);
        s.signed_sum += (p - pp).norm() > (q - pp).norm() ? d : -d;
        azimuth_signed.push_back({std::atan2(p.y() - pp.y(), p.x() - pp.x()),
                                  (p - pp).norm() > (q - pp).norm() ? d : -d});
        if (std::getenv("EVAL_LIPS_POINTS")) {  // every point: mirror, path, u, v, signed error
          std::printf("point %d %s %.2f %.2f %+.3f\n", MirrorIndex(fit.edge.mirror), LipPathName(*fit.edge.path),
                      p.x(), p.y(), (p - pp).norm() > (q - pp).norm() ? d : -d);
        }
      }
      constexpr double kCurveDeg = 2.5;
      for (const auto& [azimuth, unused] : azimuth_signed) {
        double sum = 0;
        int count = 0;
        for (const auto& [other, signed_d] : azimuth_signed) {
          if (std::abs(std::remainder(other - azimuth, 2 * M_PI)) <= kCurveDeg * M_PI / 180) {
            sum += signed_d;
            ++count;
          }
        }
        s.curve_offsets.push_back(std::abs(sum / count));
      }
      s.band.push_back(fit.band);
      s.contrast.push_back(fit.contrast);
      s.noise.push_back(fit.noise);
      all_edges.push_back(fit.edge);
    }
  }
  std::printf("%-6s %-6s %-8s %-12s %6s %7s %8s %8s %8s %8s %7s %8s %6s %8s %8s %8s %6s %8s %9s %7s %8s\n",
              "mirror", "edge", "circle", "path", "images", "points", "mean_px", "p95_px",
              "max_px", "outward", "band", "contrast", "noise", "no_truth", "edge_mn", "edge_p95",
              "on_rim", "curve_mn", "curve_p95", "fit_mn", "fit_p95");
  for (const auto& [key, s] : stats) {
    double mean = 0;
    for (double d : s.distances) mean += d / s.distances.size();
    double edge_mean = 0;
    for (double d : s.edge_distances) edge_mean += d / s.edge_distances.size();
    double curve_mean = 0;
    for (double d : s.curve_offsets) curve_mean += d / s.curve_offsets.size();
    double fit_mean = 0;
    for (double d : s.fit_distances) fit_mean += d / s.fit_distances.size();
    std::printf(
        "%-6d %-6s %-8s %-12s %6d %7zu %8.4f %8.4f %8.4f %+8.4f %7.1f %8.1f %6.2f %8d %8.4f %8.4f "
        "%6d %8.4f %9.4f %7.4f %8.4f\n",
        std::get<0>(key), std::get<1>(key).c_str(), std::get<2>(key).c_str(),
        std::get<3>(key).c_str(), s.images, s.distances.size(), mean,
        Percentile(s.distances, 0.95), Percentile(s.distances, 1.0),
        s.signed_sum / std::max<size_t>(1, s.distances.size()), Percentile(s.band, 0.5),
        Percentile(s.contrast, 0.5), Percentile(s.noise, 0.5), s.no_truth, edge_mean,
        Percentile(s.edge_distances, 0.95), s.on_rim, curve_mean,
        Percentile(s.curve_offsets, 0.95), fit_mean, Percentile(s.fit_distances, 0.95));
  }
  if (!cpu_ms.empty()) {
    double sum = 0;
    for (double t : cpu_ms) sum += t;
    std::printf("DetectLipEdges CPU per %dx%d image: mean %.1f ms, max %.1f ms\n",
                truth_params.image_width, truth_params.image_height, sum / cpu_ms.size(),
                Percentile(cpu_ms, 1.0));
  }
  const double f_true = 0.5 * (truth_params.camera[kFx] + truth_params.camera[kFy]);
  for (const auto& [name, prior] : {std::pair<const char*, const RigModel*>{"nominal", &nominal},
                                    std::pair<const char*, const RigModel*>{"true rig", &truth}}) {
    const auto est = detectors::InitialIntrinsicsFromLips(all_edges, *prior);
    if (!est) {
      std::printf("lip-only fit from the %s model: failed (%zu edges)\n", name, all_edges.size());
      continue;
    }
    std::printf("lip-only fit from the %s model: f %.3f (%+.3f%%), pp - true (%+.3f, %+.3f) px, "
                "rms %.3f px, %d points\n", name, est->f, 100 * (est->f / f_true - 1),
                est->cx - truth_params.camera[kCx], est->cy - truth_params.camera[kCy], est->rms_px,
                est->n_points);
  }
  return 0;
}
