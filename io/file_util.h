// What every reader and writer of io/ shares: the user-facing input error, and a file that
// is written under a temporary name and renamed into place only when complete (docs/design.md, Conventions:
// nothing half-written is left behind).
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

#include "model/input_error.h"

namespace omni::io {

// Thrown for unreadable or invalid input files (model/input_error.h): what() names the file and
// the key (or line) and says what was expected.
using InputError = omni::InputError;

// A file written under a temporary name in the folder of `path` (same file system, so the final
// rename is atomic) and renamed onto `path` by Commit(). Destroyed without a successful Commit(),
// it removes the temporary file: an existing file at `path` is then untouched.
class AtomicFile {
 public:
  // Creates the temporary file; throws std::runtime_error naming `path` if its folder does not
  // exist or is not writable.
  explicit AtomicFile(std::string path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  // Appends bytes; throws std::runtime_error (e.g. disk full).
  void Write(std::string_view data);
  // Flushes to disk, closes and renames onto path(); throws std::runtime_error on failure (the
  // temporary file is then removed).
  void Commit();

  const std::string& path() const { return path_; }

 private:
  void Discard() noexcept;

  std::string path_;
  std::string temp_path_;
  int fd_ = -1;
};

// Writes `contents` to `path` atomically (AtomicFile); throws std::runtime_error on failure.
void WriteFileAtomically(const std::string& path, const std::string& contents);

// Shortest decimal text that reads back to exactly `value` (std::to_chars); "nan", "inf", "-inf"
// for non-finite values.
std::string FormatDouble(double value);

// Parses a whole string as a double (std::from_chars, an optional leading '+' allowed). Returns
// false if `text` is not entirely a number. "nan"/"inf" parse (callers decide whether to accept
// non-finite values); out-of-range magnitudes parse as +-inf or 0 like strtod.
bool ParseDouble(std::string_view text, double* value);

}  // namespace omni::io
