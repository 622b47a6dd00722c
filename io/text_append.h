// printf-style text appended to a string, for the reports the libraries build line by line
// (calib/monte_carlo.h, detectors/detector_evaluation.h).
#pragma once

#include <string>

namespace omni::io {

// Appends the formatted text (any length) to *out.
void AppendFormat(std::string* out, const char* format, ...)
    __attribute__((format(printf, 2, 3)));

}  // namespace omni::io
