// `omnistereo <command> --help` describes the flags as that command uses them: what its --out
// writes, no other command's options in a shared flag's text.
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/cli_test_util.h"
#include "tests/temp_dir.h"

namespace omni {
namespace {

namespace fs = std::filesystem;

std::string Help(const std::string& command) {
  const fs::path dir = testing::UniqueTempDir("omni_help_cli");
  fs::create_directories(dir);
  std::string err, out;
  EXPECT_EQ(testing::RunOmnistereo(command + " --help", dir / "err.txt", &err, dir / "out.txt", &out),
            0)
      << command << ": " << err;
  return out;
}

// The text of `--flag` in a command's help ("" when not listed).
std::string FlagLine(const std::string& help, const std::string& flag) {
  const auto at = help.find("  --" + flag + " (");
  if (at == std::string::npos) return "";
  return help.substr(at, help.find('\n', at) - at);
}

std::vector<std::string> CommandNames() {
  std::istringstream usage(Help(""));
  std::vector<std::string> names;
  std::string line;
  bool listing = false;
  while (std::getline(usage, line)) {
    if (line == "commands:") {
      listing = true;
    } else if (listing && line.size() > 2) {
      names.push_back(line.substr(2, line.find(' ', 2) - 2));
    }
  }
  return names;
}

TEST(HelpCli, EachCommandSaysWhatItsOutWrites) {
  const std::vector<std::string> names = CommandNames();
  ASSERT_GE(names.size(), 15u);
  int with_out = 0;
  for (const std::string& name : names) {
    const std::string out = FlagLine(Help(name), "out");
    if (out.empty()) continue;
    ++with_out;
    EXPECT_EQ(out.find("output file or folder"), std::string::npos) << name << ": " << out;
    EXPECT_EQ(out.find("(design, calibrate, refine)"), std::string::npos)
        << name << ": the general text, not the command's: " << out;
  }
  EXPECT_GE(with_out, 15);
  EXPECT_NE(FlagLine(Help("detect"), "out").find("detections file"), std::string::npos);
  EXPECT_NE(FlagLine(Help("report"), "out").find("folder"), std::string::npos);
}

TEST(HelpCli, SharedFlagsNameNoOtherCommand) {
  EXPECT_EQ(FlagLine(Help("export"), "frame").find("triangulate"), std::string::npos);
  // calibrate --truth is the corner-noise check, not triangulate's RMSE table.
  const std::string truth = FlagLine(Help("calibrate"), "truth");
  EXPECT_EQ(truth.find("RMSE table"), std::string::npos) << truth;
  EXPECT_NE(truth.find("true corner error"), std::string::npos) << truth;
  EXPECT_NE(FlagLine(Help("triangulate"), "frame").find("--truth"), std::string::npos);
  const std::string report = Help("report");
  for (const char* flag : {"report_range_mm", "tolerances"}) {
    const std::string line = FlagLine(report, flag);
    ASSERT_FALSE(line.empty()) << flag;
    EXPECT_EQ(line.find("calibrate --report"), std::string::npos) << line;
  }
}

}  // namespace
}  // namespace omni
