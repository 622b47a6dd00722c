// The rig's 39 parameters in one table: the names of
// docs/design.md's Conventions, the block each lives in (RigParams' arrays, the groups a
// session's `estimate` names) and its index there, its place in the flat vector, its internal
// unit, the sigma beyond which calibration calls it nearly unobservable, the value beyond any
// assembly error, whether a session may hold it with an assumed sigma, a radial coefficient's
// power, its part in the camera-rotation valley, whether the in-field check lets it drift, what a
// model file requires of it, its role in the solve (SolveRole) and the data that would determine
// it. The blocks (kRigBlocks) carry
// their coarse group, the map a model file holds them in and the session's priors and default
// estimate. Calibration, covariance, triangulation, the model and session files, the tolerance
// check, the result tables and the health checks read it.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "model/rig_params.h"
#include "model/types.h"

namespace omni {

enum class ParameterUnit { kPixel, kNone, kMillimetre, kRadian };

// Where a parameter sits in the camera-rotation valley: turning the camera against the mirror
// bodies moves the principal point together with every tilt (a mirror's, the reflex plane's) and
// every lateral shift of a mirror, so those correlate near +-1 and are not told apart.
enum class RotationValley { kNone, kPrincipalPoint, kTilt, kLateralShift };

// What a model file requires of the value (beyond a finite number).
enum class FileCheck { kAny, kPositive, kHyperboloidK };  // -, > 0, > 2 (a hyperboloid's k)

// What the calibration does with a parameter beyond refining it with its block (calib/).
enum class SolveRole {
  kPlain,
  kSkew,         // held unless CalibrationOptions::refine_skew
  kTangential,   // held (and considered) unless refine_tangential
  kHighRadial,   // the highest radial term: held unless the session's radii tell it from the lower
  kAxialScale,   // scales a ring's image as a mirror profile's power term does: traded with it
};

// A parameter block of RigParams, in the flat order.
struct RigBlock {
  const char* name;     // "camera", "distortion", "mirror1_shape", ... (a session's `estimate`)
  int size;
  int offset;           // of its first parameter in the flat vector
  // The coarse group its parameters belong to: camera | distortion | mirror1 | mirror2 | reflex
  // (a body's shape, pose and profile are that body's; the in-field check's groups, health/drift.h,
  // and the projection-error shares, calib/projection_uncertainty.h).
  const char* group;
  // The map that holds its parameters in a model file, each under its RigParameter::Key().
  const char* section;
  // The maps under which a model file's `calibration.parameters` may also spell a parameter
  // (map + "." + key, older files): camera.fx, camera.distortion.dist_k1, mirror1.c1, ...
  std::array<const char*, 3> spelled_under;
  bool prior;           // a session may give it a manufacturing prior (`priors:`)
  bool estimated;       // a calibration refines it unless its session says otherwise
};
// clang-format off
inline constexpr std::array<RigBlock, kRigBlockCount> kRigBlocks = {{
    // name             size offset group         section                    spelled_under                                   prior  estimated
    {"camera",          5,   0,     "camera",     "camera",                  {"camera"},                                     false, true},
    {"distortion",      5,   5,     "distortion", "camera.distortion",       {"camera", "distortion", "camera.distortion"},  false, true},
    {"mirror1_shape",   2,   10,    "mirror1",    "design",                  {"mirror1"},                                    true,  false},
    {"mirror2_shape",   2,   12,    "mirror2",    "design",                  {"mirror2"},                                    true,  false},
    {"mirror1_pose",    5,   14,    "mirror1",    "mirror1.cam_from_mirror", {},                                             false, true},
    {"mirror2_pose",    5,   19,    "mirror2",    "mirror2.cam_from_mirror", {},                                             false, true},
    {"reflex",          3,   24,    "reflex",     "mirror1.reflex",          {"mirror1.reflex"},                             false, true},
    {"mirror1_profile", 6,   27,    "mirror1",    "mirror1.profile",         {"mirror1.profile"},                            false, false},
    {"mirror2_profile", 6,   33,    "mirror2",    "mirror2.profile",         {"mirror2.profile"},                            false, false}}};
// clang-format on
inline constexpr int kRigParameterCount = 39;

// A block's first parameter in the flat vector, for code that indexes the flat vector.
constexpr int BlockOffset(RigBlockId block) { return kRigBlocks[block].offset; }

struct RigParameter {
  const char* name;   // docs/design.md, Conventions: "fx", "dist_k1", "c1", "mirror1.rx", "reflex.dz"
  const char* block;  // kRigBlocks' name
  int index;          // within the block
  int flat;           // within the flat vector
  ParameterUnit unit; // internal (tilts in rad; tables show deg)
  // Calibration names it nearly unobservable when its sigma exceeds this (internal units): far
  // beyond any assembly tolerance. 0 for the radial coefficients, whose bound depends on the
  // radii the session reaches (calib: kDistortionBoundPx, with radial_power below).
  double unobservable_sigma;
  double diverged_beyond;  // |value| past any assembly error: the solve diverged; 0: unchecked
  bool considerable;       // a session may hold it with an assumed sigma (`consider:`)
  // The radial coefficients' power of the normalised radius (dist_k1 r^3, dist_k2 r^5, dist_k3
  // r^7: the pixels a coefficient moves at radius r); 0 for the others.
  int radial_power;
  RotationValley valley;
  // A way the calibrated rig may move in the field (health/drift.h; its finite-difference step:
  // DriftStep(unit)).
  bool drift;
  FileCheck file_check;  // model files
  SolveRole role;
  const char* hint;        // the data that would determine it
  // Its key inside its block's map in a model file ("rx" of mirror1.cam_from_mirror).
  std::string Key() const;
};

const std::array<RigParameter, kRigParameterCount>& RigParameterTable();

// The parameter of that name, or of a model file's `calibration.parameters` spelling of it
// (camera.fx, camera.distortion.dist_k1, mirror1.c1, mirror2.k2, mirror1.reflex.rx); nullptr if
// there is none.
const RigParameter* FindRigParameter(const std::string& name);

// A parameter's name in a rig of that kind: p.name, except a single-mirror rig's shape block,
// its conic's vertex radius and conic constant (mirror1.R, mirror1.K; FindRigParameter finds
// them).
std::string ParameterName(const RigParameter& p, RigKind rig);

// The data that would determine p in a rig of that kind: p.hint, except where the hint speaks of
// two rings and a single-mirror rig has one (the camera's and the distortion's).
const char* ParameterHint(const RigParameter& p, RigKind rig);

// The block of that name; nullptr if there is none.
const RigBlock* FindRigBlock(const std::string& name);

// The block's parameters in block order.
const RigParameter* BlockParameters(RigBlockId block);
// A parameter's block and coarse group.
RigBlockId BlockOf(const RigParameter& p);
const char* GroupOf(const RigParameter& p);

// The names of a block's parameters in block order (empty for an unknown block).
const std::vector<std::string>& BlockParameterNames(const std::string& block);

// The groups a calibration refines unless its session says otherwise (RigBlock::estimated).
const std::vector<std::string>& DefaultEstimateBlocks();

// A block's array in `rig` (kRigBlocks' name; nullptr for an unknown one).
double* BlockIn(RigParams* rig, const std::string& block);
const double* BlockIn(const RigParams& rig, const std::string& block);
double* BlockIn(RigParams* rig, RigBlockId block);
const double* BlockIn(const RigParams& rig, RigBlockId block);

// The parameter `name` (FindRigParameter's spellings) in `rig`; nullptr if there is none.
double* ParameterOf(RigParams* rig, const std::string& name);
const double* ParameterOf(const RigParams& rig, const std::string& name);

// The radial coefficient's power of the radius (RigParameter::radial_power) of the parameter of
// that name; 0 for another or an unknown name.
int RadialPower(const std::string& name);

// The finite-difference step of a drift coordinate in that unit (health/drift.h): about 1% of a
// typical knock (0.02 px, 2e-5 rad ~ 0.001 deg, 2e-3 mm).
double DriftStep(ParameterUnit unit);

// The parameters of that role, in table order.
std::vector<const RigParameter*> ParametersWithRole(SolveRole role);

// A value in its table unit ("px", "", "mm", "deg": tilts converted from rad).
double DisplayValue(const RigParameter& p, double value);
const char* DisplayUnit(const RigParameter& p);

}  // namespace omni
