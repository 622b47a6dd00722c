// `omnistereo calibrate --session S --out calibrated.yaml [--detections D] [--truth_model T]`: estimate
// the non-central rig from a session (calib/calibrate.h). Without --detections the session's
// images go through the detectors. Progress per stage on stderr; the parameter table (mm, deg,
// with sigma; with --truth_model also the true value) on stdout; the calibrated model, with its
// `calibration:` section, written atomically to --out only if the solve succeeded.
#include <chrono>
#include <cstdio>
#include <ctime>
#include <string>

#include <gflags/gflags.h>
#include <opencv2/imgcodecs.hpp>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "calib/calibrate.h"
#include "detectors/detect_image.h"
#include "model/io/detections_file.h"
#include "model/io/model_file.h"
#include "model/io/session_file.h"

DEFINE_string(truth_model, "", "calibrate: the true model file, to add a truth column to the table");

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

io::Detections DetectSession(const io::Session& session, const RigParams& start) {
  detectors::DetectorContext ctx(start, session.targets, session.use_lips);
  io::Detections detections;
  detections.session = session.path;
  for (size_t i = 0; i < session.images.size(); ++i) {
    const std::string& file = session.images[i];
    const cv::Mat image = cv::imread(file, cv::IMREAD_UNCHANGED);
    if (image.empty()) throw io::InputError(file + ": cannot read the image");
    std::vector<std::string> warnings;
    io::ImageDetections found = detectors::DetectImage(image, &ctx, &warnings);
    found.file = file;
    found.width = image.cols;
    found.height = image.rows;
    for (const auto& w : warnings) std::fprintf(stderr, "%s: %s\n", file.c_str(), w.c_str());
    std::fprintf(stderr, "[%zu/%zu] %s: %zu corners\n", i + 1, session.images.size(),
                 file.c_str(), found.corners.size());
    detections.images.push_back(std::move(found));
  }
  return detections;
}

}  // namespace

int RunCalibrate() {
  if (FLAGS_session.empty() || FLAGS_out.empty()) {
    throw io::InputError("--session and --out are required");
  }
  const io::Session session = io::ReadSessionFile(FLAGS_session);
  const RigParams start = io::ReadModelFile(session.model_path);
  const io::Detections detections = FLAGS_detections.empty()
                                        ? DetectSession(session, start)
                                        : io::ReadDetectionsFile(FLAGS_detections);

  calib::CalibrationOptions options = calib::OptionsFromSession(session);
  options.progress = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  const auto t0 = std::chrono::steady_clock::now();
  calib::CalibrationResult result = calib::Calibrate(start, session.targets, detections, options);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  CalibrationInfo& info = *result.rig.calibration;
  info.session = FLAGS_session;
  info.tool_version = std::string("omnistereo ") + OMNISTEREO_VERSION;
  info.date = UtcNow();

  std::optional<RigParams> truth;
  if (!FLAGS_truth_model.empty()) truth = io::ReadModelFile(FLAGS_truth_model);
  std::printf("%s", calib::ResultTable(result, truth ? &*truth : nullptr).c_str());
  for (const auto& r : result.rejected) {
    std::printf("left out: image %d (%s) target %d corner %d mirror %d at (%.2f, %.2f): %s",
                r.image, detections.images[r.image].file.c_str(), r.target, r.id, r.mirror,
                r.pixel.x(), r.pixel.y(), r.reason.c_str());
    if (r.residual_px > 0) std::printf(" (%.2f px)", r.residual_px);
    std::printf("\n");
  }
  std::printf("solved in %.2f s (%s); %zu target placements in %zu images\n", seconds,
              result.converged ? "converged" : "NOT converged", result.placements.size(),
              detections.images.size());
  io::WriteModelFile(FLAGS_out, result.rig);
  std::printf("calibrated model written to %s\n", FLAGS_out.c_str());
  return 0;
}

}  // namespace omni::apps
