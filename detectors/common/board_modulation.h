// How much of a chessboard's contrast survives a Gaussian blur: the pattern's modulation, for
// deciding whether its corners are readable at all (bench/eval_detectors' "readable" count).
// A chessboard is the product of two square waves (period two squares, along each of its lines'
// directions); a Gaussian blur is separable, so the blurred pattern's extreme, at a square's
// centre, is the product of the two blurred square waves' values there. Relative to the sharp
// pattern's (max - min), the blurred one keeps
//   M = g(s1 / sigma) g(s2 / sigma),  g(x) = sum_n (-1)^n [Phi((n + 1/2) x) - Phi((n - 1/2) x)],
// with s1, s2 the local square sides in pixels (perspective: each line direction's own) and sigma
// the blur in the same pixels. For small squares the fundamental dominates:
// g ~ (4 / pi) exp(-pi^2 sigma^2 / (2 s^2)), e.g. 2.6 px of blur on 7 / 5.6 / 3.8 px squares
// keeps 41% / 19% / 1.6%.
#pragma once

namespace omni::detectors {

// M above (0..1); 1 for sigma <= 0. Squares in pixels (> 0).
double ChessboardModulation(double square1_px, double square2_px, double blur_sigma_px);

}  // namespace omni::detectors
