// A cost's rig blocks: each cost over the rig names the blocks it reads ONCE, as a constexpr list
// of RigBlockIds in the order of its parameter list (then its nuisance blocks: a target pose, a
// lip azimuth). Its Ceres block sizes, the RigBlocks bundle it hands the optical path, its
// no-derivative and held masks and the parameter blocks it is wired to are all derived from that
// list here.
#pragma once

#include <array>
#include <cstdint>
#include <utility>

#include "calib/slot_autodiff.h"
#include "model/rig_parameters.h"
#include "model/rig_params.h"

namespace omni::calib {

// Per rig block (indexed by RigBlockId), a mask of its coordinates (bit k: coordinate k).
using BlockMasks = std::array<uint32_t, kRigBlockCount>;

// Every coordinate of a block.
constexpr uint32_t AllCoordinates(RigBlockId block) { return (1u << kRigBlocks[block].size) - 1; }

// The masks of every coordinate of the blocks outside `differentiable`: blocks that only decide
// validity (or that a path does not read), which get no Jet slot.
constexpr BlockMasks NoDerivativeOutside(RigBlockSet differentiable) {
  BlockMasks m{};
  for (int b = 0; b < kRigBlockCount; ++b) {
    if (!differentiable[b]) m[b] = AllCoordinates(static_cast<RigBlockId>(b));
  }
  return m;
}

// The masks of `by_block` in the order of a cost's list, followed by 0 for its nuisance blocks
// (N >= list size).
template <size_t N, size_t L>
std::array<uint32_t, N> InListOrder(const std::array<RigBlockId, L>& list,
                                    const BlockMasks& by_block) {
  static_assert(N >= L);
  std::array<uint32_t, N> out{};
  for (size_t i = 0; i < L; ++i) out[i] = by_block[list[i]];
  return out;
}

// The rig's parameter blocks of a cost's list, in its order, followed by the nuisance blocks.
template <size_t L, typename... Extra>
std::array<double*, L + sizeof...(Extra)> ParameterBlocks(const std::array<RigBlockId, L>& list,
                                                          RigParams* rig, Extra*... extra) {
  std::array<double*, L + sizeof...(Extra)> out{};
  for (size_t i = 0; i < L; ++i) out[i] = BlockIn(rig, list[i]);
  size_t i = L;
  ((out[i++] = extra), ...);
  return out;
}

// The SlotAutoDiffCostFunction of a functor over its rig blocks Functor::kBlocks (their sizes
// from the parameter table), then nuisance blocks of sizes kExtra...
template <typename Functor, int kNumResiduals, typename Seq, int... kExtra>
struct RigSlotCostOf;
template <typename Functor, int kNumResiduals, size_t... I, int... kExtra>
struct RigSlotCostOf<Functor, kNumResiduals, std::index_sequence<I...>, kExtra...> {
  using type = SlotAutoDiffCostFunction<Functor, kNumResiduals,
                                        kRigBlocks[Functor::kBlocks[I]].size..., kExtra...>;
};
template <typename Functor, int kNumResiduals, int... kExtra>
using RigSlotCost =
    typename RigSlotCostOf<Functor, kNumResiduals,
                           std::make_index_sequence<Functor::kBlocks.size()>, kExtra...>::type;

}  // namespace omni::calib
