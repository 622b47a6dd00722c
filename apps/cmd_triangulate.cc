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
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/stereo_cli.h"
#include "io/csv.h"
#include "io/detections_file.h"
#include "io/model_file.h"
#include "io/truth_file.h"
#include "stereo/triangulate_session.h"

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

// The flags as the session triangulation's options; throws io::InputError naming the flag.
stereo::SessionTriangulationOptions OptionsFromFlags() {
  stereo::SessionTriangulationOptions options;
  options.model = FLAGS_model;
  options.detections = FLAGS_detections;
  options.truth = FLAGS_truth;
  options.out = FLAGS_out;
  options.sigma_px = FLAGS_sigma_px;
  options.sigma_px_ring2 = FLAGS_sigma_px_ring2;
  options.sigma_given = !gflags::GetCommandLineFlagInfoOrDie("sigma_px").is_default ||
                        !gflags::GetCommandLineFlagInfoOrDie("sigma_px_ring2").is_default;
  options.model_covariance = FLAGS_model_covariance;
  options.frame = FLAGS_frame;
  options.method = FLAGS_method;
  options.noise_px = FLAGS_noise_px;
  options.noise_px_ring2 = FLAGS_noise_px_ring2;
  options.seed = FLAGS_seed;
  options.seeds = FLAGS_seeds;
  if (const std::string error = options.Check(); !error.empty()) throw io::InputError(error);
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

}  // namespace

int RunTriangulate() {
  const stereo::SessionTriangulationOptions options = OptionsFromFlags();
  const RigParams rig = io::ReadModelFile(options.model);
  RequireTwoRings(rig, options.model, "triangulate intersects the rays of a point seen in both "
                  "rings (one ring sees it from one viewpoint: a direction, no range)");
  const Triangulator triangulator{RigModel(rig)};
  const std::string warning = stereo::CheckModelFor(triangulator, options);
  if (!warning.empty()) std::fprintf(stderr, "triangulate: warning: %s\n", warning.c_str());
  std::optional<Truth> truth;
  if (!options.truth.empty()) truth = io::ReadTruthFile(options.truth);
  const std::vector<ReferenceRow> reference = io::ReadReferenceTable(FLAGS_reference_table);
  std::optional<RigParams> true_rig;
  if (truth && options.frame == "mirror1") true_rig = TrueRig(*truth);
  std::optional<Observations> detections;
  if (!options.detections.empty()) detections = io::ReadDetectionsFile(options.detections);

  const stereo::SessionTriangulationRun run = stereo::TriangulateSession(
      triangulator, rig, options, detections ? &*detections : nullptr, truth ? &*truth : nullptr,
      true_rig ? &*true_rig : nullptr);
  io::WriteLabelledCsv(options.out, stereo::TriangulatedColumns(), stereo::TriangulatedRows(run));
  std::printf("%s", stereo::TriangulationSummary(run, options).c_str());
  if (truth) {
    std::printf("%s",
                stereo::TruthTables(triangulator, *truth, run, options, reference).c_str());
  }
  return 0;
}

}  // namespace omni::apps
