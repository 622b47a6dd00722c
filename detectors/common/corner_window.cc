#include "detectors/common/corner_window.h"

#include <algorithm>
#include <cmath>

namespace omni::detectors {

double CameraPixelsPerDegree(const RigParams& rig) {
  return 0.5 * (rig.camera[kFx] + rig.camera[kFy]) * M_PI / 180.0;
}

int ChessboardHalfWindow(double square_side_px, double camera_px_per_deg) {
  if (square_side_px < 3.0) return 1;
  const int cap = std::max(kChessboardMinCapPx,
                           static_cast<int>(std::lround(kChessboardMaxHalfDeg * camera_px_per_deg)));
  return std::clamp(static_cast<int>(std::lround(kChessboardHalfSquares * square_side_px)), 2, cap);
}

int TagCornerHalfWindow(double tag_side_px) { return static_cast<int>(std::lround(0.15 * tag_side_px)); }

double XJunctionProbe(double tag_side_px) { return std::max(1.5, 0.12 * tag_side_px); }

}  // namespace omni::detectors
