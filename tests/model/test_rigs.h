// Rigs shared by the model tests: the paper's big and small rigs (tab:optimal_parameter_values).
#pragma once

#include "model/ideal_model.h"

namespace omni::testing {

// Published optimum of the big rig (the authors' values to more digits than the table).
inline DesignParams BigRigDesign() { return DesignParams{123.488, 241.803, 5.7319, 9.7443, 233.684, 37.0}; }
inline DesignParams SmallRigDesign() { return DesignParams{104.59, 204.34, 6.88, 11.47, 200.0, 28.0}; }
inline Pinhole<double> DefaultCamera() { return Pinhole<double>{1450.0, 1450.0, 639.5, 479.5, 0.0}; }
inline IdealModel BigRig(double r_cam = 7.0) {
  return MakeIdealModel(BigRigDesign(), r_cam, DefaultCamera());
}

}  // namespace omni::testing
