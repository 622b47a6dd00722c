#include "model/rig_parameters.h"

#include <cmath>
#include <map>

namespace omni {
namespace {

constexpr double kRad = M_PI / 180.0;  // one degree in rad

constexpr const char* kCameraHint = "targets filling both rings all around the rig, at near and far ranges";
constexpr const char* kDistortionHint =
    "corners over the whole radial extent of both rings (targets at several heights and ranges)";
// A single-mirror rig's wording of the two above (ParameterHint).
constexpr const char* kSingleCameraHint =
    "targets filling the ring all around the camera, at near and far ranges";
constexpr const char* kSingleDistortionHint =
    "corners over the ring's whole radial extent (targets at several heights and ranges)";
constexpr const char* kShapeHint =
    "a manufacturing-tolerance prior on the mirror shape, or targets at many ranges";
constexpr const char* kLateralHint =
    "targets all around the rig (full azimuth) and at several heights";
constexpr const char* kAxialHint =
    "targets at several ranges including near ones (0.3-0.6 m): an axial shift shows only as "
    "parallax";
constexpr const char* kReflexTiltHint = "inner-ring (mirror 2) observations all around the rig";
constexpr const char* kProfileHint =
    "corners over the ring's whole radial extent (targets low and high), near and far, all "
    "around the rig";

using U = ParameterUnit;
using V = RotationValley;
using F = FileCheck;
using R = SolveRole;

// Bounds: 20 px for the pinhole, 5 px of skew, 0.05 for a tangential coefficient, 2 mm for a
// shape's c and 0.2 for its k, 1 deg for a tilt and 1 mm for a shift: each far beyond what an
// assembly error or a mirror's manufacture gives. Divergence: 10 deg, 20 mm.
// Radial powers: the pixels dist_k1, k2, k3 move at normalised radius r go as r^3, r^5, r^7.
// Valley: the principal point, the tilts, the mirrors' lateral shifts (RotationValley). Drift: the
// camera's pinhole (not skew) and every pose of a body and of the reflex disc. File checks: the
// pinhole's focal lengths and the shapes' c are > 0, their k > 2 (a hyperboloid). Roles: skew,
// the tangential pair and dist_k3 are held unless asked or told; the focal lengths, the mirrors'
// tz and the reflex dz scale the rings as a profile's power term does.
//    name  block  index  flat  unit  unobservable_sigma  diverged_beyond  considerable
//    radial_power  valley  drift  file_check  role  hint
// clang-format off
constexpr std::array<RigParameter, kRigParameterCount> kTable = {{
    {"fx",               "camera",          0, 0,  U::kPixel,      20.0,       0,         false, 0, V::kNone,           true,  F::kPositive,     R::kAxialScale,   kCameraHint},
    {"fy",               "camera",          1, 1,  U::kPixel,      20.0,       0,         false, 0, V::kNone,           true,  F::kPositive,     R::kAxialScale,   kCameraHint},
    {"cx",               "camera",          2, 2,  U::kPixel,      20.0,       0,         false, 0, V::kPrincipalPoint, true,  F::kAny,          R::kPlain,        kCameraHint},
    {"cy",               "camera",          3, 3,  U::kPixel,      20.0,       0,         false, 0, V::kPrincipalPoint, true,  F::kAny,          R::kPlain,        kCameraHint},
    {"skew",             "camera",          4, 4,  U::kPixel,      5.0,        0,         true,  0, V::kNone,           false, F::kAny,          R::kSkew,         kCameraHint},
    {"dist_k1",          "distortion",      0, 5,  U::kNone,       0,          0,         false, 3, V::kNone,           false, F::kAny,          R::kPlain,        kDistortionHint},
    {"dist_k2",          "distortion",      1, 6,  U::kNone,       0,          0,         false, 5, V::kNone,           false, F::kAny,          R::kPlain,        kDistortionHint},
    {"dist_p1",          "distortion",      2, 7,  U::kNone,       0.05,       0,         true,  0, V::kNone,           false, F::kAny,          R::kTangential,   kDistortionHint},
    {"dist_p2",          "distortion",      3, 8,  U::kNone,       0.05,       0,         true,  0, V::kNone,           false, F::kAny,          R::kTangential,   kDistortionHint},
    {"dist_k3",          "distortion",      4, 9,  U::kNone,       0,          0,         true,  7, V::kNone,           false, F::kAny,          R::kHighRadial,   kDistortionHint},
    {"c1",               "mirror1_shape",   0, 10, U::kMillimetre, 2.0,        0,         false, 0, V::kNone,           false, F::kPositive,     R::kPlain,        kShapeHint},
    {"k1",               "mirror1_shape",   1, 11, U::kNone,       0.2,        0,         false, 0, V::kNone,           false, F::kHyperboloidK, R::kPlain,        kShapeHint},
    {"c2",               "mirror2_shape",   0, 12, U::kMillimetre, 2.0,        0,         false, 0, V::kNone,           false, F::kPositive,     R::kPlain,        kShapeHint},
    {"k2",               "mirror2_shape",   1, 13, U::kNone,       0.2,        0,         false, 0, V::kNone,           false, F::kHyperboloidK, R::kPlain,        kShapeHint},
    {"mirror1.rx",       "mirror1_pose",    0, 14, U::kRadian,     1.0 * kRad, 10 * kRad, false, 0, V::kTilt,           true,  F::kAny,          R::kPlain,        kLateralHint},
    {"mirror1.ry",       "mirror1_pose",    1, 15, U::kRadian,     1.0 * kRad, 10 * kRad, false, 0, V::kTilt,           true,  F::kAny,          R::kPlain,        kLateralHint},
    {"mirror1.tx",       "mirror1_pose",    2, 16, U::kMillimetre, 1.0,        20.0,      false, 0, V::kLateralShift,   true,  F::kAny,          R::kPlain,        kLateralHint},
    {"mirror1.ty",       "mirror1_pose",    3, 17, U::kMillimetre, 1.0,        20.0,      false, 0, V::kLateralShift,   true,  F::kAny,          R::kPlain,        kLateralHint},
    {"mirror1.tz",       "mirror1_pose",    4, 18, U::kMillimetre, 1.0,        20.0,      false, 0, V::kNone,           true,  F::kAny,          R::kAxialScale,   kAxialHint},
    {"mirror2.rx",       "mirror2_pose",    0, 19, U::kRadian,     1.0 * kRad, 10 * kRad, false, 0, V::kTilt,           true,  F::kAny,          R::kPlain,        kLateralHint},
    {"mirror2.ry",       "mirror2_pose",    1, 20, U::kRadian,     1.0 * kRad, 10 * kRad, false, 0, V::kTilt,           true,  F::kAny,          R::kPlain,        kLateralHint},
    {"mirror2.tx",       "mirror2_pose",    2, 21, U::kMillimetre, 1.0,        20.0,      false, 0, V::kLateralShift,   true,  F::kAny,          R::kPlain,        kLateralHint},
    {"mirror2.ty",       "mirror2_pose",    3, 22, U::kMillimetre, 1.0,        20.0,      false, 0, V::kLateralShift,   true,  F::kAny,          R::kPlain,        kLateralHint},
    {"mirror2.tz",       "mirror2_pose",    4, 23, U::kMillimetre, 1.0,        20.0,      false, 0, V::kNone,           true,  F::kAny,          R::kAxialScale,   kAxialHint},
    {"reflex.rx",        "reflex",          0, 24, U::kRadian,     1.0 * kRad, 10 * kRad, false, 0, V::kTilt,           true,  F::kAny,          R::kPlain,        kReflexTiltHint},
    {"reflex.ry",        "reflex",          1, 25, U::kRadian,     1.0 * kRad, 10 * kRad, false, 0, V::kTilt,           true,  F::kAny,          R::kPlain,        kReflexTiltHint},
    {"reflex.dz",        "reflex",          2, 26, U::kMillimetre, 1.0,        20.0,      false, 0, V::kNone,           true,  F::kAny,          R::kAxialScale,   kAxialHint},
    // Profile coefficients (model/mirror_profile.h): half a term's peak-to-valley in mm. Beyond
    // 20 um of sigma a term is not told; beyond 0.5 mm the part is not the designed mirror.
    {"mirror1.sag_p1",   "mirror1_profile", 0, 27, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
    {"mirror1.sag_p2",   "mirror1_profile", 1, 28, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
    {"mirror1.sag_p3",   "mirror1_profile", 2, 29, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
    {"mirror1.sag_p4",   "mirror1_profile", 3, 30, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
    {"mirror1.sag_cos2", "mirror1_profile", 4, 31, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
    {"mirror1.sag_sin2", "mirror1_profile", 5, 32, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
    {"mirror2.sag_p1",   "mirror2_profile", 0, 33, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
    {"mirror2.sag_p2",   "mirror2_profile", 1, 34, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
    {"mirror2.sag_p3",   "mirror2_profile", 2, 35, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
    {"mirror2.sag_p4",   "mirror2_profile", 3, 36, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
    {"mirror2.sag_cos2", "mirror2_profile", 4, 37, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
    {"mirror2.sag_sin2", "mirror2_profile", 5, 38, U::kMillimetre, 0.02,       0.5,       true,  0, V::kNone,           false, F::kAny,          R::kPlain,        kProfileHint},
}};
// clang-format on

constexpr bool Same(const char* x, const char* y) {
  while (*x && *x == *y) ++x, ++y;
  return *x == *y;
}

// The table agrees with kRigBlocks: the blocks follow each other in the flat order, each holds
// its parameters in order at its offset; only the distortion's radial coefficients have a radial
// power, and a model file checks only values it reads one key at a time (camera, design).
constexpr bool TableMatchesBlocks() {
  int i = 0;
  for (int id = 0; id < kRigBlockCount; ++id) {
    const RigBlock& b = kRigBlocks[id];
    if (b.offset != i) return false;
    for (int k = 0; k < b.size; ++k, ++i) {
      const RigParameter& p = kTable[i];
      if (p.index != k || p.flat != b.offset + k || !Same(p.block, b.name)) return false;
      if (p.radial_power != 0 && id != kDistortionBlock) return false;
      if (p.file_check != FileCheck::kAny && id != kCameraBlock && id != kShape1Block &&
          id != kShape2Block) {
        return false;
      }
    }
  }
  return i == kRigParameterCount;
}
static_assert(TableMatchesBlocks(), "kTable and kRigBlocks disagree");

// The named coordinates (rig_blocks.h) are the table's: each constant indexes its name.
constexpr bool Names(RigBlockId block, int index, const char* name) {
  return Same(kTable[kRigBlocks[block].offset + index].name, name);
}
static_assert(Names(kCameraBlock, kFx, "fx") && Names(kCameraBlock, kFy, "fy") &&
              Names(kCameraBlock, kCx, "cx") && Names(kCameraBlock, kCy, "cy") &&
              Names(kCameraBlock, kSkew, "skew"));
static_assert(Names(kDistortionBlock, kDistK1, "dist_k1") &&
              Names(kDistortionBlock, kDistK2, "dist_k2") &&
              Names(kDistortionBlock, kDistP1, "dist_p1") &&
              Names(kDistortionBlock, kDistP2, "dist_p2") &&
              Names(kDistortionBlock, kDistK3, "dist_k3"));
static_assert(Names(kShape1Block, kShapeC, "c1") && Names(kShape1Block, kShapeK, "k1") &&
              Names(kShape2Block, kShapeC, "c2") && Names(kShape2Block, kShapeK, "k2"));
static_assert(Names(kPose1Block, kRx, "mirror1.rx") && Names(kPose1Block, kRy, "mirror1.ry") &&
              Names(kPose1Block, kTx, "mirror1.tx") && Names(kPose1Block, kTy, "mirror1.ty") &&
              Names(kPose1Block, kTz, "mirror1.tz") && Names(kPose2Block, kRx, "mirror2.rx") &&
              Names(kPose2Block, kTz, "mirror2.tz"));
static_assert(Names(kReflexBlock, kReflexRx, "reflex.rx") &&
              Names(kReflexBlock, kReflexRy, "reflex.ry") &&
              Names(kReflexBlock, kReflexDz, "reflex.dz"));
static_assert(Names(kProfile1Block, kSagP1, "mirror1.sag_p1") &&
              Names(kProfile1Block, kSagP4, "mirror1.sag_p4") &&
              Names(kProfile1Block, kSagCos2, "mirror1.sag_cos2") &&
              Names(kProfile2Block, kSagSin2, "mirror2.sag_sin2"));

}  // namespace

std::string RigParameter::Key() const {
  const std::string full = name;
  const size_t dot = full.find('.');
  return dot == std::string::npos ? full : full.substr(dot + 1);
}

const std::array<RigParameter, kRigParameterCount>& RigParameterTable() { return kTable; }

const RigParameter* FindRigParameter(const std::string& name) {
  static const std::map<std::string, const RigParameter*> by_name = [] {
    std::map<std::string, const RigParameter*> m;
    for (const RigParameter& p : kTable) {
      m[p.name] = &p;
      // A model file's spellings: a map the value is (or was) written under, then its key.
      for (const char* map : kRigBlocks[BlockOf(p)].spelled_under) {
        if (map) m[std::string(map) + "." + p.Key()] = &p;
      }
    }
    // A single-mirror rig's conic (ParameterName).
    for (int i = 0; i < kRigBlocks[kShape1Block].size; ++i) {
      const RigParameter& p = kTable[kRigBlocks[kShape1Block].offset + i];
      m[ParameterName(p, RigKind::kSingle)] = &p;
    }
    return m;
  }();
  const auto it = by_name.find(name);
  return it == by_name.end() ? nullptr : it->second;
}

std::string ParameterName(const RigParameter& p, RigKind rig) {
  if (rig == RigKind::kSingle && BlockOf(p) == kShape1Block) {
    return p.index == kShapeC ? "mirror1.R" : "mirror1.K";
  }
  return p.name;
}

const char* ParameterHint(const RigParameter& p, RigKind rig) {
  if (rig == RigKind::kSingle) {
    if (p.hint == kCameraHint) return kSingleCameraHint;
    if (p.hint == kDistortionHint) return kSingleDistortionHint;
  }
  return p.hint;
}

const RigBlock* FindRigBlock(const std::string& name) {
  for (const RigBlock& b : kRigBlocks) {
    if (name == b.name) return &b;
  }
  return nullptr;
}

const RigParameter* BlockParameters(RigBlockId block) { return &kTable[kRigBlocks[block].offset]; }

RigBlockId BlockOf(const RigParameter& p) {
  int id = 0;
  while (id + 1 < kRigBlockCount && kRigBlocks[id + 1].offset <= p.flat) ++id;
  return static_cast<RigBlockId>(id);
}

const char* GroupOf(const RigParameter& p) { return kRigBlocks[BlockOf(p)].group; }

const std::vector<std::string>& BlockParameterNames(const std::string& block) {
  static const std::map<std::string, std::vector<std::string>> names = [] {
    std::map<std::string, std::vector<std::string>> m;
    for (const RigParameter& p : kTable) m[p.block].push_back(p.name);
    return m;
  }();
  static const std::vector<std::string> none;
  const auto it = names.find(block);
  return it == names.end() ? none : it->second;
}

const std::vector<std::string>& DefaultEstimateBlocks() {
  static const std::vector<std::string> blocks = [] {
    std::vector<std::string> out;
    for (const RigBlock& b : kRigBlocks) {
      if (b.estimated) out.push_back(b.name);
    }
    return out;
  }();
  return blocks;
}

const double* BlockIn(const RigParams& rig, RigBlockId block) { return RigBlocksOf(rig)[block]; }

double* BlockIn(RigParams* rig, RigBlockId block) {
  return const_cast<double*>(BlockIn(static_cast<const RigParams&>(*rig), block));
}

const double* BlockIn(const RigParams& rig, const std::string& block) {
  for (int id = 0; id < kRigBlockCount; ++id) {
    if (block == kRigBlocks[id].name) return BlockIn(rig, static_cast<RigBlockId>(id));
  }
  return nullptr;
}

double* BlockIn(RigParams* rig, const std::string& block) {
  return const_cast<double*>(BlockIn(static_cast<const RigParams&>(*rig), block));
}

const double* ParameterOf(const RigParams& rig, const std::string& name) {
  const RigParameter* p = FindRigParameter(name);
  return p ? BlockIn(rig, BlockOf(*p)) + p->index : nullptr;
}

double* ParameterOf(RigParams* rig, const std::string& name) {
  return const_cast<double*>(ParameterOf(static_cast<const RigParams&>(*rig), name));
}

int RadialPower(const std::string& name) {
  const RigParameter* p = FindRigParameter(name);
  return p ? p->radial_power : 0;
}

double DriftStep(ParameterUnit unit) {
  switch (unit) {
    case ParameterUnit::kPixel: return 0.02;
    case ParameterUnit::kRadian: return 2e-5;
    case ParameterUnit::kMillimetre: return 2e-3;
    case ParameterUnit::kNone: return 0;
  }
  return 0;
}

std::vector<const RigParameter*> ParametersWithRole(SolveRole role) {
  std::vector<const RigParameter*> out;
  for (const RigParameter& p : kTable) {
    if (p.role == role) out.push_back(&p);
  }
  return out;
}

double DisplayValue(const RigParameter& p, double value) {
  return p.unit == ParameterUnit::kRadian ? value / kRad : value;
}

const char* DisplayUnit(const RigParameter& p) {
  switch (p.unit) {
    case ParameterUnit::kPixel: return "px";
    case ParameterUnit::kNone: return "";
    case ParameterUnit::kMillimetre: return "mm";
    case ParameterUnit::kRadian: return "deg";
  }
  return "";
}

}  // namespace omni
