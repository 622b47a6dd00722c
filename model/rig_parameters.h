// The rig's 39 parameters in one table (issue 18; each mirror's profile, issue 40): the names of docs/design.md's Conventions, the block each lives in
// (RigParams' arrays, the groups a session's `estimate` names) and its index there, its place in
// the flat vector, its internal unit, the sigma beyond which calibration calls it nearly
// unobservable, the value beyond any assembly error, whether a session may hold it with an
// assumed sigma, and the data that would determine it. Calibration, covariance, triangulation,
// the model and session files and the result tables read it; no other file spells a name.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "model/rig_params.h"

namespace omni {

enum class ParameterUnit { kPixel, kNone, kMillimetre, kRadian };

// A parameter block of RigParams, in the flat order.
struct RigBlock {
  const char* name;  // "camera", "distortion", "mirror1_shape", ... (a session's `estimate`)
  int size;
  int offset;        // of its first parameter in the flat vector
};
inline constexpr std::array<RigBlock, 9> kRigBlocks = {{{"camera", 5, 0},
                                                        {"distortion", 5, 5},
                                                        {"mirror1_shape", 2, 10},
                                                        {"mirror2_shape", 2, 12},
                                                        {"mirror1_pose", 5, 14},
                                                        {"mirror2_pose", 5, 19},
                                                        {"reflex", 3, 24},
                                                        {"mirror1_profile", 6, 27},
                                                        {"mirror2_profile", 6, 33}}};
inline constexpr int kRigParameterCount = 39;
// Flat offsets by block (kRigBlocks' order), for code that indexes the flat vector.
inline constexpr int kCameraOffset = 0, kDistortionOffset = 5, kShape1Offset = 10,
                     kShape2Offset = 12, kPose1Offset = 14, kPose2Offset = 19, kReflexOffset = 24,
                     kProfile1Offset = 27, kProfile2Offset = 33;

struct RigParameter {
  const char* name;   // docs/design.md, Conventions: "fx", "dist_k1", "c1", "mirror1.rx", "reflex.dz"
  const char* block;  // kRigBlocks' name
  int index;          // within the block
  int flat;           // within the flat vector
  ParameterUnit unit; // internal (tilts in rad; tables show deg)
  // Calibration names it nearly unobservable when its sigma exceeds this (internal units): far
  // beyond any assembly tolerance. 0 for the radial coefficients, whose bound depends on the
  // radii the session reaches (calib: kDistortionBoundPx).
  double unobservable_sigma;
  double diverged_beyond;  // |value| past any assembly error: the solve diverged; 0: unchecked
  bool considerable;       // a session may hold it with an assumed sigma (`consider:`)
  const char* hint;        // the data that would determine it
  // Its key inside its block's map in a model file ("rx" of mirror1.cam_from_mirror).
  std::string Key() const;
};

const std::array<RigParameter, kRigParameterCount>& RigParameterTable();

// The parameter of that name, or of a model file's `calibration.parameters` spelling of it
// (camera.fx, camera.distortion.dist_k1, mirror1.c1, mirror2.k2, mirror1.reflex.rx); nullptr if
// there is none.
const RigParameter* FindRigParameter(const std::string& name);

// The block of that name; nullptr if there is none.
const RigBlock* FindRigBlock(const std::string& name);

// The names of a block's parameters in block order (empty for an unknown block).
const std::vector<std::string>& BlockParameterNames(const std::string& block);

// The groups a calibration refines unless its session says otherwise.
const std::vector<std::string>& DefaultEstimateBlocks();

// A block's array in `rig` (kRigBlocks' name; nullptr for an unknown one).
double* BlockIn(RigParams* rig, const std::string& block);
const double* BlockIn(const RigParams& rig, const std::string& block);

// The parameter `name` (FindRigParameter's spellings) in `rig`; nullptr if there is none.
double* ParameterOf(RigParams* rig, const std::string& name);
const double* ParameterOf(const RigParams& rig, const std::string& name);

// A value in its table unit ("px", "", "mm", "deg": tilts converted from rad).
double DisplayValue(const RigParameter& p, double value);
const char* DisplayUnit(const RigParameter& p);

}  // namespace omni
