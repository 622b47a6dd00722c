// What the CLI tests share: run the real `omnistereo` executable and read what it wrote.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#ifndef OMNISTEREO_EXE
#error "OMNISTEREO_EXE must name the omnistereo executable"
#endif

namespace omni::testing {

inline std::string ReadText(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs `omnistereo <args>` with stdout and stderr sent to the given files; returns the exit code
// (-1 if it did not exit normally) and fills *err (and *out) with what it printed.
inline int RunOmnistereo(const std::string& args, const std::filesystem::path& err_file,
                         std::string* err, const std::filesystem::path& out_file = "/dev/null",
                         std::string* out = nullptr) {
  const std::string cmd = std::string("'") + OMNISTEREO_EXE + "' " + args + " >'" +
                          out_file.string() + "' 2>'" + err_file.string() + "'";
  const int status = std::system(cmd.c_str());
  *err = ReadText(err_file);
  if (out) *out = ReadText(out_file);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// One ring's line of `calibrate --truth`'s corner-noise check:
// "  ring R: <residual> px vs <true error> px over <corners> corners: ratio <ratio>".
struct CornerNoiseLine {
  double residual_px = 0, true_error_px = 0, ratio = 0;
  int corners = 0;
};
inline bool ParseCornerNoiseLine(const std::string& out, int ring, CornerNoiseLine* line) {
  const std::string key = "  ring " + std::to_string(ring) + ": ";
  const auto at = out.find(key);
  return at != std::string::npos &&
         std::sscanf(out.c_str() + at + key.size(), "%lf px vs %lf px over %d corners: ratio %lf",
                     &line->residual_px, &line->true_error_px, &line->corners, &line->ratio) == 4;
}

}  // namespace omni::testing
