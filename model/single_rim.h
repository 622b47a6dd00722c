// A single-mirror rig's rim (RigParams::Single): the circle of radius r_sys where its conic ends,
// the mark the photos show of it (detectors/lips/rim_edge.h) and the calibration's observation
// of it (calib/lip_cost.h: path direct, mirror 1's r_outer circle).
#pragma once

#include "model/conic.h"
#include "model/rig_params.h"

namespace omni {

// The rim circle's height in mirror 1's body frame at the rig's current conic: the sag at r_sys
// above the vertex (MakeSingleRig's lip1.z at its own conic).
inline double SingleRimZ(const RigParams& rig) {
  const Conic<double> conic{rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeK]};
  return rig.vertex_z + conic.Sag(rig.r_sys * rig.r_sys);
}

}  // namespace omni
