// The truth file `omnistereo-truth/1` of a synthetic session (model/truth.h), as `render` writes
// it (synthetic/scene_file.h TruthText).
#pragma once

#include <string>
#include <vector>

#include "model/truth.h"

namespace omni::io {

// Throws InputError naming the file and key.
Truth ReadTruthFile(const std::string& path);

// A reference table (model/truth.h ReferenceRow): a CSV with columns range_m, rmse_mm, sd_mm
// (others skipped); empty for an empty path. Throws InputError naming the file and line.
std::vector<ReferenceRow> ReadReferenceTable(const std::string& path);

}  // namespace omni::io
