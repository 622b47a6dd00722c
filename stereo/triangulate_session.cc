#include "stereo/triangulate_session.h"

#include <cstdarg>
#include <cstdio>

#include "model/input_error.h"

namespace omni::stereo {
namespace {

// printf into a string of any length.
std::string Format(const char* format, ...) {
  va_list args, copy;
  va_start(args, format);
  va_copy(copy, args);
  const int size = std::vsnprintf(nullptr, 0, format, copy);
  va_end(copy);
  std::string text(size > 0 ? size : 0, '\0');
  if (size > 0) std::vsnprintf(text.data(), text.size() + 1, format, args);
  va_end(args);
  return text;
}

double NoiseRing2(const SessionTriangulationOptions& options) {
  return options.noise_px_ring2 >= 0 ? options.noise_px_ring2 : options.noise_px;
}

}  // namespace

std::string SessionTriangulationOptions::Check() const {
  if (model.empty()) return "--model: expected a model file (omnistereo-model/1)";
  if (out.empty()) return "--out: expected the output CSV path";
  if (detections.empty() && truth.empty()) {
    return "--detections: expected a detections file (omnistereo-detections/1), or --truth to "
           "triangulate the truth's pixels";
  }
  if (!(sigma_px >= 0)) return "--sigma_px: expected a number >= 0";
  if (!(noise_px >= 0)) return "--noise_px: expected a number >= 0";
  if (seeds < 0) return "--seeds: expected a number >= 0";
  if (seeds > 0 && (!detections.empty() || truth.empty())) {
    return "--seeds: expected --truth without --detections (the truth's pixels plus --noise_px)";
  }
  if (!(sigma_px_ring2 >= 0)) return "--sigma_px_ring2: expected a number >= 0";
  if (frame != "cam" && frame != "mirror1") {
    return "--frame: expected cam or mirror1, got '" + frame + "'";
  }
  if (method != "midpoint" && method != "reprojection") {
    return "--method: expected midpoint or reprojection, got '" + method + "'";
  }
  return "";
}

TriangulationOptions SessionTriangulationOptions::Triangulation() const {
  TriangulationOptions options;
  options.sigma_px = sigma_px;
  options.sigma_px_ring2 = sigma_px_ring2;
  options.model_covariance = model_covariance;
  options.reference = frame == "mirror1" ? ReferenceBody::kMirror1 : ReferenceBody::kCam;
  options.method = method == "reprojection" ? TriangulationMethod::kReprojection
                                            : TriangulationMethod::kMidpoint;
  return options;
}

std::string CheckModelFor(const Triangulator& triangulator,
                          const SessionTriangulationOptions& options) {
  if (options.model_covariance && !triangulator.has_model_covariance()) {
    throw InputError(options.model + ": calibration.covariance: expected a calibrated model "
                     "for --model_covariance");
  }
  const std::vector<std::string>& unknown = triangulator.unknown_parameters();
  if (unknown.empty()) return "";
  return Format("%zu calibration parameter(s) not in the model's blocks, ignored in the "
                "covariance (first: %s)", unknown.size(), unknown[0].c_str());
}

SessionTriangulationRun TriangulateSession(const Triangulator& triangulator, const RigParams& rig,
                                           const SessionTriangulationOptions& options,
                                           const Observations* detections, const Truth* truth,
                                           const RigParams* true_rig) {
  SessionTriangulationRun run;
  run.options = options.Triangulation();
  run.measured_noise = !options.sigma_given &&
                       MeasuredCornerNoise(rig, &run.options.sigma_px, &run.options.sigma_px_ring2);
  const OutputFrames frames = FramesOf(rig, run.options.reference, true_rig);
  if (detections == nullptr) {
    run.pairs = PairsOfTruth(*truth, options.noise_px, options.noise_px_ring2,
                             static_cast<unsigned>(options.seed));
  } else {
    if (truth && truth->images.size() != detections->images.size()) {
      throw InputError(options.truth + ": images: expected " +
                       std::to_string(detections->images.size()) +
                       " images as in the detections file, got " +
                       std::to_string(truth->images.size()));
    }
    run.pairs = PairsOfDetections(triangulator, *detections);
  }
  run.result = TriangulatePairs(triangulator, run.pairs.pairs, run.options, frames, truth);
  if (run.result.points.empty()) {
    throw InputError((options.detections.empty() ? options.truth : options.detections) +
                     ": expected corners seen in both rings (mirror 1 and 2), got none that "
                     "triangulate");
  }
  return run;
}

std::vector<std::string> TriangulatedColumns() {
  return {"image", "target", "id", "x_mm", "y_mm", "z_mm", "cov_xx", "cov_xy", "cov_xz", "cov_yy",
          "cov_yz", "cov_zz", "u1", "v1", "u2", "v2", "gap_mm"};
}

std::vector<std::pair<std::string, std::vector<double>>> TriangulatedRows(
    const SessionTriangulationRun& run) {
  std::vector<std::pair<std::string, std::vector<double>>> rows;
  rows.reserve(run.result.points.size());
  for (const auto& [pair, point] : run.result.points) {
    const Eigen::Vector3d& p = point.point_in_cam;  // in the output frame
    const Eigen::Matrix3d& c = point.covariance;
    rows.emplace_back(run.pairs.image_names[pair.image],
                      std::vector<double>{double(pair.target), double(pair.id), p.x(), p.y(),
                                          p.z(), c(0, 0), c(0, 1), c(0, 2), c(1, 1), c(1, 2),
                                          c(2, 2), pair.pixel1.x(), pair.pixel1.y(),
                                          pair.pixel2.x(), pair.pixel2.y(), point.gap_mm});
  }
  return rows;
}

std::string TriangulationSummary(const SessionTriangulationRun& run,
                                 const SessionTriangulationOptions& options) {
  const TriangulationOptions& used = run.options;
  return Format("triangulate: %ld observations, %zu pairs, %zu triangulated (%s, sigma_px "
                "%.3g/%.3g%s%s), %ld failed -> %s (frame %s)\n",
                run.pairs.observations, run.pairs.pairs.size(), run.result.points.size(),
                options.method.c_str(), used.sigma_px,
                used.sigma_px_ring2 > 0 ? used.sigma_px_ring2 : used.sigma_px,
                run.measured_noise ? ", the model's measured corner noise" : "",
                options.model_covariance ? " + model covariance" : "", run.result.failed,
                options.out.c_str(), used.reference == ReferenceBody::kMirror1 ? "M1" : "C");
}

std::string TruthTables(const Triangulator& triangulator, const Truth& truth,
                        const SessionTriangulationRun& run,
                        const SessionTriangulationOptions& options,
                        const std::vector<ReferenceRow>& reference) {
  std::string text;
  if (options.detections.empty()) {
    text += Format("pixels: the truth's own, noise %g/%g px (seed %d)\n", options.noise_px,
                   NoiseRing2(options), options.seed);
  }
  text += FormatRangeTable(RangeTable(run.result.errors), reference);
  if (run.result.unmatched > 0) {
    text += Format("(%ld points without a true corner)\n", run.result.unmatched);
  }
  if (options.seeds > 0) {
    text += Format("over %d seeds (from %d), noise %g/%g px (rings 1/2), RMSE in mm:\n",
                   options.seeds, options.seed, options.noise_px, NoiseRing2(options));
    text += FormatSeedSpread(SeedSpread(triangulator, truth, options.noise_px, NoiseRing2(options),
                                        options.seeds, static_cast<unsigned>(options.seed),
                                        run.options),
                             reference);
  }
  return text;
}

}  // namespace omni::stereo
