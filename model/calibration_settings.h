// Settings of the calibration's solve that a session file carries (io/session_file.h reads
// them, calib/calibrate.h uses them): kept here so that neither depends on the other.
#pragma once

#include <string>

namespace omni {

// A Gaussian prior on a refined mirror shape (session `priors: {mirror1_shape: {...}}`).
struct ShapePrior {
  double sigma_c = 0.0;  // mm, on c1 or c2
  double sigma_k = 0.0;  // unitless, on k1 or k2
};

// The solve's limits, robust loss and outlier rejection (session `solver:`).
struct SolverOptions {
  int max_iterations = 100;
  std::string loss = "huber";  // huber | cauchy | none
  double loss_scale_px = 1.0;
  double outlier_px = 3.0;     // reject observations whose residual norm exceeds this
  int threads = 2;
};

}  // namespace omni
