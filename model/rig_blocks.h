// The rig's parameter blocks by id, and the coordinates inside each block by name: what every
// file that reads a block uses instead of positions (the blocks' sizes, names and the parameter
// table: rig_parameters.h; the storage: RigParams, rig_params.h).
#pragma once

#include <bitset>
#include <initializer_list>

#include "model/types.h"

namespace omni {

// The parameter blocks (model/rig_parameters.h's kRigBlocks holds them in this order: the flat
// order of the parameter table).
enum RigBlockId : int {
  kCameraBlock,
  kDistortionBlock,
  kShape1Block,
  kShape2Block,
  kPose1Block,
  kPose2Block,
  kReflexBlock,
  kProfile1Block,
  kProfile2Block,
  kRigBlockCount
};

// Each mirror's blocks.
constexpr RigBlockId ShapeBlock(Mirror m) { return m == Mirror::kOne ? kShape1Block : kShape2Block; }
constexpr RigBlockId PoseBlock(Mirror m) { return m == Mirror::kOne ? kPose1Block : kPose2Block; }
constexpr RigBlockId ProfileBlock(Mirror m) {
  return m == Mirror::kOne ? kProfile1Block : kProfile2Block;
}

// A set of parameter blocks (bit RigBlockId): the groups a solve refines, the blocks a path uses.
using RigBlockSet = std::bitset<kRigBlockCount>;
constexpr RigBlockSet BlockSetOf(std::initializer_list<RigBlockId> ids) {
  unsigned long long bits = 0;
  for (RigBlockId id : ids) bits |= 1ull << id;
  return RigBlockSet(bits);
}

// The coordinates inside each block, named as the parameter table names them (docs/design.md,
// Conventions; rig_parameters.cc checks that they agree).
enum CameraCoordinate : int { kFx, kFy, kCx, kCy, kSkew };
enum DistortionCoordinate : int { kDistK1, kDistK2, kDistP1, kDistP2, kDistK3 };
// A mirror's shape: c1, k1 (mirror 1) or c2, k2 (mirror 2).
enum ShapeCoordinate : int { kShapeC, kShapeK };
// A mirror's pose cam_from_mirror: tilt rx, ry (rad), shift tx, ty, tz (mm).
enum PoseCoordinate : int { kRx, kRy, kTx, kTy, kTz };
// The reflex plane in mirror 1's body: tilt rx, ry (rad), axial shift dz (mm).
enum ReflexCoordinate : int { kReflexRx, kReflexRy, kReflexDz };
// A mirror's profile correction (mirror_profile.h), mm.
enum ProfileCoordinate : int { kSagP1, kSagP2, kSagP3, kSagP4, kSagCos2, kSagSin2 };

}  // namespace omni
