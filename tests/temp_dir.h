// A scratch folder per test process: tests that render or write files run in parallel (ctest -j,
// several checkouts on one machine), so a fixed /tmp name would let one run delete another's files.
// The folders are removed when the test process exits, unless a test failed (its renders and
// outputs are then what one looks at) or OMNI_KEEP_TEST_FILES is set; every suite run used to
// leave ~15 MB behind in /tmp.
#pragma once

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <set>
#include <string>
#include <system_error>

#include <gtest/gtest.h>

namespace omni::testing {

class TempDirRegistry {
 public:
  static TempDirRegistry& Instance() {
    static TempDirRegistry registry;
    return registry;
  }
  void Add(const std::filesystem::path& dir) {
    std::lock_guard<std::mutex> lock(mutex_);
    dirs_.insert(dir);
  }
  ~TempDirRegistry() {
    const ::testing::UnitTest* unit = ::testing::UnitTest::GetInstance();
    if (std::getenv("OMNI_KEEP_TEST_FILES") || (unit && unit->Failed())) return;
    for (const std::filesystem::path& dir : dirs_) {
      std::error_code ignored;
      std::filesystem::remove_all(dir, ignored);
    }
  }

 private:
  std::mutex mutex_;
  std::set<std::filesystem::path> dirs_;
};

inline std::filesystem::path UniqueTempDir(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  TempDirRegistry::Instance().Add(dir);
  return dir;
}

}  // namespace omni::testing
