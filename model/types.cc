#include "model/types.h"

namespace omni {

const char* RigKindName(RigKind kind) { return kind == RigKind::kFolded ? "folded" : "single"; }

const char* LensKindName(LensKind lens) {
  return lens == LensKind::kPerspective ? "perspective" : "telecentric";
}

}  // namespace omni
