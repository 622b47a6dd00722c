// `omnistereo calibrate --session S --out calibrated.yaml [--detections D] [--truth_model T]
// [--truth TRUTH]`: estimate the non-central rig from a session (calib/calibrate.h). Without
// --detections the session's images go through the detectors. Progress per stage on stderr; the
// parameter table (mm, deg, with sigma; with --truth_model also the true value and the projection
// difference from the true rig at 1 m) on stdout; with
// --truth (a synthetic session's omnistereo-truth/1) also the reprojection RMS per ring against
// the detector's true corner error over the same corners; the calibrated model, with its
// `calibration:` section, written atomically to --out only if the solve succeeded.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <set>
#include <map>
#include <optional>
#include <string>
#include <tuple>

#include <gflags/gflags.h>
#include <opencv2/imgcodecs.hpp>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/detect_cli.h"
#include "apps/progress.h"
#include "calib/calibrate.h"
#include "calib/projection_uncertainty.h"
#include "calib/session_options.h"
#include "design/tolerance.h"
#include "design/tolerance_file.h"
#include "detectors/detect_session.h"
#include "io/detections_file.h"
#include "io/model_file.h"
#include "io/session_file.h"
#include "io/truth_file.h"
#include "model/model_compare.h"
#include "report/report.h"
#include "stereo/sparse_triangulation.h"

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

// The session detected as `detect` does, with each image's line naming its corners per ring.
Observations DetectSession(const io::Session& session, const RigParams& start) {
  std::optional<ProgressLine> progress;
  detectors::SessionDetectOptions options;
  options.image_detail = false;
  const detectors::SessionDetection found = detectors::DetectSessionReported(
      session, start, options, ProgressHooks("detect", session.images.size(), &progress));
  if (progress) progress->Finish();
  if (!found.repeated_note.empty()) {
    std::fprintf(stderr, "warning: %s: %s\n", FLAGS_session.c_str(), found.repeated_note.c_str());
  }
  return found.detections;
}

// The calibration with its stages' lines on stderr and, on a terminal, a status line (stage,
// iteration, elapsed) below them; returns the solve's wall time in *seconds.
calib::CalibrationResult CalibrateWithProgress(const RigParams& start, const io::Session& session,
                                               const Observations& detections, double* seconds) {
  calib::CalibrationOptions options = calib::OptionsFromSession(session);
  ProgressLine progress("calibrate", 0);
  options.progress = [&](const std::string& line) { progress.Print(line); };
  options.status = [&](const std::string& now) { progress.Status(now); };
  const auto t0 = std::chrono::steady_clock::now();
  calib::CalibrationResult result = calib::Calibrate(start, session.targets, detections, options);
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

// The acceptance check "reprojection RMS within 20% of the corner noise" on a synthetic session:
// the detector's true error (detected - true pixel, 2-D RMS) over exactly the corners the solve
// kept, per ring, next to the solve's reprojection RMS. A ratio well under 1 means the fit absorbs
// part of the detector's error (coherent over boards), well over 1 a model that cannot fit.
void PrintCornerNoiseCheck(const calib::CalibrationResult& result, const Observations& detections,
                           const std::string& truth_path) {
  const Truth truth = io::ReadTruthFile(truth_path);
  std::set<std::tuple<int, int, int, int>> rejected;
  for (const auto& r : result.rejected) rejected.emplace(r.image, r.target, r.id, r.mirror);
  double squared[2] = {0, 0};
  int count[2] = {0, 0}, unmatched = 0;
  for (size_t i = 0; i < detections.images.size(); ++i) {
    const TruthImage* image = nullptr;
    // By file name: detections may name the images by path, the truth by name.
    const auto base = [](const std::string& f) { return f.substr(f.find_last_of('/') + 1); };
    for (const auto& t : truth.images) {
      if (base(t.file) == base(detections.images[i].file)) image = &t;
    }
    for (const auto& c : detections.images[i].corners) {
      if (rejected.count({static_cast<int>(i), c.target, c.id, MirrorIndex(c.mirror)})) continue;
      // A target may be placed several times in one image: the nearest true corner.
      const TrueCornerMatch match = NearestTrueCorner(
          image ? image->corners : std::vector<TruthCorner>{}, c.mirror, c.pixel, HUGE_VAL,
          [&](const TruthCorner& t) { return t.target == c.target && t.id == c.id; });
      if (!match.corner) {
        ++unmatched;
        continue;
      }
      squared[MirrorIndex(c.mirror) - 1] += match.distance_px * match.distance_px;
      ++count[MirrorIndex(c.mirror) - 1];
    }
  }
  std::printf("corner noise (--truth %s): reprojection RMS against the detector's true error "
              "over the same corners (2-D RMS)\n", truth_path.c_str());
  for (int m = 0; m < 2; ++m) {
    if (count[m] == 0) continue;
    const double true_rms = std::sqrt(squared[m] / count[m]);
    std::printf("  ring %d: %.4f px vs %.4f px over %d corners: ratio %.2f\n", m + 1,
                result.per_mirror_rms_px[m], true_rms, count[m],
                result.per_mirror_rms_px[m] / true_rms);
  }
  if (unmatched > 0) std::printf("  (%d detected corners have no true counterpart)\n", unmatched);
}

// With --truth_model: what the calibration is worth for measuring, as the projection difference
// from the true rig of points at 1 m over the stereo band, held in mirror 1's body (what
// `triangulate --frame mirror1` measures) and in the camera frame.
void PrintTruthProjection(const RigParams& truth, const RigParams& calibrated) {
  const RigModel true_model(truth);
  const RigModel calibrated_model(calibrated);
  const ProjectionDifference in_mirror1 =
      CompareProjectionsInMirror1(true_model, calibrated_model, 1000);
  const ProjectionDifference in_cam = CompareProjections(true_model, calibrated_model, 1000);
  std::printf("against the true model: projection difference at 1 m over the stereo band, RMS "
              "(max) per ring\n");
  std::printf("  points in mirror 1's body: ring 1 %.3f (%.3f) px, ring 2 %.3f (%.3f) px\n",
              in_mirror1.rms_px[0], in_mirror1.max_px[0], in_mirror1.rms_px[1],
              in_mirror1.max_px[1]);
  std::printf("  points in the camera frame: ring 1 %.3f (%.3f) px, ring 2 %.3f (%.3f) px\n",
              in_cam.rms_px[0], in_cam.max_px[0], in_cam.rms_px[1], in_cam.max_px[1]);
}

// Each detections image's frame: its file as written (absolute, or relative to the working
// folder or to the detections file's folder), else the session's image of that index.
std::vector<std::string> FramePaths(const Observations& detections, const io::Session& session,
                                    const std::string& detections_path) {
  namespace fs = std::filesystem;
  std::vector<std::string> out;
  const fs::path base = fs::path(detections_path).parent_path();
  for (size_t i = 0; i < detections.images.size(); ++i) {
    const std::string& file = detections.images[i].file;
    std::string path = i < session.images.size() ? session.images[i] : file;
    for (const fs::path& candidate : {fs::path(file), base / file}) {
      if (fs::is_regular_file(candidate)) {
        path = candidate.string();
        break;
      }
    }
    out.push_back(path);
  }
  return out;
}

// The HTML report into `dir` (--report, or report's --out); prints where it is.
void WriteReport(const calib::CalibrationResult& result, const Observations& detections,
                 const io::Session& session, const std::string& detections_path,
                 const std::string& dir, double seconds) {
  report::ReportInput in;
  in.result = &result;
  in.observations = &detections;
  in.targets = session.targets;
  in.image_paths = FramePaths(detections, session, detections_path);
  in.session = session.path;
  in.solve_seconds = seconds;
  in.range_mm = FLAGS_report_range_mm;
  if (!FLAGS_tolerances.empty()) {
    in.tolerances =
        design::CheckTolerances(result.rig, design::ReadToleranceFile(FLAGS_tolerances).spec);
  }
  std::string index;
  {
    ProgressLine progress("report", 0);
    in.status = [&](const std::string& now) { progress.Status(now); };
    index = report::WriteReport(dir, in);
  }
  std::printf("report written to %s\n", index.c_str());
}

// `report`'s detections must be those the model was calibrated from: the model's dataset (image
// count, targets) must match them and the session.
void CheckSameDataset(const CalibrationInfo& info, const Observations& detections,
                      const io::Session& session) {
  const std::string targets = calib::TargetsDescription(session.targets);
  const int images = static_cast<int>(detections.images.size());
  if ((info.images > 0 && info.images != images) ||
      (!info.targets.empty() && info.targets != targets)) {
    throw io::InputError(
        FLAGS_detections + ": not the detections " + FLAGS_model + " was calibrated from (its " +
        "calibration: dataset: has " + std::to_string(info.images) + " images of " +
        info.targets + "; these have " + std::to_string(images) + " images of " + targets +
        "); give the detections file and session that calibrate was given");
  }
}

// Solved again from the calibrated model on the same detections, the solve starts at its optimum
// and stays there; a parameter that moves by more than one of its sigmas means other data.
void CheckSolveStayed(const CalibrationInfo& info, const calib::CalibrationResult& result) {
  for (size_t i = 0; i < info.parameters.size() && i < info.sigma.size(); ++i) {
    for (size_t j = 0; j < result.names.size(); ++j) {
      if (result.names[j] != info.parameters[i] || !(info.sigma[i] > 0)) continue;
      const double moved = std::abs(result.values(j) - info.values[i]) / info.sigma[i];
      if (moved > 1.0) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "%s moved %.1f sigma when solved again", 
                      info.parameters[i].c_str(), moved);
        throw io::InputError(FLAGS_detections + ": not the detections " + FLAGS_model +
                             " was calibrated from (" + buf + "); give the detections file "
                             "that calibrate was given");
      }
    }
  }
}

// Every observation the solve left out, one line each, with why; then per target (named) how
// many, in how many photos: a target with most of the outliers is worth a look (its print,
// its size, its flatness).
void PrintLeftOut(const calib::CalibrationResult& result, const Observations& detections,
                  const std::vector<TargetSpec>& targets) {
  std::map<int, std::pair<int, std::set<int>>> per_target;  // target -> (count, images)
  for (const auto& r : result.rejected) {
    std::printf("left out: image %d (%s) target %d corner %d ring %d at (%.2f, %.2f): %s",
                r.image, detections.images[r.image].file.c_str(), r.target, r.id, r.mirror,
                r.pixel.x(), r.pixel.y(), r.reason.c_str());
    if (r.residual_px > 0) std::printf(" (%.2f px)", r.residual_px);
    std::printf("\n");
    auto& [count, images] = per_target[r.target];
    ++count;
    images.insert(r.image);
  }
  if (per_target.empty()) return;
  std::printf("left out %zu corner observation(s):", result.rejected.size());
  const char* separator = " ";
  for (const auto& [t, entry] : per_target) {
    const std::string name = t >= 0 && t < static_cast<int>(targets.size())
                                 ? TargetName(targets[t])
                                 : std::string("?");
    std::printf("%starget %d (%s) %d in %zu photo(s)", separator, t, name.c_str(), entry.first,
                entry.second.size());
    separator = ", ";
  }
  std::printf("\n");
}

// With the true rig known (synthetic sessions): the projection difference at 1 m, each group's
// share of it, and the parameter error against the covariance.
void PrintTruthShare(const calib::CalibrationResult& result, const RigParams& truth) {
  PrintTruthProjection(truth, result.rig);
  const calib::ProjectionErrorShare share = calib::ShareOfProjectionError(result, truth, 1000);
  std::printf("  linearised, points in mirror 1's body: ring 1 %.3f px, ring 2 %.3f px; with "
              "one group's error alone:", share.total_px[0], share.total_px[1]);
  for (size_t g = 0; g < share.groups.size(); ++g) {
    std::printf(" %s %.3f / %.3f", share.groups[g].c_str(), share.group_px[g][0],
                share.group_px[g][1]);
  }
  std::printf("\n  parameter error against the covariance: chi^2 %.1f for %d parameters\n",
              share.chi2, share.dof);
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
  const Observations detections = FLAGS_detections.empty()
                                        ? DetectSession(session, start)
                                        : io::ReadDetectionsFile(FLAGS_detections);

  double seconds = 0;
  calib::CalibrationResult result = CalibrateWithProgress(start, session, detections, &seconds);

  CalibrationInfo& info = *result.rig.calibration;
  info.session = FLAGS_session;
  info.tool_version = std::string("omnistereo ") + OMNISTEREO_VERSION;
  info.date = UtcNow();

  std::optional<RigParams> truth;
  if (!FLAGS_truth_model.empty()) truth = io::ReadModelFile(FLAGS_truth_model);
  std::printf("%s", calib::ResultTable(result, truth ? &*truth : nullptr).c_str());
  PrintLeftOut(result, detections, session.targets);
  if (!FLAGS_truth.empty()) PrintCornerNoiseCheck(result, detections, FLAGS_truth);
  std::printf("solved in %.2f s (%s); %zu target placements in %zu images\n", seconds,
              result.converged ? "converged" : "NOT converged", result.placements.size(),
              detections.images.size());
  const calib::ProjectionUncertainty predicted = calib::PredictProjectionUncertainty(result, 1000);
  std::printf("projection uncertainty at 1 m (from the covariance: the expected RMS difference "
              "from the true rig over the stereo band)\n");
  std::printf("  points in mirror 1's body: ring 1 %.3f px, ring 2 %.3f px; in the camera frame: "
              "ring 1 %.3f px, ring 2 %.3f px\n",
              predicted.in_mirror1_px[0], predicted.in_mirror1_px[1], predicted.in_cam_px[0],
              predicted.in_cam_px[1]);
  if (truth) PrintTruthShare(result, *truth);
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
  io::WriteModelFile(FLAGS_out, result.rig);
  std::printf("calibrated model written to %s\n", FLAGS_out.c_str());
  if (FLAGS_detections.empty()) std::printf("the detections it was calibrated from: %s\n", detections_path.c_str());
  if (!FLAGS_report.empty()) {
    WriteReport(result, detections, session, detections_path, FLAGS_report, seconds);
  }
  return 0;
}

// `report`: the report of an existing calibration. Its statistics are computed by solving again
// from the calibrated model with the session's settings: on the same detections the solve starts
// at its optimum and stays there, so the residuals, left-out corners and covariance are those of
// the calibration that wrote the model. The session is the detections file's `session:` (relative
// to the detections file) unless --session names one.
int RunReport() {
  namespace fs = std::filesystem;
  if (FLAGS_model.empty() || FLAGS_detections.empty() || FLAGS_out.empty()) {
    throw io::InputError("--model, --detections and --out (the report's folder) are required");
  }
  const Observations detections = io::ReadDetectionsFile(FLAGS_detections);
  std::string session_path = FLAGS_session;
  if (session_path.empty()) {
    if (detections.session.empty()) {
      throw io::InputError(FLAGS_detections + ": session: missing; name the session with --session");
    }
    const fs::path named(detections.session);
    session_path = named.is_absolute()
                       ? named.string()
                       : (fs::path(FLAGS_detections).parent_path() / named).string();
  }
  const io::Session session = io::ReadSessionFile(session_path);
  const RigParams model = io::ReadModelFile(FLAGS_model);
  if (!model.calibration) {
    throw io::InputError(FLAGS_model + ": calibration: missing; report needs a calibrated model "
                         "(`omnistereo calibrate` writes one)");
  }
  CheckSameDataset(*model.calibration, detections, session);
  double seconds = 0;
  const calib::CalibrationResult result =
      CalibrateWithProgress(model, session, detections, &seconds);
  CheckSolveStayed(*model.calibration, result);
  WriteReport(result, detections, session, FLAGS_detections, FLAGS_out, seconds);
  return 0;
}

}  // namespace omni::apps
