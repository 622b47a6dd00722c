// Automatic differentiation with Jet slots only for the coordinates that need a derivative.
//
// ceres::AutoDiffCostFunction gives every coordinate of every parameter block a slot of the Jet,
// so a residual over 31 coordinates carries 31 derivatives through the reflection solve even
// when the stage holds most of them constant. Here a Jet slot is spent only on a coordinate
//  - of a block Ceres asks a Jacobian for (constant blocks get a null jacobians[i]),
//  - that the residual depends on differentiably (`no_derivative`: blocks that only decide
//    validity, like the reflex plane on mirror 1's path, or that a lip path does not use),
//  - and that the solver does not hold (`held`: coordinates a SubsetManifold keeps at their
//    value in the solve the cost is built for; a cost for another use, e.g. the covariance's
//    considered columns, is built with none held).
// Jacobian columns without a slot are written as zeros: exact for `no_derivative`, and for
// `held` ones Ceres multiplies them by a zero column of the manifold's plus-Jacobian anyway.
// The Jet size is picked per evaluation from a few compiled sizes (the smallest that fits).
// The functor's templated operator() takes the blocks as an array, as
// ceres::DynamicAutoDiffCostFunction's does: (T const* const* blocks, T* residuals).
#pragma once

#include <ceres/jet.h>
#include <ceres/sized_cost_function.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <utility>

namespace omni::calib {

template <typename Functor, int kNumResiduals, int... kBlockSizes>
class SlotAutoDiffCostFunction final
    : public ceres::SizedCostFunction<kNumResiduals, kBlockSizes...> {
 public:
  static constexpr int kNumBlocks = sizeof...(kBlockSizes);
  static constexpr int kMaxSlots = (kBlockSizes + ...);
  using Masks = std::array<uint32_t, kNumBlocks>;          // bit k: coordinate k of the block

  SlotAutoDiffCostFunction(Functor functor, const Masks& no_derivative, const Masks& held)
      : functor_(std::move(functor)), no_derivative_(no_derivative), held_(held) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    if (!jacobians) return functor_(parameters, residuals);
    Masks active{};
    int n_active = 0;
    for (int i = 0; i < kNumBlocks; ++i) {
      if (!jacobians[i]) continue;
      const uint32_t all = (1u << kSizes[i]) - 1;
      active[i] = all & ~no_derivative_[i] & ~held_[i];
      n_active += __builtin_popcount(active[i]);
    }
    if (n_active <= 4) return EvaluateJet<4>(parameters, residuals, jacobians, active);
    if (n_active <= 8) return EvaluateJet<8>(parameters, residuals, jacobians, active);
    if (n_active <= 12) return EvaluateJet<12>(parameters, residuals, jacobians, active);
    if (n_active <= 16) return EvaluateJet<16>(parameters, residuals, jacobians, active);
    if (n_active <= 20) return EvaluateJet<20>(parameters, residuals, jacobians, active);
    if (n_active <= 24) return EvaluateJet<24>(parameters, residuals, jacobians, active);
    return EvaluateJet<kMaxSlots>(parameters, residuals, jacobians, active);
  }

  const Functor& functor() const { return functor_; }

 private:
  static constexpr int kSizes[kNumBlocks] = {kBlockSizes...};
  static constexpr int kMaxBlockSize = std::max({kBlockSizes...});

  template <int N>
  bool EvaluateJet(double const* const* parameters, double* residuals, double** jacobians,
                   const Masks& active) const {
    if constexpr (N > kMaxSlots) {
      return EvaluateJet<kMaxSlots>(parameters, residuals, jacobians, active);
    } else {
      using Jet = ceres::Jet<double, N>;
      Jet storage[kNumBlocks][kMaxBlockSize];
      const Jet* blocks[kNumBlocks];
      int slot = 0;
      for (int i = 0; i < kNumBlocks; ++i) {
        for (int k = 0; k < kSizes[i]; ++k) {
          storage[i][k] = Jet(parameters[i][k]);
          if (active[i] >> k & 1u) storage[i][k].v[slot++] = 1.0;
        }
        blocks[i] = storage[i];
      }
      Jet out[kNumResiduals];
      if (!functor_(blocks, out)) return false;
      for (int r = 0; r < kNumResiduals; ++r) residuals[r] = out[r].a;
      slot = 0;
      for (int i = 0; i < kNumBlocks; ++i) {
        if (!jacobians[i]) continue;
        for (int k = 0; k < kSizes[i]; ++k) {
          const bool has_slot = active[i] >> k & 1u;
          for (int r = 0; r < kNumResiduals; ++r) {
            jacobians[i][r * kSizes[i] + k] = has_slot ? out[r].v[slot] : 0.0;
          }
          slot += has_slot;
        }
      }
      return true;
    }
  }

  Functor functor_;
  Masks no_derivative_;
  Masks held_;
};

}  // namespace omni::calib
