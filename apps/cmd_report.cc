// `omnistereo report --model M --detections D --out DIR [--session S]`: the report of an existing
// calibration. Its statistics are computed by solving again from the calibrated model with the
// session's settings: on the same detections the solve starts at its optimum and stays there, so
// the residuals, left-out corners and covariance are those of the calibration that wrote the
// model (calib/calibration_checks.h says when the detections are other data). The session is the
// detections file's `session:` (relative to the detections file) unless --session names one.
#include <filesystem>
#include <string>

#include <gflags/gflags.h>

#include "apps/calibrate_cli.h"
#include "apps/command.h"
#include "apps/common_flags.h"
#include "calib/calibration_checks.h"
#include "io/detections_file.h"
#include "io/model_file.h"
#include "io/session_file.h"

namespace omni::apps {

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
  const std::string other =
      calib::DatasetMismatch(*model.calibration, detections, session.targets);
  if (!other.empty()) {
    throw io::InputError(FLAGS_detections + ": not the detections " + FLAGS_model +
                         " was calibrated from (" + other +
                         "); give the detections file and session that calibrate was given");
  }
  double seconds = 0;
  const calib::CalibrationResult result =
      CalibrateWithProgress(model, session, detections, &seconds);
  const std::string moved = calib::MovedWhenSolvedAgain(*model.calibration, result);
  if (!moved.empty()) {
    throw io::InputError(FLAGS_detections + ": not the detections " + FLAGS_model +
                         " was calibrated from (" + moved + "); give the detections file "
                         "that calibrate was given");
  }
  WriteReport(result, detections, session, FLAGS_detections, FLAGS_out, seconds);
  return 0;
}

}  // namespace omni::apps
