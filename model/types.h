// Small shared types of the geometry library: Eigen vectors templated on the scalar, rays.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace omni {

template <typename T>
using Vec2 = Eigen::Matrix<T, 2, 1>;
template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Mat3 = Eigen::Matrix<T, 3, 3>;

// Which optical path a pixel or projection belongs to. Mirror 1 forms the OUTER image ring (seen
// directly); mirror 2 the INNER ring (seen through the reflex mirror).
enum class Mirror { kOne = 1, kTwo = 2 };

inline int MirrorIndex(Mirror m) { return static_cast<int>(m); }

// The rig's optical layout (docs/design.md, The rig): the folded omnistereo rig (camera, two
// hyperboloidal mirrors and the reflex disc: two rings), or a SINGLE-mirror catadioptric camera
// (the camera looking straight at one mirror of any conic: ring 1 only, no reflex, no mirror 2).
enum class RigKind { kFolded, kSingle };
const char* RigKindName(RigKind kind);

// The camera's lens: perspective (a pinhole: u = fx x/z + ...) or telecentric (orthographic:
// u = fx x + ... with x in mm, fx in px per mm; every camera ray parallel to the axis), which
// parabolic mirrors are built with.
enum class LensKind { kPerspective, kTelecentric };
const char* LensKindName(LensKind lens);

// A back-projected ray in the camera frame C: points origin + s * direction, s > 0, direction unit.
// For a central (ideal) model the origin is the mirror's primary focus; for a non-central model it
// is the reflection point on the mirror.
struct Ray {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
};

}  // namespace omni
