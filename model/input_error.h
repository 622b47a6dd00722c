// The one error type for input a user can fix: a bad file, a bad flag, a session the calibration
// cannot use. what() is one line naming the file and key (or the cause) and what was expected;
// the CLI prints it and exits 2 (docs/design.md, Conventions). The readers of io/ throw it as
// io::InputError, the calibration's CalibrationError is one.
#pragma once

#include <stdexcept>

namespace omni {

class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace omni
