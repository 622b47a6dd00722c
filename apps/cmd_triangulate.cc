// `omnistereo triangulate --model M --detections D --out out.csv [--sigma_px S] [--truth T]`
// (without --sigma_px: a calibrated model's measured corner noise per ring, else 1 px)
// (docs/design.md, Conventions): every corner seen in both rings of an image is triangulated
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
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/stereo_cli.h"
#include "io/csv.h"
#include "io/detections_file.h"
#include "io/model_file.h"
#include "io/truth_file.h"
#include "model/triangulation.h"
#include "stereo/sparse_triangulation.h"
#include "stereo/triangulation_inputs.h"

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
DEFINE_string(reference_table, "", "with --truth: a CSV (range_m,rmse_mm,sd_mm) printed beside the "
                                   "RMSE table by range, e.g. bench/paper_triangulation_table.csv "
                                   "(the paper's)");
DEFINE_string(method, "midpoint", "midpoint (common perpendicular) | reprojection (refined)");
DEFINE_double(sigma_px_ring2, 0.0, "inner ring's (mirror 2's) pixel sigma if > 0, else --sigma_px "
                                   "(the rings' corner errors differ; the refined point weighs "
                                   "them by 1/sigma^2)");
DEFINE_bool(model_covariance, false, "add the calibrated model's parameter covariance to each "
                                     "point's covariance");

namespace omni::apps {
namespace {

// The flags as triangulation options; throws io::InputError naming the flag.
TriangulationOptions OptionsFromFlags() {
  RequireStereoFlag(FLAGS_model, "model", "a model file (omnistereo-model/1)");
  RequireStereoFlag(FLAGS_out, "out", "the output CSV path");
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
  return options;
}

// The true rig of --truth (its `model:` file), needed to compare in M1.
RigParams TrueRig(const Truth& truth) {
  if (truth.model.empty()) {
    throw io::InputError(FLAGS_truth + ": model: expected the true model file (for --frame "
                         "mirror1)");
  }
  return io::ReadModelFile(
      (std::filesystem::path(FLAGS_truth).parent_path() / truth.model).string());
}

// The corner pairs: from --detections (paired by the model), or the truth's pixels plus noise.
stereo::SessionPairs ReadPairs(const Triangulator& triangulator, const std::optional<Truth>& truth) {
  if (FLAGS_detections.empty()) {
    return stereo::PairsOfTruth(*truth, FLAGS_noise_px, FLAGS_noise_px_ring2,
                                static_cast<unsigned>(FLAGS_seed));
  }
  const Observations detections = io::ReadDetectionsFile(FLAGS_detections);
  if (truth && truth->images.size() != detections.images.size()) {
    throw io::InputError(FLAGS_truth + ": images: expected " +
                         std::to_string(detections.images.size()) +
                         " images as in the detections file, got " +
                         std::to_string(truth->images.size()));
  }
  return stereo::PairsOfDetections(triangulator, detections);
}

void WriteCsv(const stereo::SessionTriangulation& result,
              const std::vector<std::string>& image_names) {
  io::CsvWriter out(FLAGS_out, {"image", "target", "id", "x_mm", "y_mm", "z_mm", "cov_xx",
                                "cov_xy", "cov_xz", "cov_yy", "cov_yz", "cov_zz", "u1", "v1",
                                "u2", "v2", "gap_mm"});
  for (const auto& [pair, point] : result.points) {
    const Eigen::Vector3d& p = point.point_in_cam;  // in --frame
    const Eigen::Matrix3d& c = point.covariance;
    out.Add(image_names[pair.image]);
    for (double value : {double(pair.target), double(pair.id), p.x(), p.y(), p.z(), c(0, 0),
                         c(0, 1), c(0, 2), c(1, 1), c(1, 2), c(2, 2), pair.pixel1.x(),
                         pair.pixel1.y(), pair.pixel2.x(), pair.pixel2.y(), point.gap_mm}) {
      out.Add(value);
    }
    out.EndRow();
  }
  out.Commit();
}

// --reference_table's rows (empty without it); throws io::InputError naming the file and line.
std::vector<stereo::ReferenceRow> ReadReferenceTable() {
  std::vector<stereo::ReferenceRow> rows;
  if (FLAGS_reference_table.empty()) return rows;
  io::CsvReader in(FLAGS_reference_table, {"range_m", "rmse_mm", "sd_mm"});
  std::vector<double> v;
  while (in.ReadRow(&v)) {
    if (!(v[0] > 0) || !(v[1] >= 0) || !(v[2] >= 0)) {
      throw io::InputError(FLAGS_reference_table + ": line " + std::to_string(in.line()) +
                           ": expected range_m > 0 and rmse_mm, sd_mm >= 0");
    }
    rows.push_back({v[0], v[1], v[2]});
  }
  return rows;
}

void PrintTruthTables(const Triangulator& triangulator, const Truth& truth,
                      const stereo::SessionTriangulation& result,
                      const TriangulationOptions& options,
                      const std::vector<stereo::ReferenceRow>& reference) {
  const double noise2 = FLAGS_noise_px_ring2 >= 0 ? FLAGS_noise_px_ring2 : FLAGS_noise_px;
  if (FLAGS_detections.empty()) {
    std::printf("pixels: the truth's own, noise %g/%g px (seed %d)\n", FLAGS_noise_px, noise2,
                FLAGS_seed);
  }
  std::printf("%s", stereo::FormatRangeTable(stereo::RangeTable(result.errors), reference).c_str());
  if (result.unmatched > 0) std::printf("(%ld points without a true corner)\n", result.unmatched);
  if (FLAGS_seeds > 0) {
    std::printf("over %d seeds (from %d), noise %g/%g px (rings 1/2), RMSE in mm:\n", FLAGS_seeds,
                FLAGS_seed, FLAGS_noise_px, noise2);
    std::printf("%s", stereo::FormatSeedSpread(
                          stereo::SeedSpread(triangulator, truth, FLAGS_noise_px, noise2,
                                             FLAGS_seeds, static_cast<unsigned>(FLAGS_seed),
                                             options),
                          reference).c_str());
  }
}

}  // namespace

int RunTriangulate() {
  TriangulationOptions options = OptionsFromFlags();
  const RigParams rig = io::ReadModelFile(FLAGS_model);
  // Without --sigma_px, a calibrated model's measured corner noise per ring (its residual RMS is
  // sqrt(2) sigma per axis): the 1 px default made sigmas ~10x those the session measured.
  std::string sigma_source;
  if (gflags::GetCommandLineFlagInfoOrDie("sigma_px").is_default &&
      gflags::GetCommandLineFlagInfoOrDie("sigma_px_ring2").is_default &&
      stereo::MeasuredCornerNoise(rig, &options.sigma_px, &options.sigma_px_ring2)) {
    sigma_source = ", the model's measured corner noise";
  }
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
  std::optional<Truth> truth;
  if (!FLAGS_truth.empty()) truth = io::ReadTruthFile(FLAGS_truth);
  const std::vector<stereo::ReferenceRow> reference = ReadReferenceTable();
  std::optional<RigParams> true_rig;
  if (truth && options.reference == ReferenceBody::kMirror1) true_rig = TrueRig(*truth);
  const stereo::OutputFrames frames =
      stereo::FramesOf(rig, options.reference, true_rig ? &*true_rig : nullptr);

  const stereo::SessionPairs pairs = ReadPairs(triangulator, truth);
  const stereo::SessionTriangulation result = stereo::TriangulatePairs(
      triangulator, pairs.pairs, options, frames, truth ? &*truth : nullptr);
  if (result.points.empty()) {
    throw io::InputError((FLAGS_detections.empty() ? FLAGS_truth : FLAGS_detections) +
                         ": expected corners seen in both rings (mirror 1 and 2), got none that "
                         "triangulate");
  }
  WriteCsv(result, pairs.image_names);
  std::printf("triangulate: %ld observations, %zu pairs, %zu triangulated (%s, sigma_px %.3g/%.3g%s%s), "
              "%ld failed -> %s (frame %s)\n",
              pairs.observations, pairs.pairs.size(), result.points.size(), FLAGS_method.c_str(),
              options.sigma_px, options.sigma_px_ring2 > 0 ? options.sigma_px_ring2 : options.sigma_px,
              sigma_source.c_str(), FLAGS_model_covariance ? " + model covariance" : "", result.failed,
              FLAGS_out.c_str(), options.reference == ReferenceBody::kMirror1 ? "M1" : "C");
  if (truth) PrintTruthTables(triangulator, *truth, result, options, reference);
  return 0;
}

}  // namespace omni::apps
