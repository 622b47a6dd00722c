// Speed and memory of the calibration solve (a 20-image session of ~10k corner
// observations in <= 5 s wall on 2 cores, peak memory <= 1 GB; then <= 2 s). A timed run,
// not a Google Benchmark loop (one solve is seconds): the misaligned big rig's exact corners from
// synthetic's fast path plus 0.1 px noise, lips as the detector reports them, the ideal
// design as the start, the session's default solver options (2 threads).
//   bench_calibrate [images=20] [targets_per_image=4] [values_out.txt]
// values_out.txt (optional): one line per refined parameter "name value sigma" (internal units),
// to compare two builds' answers (a speed change must not move them by more than ~0.1 sigma).
//
// Monte Carlo mode (the sigmas within 20% on a realistic-preset session; calib/monte_carlo.h):
//   bench_calibrate montecarlo SESSION.yaml DETECTIONS.yaml [solves=50] [workers=2]
// calibrates the session's real detections once (from the session's model, its options): the
// reference R0, whose variance components are printed; then `solves` synthetic sessions from it,
// each solved with its own session options, one thread per solve, `workers` solves at a time.
//
// Scene mode (a big, near session: <= 10 s wall for 24 images):
//   bench_calibrate SCENE.yaml RIG.yaml [corner_noise_px=0.05] [lip_profiles=360] [values_out.txt]
// the scene file's placements through RIG (the truth) on the fast path, exact corners plus
// Gaussian noise, lips from the truth with 0.03 px noise (lip_profiles 0: none), started from
// RIG's ideal design (every pose, the reflex plane and the distortion zero, the principal point
// at the image centre, fx = fy = 1450 px as in the design files), or from the model file
// OMNI_START_MODEL names (e.g. with measured profiles: bench/measured_profile_scans.py).
//
// Predict mode (a list of photos' predicted effect, design/decide_photos.h SigmaAfterPhotos):
//   bench_calibrate predict MODEL.yaml TOLERANCES.yaml PHOTOS.txt
// each check of TOLERANCES against the calibrated MODEL: its sigma now and after the photos, one
// per line of PHOTOS.txt: "chessboard|grid rows cols square_or_tag_mm range_mm height_mm
// azimuth_deg" (the board's centre in C, facing the axis, as `tolerance` prints them).
// OMNI_PROFILE (off|hold|free|auto) sets the session's profile mode; OMNI_MODEL_OUT writes the
// calibrated model file.
#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include <glog/logging.h>

#include "calib/calibrate.h"
#include "calib/calibration_checks.h"
#include "calib/monte_carlo.h"
#include "calib/solve_benchmark.h"
#include "design/decide_photos.h"
#include "design/tolerance_file.h"
#include "calib/session_options.h"
#include "io/detections_file.h"
#include "io/model_file.h"
#include "io/session_file.h"
#include "tests/calib/calib_test_util.h"

using namespace omni;

namespace {

// Per parameter named in `list` (comma-separated): its noise-alone and considered sigma, then the
// considered columns' shares |d value / d column| * sigma_column, the five largest.
void PrintConsideredShares(const calib::CalibrationResult& result, const std::string& list) {
  const calib::CalibrationUncertainty& u = result.uncertainty;
  const auto& names = result.estimate.names;
  if (u.considered_sensitivity.rows() != static_cast<int>(names.size()) ||
      u.considered_sensitivity.cols() != u.considered_column_sigma.size()) {
    std::printf("considered shares: not available (%d x %d sensitivity, %d names)\n",
                static_cast<int>(u.considered_sensitivity.rows()),
                static_cast<int>(u.considered_sensitivity.cols()), static_cast<int>(names.size()));
    return;
  }
  size_t start = 0;
  while (start <= list.size()) {
    const size_t end = std::min(list.find(',', start), list.size());
    const std::string name = list.substr(start, end - start);
    start = end + 1;
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) continue;
    const int i = static_cast<int>(it - names.begin());
    std::vector<std::pair<double, std::string>> shares;
    for (int c = 0; c < u.considered_sensitivity.cols(); ++c) {
      const std::string column = c < static_cast<int>(u.considered_column_names.size())
                                     ? u.considered_column_names[c] : "column " + std::to_string(c);
      shares.push_back({std::abs(u.considered_sensitivity(i, c)) * u.considered_column_sigma(c), column});
    }
    std::sort(shares.rbegin(), shares.rend());
    const double total = std::sqrt(u.covariance(i, i)), noise = std::sqrt(u.noise_covariance(i, i));
    std::printf("considered share of %s: sigma %.4g, noise alone %.4g, considered %.4g:", name.c_str(),
                total, noise, std::sqrt(std::max(0.0, total * total - noise * noise)));
    for (size_t k = 0; k < shares.size() && k < 5; ++k) {
      std::printf("%s %s %.3g", k ? "," : "", shares[k].second.c_str(), shares[k].first);
    }
    std::printf("\n");
  }
}

// Solves from `start` (its stages' lines on stdout), then its report against the truth;
// values_out (may be null): "name value sigma" per refined parameter.
void SolveAndReport(const RigParams& start, const std::vector<TargetSpec>& targets,
                    const Observations& detections, calib::CalibrationOptions options,
                    const RigParams& truth, int images, const char* values_out) {
  options.progress = [](const std::string& line) { std::printf("  %s\n", line.c_str()); };
  const calib::TimedSolve solve = calib::SolveTimed(start, targets, detections, options);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("%s", calib::TimedSolveReport(solve, detections, images, options.solver.threads,
                                            usage.ru_maxrss / 1024.0, truth).c_str());
  if (values_out) std::ofstream(values_out) << calib::ValuesText(solve.result);
  // OMNI_CONSIDERED_OF=name,name...: each named parameter's considered share by column (sigma
  // times sensitivity), largest first: which held coordinate or detector bias sets its floor.
  if (const char* of = std::getenv("OMNI_CONSIDERED_OF")) PrintConsideredShares(solve.result, of);
  // OMNI_MODEL_OUT: the calibrated model file (with its covariance), e.g. for `omnistereo
  // tolerance` (bench/tolerance_acceptance.py).
  if (const char* model_out = std::getenv("OMNI_MODEL_OUT")) {
    io::WriteModelFile(model_out, solve.result.estimate.rig);
  }
}

int RunScene(int argc, char** argv) {
  const RigParams truth_rig = io::ReadModelFile(argv[2]);
  const double corner_noise = argc > 3 ? std::atof(argv[3]) : 0.05;
  const int lip_profiles = argc > 4 ? std::atoi(argv[4]) : 360;
  testing::SyntheticSession session;
  const RigParams truth = testing::MakeSceneSession(truth_rig, argv[1], &session);
  Observations detections = testing::NoisyDetections(session, corner_noise, 3);
  if (lip_profiles > 0) testing::AddLipDetections(truth, 0.03, 4, &detections, lip_profiles);
  // OMNI_START_MODEL: a model file to start from instead (e.g. the design with its mirrors'
  // measured profiles, bench/measured_profile_scans.py).
  const char* start_file = std::getenv("OMNI_START_MODEL");
  calib::CalibrationOptions options;
  // OMNI_PROFILE=off|hold|free|auto, OMNI_PROFILE_SIGMA_MM: as in the default mode.
  if (const char* profile = std::getenv("OMNI_PROFILE")) options.profile = profile;
  if (const char* sigma = std::getenv("OMNI_PROFILE_SIGMA_MM")) options.profile_sigma_mm = std::atof(sigma);
  // OMNI_LIP_BIAS_PX, OMNI_CORNER_OFFSET_PX: the detectors' considered biases (calibrate.h).
  if (const char* px = std::getenv("OMNI_LIP_BIAS_PX")) {
    options.lip_edge_bias_sigma_px = options.lip_edge_offset_floor_px = std::atof(px);
  }
  if (const char* px = std::getenv("OMNI_CORNER_OFFSET_PX")) options.corner_offset_sigma_px = std::atof(px);
  RigParams start =
      start_file ? io::ReadModelFile(start_file)
                 : testing::IdealDesignOf(truth, session.scene.width, session.scene.height);
  // The design's focal length is 1450 px at 1280 pixels across: at 5 MP (2592) twice that, which
  // the initial poses need (from 1450 no placement was posed).
  if (!start_file && session.scene.width > 1280) {
    start.camera[kFx] = start.camera[kFy] = 1450.0 * session.scene.width / 1280.0;
  }
  // The design knows the conic, not the machined profile: the truth's profile is not the start's
  // (else a held profile is the true one, and a machined session checks nothing of it).
  if (!start_file) {
    start.profile1 = start.profile2 = ProfileShape{};
    start.mirror1_profile = start.mirror2_profile = {};
  }
  SolveAndReport(start, session.targets, detections, options, truth,
                 static_cast<int>(detections.images.size()), argc > 5 ? argv[5] : nullptr);
  return 0;
}

int RunPredict(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: bench_calibrate predict MODEL.yaml TOLERANCES.yaml PHOTOS.txt\n");
    return 2;
  }
  const RigParams rig = io::ReadModelFile(argv[2]);
  const design::ToleranceFile tol = design::ReadToleranceFile(argv[3]);
  std::vector<design::CandidatePhoto> photos;
  std::ifstream in(argv[4]);
  std::string kind;
  double azimuth_deg = 0;
  design::CandidatePhoto p;
  while (in >> kind >> p.rows >> p.cols >> p.square_mm >> p.range_mm >> p.height_mm >> azimuth_deg) {
    if (kind != "chessboard" && kind != "grid") {
      std::fprintf(stderr, "%s: expected chessboard or grid first on each line, got '%s'\n", argv[4],
                   kind.c_str());
      return 2;
    }
    p.tag_grid = kind == "grid";
    p.azimuth_rad = azimuth_deg * M_PI / 180;
    photos.push_back(p);
  }
  // The pixel noise's part alone: the same rig with its noise covariance as the whole.
  RigParams noise_only = rig;
  if (noise_only.calibration && !noise_only.calibration->noise_covariance.empty()) {
    noise_only.calibration->covariance = noise_only.calibration->noise_covariance;
  }
  std::printf("%zu photos\n", photos.size());
  for (const design::ToleranceCheck& c : design::CheckTolerances(rig, tol.spec)) {
    const auto after = design::SigmaAfterPhotos(rig, c, photos);
    const auto noise = design::SigmaAfterPhotos(noise_only, c, photos);
    if (!c.sigma || !after || !noise) continue;
    std::printf("%-28s sigma %.4g -> predicted %.4g (noise alone %.4g)\n", c.name.c_str(), *c.sigma,
                *after, *noise);
  }
  return 0;
}

int RunMonteCarlo(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: bench_calibrate montecarlo SESSION.yaml DETECTIONS.yaml "
                         "[solves=50] [workers=2]\n");
    return 2;
  }
  const io::Session session = io::ReadSessionFile(argv[2]);
  const Observations detections = io::ReadDetectionsFile(argv[3]);
  const int solves = argc > 4 ? std::max(2, std::atoi(argv[4])) : 50;
  const int workers = argc > 5 ? std::max(1, std::atoi(argv[5])) : 2;
  const int used = calib::MonteCarloCheck(
      io::ReadModelFile(session.model_path), session.targets, detections,
      calib::OptionsFromSession(session), solves, workers,
      [](const std::string& text) { std::printf("%s", text.c_str()); });
  return used < 2 ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  FLAGS_minloglevel = 2;  // Ceres's per-trial-step warnings, as in the CLI
  if (argc > 1 && std::string(argv[1]) == "montecarlo") return RunMonteCarlo(argc, argv);
  if (argc > 1 && std::string(argv[1]) == "predict") return RunPredict(argc, argv);
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
  Observations detections = testing::NoisyDetections(session, 0.1, 3);
  testing::AddLipDetections(testing::MisalignedRig(), 0.05, 4, &detections, 360);
  calib::CalibrationOptions options;  // the session defaults: all but the shapes, 2 threads
  options.estimate = DefaultEstimateBlocks();
  // OMNI_PROFILE=off|hold|free|auto, OMNI_PROFILE_SIGMA_MM: the mirrors' profiles (default as a
  // session's).
  if (const char* profile = std::getenv("OMNI_PROFILE")) options.profile = profile;
  if (const char* sigma = std::getenv("OMNI_PROFILE_SIGMA_MM")) options.profile_sigma_mm = std::atof(sigma);
  // OMNI_LIP_BIAS_PX, OMNI_CORNER_OFFSET_PX: the detectors' considered biases (calibrate.h).
  if (const char* px = std::getenv("OMNI_LIP_BIAS_PX")) {
    options.lip_edge_bias_sigma_px = options.lip_edge_offset_floor_px = std::atof(px);
  }
  if (const char* px = std::getenv("OMNI_CORNER_OFFSET_PX")) options.corner_offset_sigma_px = std::atof(px);
  SolveAndReport(testing::IdealRig(), session.targets, detections, options,
                 testing::MisalignedRig(), random.images, argc > 3 ? argv[3] : nullptr);
  return 0;
}
