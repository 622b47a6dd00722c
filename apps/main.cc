// omnistereo <command> [--flags]: the toolkit's one executable (DESIGN.md §5).
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include <gflags/gflags.h>
#include <glog/logging.h>

#include "apps/command.h"
#include "model/io/model_file.h"

namespace omni::apps {
namespace {

void PrintUsage() {
  std::printf("usage: omnistereo <command> [--flags]   (omnistereo <command> --help)\n\ncommands:\n");
  for (const auto& c : Commands()) std::printf("  %-12s %s\n", c.name, c.summary);
}

void PrintCommandHelp(const Command& c) {
  std::printf("omnistereo %s: %s\n\nflags:\n", c.name, c.summary);
  for (const auto& name : c.flags) {
    gflags::CommandLineFlagInfo info;
    if (!gflags::GetCommandLineFlagInfo(name.c_str(), &info)) continue;
    std::printf("  --%s (%s) %s", info.name.c_str(), info.type.c_str(), info.description.c_str());
    if (!info.default_value.empty()) std::printf("  [default: %s]", info.default_value.c_str());
    std::printf("\n");
  }
}

}  // namespace
}  // namespace omni::apps

int main(int argc, char** argv) {
  using namespace omni::apps;
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") ||
      !std::strcmp(argv[1], "help")) {
    PrintUsage();
    return argc < 2 ? 2 : 0;
  }
  const Command* command = nullptr;
  for (const auto& c : Commands()) {
    if (std::string(argv[1]) == c.name) command = &c;
  }
  if (!command) {
    std::fprintf(stderr, "omnistereo: unknown command '%s'\n", argv[1]);
    PrintUsage();
    return 2;
  }
  for (int i = 2; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--help") || !std::strcmp(argv[i], "-h") ||
        !std::strcmp(argv[i], "-help")) {
      PrintCommandHelp(*command);
      return 0;
    }
  }
  // Shift so that gflags sees "omnistereo-<command> --flags".
  std::string program = std::string("omnistereo ") + command->name;
  argv[1] = program.data();
  int sub_argc = argc - 1;
  char** sub_argv = argv + 1;
  gflags::SetUsageMessage(command->summary);
  gflags::AllowCommandLineReparsing();
  gflags::ParseCommandLineFlags(&sub_argc, &sub_argv, true);
  if (sub_argc > 1) {
    std::fprintf(stderr, "omnistereo %s: unexpected argument '%s' (flags are --name=value)\n",
                 command->name, sub_argv[1]);
    return 2;
  }
  FLAGS_logtostderr = true;
  // Ceres logs a warning for every trial step it cannot evaluate; for this bounded model (a ray
  // that leaves a mirror's rim has no image) that is routine, the trust region shrinks and goes
  // on, so by default only errors are shown (--minloglevel=0 brings everything back).
  if (gflags::GetCommandLineFlagInfoOrDie("minloglevel").is_default) FLAGS_minloglevel = 2;
  google::InitGoogleLogging(argv[0]);
  try {
    return command->run();
  } catch (const omni::io::InputError& e) {
    std::fprintf(stderr, "omnistereo %s: %s\n", command->name, e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "omnistereo %s: error: %s\n", command->name, e.what());
    return 1;
  }
}
