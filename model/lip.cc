#include "model/lip.h"

namespace omni {

const char* LipPathName(LipPath path) {
  switch (path) {
    case LipPath::kDirect: return "direct";
    case LipPath::kViaMirror1: return "via_mirror1";
    case LipPath::kViaReflex: return "via_reflex";
    case LipPath::kViaMirror2: return "via_mirror2";
  }
  return "?";
}

bool ParseLipPath(const std::string& name, LipPath* path) {
  for (LipPath p : {LipPath::kDirect, LipPath::kViaMirror1, LipPath::kViaReflex,
                    LipPath::kViaMirror2}) {
    if (name == LipPathName(p)) {
      *path = p;
      return true;
    }
  }
  return false;
}

const char* LipCircleName(LipCircle circle) {
  return circle == LipCircle::kInner ? "r_inner" : "r_outer";
}

bool ParseLipCircle(const std::string& name, LipCircle* circle) {
  if (name == "r_inner") *circle = LipCircle::kInner;
  else if (name == "r_outer") *circle = LipCircle::kOuter;
  else return false;
  return true;
}

LipBlocks<double> LipBlocksOf(const RigParams& rig) {
  return LipBlocks<double>{rig.camera.data(),       rig.distortion.data(), rig.mirror1_shape.data(),
                           rig.mirror1_pose.data(), rig.reflex.data(),     rig.mirror2_shape.data(),
                           rig.mirror2_pose.data()};
}

const Lip& LipOf(const RigParams& rig, LipPath path) {
  return LipOwner(path) == Mirror::kOne ? rig.lip1 : rig.lip2;
}

std::optional<Eigen::Vector2d> ProjectLipPoint(const RigModel& model, LipPath path,
                                               LipCircle circle, double phi,
                                               double* disc_margin_mm) {
  const RigParams& rig = model.params();
  const Lip& lip = LipOf(rig, path);
  const double radius = circle == LipCircle::kInner ? lip.r_inner : lip.r_outer;
  Eigen::Vector2d pixel;
  if (!ProjectLipPoint(LipBlocksOf(rig), model.fixed(), path, radius, lip.z, phi, &pixel,
                       disc_margin_mm) ||
      !pixel.allFinite()) {
    return std::nullopt;
  }
  return pixel;
}

}  // namespace omni
