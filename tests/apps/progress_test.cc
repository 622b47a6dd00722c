// The progress line (apps/progress.h) on a terminal and off one: a log file must get the step's
// own lines only, with no control codes; a terminal the same lines plus a status line that is
// redrawn in place and cleared at the end.
#include "apps/progress.h"

#include <cstdio>
#include <string>

#include <gtest/gtest.h>

namespace omni::apps {
namespace {

// Everything written to a temporary stream.
std::string Contents(std::FILE* f) {
  std::fflush(f);
  std::rewind(f);
  std::string s;
  char buf[256];
  size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) s.append(buf, n);
  return s;
}

TEST(ProgressLine, OffATerminalOnlyTheStepsLines) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  {
    ProgressLine p("render", 3, f, /*terminal=*/false);
    p.Done("a.png done");
    p.Status("sampling");
    p.Print("warning: b.png slow");
    p.Done("");
    p.Done("c.png done");
  }
  EXPECT_EQ(Contents(f), "a.png done\nwarning: b.png slow\nc.png done\n");
  std::fclose(f);
}

TEST(ProgressLine, OnATerminalAStatusLineRedrawnAndCleared) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  {
    ProgressLine p("render", 3, f, /*terminal=*/true);
    p.Done("a.png done");
    p.Done("b.png done");
    p.Done("c.png done");
  }
  const std::string s = Contents(f);
  // The step's lines, each after the previous status was erased.
  EXPECT_NE(s.find("a.png done\nrender 1/3, "), std::string::npos) << s;
  EXPECT_NE(s.find("\r\033[Kb.png done\nrender 2/3, "), std::string::npos) << s;
  EXPECT_NE(s.find("about"), std::string::npos) << s;
  EXPECT_NE(s.find("\r\033[Kc.png done\n"), std::string::npos) << s;
  // Nothing after the last item: the summary follows on a clean line.
  EXPECT_EQ(s.substr(s.size() - 11), "c.png done\n") << s;
  std::fclose(f);
}

TEST(ProgressLine, UncountedStepShowsWhatItDoesAndStopsWhenFinished) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  {
    ProgressLine p("calibrate", 0, f, /*terminal=*/true);
    p.Status("stage pinhole, iteration 0");
    p.Status("stage pinhole, iteration 1");  // within 0.1 s: not redrawn
    p.Print("stage pinhole ... converged");  // ends the stage: no status until the next
    p.Finish();
    p.Status("after the end");  // ignored
    p.Print("summary");
  }
  const std::string s = Contents(f);
  EXPECT_EQ(s,
            "calibrate: stage pinhole, iteration 0, 0 s"
            "\r\033[Kstage pinhole ... converged\n"
            "summary\n");
  std::fclose(f);
}

}  // namespace
}  // namespace omni::apps
