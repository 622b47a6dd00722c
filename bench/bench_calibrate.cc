// Speed and memory of the calibration solve (issue #6: a 20-image session of ~10k corner
// observations in <= 5 s wall on 2 cores, peak memory <= 1 GB; issue 17: <= 2 s). A timed run,
// not a Google Benchmark loop (one solve is seconds): the misaligned big rig's exact corners from
// calib/synthetic's fast path plus 0.1 px noise, lips as the detector reports them, the ideal
// design as the start, the session's default solver options (2 threads).
//   bench_calibrate [images=20] [targets_per_image=4] [values_out.txt]
// values_out.txt (optional): one line per refined parameter "name value sigma" (internal units),
// to compare two builds' answers (a speed change must not move them by more than ~0.1 sigma).
//
// Scene mode (issue 17's big, near session: <= 10 s wall for 24 images):
//   bench_calibrate SCENE.yaml RIG.yaml [corner_noise_px=0.05] [lip_profiles=360] [values_out.txt]
// the scene file's placements through RIG (the truth) on the fast path, exact corners plus
// Gaussian noise, lips from the truth with 0.03 px noise (lip_profiles 0: none), started from
// RIG's ideal design (every pose, the reflex plane and the distortion zero, the principal point
// at the image centre, fx = fy = 1450 px as in the design files).
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <ctime>
#include <string>

#include <glog/logging.h>

#include "calib/calibrate.h"
#include "model/io/model_file.h"
#include "model/model_compare.h"
#include "model/rig_model.h"
#include "tests/calib/calib_test_util.h"

using namespace omni;

namespace {

// RIG's ideal design: what a user starts from (sample_configs/big_rig_ideal.yaml's camera).
RigParams IdealDesignOf(const RigParams& rig, int width, int height) {
  RigParams ideal = rig;
  ideal.kind = ModelKind::kIdeal;
  ideal.camera = {1450.0, 1450.0, (width - 1) / 2.0, (height - 1) / 2.0, 0.0};
  ideal.distortion = {};
  ideal.mirror1_pose = {};
  ideal.mirror2_pose = {};
  ideal.reflex = {};
  ideal.calibration.reset();
  return ideal;
}

void Report(const calib::CalibrationResult& result, const RigParams& truth, double wall_s,
            double cpu_s, int images, size_t corners, size_t lip_points, int threads,
            const char* values_out) {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("images %d, corner observations %zu, lip edge points %zu, threads %d\n", images,
              corners, lip_points, threads);
  std::printf("solve: %.2f s wall, %.2f s CPU (%s), rms %.3f px over %d observations\n", wall_s,
              cpu_s, result.converged ? "converged" : "NOT converged", result.rms_px,
              result.n_observations);
  std::printf("peak memory (whole process, max RSS): %.1f MB\n", usage.ru_maxrss / 1024.0);
  std::printf("%s", calib::ResultTable(result, &truth).c_str());
  double worst = 0;
  std::string worst_name;
  for (size_t i = 0; i < result.names.size(); ++i) {
    if (!testing::IsMisalignment(result.names[i]) || !(result.sigma(i) > 0)) continue;
    const double z = std::abs(result.values(i) - testing::TruthValue(truth, result.names[i])) /
                     result.sigma(i);
    if (z > worst) worst = z, worst_name = result.names[i];
  }
  const RigModel true_model(truth), calibrated(result.rig);
  const ProjectionDifference m1 = CompareProjectionsInMirror1(true_model, calibrated, 1000);
  const ProjectionDifference cam = CompareProjections(true_model, calibrated, 1000);
  std::printf("worst misalignment |value-truth|/sigma %.2f (%s); projection at 1 m RMS: mirror 1's "
              "body %.3f / %.3f px, C %.3f / %.3f px (ring 1 / ring 2)\n",
              worst, worst_name.c_str(), m1.rms_px[0], m1.rms_px[1], cam.rms_px[0],
              cam.rms_px[1]);
  if (values_out) {
    std::ofstream out(values_out);
    out.precision(17);
    for (size_t i = 0; i < result.names.size(); ++i) {
      out << result.names[i] << " " << result.values(i) << " " << result.sigma(i) << "\n";
    }
  }
}

int RunScene(int argc, char** argv) {
  const RigParams truth_rig = io::ReadModelFile(argv[2]);
  const double corner_noise = argc > 3 ? std::atof(argv[3]) : 0.05;
  const int lip_profiles = argc > 4 ? std::atoi(argv[4]) : 360;
  testing::SyntheticSession session;
  const RigParams truth = testing::MakeSceneSession(truth_rig, argv[1], &session);
  io::Detections detections = testing::NoisyDetections(session, corner_noise, 3);
  if (lip_profiles > 0) testing::AddLipDetections(truth, 0.03, 4, &detections, lip_profiles);
  size_t corners = 0, lip_points = 0;
  for (const auto& image : detections.images) {
    corners += image.corners.size();
    for (const auto& lip : image.lips) lip_points += lip.points.size();
  }
  calib::CalibrationOptions options;
  options.progress = [](const std::string& line) { std::printf("  %s\n", line.c_str()); };
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t cpu0 = std::clock();
  const calib::CalibrationResult result = calib::Calibrate(
      IdealDesignOf(truth, session.scene.width, session.scene.height), session.targets,
      detections, options);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
  Report(result, truth, wall_s, cpu_s, static_cast<int>(detections.images.size()), corners,
         lip_points, options.solver.threads, argc > 5 ? argv[5] : nullptr);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  FLAGS_minloglevel = 2;  // Ceres's per-trial-step warnings, as in the CLI
  if (argc > 2 && std::string(argv[1]).size() > 5 &&
      std::string(argv[1]).substr(std::string(argv[1]).size() - 5) == ".yaml") {
    return RunScene(argc, argv);
  }
  synthetic::RandomPlacement random;
  random.images = argc > 1 ? std::atoi(argv[1]) : 20;
  random.targets_min = random.targets_max = argc > 2 ? std::atoi(argv[2]) : 4;
  random.range_min_mm = 500;
  random.range_max_mm = 2000;
  random.seed = 11;
  const auto session = testing::MakeSession(
      testing::MisalignedRig(), random,
      {testing::Chessboard(7, 10, 40.0), testing::Chessboard(8, 9, 45.0),
       testing::Chessboard(6, 11, 50.0), testing::Chessboard(9, 12, 35.0)});
  io::Detections detections = testing::NoisyDetections(session, 0.1, 3);
  testing::AddLipDetections(testing::MisalignedRig(), 0.05, 4, &detections, 360);
  size_t corners = 0, lip_points = 0;
  for (const auto& image : detections.images) {
    corners += image.corners.size();
    for (const auto& lip : image.lips) lip_points += lip.points.size();
  }

  calib::CalibrationOptions options;  // the session defaults: all but the shapes, 2 threads
  options.estimate = {"camera", "distortion", "mirror1_pose", "mirror2_pose", "reflex"};
  options.progress = [](const std::string& line) { std::printf("  %s\n", line.c_str()); };
  const auto t0 = std::chrono::steady_clock::now();
  std::clock_t cpu0 = std::clock();
  const calib::CalibrationResult result =
      calib::Calibrate(testing::IdealRig(), session.targets, detections, options);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
  Report(result, testing::MisalignedRig(), wall_s, cpu_s, random.images, corners, lip_points,
         options.solver.threads, argc > 3 ? argv[3] : nullptr);
  return 0;
}
