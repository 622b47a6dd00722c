#include "apps/calibrate_cli.h"

#include <chrono>
#include <cstdio>

#include <gflags/gflags.h>

#include "apps/progress.h"
#include "calib/session_options.h"
#include "design/tolerance.h"
#include "design/tolerance_file.h"
#include "io/detections_file.h"
#include "report/report.h"

DECLARE_double(report_range_mm);
DECLARE_string(tolerances);

namespace omni::apps {

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

void WriteReport(const calib::CalibrationResult& result, const Observations& detections,
                 const io::Session& session, const std::string& detections_path,
                 const std::string& dir, double seconds) {
  report::ReportInput in;
  in.result = &result;
  in.observations = &detections;
  in.targets = session.targets;
  in.image_paths = io::ImagePathsOf(detections, detections_path, session.images);
  in.session = session.path;
  in.solve_seconds = seconds;
  in.range_mm = FLAGS_report_range_mm;
  if (!FLAGS_tolerances.empty()) {
    in.tolerances =
        design::CheckTolerances(result.estimate.rig, design::ReadToleranceFile(FLAGS_tolerances).spec);
  }
  std::string index;
  {
    ProgressLine progress("report", 0);
    in.status = [&](const std::string& now) { progress.Status(now); };
    index = report::WriteReport(dir, in);
  }
  std::printf("report written to %s\n", index.c_str());
}

}  // namespace omni::apps
