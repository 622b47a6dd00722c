// libFuzzer harness for one of the toolkit's file parsers (chosen by OMNI_FUZZ_PARSER at compile
// time; fuzz/CMakeLists.txt builds one executable per parser; scripts/fuzz.sh runs them). The
// input is written to a file and read the way the commands read it. The contract under test:
// any input either parses or throws io::InputError (one clear line for the user); any other
// exception, a crash, a hang, or a memory error / undefined behaviour (ASan + UBSan) is a finding.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "design/design_config.h"
#include "design/tolerance_file.h"
#include "io/csv.h"
#include "io/detections_file.h"
#include "io/file_util.h"
#include "io/model_file.h"
#include "io/ply.h"
#include "io/session_file.h"
#include "model/rig_model.h"
#include "synthetic/scene_file.h"

namespace {

// One scratch file per fuzzing process (libFuzzer's -fork / -jobs run several).
const std::string& ScratchPath() {
  static const std::string path = [] {
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir ? dir : "/tmp") + "/omni_fuzz_" + std::to_string(getpid()) +
           OMNI_FUZZ_EXTENSION;
  }();
  return path;
}

// The scene parser needs a rig; the big rig as built (sample_configs), read once.
const omni::RigModel& SceneRig() {
  static const omni::RigModel rig(
      omni::io::ReadModelFile(OMNI_SOURCE_DIR "/sample_configs/big_rig_misaligned.yaml"));
  return rig;
}

void Parse(const std::string& path) {
  using namespace omni;
  const std::string parser = OMNI_FUZZ_PARSER;
  if (parser == "model") {
    io::ReadModelFile(path);
  } else if (parser == "session") {
    io::ReadSessionFile(path);
  } else if (parser == "detections") {
    io::ReadDetectionsFile(path);
  } else if (parser == "design") {
    design::ReadDesignConfig(path);
  } else if (parser == "tolerance") {
    design::ReadToleranceFile(path);
  } else if (parser == "scene") {
    synthetic::ReadSceneFile(path, SceneRig());
  } else if (parser == "points_csv" || parser == "pixels_csv") {
    const std::vector<std::string> columns =
        parser == "points_csv" ? std::vector<std::string>{"x_mm", "y_mm", "z_mm"}
                               : std::vector<std::string>{"u", "v"};
    io::CsvReader in(path, columns);
    std::vector<double> row;
    while (in.ReadRow(&row)) {
    }
  } else if (parser == "ply") {
    io::ReadPlyFile(path);
  } else {
    std::fprintf(stderr, "fuzz_parser: unknown parser %s\n", parser.c_str());
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string& path = ScratchPath();
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  try {
    Parse(path);
  } catch (const omni::io::InputError&) {
    // The contract: bad input is reported as one InputError.
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_parser(%s): not an InputError: %s\n", OMNI_FUZZ_PARSER, e.what());
    std::abort();
  }
  return 0;
}
