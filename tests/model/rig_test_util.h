// Rigs and grids shared by the non-central model tests.
#pragma once

#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "model/rig_model.h"
#include "model/rig_parameters.h"
#include "model/rig_params.h"
#include "tests/model/test_rigs.h"

namespace omni::testing {

constexpr double kRigDeg = M_PI / 180.0;

// Every parameter of `rig` as a constant of type T (e.g. a Jet), flat in the table's order.
template <typename T>
std::array<T, kRigParameterCount> FlatConstants(const RigParams& rig) {
  std::array<T, kRigParameterCount> x;
  for (int b = 0; b < kRigBlockCount; ++b) {
    const RigBlockId id = static_cast<RigBlockId>(b);
    for (int k = 0; k < kRigBlocks[id].size; ++k) x[BlockOffset(id) + k] = T(BlockIn(rig, id)[k]);
  }
  return x;
}
// The blocks over a flat parameter vector (FlatConstants).
template <typename T>
RigBlocks<T> BlocksOver(const std::array<T, kRigParameterCount>& x) {
  RigBlocks<T> blocks;
  for (int b = 0; b < kRigBlockCount; ++b) {
    blocks[static_cast<RigBlockId>(b)] = x.data() + BlockOffset(static_cast<RigBlockId>(b));
  }
  return blocks;
}

// The nominal big rig, r_cam = 7 mm, 1280 x 960.
inline RigParams BigRigParams() {
  return MakeIdealRig(BigRigDesign(), 7.0, DefaultCamera(), 1280, 960);
}

// The big rig with every pose (both mirrors and the reflex plane) misaligned by uniformly random
// tilts up to max_deg (each component) and translations up to max_mm; optionally a realistic
// lens distortion and a principal point off centre.
inline RigParams MisalignedBigRig(std::mt19937* rng, double max_mm, double max_deg,
                                  bool with_distortion) {
  RigParams rig = BigRigParams();
  rig.kind = ModelKind::kNoncentral;
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (auto* pose : {&rig.mirror1_pose, &rig.mirror2_pose}) {
    (*pose)[0] = u(*rng) * max_deg * kRigDeg;
    (*pose)[1] = u(*rng) * max_deg * kRigDeg;
    for (int i = 2; i < 5; ++i) (*pose)[i] = u(*rng) * max_mm;
  }
  rig.reflex = {u(*rng) * max_deg * kRigDeg, u(*rng) * max_deg * kRigDeg, u(*rng) * max_mm};
  if (with_distortion) {
    rig.camera[kCx] += 4.3 + u(*rng);
    rig.camera[kCy] -= 3.1 + u(*rng);
    rig.camera[kSkew] = 0.2 * u(*rng);
    rig.distortion = {-0.06 + 0.01 * u(*rng), 0.012, 2e-4 * u(*rng), -1.5e-4 * u(*rng), -0.002};
  }
  return rig;
}

// Pixel grid over the image with the given step (pixel centres, offset so that no sample sits
// exactly on the image centre).
inline std::vector<Eigen::Vector2d> PixelGrid(const RigParams& rig, double step) {
  std::vector<Eigen::Vector2d> pixels;
  for (double v = 0.37; v < rig.image_height; v += step) {
    for (double u = 0.21; u < rig.image_width; u += step) pixels.emplace_back(u, v);
  }
  return pixels;
}

}  // namespace omni::testing
