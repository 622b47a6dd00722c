// `omnistereo triangulate --model M --detections D --out out.csv [--sigma_px 1] [--truth T]`
// (DESIGN.md §5): every corner seen in both rings of an image is triangulated
// (model/triangulation.h) with its 3x3 covariance [uncertainty_propagation]. With --truth (the
// `omnistereo-truth/1` file of a synthetic session) the paper's table
// (tab:rmse_triangulation_experiment) is printed: RMSE, SD and points per range, with the mean
// predicted sigma and the mean NEES. Without --detections the truth's own pixels are used, with
// Gaussian noise of --noise_px (the experiment without a detector); --seeds N repeats that N times
// and prints how the RMSE per range spreads over the seeds beside the propagated prediction.
// --frame mirror1 gives the points relative to mirror 1's body (frame M1) instead of C; with
// --truth they are then compared with the true corners in the TRUE rig's M1 (the truth file's
// model), which takes out the calibrated camera frame's unobservable turn (model/triangulation.h
// ReferenceBody).
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "model/io/csv.h"
#include "model/io/detections_file.h"
#include "model/io/model_file.h"
#include "model/stereo/sparse_triangulation.h"
#include "model/triangulation.h"

DEFINE_string(truth, "", "ground truth of a synthetic session (omnistereo-truth/1): print the "
                         "RMSE table by range; without --detections, triangulate its pixels");
DEFINE_double(noise_px, 0.0, "with --truth and no --detections: Gaussian noise (px) added to "
                             "each truth pixel coordinate");
DEFINE_double(noise_px_ring2, -1.0, "with --noise_px: ring 2's (mirror 2's) noise if >= 0, "
                                    "else --noise_px");
DEFINE_int32(seed, 1, "random seed of --noise_px");
DEFINE_int32(seeds, 0, "with --truth and no --detections: also repeat the noisy experiment over "
                       "this many seeds (from --seed) and print, per range, the predicted RMSE "
                       "at the noise sigmas and the spread of the RMSE over the seeds");
DEFINE_string(method, "midpoint", "midpoint (common perpendicular) | reprojection (refined)");
DEFINE_double(sigma_px_ring2, 0.0, "inner ring's (mirror 2's) pixel sigma if > 0, else --sigma_px "
                                   "(the rings' corner errors differ; the refined point weighs "
                                   "them by 1/sigma^2)");
DEFINE_bool(model_covariance, false, "add the calibrated model's parameter covariance to each "
                                     "point's covariance");
DEFINE_string(frame, "cam", "frame of the output points and covariances: cam (C) | mirror1 (M1, "
                            "mirror 1's body; with --truth compared in the true rig's M1)");

namespace omni::apps {
namespace {

void RequireFlag(const std::string& value, const char* flag, const char* what) {
  if (value.empty()) throw io::InputError(std::string("--") + flag + ": expected " + what);
}

Pose<double> CamFromMirror1(const RigParams& rig) {
  return PoseFromBlock(rig.mirror1_pose.data());
}

// `p` (in the frame `to_from_cam` maps from, C) moved rigidly: point, covariances and pixel
// Jacobian re-expressed.
TriangulatedPoint Moved(TriangulatedPoint p, const Pose<double>& to_from_cam) {
  const Eigen::Matrix3d& r = to_from_cam.rotation;
  p.point_in_cam = to_from_cam * p.point_in_cam;
  p.covariance = r * p.covariance * r.transpose();
  p.model_covariance = r * p.model_covariance * r.transpose();
  p.jacobian_px = r * p.jacobian_px;
  return p;
}

}  // namespace

int RunTriangulate() {
  RequireFlag(FLAGS_model, "model", "a model file (omnistereo-model/1)");
  RequireFlag(FLAGS_out, "out", "the output CSV path");
  if (FLAGS_detections.empty() && FLAGS_truth.empty()) {
    throw io::InputError("--detections: expected a detections file (omnistereo-detections/1), "
                         "or --truth to triangulate the truth's pixels");
  }
  if (!(FLAGS_sigma_px >= 0)) throw io::InputError("--sigma_px: expected a number >= 0");
  if (!(FLAGS_noise_px >= 0)) throw io::InputError("--noise_px: expected a number >= 0");
  if (FLAGS_seeds < 0) throw io::InputError("--seeds: expected a number >= 0");
  if (FLAGS_seeds > 0 && (!FLAGS_detections.empty() || FLAGS_truth.empty())) {
    throw io::InputError("--seeds: expected --truth without --detections (the truth's pixels "
                         "plus --noise_px)");
  }
  TriangulationOptions options;
  if (!(FLAGS_sigma_px_ring2 >= 0)) throw io::InputError("--sigma_px_ring2: expected a number >= 0");
  options.sigma_px = FLAGS_sigma_px;
  options.sigma_px_ring2 = FLAGS_sigma_px_ring2;
  options.model_covariance = FLAGS_model_covariance;
  if (FLAGS_frame == "mirror1") {
    options.reference = ReferenceBody::kMirror1;
  } else if (FLAGS_frame != "cam") {
    throw io::InputError("--frame: expected cam or mirror1, got '" + FLAGS_frame + "'");
  }
  if (FLAGS_method == "midpoint") {
    options.method = TriangulationMethod::kMidpoint;
  } else if (FLAGS_method == "reprojection") {
    options.method = TriangulationMethod::kReprojection;
  } else {
    throw io::InputError("--method: expected midpoint or reprojection, got '" + FLAGS_method + "'");
  }

  const RigParams rig = io::ReadModelFile(FLAGS_model);
  const Triangulator triangulator{RigModel(rig)};
  if (FLAGS_model_covariance && !triangulator.has_model_covariance()) {
    throw io::InputError(FLAGS_model + ": calibration.covariance: expected a calibrated model "
                         "for --model_covariance");
  }
  if (!triangulator.unknown_parameters().empty()) {
    std::fprintf(stderr, "triangulate: warning: %zu calibration parameter(s) not in the model's "
                 "blocks, ignored in the covariance (first: %s)\n",
                 triangulator.unknown_parameters().size(),
                 triangulator.unknown_parameters()[0].c_str());
  }

  std::optional<stereo::Truth> truth;
  if (!FLAGS_truth.empty()) truth = stereo::ReadTruthFile(FLAGS_truth);
  // Output frame from C, and (with --truth) the estimate's M1 taken to the true rig's C.
  const Pose<double> out_from_cam = options.reference == ReferenceBody::kMirror1
                                        ? CamFromMirror1(rig).Inverse()
                                        : Pose<double>{Eigen::Matrix3d::Identity(),
                                                       Eigen::Vector3d::Zero()};
  Pose<double> true_cam_from_cam = {Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()};
  if (truth && options.reference == ReferenceBody::kMirror1) {
    if (truth->model.empty()) {
      throw io::InputError(FLAGS_truth + ": model: expected the true model file (for --frame "
                           "mirror1)");
    }
    const std::filesystem::path model_path =
        std::filesystem::path(FLAGS_truth).parent_path() / truth->model;
    const Pose<double> true_cam_from_mirror1 = CamFromMirror1(io::ReadModelFile(model_path.string()));
    const Pose<double> mirror1_from_cam = out_from_cam;
    true_cam_from_cam = {true_cam_from_mirror1.rotation * mirror1_from_cam.rotation,
                         true_cam_from_mirror1 * mirror1_from_cam.translation};
  }

  // The pixel pairs and the image names.
  std::vector<stereo::CornerPair> pairs;
  std::vector<std::string> image_names;
  long observations = 0;
  if (!FLAGS_detections.empty()) {
    const io::Detections detections = io::ReadDetectionsFile(FLAGS_detections);
    for (int i = 0; i < static_cast<int>(detections.images.size()); ++i) {
      const auto& image = detections.images[i];
      image_names.push_back(image.file);
      observations += static_cast<long>(image.corners.size());
      const auto image_pairs = stereo::PairCorners(triangulator, i, image.corners);
      pairs.insert(pairs.end(), image_pairs.begin(), image_pairs.end());
    }
    if (truth && truth->images.size() != detections.images.size()) {
      throw io::InputError(FLAGS_truth + ": images: expected " +
                           std::to_string(detections.images.size()) +
                           " images as in the detections file, got " +
                           std::to_string(truth->images.size()));
    }
  } else {
    std::mt19937 rng(static_cast<unsigned>(FLAGS_seed));
    pairs = stereo::TruthPairs(*truth, FLAGS_noise_px, &rng, FLAGS_noise_px_ring2);
    for (const auto& image : truth->images) image_names.push_back(image.file);
    observations = 2 * static_cast<long>(pairs.size());
  }

  io::CsvWriter out(FLAGS_out, {"image", "target", "id", "x_mm", "y_mm", "z_mm", "cov_xx",
                                "cov_xy", "cov_xz", "cov_yy", "cov_yz", "cov_zz", "u1", "v1",
                                "u2", "v2", "gap_mm"});
  std::vector<stereo::CornerError> errors;
  long triangulated = 0, failed = 0, unmatched = 0;
  for (const auto& pair : pairs) {
    const auto point = triangulator.Triangulate(pair.pixel1, pair.pixel2, options);
    if (!point) {
      ++failed;
      continue;
    }
    const TriangulatedPoint in_frame = Moved(*point, out_from_cam);
    const Eigen::Vector3d& p = in_frame.point_in_cam;  // in --frame
    const Eigen::Matrix3d& c = in_frame.covariance;
    out.Add(image_names[pair.image]);
    for (double value : {double(pair.target), double(pair.id), p.x(), p.y(), p.z(), c(0, 0),
                         c(0, 1), c(0, 2), c(1, 1), c(1, 2), c(2, 2), pair.pixel1.x(),
                         pair.pixel1.y(), pair.pixel2.x(), pair.pixel2.y(), point->gap_mm}) {
      out.Add(value);
    }
    out.EndRow();
    ++triangulated;
    if (truth) {
      if (auto e = stereo::CompareWithTruth(*truth, pair, Moved(*point, true_cam_from_cam))) {
        errors.push_back(*e);
      }
      else ++unmatched;
    }
  }
  if (triangulated == 0) {
    throw io::InputError((FLAGS_detections.empty() ? FLAGS_truth : FLAGS_detections) +
                         ": expected corners seen in both rings (mirror 1 and 2), got none that "
                         "triangulate");
  }
  out.Commit();
  std::printf("triangulate: %ld observations, %zu pairs, %ld triangulated (%s, sigma_px %g/%g%s), "
              "%ld failed -> %s (frame %s)\n",
              observations, pairs.size(), triangulated, FLAGS_method.c_str(), FLAGS_sigma_px,
              FLAGS_sigma_px_ring2 > 0 ? FLAGS_sigma_px_ring2 : FLAGS_sigma_px,
              FLAGS_model_covariance ? " + model covariance" : "", failed, FLAGS_out.c_str(),
              options.reference == ReferenceBody::kMirror1 ? "M1" : "C");
  if (truth) {
    if (FLAGS_detections.empty()) {
      std::printf("pixels: the truth's own, noise %g/%g px (seed %d)\n", FLAGS_noise_px,
                  FLAGS_noise_px_ring2 >= 0 ? FLAGS_noise_px_ring2 : FLAGS_noise_px, FLAGS_seed);
    }
    std::printf("%s", stereo::FormatRangeTable(stereo::RangeTable(errors)).c_str());
    if (unmatched > 0) std::printf("(%ld points without a true corner)\n", unmatched);
  }
  if (FLAGS_seeds > 0) {
    const double noise2 = FLAGS_noise_px_ring2 >= 0 ? FLAGS_noise_px_ring2 : FLAGS_noise_px;
    std::printf("over %d seeds (from %d), noise %g/%g px (rings 1/2), RMSE in mm:\n", FLAGS_seeds,
                FLAGS_seed, FLAGS_noise_px, noise2);
    std::printf("%s", stereo::FormatSeedSpread(
                          stereo::SeedSpread(triangulator, *truth, FLAGS_noise_px, noise2,
                                             FLAGS_seeds, static_cast<unsigned>(FLAGS_seed),
                                             options)).c_str());
  }
  return 0;
}

}  // namespace omni::apps
