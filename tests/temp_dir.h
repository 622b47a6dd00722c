// A scratch folder per test process: tests that render or write files run in parallel (ctest -j,
// several checkouts on one machine), so a fixed /tmp name would let one run delete another's files.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>

namespace omni::testing {

inline std::filesystem::path UniqueTempDir(const std::string& name) {
  return std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
}

}  // namespace omni::testing
