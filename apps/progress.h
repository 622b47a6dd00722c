// Progress of a long step on stderr: on a terminal, one status line updated in place
// under the step's own lines: "render 5/16, 75 s, about 165 s left" for a step of counted items,
// "calibrate: stage alignment, iteration 12, 4 s" for a step of stages (total 0). When stderr is
// not a terminal (a log file, a pipe, CI) the step's own lines only, plain, no control codes.
#pragma once

#include <chrono>
#include <cstdio>
#include <mutex>
#include <string>

namespace omni::apps {

class ProgressLine {
 public:
  // `total`: the number of items, or 0 when the step counts none (stages, iterations).
  ProgressLine(std::string what, int total);
  // For tests: the stream and whether it is a terminal.
  ProgressLine(std::string what, int total, std::FILE* out, bool terminal);
  ~ProgressLine();  // clears the status line
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  // One item done: `line` (may be empty) printed as a line of its own, then the status.
  void Done(const std::string& line);
  // A line between items (a warning, a stage's summary); the status stays below it (in a step
  // without a count it is cleared until the next Status).
  void Print(const std::string& line);
  // What the step is doing now, shown in the status line only (on a terminal; redrawn at most
  // ten times a second, so it may be called per solver iteration).
  void Status(const std::string& now);
  // The step is over: the status line is cleared and not drawn again (before the step's summary
  // on stdout).
  void Finish();

 private:
  void PrintLocked(const std::string& line);
  void DrawStatusLocked();
  std::string what_, now_;
  int total_ = 0, done_ = 0;
  std::FILE* out_ = stderr;
  bool terminal_ = false;
  bool status_shown_ = false;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
  std::mutex mutex_;  // items may finish on several threads (render's POV-Ray processes)
};

}  // namespace omni::apps
