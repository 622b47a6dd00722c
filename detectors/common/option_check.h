// The detector options' Check() messages (the project's options convention: empty, or
// "<field>: expected <what>, got <value>").
#pragma once

#include <string>

namespace omni::detectors {

// "<field>: expected <what>, got <value>" (value as %g).
std::string OptionError(const std::string& field, const std::string& expected, double got);

// `inner` (a nested options struct's Check()) with `prefix` before its field name; empty if it is.
std::string NestedOptionError(const std::string& prefix, const std::string& inner);

}  // namespace omni::detectors
