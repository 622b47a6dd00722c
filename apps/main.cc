// omnistereo <command> [--flags]: the toolkit's one executable (docs/design.md, Conventions).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include <malloc.h>

#include <gflags/gflags.h>
#include <glog/logging.h>

#include "apps/command.h"
#include "io/model_file.h"

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
    std::string description = info.description;
    for (const auto& [flag, text] : c.help) {
      if (flag == name) description = text;
    }
    std::printf("  --%s (%s) %s", info.name.c_str(), info.type.c_str(), description.c_str());
    if (info.type == "double" && !info.default_value.empty()) {
      // gflags prints a double's default to 17 digits (0.29999999999999999).
      std::printf("  [default: %g]", std::strtod(info.default_value.c_str(), nullptr));
    } else if (!info.default_value.empty()) {
      std::printf("  [default: %s]", info.default_value.c_str());
    }
    std::printf("\n");
  }
}

// Edit distance (insertions, deletions, substitutions, transpositions of neighbours).
int EditDistance(const std::string& a, const std::string& b) {
  std::vector<std::vector<int>> d(a.size() + 1, std::vector<int>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = static_cast<int>(i);
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = static_cast<int>(j);
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1,
                          d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[a.size()][b.size()];
}

// The first argument that looks like a flag (-name, --name, --name=value, --noname for a bool)
// but names none gflags knows, with the closest of the command's flags; empty if all are known.
// gflags itself is told to allow unknown flags (it is re-parsed per command), so a misspelt
// --modle would otherwise be dropped and its value reported as an unexpected argument.
std::string UnknownFlagMessage(const Command& command, int argc, char** argv) {
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") break;
    if (arg.size() < 2 || arg[0] != '-') continue;
    std::string name = arg.substr(arg[1] == '-' ? 2 : 1);
    name = name.substr(0, name.find('='));
    gflags::CommandLineFlagInfo info;
    if (gflags::GetCommandLineFlagInfo(name.c_str(), &info)) continue;
    if (name.rfind("no", 0) == 0 && gflags::GetCommandLineFlagInfo(name.substr(2).c_str(), &info) &&
        info.type == "bool") {
      continue;
    }
    std::string message = "unknown flag --" + name;
    std::string best;
    int best_distance = 3;  // suggest only near misses
    for (const std::string& flag : command.flags) {
      const int distance = EditDistance(name, flag);
      if (distance < best_distance) best_distance = distance, best = flag;
    }
    message += best.empty() ? " (omnistereo " + std::string(command.name) + " --help lists its flags)"
                            : "; did you mean --" + best + "?";
    return message;
  }
  return "";
}

// For a command that takes several photos (--images): every --image and --images given, in
// order, as one --images=a,b,c (gflags keeps only the last of a repeated flag, and the issue's
// `check --image I --image J` is the natural way to name two photos). A command whose --image is
// one photo of its own (Command::image_apart_from_images) gathers only its --images.
std::vector<std::string> MergePhotoFlags(const Command& command, int argc, char** argv) {
  std::vector<std::string> args(argv, argv + argc);
  if (std::find(command.flags.begin(), command.flags.end(), "images") == command.flags.end()) {
    return args;
  }
  std::vector<std::string> kept(args.begin(), args.begin() + 2), photos;
  for (size_t i = 2; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--") {
      kept.insert(kept.end(), args.begin() + i, args.end());
      break;
    }
    bool matched = false;
    for (const char* name : {"image", "images"}) {
      if (command.image_apart_from_images && std::string(name) == "image") continue;
      for (const std::string dashes : {"-", "--"}) {
        const std::string flag = dashes + name;
        if (a == flag && i + 1 < args.size()) {
          photos.push_back(args[++i]);
          matched = true;
        } else if (a.rfind(flag + "=", 0) == 0) {
          photos.push_back(a.substr(flag.size() + 1));
          matched = true;
        }
        if (matched) break;
      }
      if (matched) break;
    }
    if (!matched) kept.push_back(a);
  }
  std::string joined;
  for (const std::string& p : photos) {
    if (!p.empty()) joined += (joined.empty() ? "" : ",") + p;
  }
  if (!photos.empty()) kept.push_back("--images=" + joined);
  return kept;
}

}  // namespace
}  // namespace omni::apps

int main(int argc, char** argv) {
  using namespace omni::apps;
  // Detection makes and frees full-view buffers (views, derivatives, masks) dozens of times per
  // image. glibc serves blocks over its mmap threshold (128 KiB, raised only as such blocks are
  // freed) from fresh pages and hands them back when freed, so every image page-faulted them in
  // again: 25% of detection's CPU (perf, realistic_scene: 180 -> 135 ms per 1280x960 image).
  // Blocks up to 32 MiB (a 4k colour frame in float is 100 MiB) come from the heap and stay
  // there for the next image; the heap is trimmed only above 256 MiB free. Set here, not in the
  // library: an allocator's settings are the program's to choose (a Python host's among them).
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
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
  if (const std::string unknown = UnknownFlagMessage(*command, argc, argv); !unknown.empty()) {
    std::fprintf(stderr, "omnistereo %s: %s\n", command->name, unknown.c_str());
    return 2;
  }
  // Shift so that gflags sees "omnistereo-<command> --flags".
  std::vector<std::string> args = MergePhotoFlags(*command, argc, argv);
  args[1] = std::string("omnistereo ") + command->name;
  std::vector<char*> arg_pointers;
  for (std::string& a : args) arg_pointers.push_back(a.data());
  arg_pointers.push_back(nullptr);
  int sub_argc = static_cast<int>(args.size()) - 1;
  char** sub_argv = arg_pointers.data() + 1;
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
