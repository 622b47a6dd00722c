#include "detectors/common/board_modulation.h"

#include <algorithm>
#include <cmath>

namespace omni::detectors {
namespace {

double Phi(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

// The blurred unit square wave (+1 on the square |t| < s / 2, alternating) at the square's
// centre, x = s / sigma. The terms fall as exp(-(n x)^2 / 2): 40 squares each side are plenty
// for x >= 0.1 (below that the value is ~0 anyway).
double BlurredSquareWaveAtCentre(double x) {
  double g = 0;
  for (int n = -40; n <= 40; ++n) {
    g += (n % 2 == 0 ? 1 : -1) * (Phi((n + 0.5) * x) - Phi((n - 0.5) * x));
  }
  return std::clamp(g, 0.0, 1.0);
}

}  // namespace

double ChessboardModulation(double square1_px, double square2_px, double blur_sigma_px) {
  if (!(blur_sigma_px > 0)) return 1;
  return BlurredSquareWaveAtCentre(square1_px / blur_sigma_px) *
         BlurredSquareWaveAtCentre(square2_px / blur_sigma_px);
}

}  // namespace omni::detectors
