#include "apps/progress.h"

#include <unistd.h>

#include <cstdio>

namespace omni::apps {

ProgressLine::ProgressLine(std::string what, int total)
    : what_(std::move(what)),
      total_(total),
      terminal_(isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()) {}

ProgressLine::~ProgressLine() {
  if (terminal_ && done_ > 0 && done_ < total_) std::fprintf(stderr, "\r\033[K");
}

void ProgressLine::PrintLocked(const std::string& line) {
  if (terminal_) std::fprintf(stderr, "\r\033[K");  // the old status
  if (!line.empty()) std::fprintf(stderr, "%s\n", line.c_str());
  // Nothing before the first item; after the last the step's summary follows on stdout.
  if (!terminal_ || done_ == 0 || done_ >= total_) return;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double left = elapsed / done_ * (total_ - done_);
  std::fprintf(stderr, "%s %d/%d, %.0f s, about %.0f s left", what_.c_str(), done_, total_,
               elapsed, left);
  std::fflush(stderr);
}

void ProgressLine::Done(const std::string& line) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++done_;
  PrintLocked(line);
}

void ProgressLine::Print(const std::string& line) {
  std::lock_guard<std::mutex> lock(mutex_);
  PrintLocked(line);
}

}  // namespace omni::apps
