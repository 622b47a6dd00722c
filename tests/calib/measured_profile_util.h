// Measured mirror profiles for tests: a profiled truth, a profilometer's scan of it, and a
// starting model (the design, kind noncentral) whose mirrors name those scans (`profile_from:`),
// written as files and read back as the commands read them.
#pragma once

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <tuple>

#include "io/model_file.h"
#include "tests/calib/calib_test_util.h"

namespace omni::testing {

// The misaligned sample rig with a smooth profile error on both mirrors: P1(w) is r^2 over the
// used radii, half its peak-to-valley in sag_p1; a little P2 and astigmatism besides
// (calib_profile_test.cc's).
inline RigParams ProfiledTruth(double pv_mm) {
  RigParams truth = MisalignedRig();
  truth.profile1 = DefaultProfileShape(truth, Mirror::kOne);
  truth.profile2 = DefaultProfileShape(truth, Mirror::kTwo);
  truth.mirror1_profile = {0.5 * pv_mm, -0.1 * pv_mm, 0, 0, 0.05 * pv_mm, 0};
  truth.mirror2_profile = {0.5 * pv_mm, 0.1 * pv_mm, 0, 0, 0, -0.05 * pv_mm};
  return truth;
}

// A profilometer's scan of `mirror` of `surface`: lines at 0, 60 and 120 deg from the rim inwards
// past the profile's radii (points inside mirror 2's hole left out), every 0.25 mm, N(0, noise^2)
// and a 3 um piston (the instrument's zero).
inline std::string ScanOf(const RigParams& surface, Mirror mirror, double noise_mm, unsigned seed) {
  const ProfileShape& shape = mirror == Mirror::kOne ? surface.profile1 : surface.profile2;
  const auto& coeffs = mirror == Mirror::kOne ? surface.mirror1_profile : surface.mirror2_profile;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, noise_mm);
  std::ostringstream text;
  text.precision(17);
  text << "theta_deg,r_mm,sag_mm\n";
  for (double deg : {0.0, 60.0, 120.0}) {
    const double t = deg * M_PI / 180;
    for (double r = std::max(surface.r_cam, shape.r_min - 1); r <= surface.r_sys + 1e-9; r += 0.25) {
      const double sag = ProfileSag(coeffs.data(), shape, r * std::cos(t), r * std::sin(t), false).z;
      text << deg << "," << r << "," << sag + 0.003 + noise(rng) << "\n";
    }
  }
  return text.str();
}

// A starting model whose mirrors' profiles are scans of `surface` (noise seeds seed + 1, seed +
// 2), written into `dir` and read back as calibrate would: `base` (default: the design, as kind
// noncentral) without its profiles, each mirror naming its scan stated to accuracy_mm.
inline RigParams StartWithScans(const std::filesystem::path& dir, const RigParams& surface,
                                double accuracy_mm = 0.001, double noise_mm = 0.001,
                                unsigned seed = 0, const RigParams* base = nullptr) {
  std::filesystem::create_directories(dir / "scans");
  RigParams start = base ? *base : IdealRig();
  start.kind = ModelKind::kNoncentral;
  start.profile1.present = start.profile2.present = false;
  start.measured_profile = {};
  start.calibration.reset();
  std::string text = io::ModelFileText(start);
  for (const auto& [lip, name, mirror_seed] :
       {std::tuple<const char*, const char*, unsigned>{"  lip: {color: blue", "mirror1", 1},
        std::tuple<const char*, const char*, unsigned>{"  lip: {color: red", "mirror2", 2}}) {
    std::ofstream(dir / "scans" / (std::string(name) + ".csv"))
        << ScanOf(surface, mirror_seed == 1 ? Mirror::kOne : Mirror::kTwo, noise_mm,
                  seed + mirror_seed);
    const size_t at = text.find('\n', text.find(lip)) + 1;
    char accuracy[64];
    std::snprintf(accuracy, sizeof(accuracy), "%.17g", accuracy_mm);
    text.insert(at, "  profile_from: scans/" + std::string(name) +
                        ".csv\n  profile_accuracy_mm: " + accuracy + "\n");
  }
  std::ofstream(dir / "start.yaml") << text;
  return io::ReadModelFile((dir / "start.yaml").string());
}

}  // namespace omni::testing
