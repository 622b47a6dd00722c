// `omnistereo demo [--out DIR]`: the main job on the bundled default, end to end on a synthetic
// session whose truth we know:
//   1. render sample_configs/demo_scene.yaml through the misaligned big rig
//      (sample_configs/big_rig_misaligned.yaml) with POV-Ray;
//   2. start from the paper's ideal design (sample_configs/big_rig_ideal.yaml) at the session's
//      image size, as a user with a freshly built rig would;
//   3. detect the targets (chessboards, tag grids) and the lips;
//   4. calibrate, and print every parameter with its sigma against the truth;
//   5. say what calibration gained: projection difference from the true model over both rings'
//      stereo band at 1 m, for the ideal and for the calibrated model, with the points fixed in
//      mirror 1's body (the rig's frame), in the camera frame, and up to a camera rotation.
// Each step is the same call as its own command (render, detect, calibrate).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "io/model_file.h"
#include "io/session_file.h"
#include "model/model_compare.h"
#include "synthetic/scene.h"

DECLARE_string(overlay);
DECLARE_string(truth_model);
DECLARE_string(truth);
DECLARE_string(report);

namespace omni::apps {
namespace {

void Banner(const char* text) { std::printf("\n=== %s ===\n", text); std::fflush(stdout); }

void PrintDifference(const char* label, const ProjectionDifference& d) {
  std::printf("  %-22s ring 1: RMS %7.3f px (max %7.3f)   ring 2: RMS %7.3f px (max %7.3f)%s\n",
              label, d.rms_px[0], d.max_px[0], d.rms_px[1], d.max_px[1],
              d.lost ? "   (some points not projected)" : "");
}

// The projection difference from the rendered rig before and after calibration, in mirror 1's
// body, in C, and in C up to the best rotation.
void PrintWhatCalibrationGained(const RigParams& truth, const RigParams& nominal,
                                const RigParams& calibrated) {
  Banner("what calibration gained");
  const RigModel true_model(truth);
  std::printf("projection difference from the true rig over the stereo band at 1 m, points fixed "
              "in mirror 1's body\n(the rig's own frame, `triangulate --frame mirror1`):\n");
  PrintDifference("ideal model:", CompareProjectionsInMirror1(true_model, RigModel(nominal), 1000));
  PrintDifference("calibrated model:",
                  CompareProjectionsInMirror1(true_model, RigModel(calibrated), 1000));
  std::printf("points fixed in the camera frame C (adds C's pointing against the mirrors, which "
              "the lens's held\ndecentring distortion dist_p1, dist_p2 leaves open):\n");
  PrintDifference("ideal model:", CompareProjections(true_model, RigModel(nominal), 1000));
  PrintDifference("calibrated model:", CompareProjections(true_model, RigModel(calibrated), 1000));
  std::printf("the same after removing the best rotation of the camera frame (it turns every "
              "measured point rigidly\nand changes no distance):\n");
  Eigen::Vector3d rotation;
  const ProjectionDifference ideal_aligned =
      CompareProjectionsUpToRotation(true_model, RigModel(nominal), 1000, &rotation);
  PrintDifference("ideal model:", ideal_aligned);
  const ProjectionDifference calibrated_aligned =
      CompareProjectionsUpToRotation(true_model, RigModel(calibrated), 1000, &rotation);
  PrintDifference("calibrated model:", calibrated_aligned);
  std::printf("  (the calibrated camera frame is turned %.3f deg from the true one)\n",
              rotation.norm() * 180 / M_PI);
}

}  // namespace

int RunDemo() {
  namespace fs = std::filesystem;
  const std::string source = OMNISTEREO_SOURCE_DIR;
  const std::string dir = FLAGS_out.empty() ? "demo_out" : FLAGS_out;

  Banner("1/4 render a synthetic session of a misaligned rig (POV-Ray)");
  FLAGS_model = source + "/sample_configs/big_rig_misaligned.yaml";
  FLAGS_scene = source + "/sample_configs/demo_scene.yaml";
  FLAGS_out = dir;
  if (const int rc = RunRender(); rc != 0) return rc;
  const std::string truth_path = dir + "/model.yaml";

  Banner("2/4 start from the ideal design");
  const RigParams truth = io::ReadModelFile(truth_path);
  const RigParams nominal = synthetic::RigAtImageSize(
      io::ReadModelFile(source + "/sample_configs/big_rig_ideal.yaml"), truth.image_width,
      truth.image_height);
  const std::string nominal_path = dir + "/nominal.yaml";
  io::WriteModelFile(nominal_path, nominal);
  io::Session session = io::ReadSessionFile(dir + "/session.yaml");
  session.model_path = nominal_path;
  io::WriteFileAtomically(dir + "/session.yaml", io::SessionText(session, dir));
  std::printf("starting model %s (the paper's design, no misalignment, no distortion)\n",
              nominal_path.c_str());

  Banner("3/4 detect targets and lips");
  FLAGS_session = dir + "/session.yaml";
  FLAGS_out = dir + "/detections.yaml";
  FLAGS_overlay = dir + "/overlay";
  if (const int rc = RunDetect(); rc != 0) return rc;

  Banner("4/4 calibrate (truth column: the rig that was rendered)");
  FLAGS_detections = dir + "/detections.yaml";
  FLAGS_out = dir + "/calibrated.yaml";
  FLAGS_truth_model = truth_path;
  FLAGS_truth = dir + "/truth.yaml";
  FLAGS_report = dir + "/report";
  if (const int rc = RunCalibrate(); rc != 0) return rc;

  PrintWhatCalibrationGained(truth, nominal, io::ReadModelFile(dir + "/calibrated.yaml"));
  std::printf("\noutputs in %s: images, truth.yaml, session.yaml, detections.yaml, overlay/, "
              "calibrated.yaml, report/index.html\n",
              fs::absolute(dir).string().c_str());
  return 0;
}

}  // namespace omni::apps
