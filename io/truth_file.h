// The truth file `omnistereo-truth/1` of a synthetic session (model/truth.h), as `render` writes
// it (synthetic/scene_file.h TruthText).
#pragma once

#include <string>

#include "model/truth.h"

namespace omni::io {

// Throws InputError naming the file and key.
Truth ReadTruthFile(const std::string& path);

}  // namespace omni::io
