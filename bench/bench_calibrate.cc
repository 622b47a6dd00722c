// Speed and memory of the calibration solve (issue #6: a 20-image session of ~10k corner
// observations in <= 5 s wall on 2 cores, peak memory <= 1 GB). A timed run, not a Google
// Benchmark loop (one solve is seconds): the misaligned big rig's exact corners from
// calib/synthetic's fast path plus 0.1 px noise, lips as the detector reports them, the ideal
// design as the start, the session's default solver options (2 threads).
//   bench_calibrate [images=20] [targets_per_image=4] [values_out.txt]
// values_out.txt (optional): one line per refined parameter "name value sigma" (internal units),
// to compare two builds' answers (a speed change must not move them by more than ~0.1 sigma).
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <ctime>
#include <string>

#include <glog/logging.h>

#include "calib/calibrate.h"
#include "tests/calib/calib_test_util.h"

using namespace omni;

int main(int argc, char** argv) {
  FLAGS_minloglevel = 2;  // Ceres's per-trial-step warnings, as in the CLI
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
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("images %d, corner observations %zu, lip edge points %zu, threads %d\n",
              random.images, corners, lip_points, options.solver.threads);
  std::printf("solve: %.2f s wall, %.2f s CPU (%s), rms %.3f px over %d observations\n", wall_s, cpu_s,
              result.converged ? "converged" : "NOT converged", result.rms_px,
              result.n_observations);
  std::printf("peak memory (whole process, max RSS): %.1f MB\n", usage.ru_maxrss / 1024.0);
  const RigParams truth = testing::MisalignedRig();
  std::printf("%s", calib::ResultTable(result, &truth).c_str());
  if (argc > 3) {
    std::ofstream out(argv[3]);
    out.precision(17);
    for (size_t i = 0; i < result.names.size(); ++i) {
      out << result.names[i] << " " << result.values(i) << " " << result.sigma(i) << "\n";
    }
  }
  return 0;
}
