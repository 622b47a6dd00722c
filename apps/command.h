// The `omnistereo` subcommands. Each is a thin function: flags -> options -> one library call ->
// summary. A command returns the process exit code; user-facing errors are thrown as
// omni::io::InputError (or std::runtime_error) and printed once, by main.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace omni::apps {

struct Command {
  const char* name;
  const char* summary;
  std::vector<std::string> flags;  // the gflags this command reads, listed by --help
  int (*run)();
  // --help's text of a shared flag for this command where the flag's own is general (what
  // --out writes, say): flag name, text.
  std::vector<std::pair<std::string, std::string>> help = {};
  // --image is one photo of its own (depth: one frame, its own outputs) rather than one more of
  // --images: main then gathers only the repeated --images into one list.
  bool image_apart_from_images = false;
};

const std::vector<Command>& Commands();

int RunDesign();
int RunRender();
int RunDetect();
int RunCalibrate();
int RunReport();
int RunProject();
int RunUnproject();
int RunTriangulate();
int RunTolerance();
int RunPanorama();
int RunDepth();
int RunExport();
int RunTarget();
int RunInit();
int RunCheck();
int RunRefine();
int RunDemo();

// For commands that later issues will fill in: prints one line and returns 2.
int NotYetImplemented(const char* name, const char* issue);

}  // namespace omni::apps
