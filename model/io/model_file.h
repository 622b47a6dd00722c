// Reading and writing `omnistereo-model/1` YAML files (shared/formats/model_example.yaml).
// I/O is kept apart from the geometry: model/ never includes this.
#pragma once

#include <stdexcept>
#include <string>

#include "model/rig_params.h"

namespace omni::io {

// Thrown for unreadable or invalid input files; what() names the file and the key and says
// what was expected, ready to print as the one line a user sees.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Reads a model file; throws InputError (missing file, malformed YAML, unknown major version,
// missing key, non-finite number, k <= 2, c <= 0, ...).
RigParams ReadModelFile(const std::string& path);

// Writes a model file atomically (temporary file in the same folder, then rename), including the
// `derived:` section and, if present, `calibration:`. Numbers at full double precision.
// Throws std::runtime_error if the file cannot be written; never leaves a partial file.
void WriteModelFile(const std::string& path, const RigParams& rig);

// Writes text to path atomically (temp file + rename); throws std::runtime_error on failure.
void WriteFileAtomically(const std::string& path, const std::string& contents);

}  // namespace omni::io
