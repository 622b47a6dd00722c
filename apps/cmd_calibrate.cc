// `omnistereo calibrate --session S --out calibrated.yaml [--detections D] [--truth_model T]
// [--truth TRUTH]`: estimate the non-central rig from a session (calib/calibrate.h). Without
// --detections the session's images go through the detectors. Progress per stage on stderr; the
// parameter table (mm, deg, with sigma; with --truth_model also the true value and the projection
// difference from the true rig at 1 m) on stdout; with
// --truth (a synthetic session's omnistereo-truth/1) also the reprojection RMS per ring against
// the detector's true corner error over the same corners; the calibrated model, with its
// `calibration:` section, written atomically to --out only if the solve succeeded.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <optional>
#include <string>

#include <gflags/gflags.h>

#include "apps/calibrate_cli.h"
#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/detect_cli.h"
#include "apps/health_cli.h"
#include "calib/calibrate.h"
#include "calib/single_mirror_summary.h"
#include "calib/calibration_checks.h"
#include "calib/projection_uncertainty.h"
#include "health/check.h"
#include "health/lip_reference.h"
#include "io/detections_file.h"
#include "io/model_file.h"
#include "io/session_file.h"
#include "io/truth_file.h"
#include "model/single_rim.h"

DEFINE_string(truth_model, "", "calibrate, refine: the true model file (synthetic sessions), to add a "
                                "truth column to the table");
DEFINE_string(report, "", "calibrate: write an HTML report (index.html and its images) into this folder");
DEFINE_double(report_range_mm, 2000, "the range of the report's second projection-uncertainty map (mm)");
DEFINE_string(tolerances, "", "an omnistereo-tolerances/1 file: the report gives the calibrated "
                              "rig's verdicts against it");
DECLARE_string(truth);

namespace omni::apps {
namespace {

std::string UtcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// The calibration photos' lip bins under the calibrated model (a single mirror's: its rim's edge),
// kept in its `calibration:` so that `check` measures change from them (health/lip_reference.h);
// one line says what they hold. A single mirror whose image's edge is not its rim (`rim_left_out`)
// is measured at the mirror circle that edge is, fitted to the detected edge points.
void StoreLipReference(const io::Session& session, const Observations& detections,
                       bool rim_left_out, RigParams* rig) {
  CalibrationInfo& info = *rig->calibration;
  const char* what = rig->Single() ? "rim" : "lip";
  RigParams observed = *rig;
  if (rig->Single() && (rim_left_out || !RimEdgeIsTheRim(RigModel(*rig)))) {
    std::vector<Eigen::Vector2d> edge;
    for (const ImageObservations& image : detections.images) {
      for (const LipEdgeObservation& lip : image.lips) {
        if (lip.path != LipPath::kDirect) continue;
        // A spread subsample: the radius is a median.
        for (size_t k = 0; k < lip.points.size(); k += 4) edge.push_back(lip.points[k]);
      }
    }
    const double radius = RimCircleRadiusOf(RigModel(*rig), edge);
    if (!(radius > 0)) {
      std::printf("rim reference for `check`: none (the edge of the mirror's image is not its rim, "
                  "and no circle on the mirror fits the detected edge)\n");
      return;
    }
    info.lip_reference_edge_radius = radius;
    observed = WithRimCircleAt(*rig, radius);
    std::printf("rim reference for `check`: the edge of the mirror's image is not its rim; it is "
                "the mirror's circle of radius %.2f mm at this model's scale (the rim: %.2f mm), "
                "which check follows\n",
                radius, rig->r_sys);
    if (radius > rig->r_sys) {
      // The photos show the mirror out to that circle, so at this model's scale its rim lies at
      // least there: the model's mirror (r_sys bounds every ray it images) must reach it, or
      // detect, panorama and a scoring session with this model lose the outer zone.
      std::printf("the model's mirror extended from %.2f to %.2f mm (r_sys): the photos show it "
                  "out to there at this model's scale, which they do not fix (the image's edge "
                  "is not the rim)\n",
                  rig->r_sys, radius);
      *rig = WithMirrorReaching(*rig, radius);
    }
  }
  int photos = 0;
  info.lip_reference = LearnLipReference(observed, session.images, session.bayer, session.tone,
                                         &photos, &info.lip_reference_rim_scene_px);
  info.lip_reference_sectors = health::CheckOptions{}.azimuth_bins;
  if (info.lip_reference.empty()) {
    info.lip_reference_edge_radius = 0;
    std::printf("%s reference for `check`: none (%d of the session's %zu photos read, with %s "
                "needed in 3 or more): %s\n",
                what, photos, session.images.size(), rig->Single() ? "the rim" : "lips",
                rig->Single() ? "check cannot tell a move of the camera against the mirror"
                              : "check will measure the lips from zero");
    return;
  }
  const LipReferenceBin* worst = &info.lip_reference[0];
  double scatter_min = 1e9, scatter_max = 0;
  for (const LipReferenceBin& bin : info.lip_reference) {
    if (std::abs(bin.mean_px) > std::abs(worst->mean_px)) worst = &bin;
    scatter_min = std::min(scatter_min, bin.scatter_px);
    scatter_max = std::max(scatter_max, bin.scatter_px);
  }
  std::printf("%s reference for `check`: %zu %s bins (edge x %d deg of azimuth) over %d photos; "
              "the edges' detected bias there up to %+.2f px (%s at %.1f deg), one photo's scatter "
              "%.2f-%.2f px\n",
              what, info.lip_reference.size(), what, 360 / info.lip_reference_sectors, photos,
              worst->mean_px, worst->edge.c_str(), worst->azimuth_deg, scatter_min, scatter_max);
  if (info.lip_reference_rim_scene_px > 0) {
    std::printf("  what one photo's scene moves the rim's edge by as a whole: %.2f px (its scale, "
                "shift and tilt; pooled with %.2f px as %g photos' worth): check allows for it\n",
                info.lip_reference_rim_scene_px, health::CheckOptions{}.rim_scene_prior_px,
                health::kPooledScatterPhotos);
  }
}

}  // namespace

int RunCalibrate() {
  if (FLAGS_session.empty() || FLAGS_out.empty()) {
    throw io::InputError("--session and --out are required");
  }
  const io::Session session = io::ReadSessionFile(FLAGS_session);
  if (session.targets.empty()) {
    throw io::InputError(FLAGS_session + ": targets: [] is a lips-only session: calibrate needs "
                         "target corners (`omnistereo detect` checks the intrinsics from the lips "
                         "alone)");
  }
  const RigParams start = io::ReadModelFile(session.model_path);
  // Detected as `detect` does, each image's line naming its corners per ring only.
  detectors::SessionDetectOptions brief;
  brief.image_detail = false;
  const Observations detections = FLAGS_detections.empty()
                                      ? DetectOnTerminal(session, start, brief).detections
                                      : io::ReadDetectionsFile(FLAGS_detections);

  double seconds = 0;
  calib::CalibrationResult result = CalibrateWithProgress(start, session, detections, &seconds);

  result.estimate.rig.calibration = calib::CalibrationInfoOf(
      result, {FLAGS_session, std::string("omnistereo ") + OMNISTEREO_VERSION, UtcNow()});
  if (session.use_lips) {
    StoreLipReference(session, detections, result.solve.rim_left_out, &result.estimate.rig);
  }

  std::optional<RigParams> truth;
  if (!FLAGS_truth_model.empty()) truth = io::ReadModelFile(FLAGS_truth_model);
  std::printf("%s", calib::ResultTable(result, truth ? &*truth : nullptr).c_str());
  std::printf("%s", calib::LeftOutText(result, detections, session.targets).c_str());
  if (!FLAGS_truth.empty()) {
    const calib::CornerNoise noise =
        calib::CornerNoiseAgainstTruth(result, detections, io::ReadTruthFile(FLAGS_truth));
    std::printf("%s", calib::CornerNoiseText(result, noise, FLAGS_truth).c_str());
  }
  std::printf("solved in %.2f s (%s); %zu target placements in %zu images\n", seconds,
              result.solve.converged ? "converged" : "NOT converged",
              result.residuals.placements.size(), detections.images.size());
  if (!result.estimate.rig.Single() && !result.estimate.names.empty()) {
    const calib::ProjectionUncertainty predicted = calib::PredictProjectionUncertainty(result, 1000);
    std::printf("projection uncertainty at 1 m (from the covariance: the expected RMS difference "
                "from the true rig over the stereo band)\n");
    std::printf("  points in mirror 1's body: ring 1 %.3f px, ring 2 %.3f px; in the camera frame: "
                "ring 1 %.3f px, ring 2 %.3f px\n",
                predicted.in_mirror1_px[0], predicted.in_mirror1_px[1], predicted.in_cam_px[0],
                predicted.in_cam_px[1]);
  }
  if (result.estimate.rig.Single() && !result.estimate.names.empty()) {
    std::printf("%s", calib::SingleMirrorText(calib::SummariseSingleMirror(result)).c_str());
  }
  if (truth) std::printf("%s", calib::TruthShareText(result, *truth).c_str());
  // Detected here: the detections are kept beside the model (`report`, `refine` and a second
  // calibration read them; detecting again costs the same time).
  std::string detections_path = FLAGS_detections;
  if (detections_path.empty()) {
    namespace fs = std::filesystem;
    const fs::path out(FLAGS_out);
    detections_path = (out.parent_path() / (out.stem().string() + "_detections.yaml")).string();
    io::WriteDetectionsFile(detections_path,
                            io::WithPathsRelativeToFile(detections, detections_path));
  }
  io::WriteModelFile(FLAGS_out, result.estimate.rig);
  std::printf("calibrated model written to %s\n", FLAGS_out.c_str());
  if (FLAGS_detections.empty()) std::printf("the detections it was calibrated from: %s\n", detections_path.c_str());
  if (!FLAGS_report.empty()) WriteReport(result, detections, session, detections_path, FLAGS_report, seconds);
  return 0;
}

}  // namespace omni::apps
