// A report folder opened in headless Chromium (Debian `chromium`, installed by
// scripts/install_deps.sh), as a user's browser would: every <img> loads (a probe copy of the
// page, with a script added that lists the images that did not, is read back with --dump-dom),
// nothing is logged to the page's console (a missing file logs "Failed to load resource"), and a
// screenshot of the page is not blank.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace omni::testing {

inline std::string RunAndRead(const std::string& command) {
  std::string out;
  if (FILE* pipe = popen(command.c_str(), "r")) {
    char buf[4096];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof(buf), pipe)) > 0) out.append(buf, n);
    pclose(pipe);
  }
  return out;
}

// At least min_images <img> in the page, every one of them loading.
inline void CheckReportInBrowser(const std::string& dir, int min_images) {
  namespace fs = std::filesystem;
  ASSERT_EQ(std::system("command -v chromium > /dev/null 2>&1"), 0)
      << "chromium is not installed (scripts/install_deps.sh installs it)";
  const std::string index = fs::absolute(dir + "/index.html").string();
  std::ifstream in(index);
  std::stringstream page;
  page << in.rdbuf();
  std::string probe = page.str();
  int expected_images = 0;
  for (size_t at = probe.find("<img "); at != std::string::npos; at = probe.find("<img ", at + 1)) {
    ++expected_images;
  }
  EXPECT_GE(expected_images, min_images);
  const std::string script =
      "<script>window.addEventListener('load', () => { const bad = [...document.images]"
      ".filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.getAttribute('src'));"
      "document.title = bad.length ? 'BROKEN ' + bad.join(' ') : 'IMAGES OK ' + "
      "document.images.length; });</script>";
  probe.replace(probe.rfind("</body>"), 7, script + "</body>");
  const std::string probe_path = fs::absolute(dir + "/probe.html").string();
  std::ofstream(probe_path) << probe;
  const std::string chromium =
      "chromium --headless --no-sandbox --disable-gpu --disable-dev-shm-usage "
      "--user-data-dir=" + fs::absolute(dir + "/.chromium").string() + " ";
  const std::string dom =
      RunAndRead(chromium + "--virtual-time-budget=10000 --dump-dom 'file://" + probe_path +
                 "' 2>/dev/null");
  EXPECT_NE(dom.find("<title>IMAGES OK " + std::to_string(expected_images) + "</title>"),
            std::string::npos)
      << dom.substr(0, 400);
  const std::string log = RunAndRead(chromium + "--enable-logging=stderr --v=0 " +
                                     "--virtual-time-budget=10000 --dump-dom 'file://" + index +
                                     "' 2>&1 >/dev/null");
  EXPECT_EQ(log.find(":CONSOLE("), std::string::npos) << log;
  const std::string shot = fs::absolute(dir + "/screenshot.png").string();
  RunAndRead(chromium + "--window-size=1100,1600 --screenshot=" + shot + " 'file://" + index +
             "' 2>/dev/null");
  const cv::Mat image = cv::imread(shot, cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(image.empty()) << "no screenshot";
  cv::Scalar mean, stddev;
  cv::meanStdDev(image, mean, stddev);
  EXPECT_GT(stddev[0], 10) << "the screenshot is blank";
  fs::remove(probe_path);
  fs::remove(shot);
  fs::remove_all(dir + "/.chromium");
}

}  // namespace omni::testing
