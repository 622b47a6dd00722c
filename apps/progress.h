// Progress of a long step on stderr (issue 19): on a terminal, one status line updated in place
// under the step's own lines, "render 5/16, 75 s, about 165 s left"; when stderr is not a
// terminal (a log file, a pipe, CI) the step's own lines only, as before.
#pragma once

#include <chrono>
#include <mutex>
#include <string>

namespace omni::apps {

class ProgressLine {
 public:
  ProgressLine(std::string what, int total);
  ~ProgressLine();  // clears the status line
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  // One item done: `line` (may be empty) printed as a line of its own, then the status.
  void Done(const std::string& line);
  // A line between items (a warning); the status stays below it.
  void Print(const std::string& line);

 private:
  void PrintLocked(const std::string& line);
  std::string what_;
  int total_ = 0, done_ = 0;
  bool terminal_ = false;
  std::chrono::steady_clock::time_point start_;
  std::mutex mutex_;  // items may finish on several threads (render's POV-Ray processes)
};

}  // namespace omni::apps
