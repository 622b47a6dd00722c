// Reading and writing `omnistereo-model/1` YAML files (tests/data/model_example.yaml).
// I/O is kept apart from the geometry: model/ never includes this.
#pragma once

#include <stdexcept>
#include <string>

#include <Eigen/Core>

#include "io/file_util.h"  // InputError, AtomicFile
#include "model/model_derived.h"
#include "model/rig_params.h"

namespace omni::io {

// Reads a model file; throws InputError (missing file, malformed YAML, unknown major version,
// missing key, non-finite number, k <= 2, c <= 0, ...) with the one line
// "<file>: <key path, e.g. design.k1>: <what was expected>, got <what>".
// Accepts `format: omnistereo-model/1` and any 1.x; every key of the format example is required
// except `units` (if present: mm, rad), `derived` (ignored) and `calibration`. Unknown keys are
// ignored (newer minor versions add keys). Tilts may be given in degrees as rx_deg / ry_deg.
RigParams ReadModelFile(const std::string& path);

// Writes a model file atomically (temporary file in the same folder, then rename), including the
// `derived:` section and, if present, `calibration:`. Numbers at full double precision.
// Throws std::runtime_error if the file cannot be written (missing or read-only folder) or if
// the rig would not read back (non-finite number, k <= 2, calibration arrays of wrong length);
// never leaves a partial or temporary file, and a failed write leaves an existing file untouched.
void WriteModelFile(const std::string& path, const RigParams& rig);

// Writes text to path atomically (temp file + rename); throws std::runtime_error on failure.
void WriteFileAtomically(const std::string& path, const std::string& contents);

// The text WriteModelFile writes (header comments, flow maps as in the format example, numbers
// as the shortest text that reads back bit-for-bit). Does not validate: WriteModelFile parses
// this text back and refuses (std::runtime_error) a rig the reader would reject.
std::string ModelFileText(const RigParams& rig);

// Parses model-file text; `file` names the source in error messages. Throws InputError.
RigParams ParseModelText(const std::string& text, const std::string& file);


}  // namespace omni::io
