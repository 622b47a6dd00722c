#include "model/observations.h"

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

const char* BandEdgeName(BandEdge edge) { return edge == BandEdge::kInner ? "inner" : "outer"; }

bool ParseBandEdge(const std::string& name, BandEdge* edge) {
  if (name == "inner") *edge = BandEdge::kInner;
  else if (name == "outer") *edge = BandEdge::kOuter;
  else return false;
  return true;
}

}  // namespace omni
