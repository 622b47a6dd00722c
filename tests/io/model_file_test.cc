// Model files (tests/data/model_example.yaml): bit-exact round trips, the shared example,
// the derived section against an independent computation, one clear error per malformed input,
// and atomic writes.
#include "io/model_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <random>
#include <utility>

#include "tests/io/io_test_util.h"

namespace omni::io {
namespace {

using omni::testing::ReadText;
using omni::testing::ScratchDir;
using omni::testing::WriteText;

const std::string kExamplePath = std::string(OMNI_TEST_DATA_DIR) + "/model_example.yaml";

std::uint64_t Bits(double x) {
  std::uint64_t bits;
  std::memcpy(&bits, &x, sizeof(bits));
  return bits;
}

#define EXPECT_BIT_EQ(a, b) EXPECT_EQ(Bits(a), Bits(b)) << #a << " = " << (a) << " vs " << (b)

template <std::size_t N>
void ExpectBitEqual(const std::array<double, N>& a, const std::array<double, N>& b,
                    const char* what) {
  for (std::size_t i = 0; i < N; ++i) EXPECT_EQ(Bits(a[i]), Bits(b[i])) << what << "[" << i << "]";
}

void ExpectBitEqual(const std::vector<double>& a, const std::vector<double>& b, const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(Bits(a[i]), Bits(b[i])) << what << "[" << i << "]";
}

void ExpectSameLip(const Lip& a, const Lip& b) {
  EXPECT_EQ(a.color, b.color);
  EXPECT_BIT_EQ(a.r_inner, b.r_inner);
  EXPECT_BIT_EQ(a.r_outer, b.r_outer);
  EXPECT_BIT_EQ(a.z, b.z);
}

void ExpectSameRig(const RigParams& a, const RigParams& b) {
  EXPECT_EQ(a.kind, b.kind);
  EXPECT_EQ(a.image_width, b.image_width);
  EXPECT_EQ(a.image_height, b.image_height);
  ExpectBitEqual(a.camera, b.camera, "camera");
  ExpectBitEqual(a.distortion, b.distortion, "distortion");
  ExpectBitEqual(a.mirror1_shape, b.mirror1_shape, "mirror1_shape");
  ExpectBitEqual(a.mirror2_shape, b.mirror2_shape, "mirror2_shape");
  ExpectBitEqual(a.mirror1_pose, b.mirror1_pose, "mirror1_pose");
  ExpectBitEqual(a.mirror2_pose, b.mirror2_pose, "mirror2_pose");
  ExpectBitEqual(a.reflex, b.reflex, "reflex");
  EXPECT_BIT_EQ(a.d, b.d);
  EXPECT_BIT_EQ(a.r_sys, b.r_sys);
  EXPECT_BIT_EQ(a.r_ref, b.r_ref);
  EXPECT_BIT_EQ(a.r_cam, b.r_cam);
  ExpectSameLip(a.lip1, b.lip1);
  ExpectSameLip(a.lip2, b.lip2);
  for (const auto& [pa, pb] : {std::pair{&a.profile1, &b.profile1}, std::pair{&a.profile2, &b.profile2}}) {
    EXPECT_EQ(pa->present, pb->present);
    if (!pa->present) continue;
    EXPECT_BIT_EQ(pa->r_min, pb->r_min);
    EXPECT_BIT_EQ(pa->r_max, pb->r_max);
    EXPECT_BIT_EQ(pa->ripple_amplitude, pb->ripple_amplitude);
    if (pa->ripple_amplitude != 0) {
      EXPECT_BIT_EQ(pa->ripple_period, pb->ripple_period);
      EXPECT_BIT_EQ(pa->ripple_phase, pb->ripple_phase);
    }
  }
  if (a.profile1.present) ExpectBitEqual(a.mirror1_profile, b.mirror1_profile, "mirror1_profile");
  if (a.profile2.present) ExpectBitEqual(a.mirror2_profile, b.mirror2_profile, "mirror2_profile");
  ASSERT_EQ(a.calibration.has_value(), b.calibration.has_value());
  if (!a.calibration) return;
  const CalibrationInfo& ca = *a.calibration;
  const CalibrationInfo& cb = *b.calibration;
  EXPECT_EQ(ca.parameters, cb.parameters);
  ExpectBitEqual(ca.values, cb.values, "values");
  ExpectBitEqual(ca.sigma, cb.sigma, "sigma");
  ExpectBitEqual(ca.covariance, cb.covariance, "covariance");
  EXPECT_BIT_EQ(ca.rms_px, cb.rms_px);
  EXPECT_EQ(ca.n_observations, cb.n_observations);
  EXPECT_EQ(ca.n_outliers, cb.n_outliers);
  ExpectBitEqual(ca.per_mirror_rms_px, cb.per_mirror_rms_px, "per_mirror_rms_px");
  EXPECT_EQ(ca.lip_reference_sectors, cb.lip_reference_sectors);
  ASSERT_EQ(ca.lip_reference.size(), cb.lip_reference.size());
  for (std::size_t i = 0; i < ca.lip_reference.size(); ++i) {
    const LipReferenceBin &ra = ca.lip_reference[i], &rb = cb.lip_reference[i];
    EXPECT_EQ(ra.edge, rb.edge);
    EXPECT_BIT_EQ(ra.azimuth_deg, rb.azimuth_deg);
    EXPECT_EQ(ra.photos, rb.photos);
    EXPECT_BIT_EQ(ra.mean_px, rb.mean_px);
    EXPECT_BIT_EQ(ra.scatter_px, rb.scatter_px);
  }
  EXPECT_EQ(ca.session, cb.session);
  EXPECT_EQ(ca.images, cb.images);
  EXPECT_EQ(ca.targets, cb.targets);
  EXPECT_EQ(ca.tool_version, cb.tool_version);
  EXPECT_EQ(ca.date, cb.date);
}

// A misaligned, distorted, calibrated rig whose numbers use every bit of the mantissa.
RigParams RandomNoncentralRig(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  auto uniform = [&rng](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  RigParams rig;
  rig.kind = ModelKind::kNoncentral;
  rig.image_width = 640 + static_cast<int>(rng() % 4000);
  rig.image_height = 480 + static_cast<int>(rng() % 3000);
  rig.camera = {uniform(800, 2000), uniform(800, 2000), uniform(600, 700), uniform(400, 500),
                uniform(-1, 1)};
  for (double& k : rig.distortion) k = uniform(-0.3, 0.3);
  rig.mirror1_shape = {uniform(90, 150), uniform(2.5, 12)};
  rig.mirror2_shape = {uniform(180, 260), uniform(2.5, 12)};
  rig.d = uniform(180, 250);
  rig.r_sys = uniform(25, 45);
  rig.r_ref = uniform(0.3, 0.6) * rig.r_sys;
  rig.r_cam = uniform(0.1, 0.3) * rig.r_sys;
  for (double* pose : {rig.mirror1_pose.data(), rig.mirror2_pose.data()}) {
    pose[kRx] = uniform(-0.02, 0.02);
    pose[kRy] = uniform(-0.02, 0.02);
    for (int i : {kTx, kTy, kTz}) pose[i] = uniform(-0.8, 0.8);
  }
  rig.reflex = {uniform(-0.01, 0.01), uniform(-0.01, 0.01), uniform(-0.5, 0.5)};
  rig.lip1 = Lip{"blue", rig.r_sys, rig.r_sys + uniform(1, 5), uniform(120, 140)};
  rig.lip2 = Lip{"#8b1a1a", rig.r_sys, rig.r_sys + uniform(1, 5), uniform(-20, -10)};
  // Machined mirrors on every other seed: a profile (mirror 1 with a ripple), microns.
  if (seed % 2 == 0) {
    rig.profile1 = DefaultProfileShape(rig, Mirror::kOne);
    rig.profile2 = DefaultProfileShape(rig, Mirror::kTwo);
    rig.profile2.r_max = uniform(0.8, 1.0) * rig.r_sys;
    for (double& c : rig.mirror1_profile) c = uniform(-0.004, 0.004);
    for (double& c : rig.mirror2_profile) c = uniform(-0.004, 0.004);
    rig.profile1.ripple_amplitude = uniform(-0.002, 0.002);
    rig.profile1.ripple_period = uniform(4, 8);
    rig.profile1.ripple_phase = uniform(-3, 3);
  }

  CalibrationInfo cal;
  cal.parameters = {"camera.fx",  "camera.fy",  "camera.cx",  "camera.cy",  "distortion.dist_k1",
                    "mirror1.rx", "mirror1.ry", "mirror1.tx", "mirror1.ty", "mirror1.tz"};
  const std::size_t n = cal.parameters.size();
  for (std::size_t i = 0; i < n; ++i) {
    cal.values.push_back(uniform(-1000, 1000));
    cal.sigma.push_back(uniform(0, 1) * std::pow(10.0, uniform(-8, 2)));
  }
  for (std::size_t i = 0; i < n * n; ++i) cal.covariance.push_back(uniform(-1, 1) * std::pow(10.0, uniform(-12, 3)));
  // Numbers that trip naive formatting: signed zero, subnormals, extremes, integers.
  cal.covariance[1] = -0.0;
  cal.covariance[2] = 4.9406564584124654e-324;
  cal.covariance[3] = -2.2250738585072014e-308;
  cal.covariance[4] = 1.7976931348623157e308;
  cal.covariance[5] = 1e22;
  cal.covariance[6] = 123456789012345680.0;
  cal.covariance[7] = 0.1 + 0.2;
  cal.rms_px = uniform(0.05, 1);
  cal.n_observations = static_cast<int>(rng() % 100000);
  cal.n_outliers = static_cast<int>(rng() % 100);
  cal.per_mirror_rms_px = {uniform(0.05, 1), uniform(0.05, 1)};
  cal.session = "sessions/lab #3: \"bench\" \\ run\t2";  // needs quoting and escapes
  cal.images = static_cast<int>(rng() % 200);
  cal.targets = "aprilgrid 6x6, chessboard 9x6 (µm-flat)";
  cal.tool_version = "0.1.0";
  cal.date = "2024-05-01T12:34:56Z";
  if (seed % 2) {  // the check's lip bins of the calibration photos (optional)
    cal.lip_reference_sectors = 24;
    for (const char* edge : {"direct r_outer", "via_mirror2 r_outer"}) {
      cal.lip_reference.push_back({edge, 7.5 + 15 * static_cast<int>(rng() % 24),
                                   static_cast<int>(2 + rng() % 20), uniform(-2, 2),
                                   uniform(0, 0.5)});
    }
  }
  rig.calibration = cal;
  return rig;
}

TEST(ModelFileTest, RandomNoncentralRigRoundTripsBitForBit) {
  ScratchDir dir;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const RigParams rig = RandomNoncentralRig(seed);
    const std::string path = dir / "rig.yaml";
    WriteModelFile(path, rig);
    ExpectSameRig(rig, ReadModelFile(path));
  }
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"rig.yaml"});  // no temporary files left
}

TEST(ModelFileTest, IdealRigWithoutCalibrationRoundTrips) {
  ScratchDir dir;
  const RigParams rig = MakeIdealRig(DesignParams{123.488, 241.803, 5.7319, 9.7443, 233.684, 37.0},
                                     7.0, Pinhole<double>{1450.0, 1450.0, 639.5, 479.5, 0.0},
                                     1280, 960);
  WriteModelFile(dir / "ideal.yaml", rig);
  const RigParams back = ReadModelFile(dir / "ideal.yaml");
  ExpectSameRig(rig, back);
  EXPECT_EQ(back.kind, ModelKind::kIdeal);
  EXPECT_FALSE(back.calibration.has_value());
}

TEST(ModelFileTest, ReadsSharedFormatExample) {
  const RigParams rig = ReadModelFile(kExamplePath);
  EXPECT_EQ(rig.kind, ModelKind::kNoncentral);
  EXPECT_EQ(rig.image_width, 1280);
  EXPECT_EQ(rig.image_height, 960);
  EXPECT_EQ(rig.camera, (std::array<double, 5>{1450.0, 1450.0, 642.3, 478.9, 0.0}));
  EXPECT_EQ(rig.distortion, (std::array<double, 5>{}));
  EXPECT_EQ(rig.mirror1_shape, (std::array<double, 2>{123.488, 5.7319}));
  EXPECT_EQ(rig.mirror2_shape, (std::array<double, 2>{241.803, 9.7443}));
  EXPECT_EQ(rig.d, 233.684);
  EXPECT_EQ(rig.r_sys, 37.0);
  EXPECT_EQ(rig.r_ref, 17.226);
  EXPECT_EQ(rig.r_cam, 7.0);
  EXPECT_EQ(rig.mirror1_pose, (std::array<double, 5>{}));
  EXPECT_EQ(rig.mirror2_pose, (std::array<double, 5>{}));
  EXPECT_EQ(rig.reflex, (std::array<double, 3>{}));
  EXPECT_EQ(rig.lip1.color, "blue");
  EXPECT_EQ(rig.lip1.r_inner, 37.0);
  EXPECT_EQ(rig.lip1.r_outer, 40.0);
  EXPECT_EQ(rig.lip1.z, 132.71);
  EXPECT_EQ(rig.lip2.color, "red");
  EXPECT_EQ(rig.lip2.r_inner, 37.0);
  EXPECT_EQ(rig.lip2.r_outer, 40.0);
  EXPECT_EQ(rig.lip2.z, -17.29);
  EXPECT_FALSE(rig.calibration.has_value());
}

// Every key path of a YAML tree (maps only; list items are values).
void CollectKeys(const YAML::Node& node, const std::string& prefix, std::vector<std::string>* keys) {
  if (!node.IsMap()) return;
  for (const auto& entry : node) {
    const std::string key = prefix + entry.first.as<std::string>();
    keys->push_back(key);
    CollectKeys(entry.second, key + ".", keys);
  }
}

TEST(ModelFileTest, WrittenFileKeepsEveryKeyAndTheLayoutOfTheExample) {
  ScratchDir dir;
  WriteModelFile(dir / "out.yaml", ReadModelFile(kExamplePath));
  const std::string text = ReadText(dir / "out.yaml");
  std::vector<std::string> example_keys, written_keys;
  CollectKeys(YAML::LoadFile(kExamplePath), "", &example_keys);
  CollectKeys(YAML::Load(text), "", &written_keys);
  for (const std::string& key : example_keys) {
    EXPECT_NE(std::find(written_keys.begin(), written_keys.end(), key), written_keys.end()) << key;
  }
  EXPECT_EQ(text.rfind("# omnistereo-model/1", 0), 0u) << "starts with a comment saying what it is";
  EXPECT_NE(text.find("\nformat: omnistereo-model/1\nkind: noncentral"), std::string::npos);
  EXPECT_NE(text.find("\n  cam_from_mirror: {rx: 0.0, ry: 0.0, tx: 0.0, ty: 0.0, tz: 0.0}\n"),
            std::string::npos);
  EXPECT_NE(text.find("\n  distortion: {model: radtan, dist_k1: 0.0, dist_k2: 0.0, dist_p1: 0.0, "
                      "dist_p2: 0.0, dist_k3: 0.0}\n"),
            std::string::npos);
  EXPECT_NE(text.find("\n  lip: {color: blue, r_inner: 37.0, r_outer: 40.0, z: 132.71}"),
            std::string::npos);
  EXPECT_NE(text.find("\n  c1: 123.488\n"), std::string::npos);
}

TEST(ModelFileTest, DerivedSectionOfTheNominalBigRig) {
  const RigParams rig = ReadModelFile(kExamplePath);
  const ModelDerived derived = ComputeModelDerived(rig);
  constexpr double kTol = 1e-12;
  EXPECT_TRUE(derived.focus1_in_cam.isApprox(Eigen::Vector3d(0, 0, 123.488), kTol));
  EXPECT_TRUE(derived.focus2_in_cam.isApprox(Eigen::Vector3d(0, 0, -8.119), kTol));
  EXPECT_TRUE(derived.axis1_in_cam.isApprox(Eigen::Vector3d(0, 0, 1), kTol));
  EXPECT_TRUE(derived.axis2_in_cam.isApprox(Eigen::Vector3d(0, 0, 1), kTol));
  EXPECT_TRUE(derived.reflex_point_in_cam.isApprox(Eigen::Vector3d(0, 0, 116.842), kTol));
  EXPECT_TRUE(derived.reflex_normal_in_cam.isApprox(Eigen::Vector3d(0, 0, -1), kTol));
  EXPECT_NEAR(derived.baseline, 131.607, 1e-10);

  // The written section carries these very numbers (read here by yaml-cpp, not by our reader).
  ScratchDir dir;
  WriteModelFile(dir / "out.yaml", rig);
  const YAML::Node written = YAML::LoadFile(dir / "out.yaml")["derived"];
  ASSERT_TRUE(written.IsMap());
  const auto vec = [&](const char* key) {
    const auto v = written[key].as<std::vector<double>>();
    return Eigen::Vector3d(v.at(0), v.at(1), v.at(2));
  };
  EXPECT_EQ(vec("focus1_in_cam"), derived.focus1_in_cam);
  EXPECT_EQ(vec("axis1_in_cam"), derived.axis1_in_cam);
  EXPECT_EQ(vec("focus2_in_cam"), derived.focus2_in_cam);
  EXPECT_EQ(vec("axis2_in_cam"), derived.axis2_in_cam);
  EXPECT_EQ(vec("reflex_point_in_cam"), derived.reflex_point_in_cam);
  EXPECT_EQ(vec("reflex_normal_in_cam"), derived.reflex_normal_in_cam);
  EXPECT_EQ(written["baseline"].as<double>(), derived.baseline);
}

TEST(ModelFileTest, DerivedSectionOfATiltedRigMatchesAngleAxis) {
  RigParams rig = ReadModelFile(kExamplePath);
  rig.mirror1_pose = {0.02, -0.015, 0.3, -0.2, 0.5};
  rig.mirror2_pose = {-0.01, 0.004, -0.4, 0.1, -0.3};
  rig.reflex = {0.006, 0.003, 0.25};
  const auto rotation = [](double rx, double ry) {
    const Eigen::Vector3d w(rx, ry, 0);
    return Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  };
  const Eigen::Matrix3d R1 = rotation(0.02, -0.015);
  const Eigen::Matrix3d R2 = rotation(-0.01, 0.004);
  const Eigen::Matrix3d R_ref = rotation(0.006, 0.003);
  const Eigen::Vector3d t1(0.3, -0.2, 0.5), t2(-0.4, 0.1, -0.3);
  const Eigen::Vector3d focus1 = R1 * Eigen::Vector3d(0, 0, 123.488) + t1;
  const Eigen::Vector3d focus2 = R2 * Eigen::Vector3d(0, 0, 233.684 - 241.803) + t2;
  const Eigen::Vector3d reflex_point = R1 * Eigen::Vector3d(0, 0, 233.684 / 2 + 0.25) + t1;
  const Eigen::Vector3d reflex_normal = R1 * R_ref * Eigen::Vector3d(0, 0, -1);

  const ModelDerived derived = ComputeModelDerived(rig);
  constexpr double kTol = 1e-12;
  EXPECT_TRUE(derived.focus1_in_cam.isApprox(focus1, kTol)) << derived.focus1_in_cam.transpose();
  EXPECT_TRUE(derived.axis1_in_cam.isApprox(R1.col(2), kTol));
  EXPECT_TRUE(derived.focus2_in_cam.isApprox(focus2, kTol)) << derived.focus2_in_cam.transpose();
  EXPECT_TRUE(derived.axis2_in_cam.isApprox(R2.col(2), kTol));
  EXPECT_TRUE(derived.reflex_point_in_cam.isApprox(reflex_point, kTol));
  EXPECT_TRUE(derived.reflex_normal_in_cam.isApprox(reflex_normal, kTol));
  EXPECT_NEAR(derived.baseline, (focus1 - focus2).norm(), 1e-10);
  // The tilt moves focus 1 sideways by about c1 * tilt: a sanity check on the sign convention
  // (positive ry tilts +z towards +x).
  EXPECT_NEAR(derived.focus1_in_cam.x(), 0.3 + 123.488 * std::sin(-0.015), 0.01);
}

TEST(ModelFileTest, AcceptsMinorVersionsAndDegreeKeys) {
  ScratchDir dir;
  std::string text = ReadText(kExamplePath);
  text.replace(text.find("format: omnistereo-model/1"), 26, "format: omnistereo-model/1.7");
  text.replace(text.find("reflex: {rx: 0.0"), 16, "reflex: {rx_deg: 0.5");
  WriteText(dir / "m.yaml", text);
  const RigParams rig = ReadModelFile(dir / "m.yaml");
  EXPECT_DOUBLE_EQ(rig.reflex[kReflexRx], 0.5 * M_PI / 180);
}

// ---------------------------------------------------------------------------------------------
// Malformed input: one line naming the file and the key.

struct Malformed {
  const char* name;
  std::vector<std::pair<std::string, std::string>> edits;  // replace first match; "" appends
  std::string key;       // the message starts with "<file>: <key>:"
  std::string expected;  // ... and contains this
};

std::ostream& operator<<(std::ostream& os, const Malformed& m) { return os << m.name; }

const char kCalibration[] =
    "calibration:\n"
    "  parameters: [camera.fx, camera.fy, mirror1.tx]\n"
    "  values: [1450.0, 1451.0, 0.1]\n"
    "  sigma: [0.5, 0.5, 0.01]\n"
    "  covariance: [0.25, 0, 0, 0, 0.25, 0, 0, 0, 0.0001]\n"
    "  residuals: {rms_px: 0.3, n_observations: 1000, n_outliers: 3, per_mirror_rms_px: [0.3, 0.31]}\n"
    "  dataset: {session: s.yaml, images: 20, targets: aprilgrid}\n"
    "  tool_version: \"0.1.0\"\n"
    "  date: \"2024-05-01\"\n";

// A held profile's record (calibration.held_profiles): 6 x 6 prior covariance and data information.
const char kHeldProfiles[] =
    "  held_profiles:\n"
    "    - {mirror: 2, prior: tolerance, r_min: 7, r_max: 37,\n"
    "      prior_covariance: [4e-06, 0, 0, 0, 0, 0, 0, 4e-06, 0, 0, 0, 0, 0, 0, 4e-06, 0, 0, 0,\n"
    "         0, 0, 0, 4e-06, 0, 0, 0, 0, 0, 0, 4e-06, 0, 0, 0, 0, 0, 0, 4e-06],\n"
    "      data_information: [1, 2, 0, 0, 0, 0, 2, 5e+07, 0, 0, 0, 0, 0, 0, 3e+09, 0, 0, 0,\n"
    "         0, 0, 0, 4e+09, 0, 0, 0, 0, 0, 0, 5e+09, 0, 0, 0, 0, 0, 0, 6e+09]}\n";

std::string CalibrationWith(const std::string& from, const std::string& to) {
  std::string text = kCalibration;
  text.replace(text.find(from), from.size(), to);
  return text;
}

class MalformedModelTest : public ::testing::TestWithParam<Malformed> {};

TEST_P(MalformedModelTest, ThrowsOneLineNamingFileAndKey) {
  const Malformed& m = GetParam();
  std::string text = ReadText(kExamplePath);
  for (const auto& [from, to] : m.edits) {
    if (from.empty()) {
      text += to;
      continue;
    }
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << "test edit does not apply: " << from;
    text.replace(at, from.size(), to);
  }
  ScratchDir dir;
  const std::string path = dir / (std::string(m.name) + ".yaml");
  WriteText(path, text);
  try {
    ReadModelFile(path);
    FAIL() << "no error for " << m.name;
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path + ": " + m.key + ":", 0), 0u) << message;
    EXPECT_NE(message.find(m.expected), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

const std::string kIdeal = "kind: ideal";
const std::pair<std::string, std::string> kMakeIdeal{"kind: noncentral", kIdeal};
const std::string kM2Pose = "mirror2:\n  cam_from_mirror: {rx: 0.0, ry: 0.0, tx: 0.0, ty: 0.0, tz: 0.0}";
const std::string kLip1 = "lip: {color: blue, r_inner: 37.0, r_outer: 40.0, z: 132.71}";
const std::string kLip2 = "lip: {color: red, r_inner: 37.0, r_outer: 40.0, z: -17.29}";

INSTANTIATE_TEST_SUITE_P(
    AllCases, MalformedModelTest,
    ::testing::Values(
        Malformed{"malformed_yaml", {{"c1: 123.488", "c1: [123.488"}}, "line 16, column 5", "expected valid YAML"},
        Malformed{"format_major_2", {{"format: omnistereo-model/1", "format: omnistereo-model/2"}}, "format", "major version 1"},
        Malformed{"format_other_schema", {{"format: omnistereo-model/1", "format: omnistereo-session/1"}}, "format",
                  "omnistereo-session/1"},
        Malformed{"format_missing", {{"format: omnistereo-model/1\n", ""}}, "format", "key missing"},
        Malformed{"kind_unknown", {{"kind: noncentral", "kind: central"}}, "kind", "'central'"},
        Malformed{"missing_k1", {{"  k1: 5.7319\n", ""}}, "design.k1", "key missing"},
        Malformed{"missing_mirror2", {{"mirror2:", "mirror_2:"}}, "mirror2", "expected a map"},
        Malformed{"missing_lip_z", {{", z: -17.29", ""}}, "mirror2.lip.z", "key missing"},
        Malformed{"missing_distortion_key", {{"dist_p2: 0.0, ", ""}}, "camera.distortion.dist_p2",
                  "key missing"},
        Malformed{"text_for_number", {{"k1: 5.7319", "k1: abc"}}, "design.k1", "got 'abc'"},
        Malformed{"quoted_number", {{"c1: 123.488", "c1: \"123.488\""}}, "design.c1", "quoted"},
        Malformed{"list_for_number", {{"fx: 1450.0", "fx: [1450.0]"}}, "camera.fx", "got a list"},
        Malformed{"fraction_for_integer", {{"width: 1280", "width: 1280.5"}}, "image.width",
                  "expected an integer"},
        Malformed{"number_for_map", {{"camera:\n", "camera: 5\ncamera_old:\n"}}, "camera",
                  "expected a map"},
        Malformed{"nan", {{"c2: 241.803", "c2: .nan"}}, "design.c2", "finite"},
        Malformed{"inf_in_flow_map", {{"{rx: 0.0, ry: 0.0, tx: 0.0", "{rx: 0.0, ry: 0.0, tx: -.inf"}},
                  "mirror1.cam_from_mirror.tx", "finite"},
        Malformed{"k1_is_2", {{"k1: 5.7319", "k1: 2.0"}}, "design.k1", "k > 2"},
        Malformed{"k2_below_2", {{"k2: 9.7443", "k2: 1.5"}}, "design.k2", "k > 2"},
        Malformed{"c1_zero", {{"c1: 123.488", "c1: 0.0"}}, "design.c1", "> 0"},
        Malformed{"c2_negative", {{"c2: 241.803", "c2: -241.803"}}, "design.c2", "> 0"},
        Malformed{"d_zero", {{"d: 233.684", "d: 0"}}, "design.d", "> 0"},
        Malformed{"r_sys_negative", {{"r_sys: 37.0", "r_sys: -37.0"}}, "design.r_sys", "> 0"},
        Malformed{"r_ref_beyond_r_sys", {{"r_ref: 17.226", "r_ref: 37.0"}}, "design.r_ref",
                  "(0, r_sys)"},
        Malformed{"r_cam_zero", {{"r_cam: 7.0", "r_cam: 0.0"}}, "design.r_cam", "(0, r_sys)"},
        Malformed{"fx_zero", {{"fx: 1450.0", "fx: 0.0"}}, "camera.fx", "> 0"},
        Malformed{"fy_negative", {{"fy: 1450.0", "fy: -1450.0"}}, "camera.fy", "> 0"},
        Malformed{"width_zero", {{"width: 1280", "width: 0"}}, "image.width", ">= 1"},
        Malformed{"height_negative", {{"height: 960", "height: -960"}}, "image.height", ">= 1"},
        Malformed{"ideal_with_misaligned_mirror2", {kMakeIdeal, {kM2Pose, kM2Pose.substr(0, kM2Pose.size() - 4) + "0.5}"}},
                  "mirror2.cam_from_mirror.tz", "kind is ideal"},
        Malformed{"ideal_with_reflex_offset", {kMakeIdeal, {"dz: 0.0", "dz: 0.2"}}, "mirror1.reflex.dz",
                  "kind is ideal"},
        Malformed{"ideal_with_distortion", {kMakeIdeal, {"dist_k1: 0.0", "dist_k1: -0.1"}},
                  "camera.distortion.dist_k1", "kind is ideal"},
        Malformed{"distortion_model", {{"model: radtan", "model: fisheye"}}, "camera.distortion.model",
                  "'radtan'"},
        Malformed{"units_cm", {{"length: mm", "length: cm"}}, "units.length", "'mm'"},
        Malformed{"rad_and_deg", {{"reflex: {rx: 0.0,", "reflex: {rx: 0.0, rx_deg: 0.0,"}},
                  "mirror1.reflex.rx", "both"},
        Malformed{"lip_color_unknown", {{"color: red", "color: crimson"}}, "mirror2.lip.color",
                  "expected a paint: blue, red, navy"},
        Malformed{"lip_color_bad_hex", {{"color: red", "color: \"#12345g\""}}, "mirror2.lip.color",
                  "'#12345g'"},
        Malformed{"lip_color_unquoted_hex",
                  {{"lip: {color: red, r_inner: 37.0, r_outer: 40.0, z: -17.29}",
                    "lip:\n    color: #8b1a1a\n    r_inner: 37.0\n    r_outer: 40.0\n    z: -17.29\n"}},
                  "mirror2.lip.color", "#rrggbb"},
        Malformed{"lip_outer_inside_inner", {{"r_outer: 40.0, z: 132.71", "r_outer: 30.0, z: 132.71"}},
                  "mirror1.lip.r_outer", "> r_inner"},
        Malformed{"calibration_values_short", {{"", CalibrationWith(", 0.1]", "]")}}, "calibration.values",
                  "expected 3 numbers"},
        Malformed{"calibration_sigma_short", {{"", CalibrationWith(", 0.01]", "]")}}, "calibration.sigma",
                  "expected 3 numbers"},
        Malformed{"calibration_covariance_short", {{"", CalibrationWith(", 0.0001]", "]")}},
                  "calibration.covariance", "expected 9 numbers"},
        Malformed{"calibration_missing_residuals", {{"", CalibrationWith("residuals:", "residual:")}},
                  "calibration.residuals", "key missing"},
        Malformed{"calibration_duplicate_name", {{"", CalibrationWith("mirror1.tx]", "camera.fx]")}},
                  "calibration.parameters[2]", "unique"},
        Malformed{"held_profile_prior_unknown",
                  {{"", CalibrationWith("  dataset:", std::string(kHeldProfiles).replace(
                                                             std::string(kHeldProfiles).find("prior: tolerance"),
                                                             16, "prior: guess") + "  dataset:")}},
                  "calibration.held_profiles[0].prior", "expected tolerance or scan"},
        Malformed{"held_profile_information_short",
                  {{"", CalibrationWith("  dataset:", std::string(kHeldProfiles).replace(
                                                             std::string(kHeldProfiles).find("data_information: [1,"),
                                                             21, "data_information: [") + "  dataset:")}},
                  "calibration.held_profiles[0].data_information", "expected 36 numbers"},
        Malformed{"lip_reference_negative_scatter",
                  {{"", CalibrationWith("  dataset:", "  lip_reference:\n    azimuth_bins: 24\n"
                                        "    bins:\n      - {edge: direct r_outer, azimuth_deg: 7.5, "
                                        "photos: 8, mean_px: 0.1, scatter_px: -0.1}\n  dataset:")}},
                  "calibration.lip_reference.bins[0].scatter_px", "standard deviation >= 0"},
        Malformed{"lip_reference_bins_not_a_list",
                  {{"", CalibrationWith("  dataset:", "  lip_reference: {azimuth_bins: 24, bins: 3}\n"
                                        "  dataset:")}},
                  "calibration.lip_reference.bins", "expected a list of bins"},
        Malformed{"lip_reference_no_photos",
                  {{"", CalibrationWith("  dataset:", "  lip_reference:\n    azimuth_bins: 24\n"
                                        "    bins:\n      - {edge: direct r_outer, azimuth_deg: 7.5, "
                                        "photos: 0, mean_px: 0.1, scatter_px: 0.1}\n  dataset:")}},
                  "calibration.lip_reference.bins[0].photos", "integer >= 1"},
        // Mirror profiles (issue 40).
        Malformed{"profile_beyond_rim", {{kLip1, kLip1 + "\n  profile: {r_max: 40.0, sag_p1: 0.003}"}},
                  "mirror1.profile.r_max", "(r_min, r_sys]"},
        Malformed{"profile_negative_r_min", {{kLip2, kLip2 + "\n  profile: {r_min: -1.0}"}},
                  "mirror2.profile.r_min", "[0, r_sys)"},
        Malformed{"profile_too_deep", {{kLip1, kLip1 + "\n  profile: {sag_p2: 0.2}"}},
                  "mirror1.profile", "at most 0.1 mm"},
        Malformed{"profile_too_steep", {{kLip1, kLip1 + "\n  profile: {ripple_amplitude: 0.05, ripple_period: 2.0}"}},
                  "mirror1.profile", "smooth"},
        Malformed{"profile_ripple_without_period", {{kLip1, kLip1 + "\n  profile: {ripple_amplitude: 0.002}"}},
                  "mirror1.profile.ripple_period", "period >= 0.5"},
        Malformed{"profile_not_a_number", {{kLip1, kLip1 + "\n  profile: {sag_p1: 3um}"}},
                  "mirror1.profile.sag_p1", "expected a number"},
        Malformed{"ideal_with_profile", {kMakeIdeal, {kLip1, kLip1 + "\n  profile: {sag_p1: 0.001}"}},
                  "mirror1.profile", "kind is ideal"},
        // The prototype's mount (issue 39).
        Malformed{"mount_inside_mirrors", {{"", "mount: {count: 3, width: 3.0, radius: 30.0, z_min: -17.0, z_max: 132.0}\n"}},
                  "mount.radius", "outside the mirrors"},
        Malformed{"mount_no_width", {{"", "mount: {count: 3, width: 0.0, radius: 41.5, z_min: -17.0, z_max: 132.0}\n"}},
                  "mount.width", "> 0"},
        Malformed{"mount_overlapping", {{"", "mount: {count: 2, width: 3.0, radius: 41.5, z_min: -17.0, z_max: 132.0, azimuths_deg: [10, 12]}\n"}},
                  "mount.azimuths_deg", "do not meet"},
        Malformed{"mount_azimuth_count", {{"", "mount: {count: 3, width: 3.0, radius: 41.5, z_min: -17.0, z_max: 132.0, azimuths_deg: [10, 130]}\n"}},
                  "mount.azimuths_deg", "expected 3 azimuths"},
        Malformed{"mount_body", {{"", "mount: {body: camera, count: 3, width: 3.0, radius: 41.5, z_min: -17.0, z_max: 132.0}\n"}},
                  "mount.body", "mirror1 or mirror2"},
        // Posts of unequal widths (issue 48): one width per post.
        Malformed{"mount_widths_count", {{"", "mount: {count: 3, widths: [3.0, 6.0], radius: 41.5, z_min: -17.0, z_max: 132.0}\n"}},
                  "mount.widths", "expected 3 widths (count)"},
        Malformed{"mount_width_and_widths", {{"", "mount: {count: 2, width: 3.0, widths: [3.0, 6.0], radius: 41.5, z_min: -17.0, z_max: 132.0}\n"}},
                  "mount.widths", "width or widths, not both"},
        Malformed{"mount_widths_zero", {{"", "mount: {count: 2, widths: [3.0, 0.0], radius: 41.5, z_min: -17.0, z_max: 132.0}\n"}},
                  "mount.widths", "> 0"},
        Malformed{"mount_widths_wide_overlap", {{"", "mount: {count: 2, widths: [3.0, 8.0], radius: 41.5, z_min: -17.0, z_max: 132.0, azimuths_deg: [10, 20]}\n"}},
                  "mount.azimuths_deg", "do not meet"},
        Malformed{"mount_upside_down", {{"", "mount: {count: 3, width: 3.0, radius: 41.5, z_min: 132.0, z_max: -17.0}\n"}},
                  "mount.z_max", "z_max > z_min"}),
    [](const ::testing::TestParamInfo<Malformed>& info) { return std::string(info.param.name); });

TEST(ModelFileTest, MountRoundTrips) {
  ScratchDir dir;
  WriteText(dir / "m.yaml", ReadText(kExamplePath) +
                                "mount: {body: mirror2, count: 3, width: 3.0, radius: 41.5, "
                                "z_min: -17.29, z_max: 132.71, azimuths_deg: [90, 210, 330]}\n");
  const RigParams rig = ReadModelFile(dir / "m.yaml");
  ASSERT_TRUE(rig.mount.present);
  EXPECT_EQ(rig.mount.body, Mirror::kTwo);
  ASSERT_EQ(rig.mount.azimuths.size(), 3u);
  EXPECT_NEAR(rig.mount.azimuths[1], 210 * M_PI / 180, 1e-15);
  WriteModelFile(dir / "back.yaml", rig);
  const RigParams back = ReadModelFile(dir / "back.yaml");
  ASSERT_TRUE(back.mount.present);
  EXPECT_EQ(back.mount.body, Mirror::kTwo);
  EXPECT_EQ(back.mount.width, 3.0);
  EXPECT_EQ(back.mount.radius, 41.5);
  EXPECT_EQ(back.mount.z_min, -17.29);
  EXPECT_EQ(back.mount.z_max, 132.71);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(back.mount.azimuths[i], rig.mount.azimuths[i], 1e-14);
  // Posts of unequal widths: one per post, written back as such; equal ones as `width:`.
  WriteText(dir / "widths.yaml", ReadText(kExamplePath) +
                                     "mount: {count: 3, widths: [3.0, 4.5, 6.0], radius: 41.5, z_min: -17.0, "
                                     "z_max: 132.0, azimuths_deg: [20, 135, 260]}\n");
  const RigParams widths = ReadModelFile(dir / "widths.yaml");
  ASSERT_EQ(widths.mount.widths.size(), 3u);
  EXPECT_EQ(widths.mount.WidthOf(1), 4.5);
  EXPECT_EQ(widths.mount.MaxWidth(), 6.0);
  WriteModelFile(dir / "widths_back.yaml", widths);
  EXPECT_NE(ReadText(dir / "widths_back.yaml").find("widths: [3, 4.5, 6]"), std::string::npos);
  const RigParams widths_back = ReadModelFile(dir / "widths_back.yaml");
  EXPECT_EQ(widths_back.mount.widths, widths.mount.widths);
  EXPECT_EQ(ReadText(dir / "back.yaml").find("widths:"), std::string::npos);
  // Without azimuths: evenly spaced from +y.
  WriteText(dir / "even.yaml", ReadText(kExamplePath) +
                                   "mount: {count: 3, width: 3.0, radius: 41.5, z_min: -17.0, "
                                   "z_max: 132.0}\n");
  const RigParams even = ReadModelFile(dir / "even.yaml");
  EXPECT_EQ(even.mount.body, Mirror::kOne);
  EXPECT_NEAR(even.mount.azimuths[0], M_PI / 2, 1e-15);
  EXPECT_NEAR(even.mount.azimuths[2], M_PI / 2 + 4 * M_PI / 3, 1e-15);
}

TEST(ModelFileTest, ValidCalibrationSectionIsRead) {
  ScratchDir dir;
  WriteText(dir / "cal.yaml", ReadText(kExamplePath) + kCalibration);
  const RigParams rig = ReadModelFile(dir / "cal.yaml");
  ASSERT_TRUE(rig.calibration.has_value());
  EXPECT_EQ(rig.calibration->parameters.size(), 3u);
  EXPECT_EQ(rig.calibration->covariance.size(), 9u);
  EXPECT_EQ(rig.calibration->n_outliers, 3);
  EXPECT_EQ(rig.calibration->tool_version, "0.1.0");
}

// A held profile's record is read, written and read back bit for bit; a file without it (older
// files) reads with none.
TEST(ModelFileTest, HeldProfilesRoundTrip) {
  ScratchDir dir;
  WriteText(dir / "held.yaml",
            ReadText(kExamplePath) + CalibrationWith("  dataset:", std::string(kHeldProfiles) + "  dataset:"));
  const RigParams rig = ReadModelFile(dir / "held.yaml");
  ASSERT_EQ(rig.calibration->held_profiles.size(), 1u);
  const HeldProfileInfo& held = rig.calibration->held_profiles[0];
  EXPECT_EQ(held.mirror, 2);
  EXPECT_EQ(held.prior, "tolerance");
  ASSERT_EQ(held.prior_covariance.size(), 36u);
  ASSERT_EQ(held.data_information.size(), 36u);
  EXPECT_EQ(held.data_information[1], 2.0);
  EXPECT_EQ(held.data_information[35], 6e9);
  RigParams more = rig;
  HeldProfileInfo scan;  // a scan's prior, held whatever the data show: no data information
  scan.mirror = 1;
  scan.prior = "scan";
  scan.r_min = 17.225725156011855;
  scan.r_max = 37;
  for (int i = 0; i < 36; ++i) scan.prior_covariance.push_back(i % 7 == 0 ? 1e-8 / 3 : -1e-10 * i);
  more.calibration->held_profiles.push_back(scan);
  WriteModelFile(dir / "back.yaml", more);
  const RigParams back = ReadModelFile(dir / "back.yaml");
  ASSERT_EQ(back.calibration->held_profiles.size(), 2u);
  for (int h = 0; h < 2; ++h) {
    const HeldProfileInfo& a = more.calibration->held_profiles[h];
    const HeldProfileInfo& b = back.calibration->held_profiles[h];
    EXPECT_EQ(a.mirror, b.mirror);
    EXPECT_EQ(a.prior, b.prior);
    EXPECT_EQ(a.r_min, b.r_min);
    EXPECT_EQ(a.r_max, b.r_max);
    EXPECT_EQ(a.prior_covariance, b.prior_covariance);
    EXPECT_EQ(a.data_information, b.data_information);
  }
  WriteText(dir / "old.yaml", ReadText(kExamplePath) + kCalibration);
  EXPECT_TRUE(ReadModelFile(dir / "old.yaml").calibration->held_profiles.empty());
}

TEST(ModelFileTest, MissingUnreadableAndEmptyFiles) {
  ScratchDir dir;
  const auto message_of = [](const std::string& path) -> std::string {
    try {
      ReadModelFile(path);
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  const std::string missing = dir / "missing.yaml";
  EXPECT_EQ(message_of(missing), missing + ": expected a readable model file, got no such file");
  EXPECT_EQ(message_of(dir.path()), dir.path() + ": expected a model file, got a folder");
  WriteText(dir / "empty.yaml", "");
  EXPECT_EQ(message_of(dir / "empty.yaml").rfind(dir / "empty.yaml: format:", 0), 0u);
  WriteText(dir / "list.yaml", "- 1\n- 2\n");
  EXPECT_EQ(message_of(dir / "list.yaml").rfind(dir / "list.yaml: format:", 0), 0u);
  if (::geteuid() != 0) {  // root reads anything
    WriteText(dir / "locked.yaml", ReadText(kExamplePath));
    ::chmod((dir / "locked.yaml").c_str(), 0);
    EXPECT_EQ(message_of(dir / "locked.yaml").rfind(dir / "locked.yaml: expected a readable", 0), 0u);
  }
}

// ---------------------------------------------------------------------------------------------
// Atomic writes.

TEST(ModelFileTest, WriteIntoMissingFolderThrowsAndCreatesNothing) {
  ScratchDir dir;
  const std::string path = dir / "no/such/folder/model.yaml";
  try {
    WriteModelFile(path, ReadModelFile(kExamplePath));
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(dir.Entries().empty());
}

TEST(ModelFileTest, WriteBelowAFileThrowsNamingThePath) {
  ScratchDir dir;
  WriteText(dir / "plain.txt", "not a folder\n");
  const std::string path = dir / "plain.txt/model.yaml";
  try {
    WriteModelFile(path, ReadModelFile(kExamplePath));
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadText(dir / "plain.txt"), "not a folder\n");
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"plain.txt"});
}

TEST(ModelFileTest, FailedWriteLeavesTheExistingFileUntouched) {
  ScratchDir dir;
  const std::string path = dir / "model.yaml";
  const RigParams good = ReadModelFile(kExamplePath);
  WriteModelFile(path, good);
  const std::string before = ReadText(path);

  RigParams bad = good;
  bad.camera[kFx] = std::nan("");
  EXPECT_THROW(WriteModelFile(path, bad), std::runtime_error);
  bad = good;
  bad.mirror2_shape[kShapeK] = 1.5;  // k2 <= 2: a file nobody could read back
  EXPECT_THROW(WriteModelFile(path, bad), std::runtime_error);
  bad = RandomNoncentralRig(7);
  bad.calibration->covariance.pop_back();
  EXPECT_THROW(WriteModelFile(path, bad), std::runtime_error);

  EXPECT_EQ(ReadText(path), before);
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"model.yaml"});
}

TEST(ModelFileTest, FailedRenameRemovesTheTemporaryFile) {
  ScratchDir dir;
  std::filesystem::create_directory(dir / "taken");
  EXPECT_THROW(WriteFileAtomically(dir / "taken", "text"), std::runtime_error);
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"taken"});
}

TEST(ModelFileTest, WriteIntoReadOnlyFolderThrows) {
  if (::geteuid() == 0) GTEST_SKIP() << "root writes anywhere";
  ScratchDir dir;
  std::filesystem::create_directory(dir / "ro");
  ::chmod((dir / "ro").c_str(), 0555);
  EXPECT_THROW(WriteModelFile(dir / "ro/model.yaml", ReadModelFile(kExamplePath)),
               std::runtime_error);
  ::chmod((dir / "ro").c_str(), 0755);
  EXPECT_TRUE(std::filesystem::is_empty(dir / "ro"));
}

TEST(ModelFileTest, AtomicWriteReplacesLongerContentCompletely) {
  ScratchDir dir;
  WriteFileAtomically(dir / "f.txt", std::string(10000, 'x'));
  WriteFileAtomically(dir / "f.txt", "short\n");
  EXPECT_EQ(ReadText(dir / "f.txt"), "short\n");
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"f.txt"});
}

}  // namespace
}  // namespace omni::io
