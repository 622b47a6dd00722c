#include "apps/progress.h"

#include <unistd.h>

namespace omni::apps {

ProgressLine::ProgressLine(std::string what, int total)
    : ProgressLine(std::move(what), total, stderr, isatty(STDERR_FILENO) == 1) {}

ProgressLine::ProgressLine(std::string what, int total, std::FILE* out, bool terminal)
    : what_(std::move(what)),
      total_(total),
      out_(out),
      terminal_(terminal),
      start_(std::chrono::steady_clock::now()) {}

ProgressLine::~ProgressLine() { Finish(); }

void ProgressLine::Finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (status_shown_) std::fprintf(out_, "\r\033[K");
  status_shown_ = false;
  finished_ = true;
  std::fflush(out_);
}

void ProgressLine::DrawStatusLocked() {
  if (status_shown_) std::fprintf(out_, "\r\033[K");  // the old status
  status_shown_ = false;
  // Nothing before the first item of a counted step, nothing after its last (the step's
  // summary follows on stdout).
  const bool counted = total_ > 0;
  if (counted ? (done_ == 0 || done_ >= total_) : now_.empty()) return;
  const auto now = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  if (counted) {
    const double left = elapsed / done_ * (total_ - done_);
    std::fprintf(out_, "%s %d/%d, %.0f s, about %.0f s left", what_.c_str(), done_, total_,
                 elapsed, left);
    if (!now_.empty()) std::fprintf(out_, "; %s", now_.c_str());
  } else {
    std::fprintf(out_, "%s: %s, %.0f s", what_.c_str(), now_.c_str(), elapsed);
  }
  status_shown_ = true;
  last_draw_ = now;
  std::fflush(out_);
}

void ProgressLine::PrintLocked(const std::string& line) {
  if (status_shown_) std::fprintf(out_, "\r\033[K");
  status_shown_ = false;
  if (!line.empty()) std::fprintf(out_, "%s\n", line.c_str());
  if (terminal_ && !finished_) DrawStatusLocked();
  std::fflush(out_);
}

void ProgressLine::Done(const std::string& line) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++done_;
  // Items without a line of their own (a Monte Carlo's draws) redraw at most ten times a second.
  if (line.empty() && status_shown_ && done_ < total_ &&
      std::chrono::steady_clock::now() - last_draw_ < std::chrono::milliseconds(100)) {
    return;
  }
  PrintLocked(line);
}

void ProgressLine::Print(const std::string& line) {
  std::lock_guard<std::mutex> lock(mutex_);
  // In a step of stages a printed line ends what the status said (a stage's summary); the
  // next Status says what follows.
  if (total_ == 0) now_.clear();
  PrintLocked(line);
}

void ProgressLine::Status(const std::string& now) {
  std::lock_guard<std::mutex> lock(mutex_);
  now_ = now;
  if (!terminal_ || finished_) return;
  const auto t = std::chrono::steady_clock::now();
  if (status_shown_ && t - last_draw_ < std::chrono::milliseconds(100)) return;
  DrawStatusLocked();
}

}  // namespace omni::apps
