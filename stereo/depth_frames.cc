#include "stereo/depth_frames.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <future>
#include <vector>

#include <sys/resource.h>

#include "model/input_error.h"

namespace omni::stereo {
namespace {

double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
         1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

}  // namespace

cv::Mat Disparity16(const DepthFrame& frame) {
  const cv::Mat valid = frame.disparity == frame.disparity;  // false at NaN
  cv::Mat scaled = frame.disparity * 16.0, d16;
  scaled.setTo(0, ~valid);
  scaled.convertTo(d16, CV_16UC1);
  return d16;
}

cv::Mat DisparityView(const DepthFrame& frame, int num_disparities) {
  const cv::Mat valid = frame.disparity == frame.disparity;
  cv::Mat view = frame.disparity * (255.0 / num_disparities), d8;
  view.setTo(0, ~valid);
  view.convertTo(d8, CV_8UC1);
  return d8;
}

double MedianSigma(const DepthFrame& frame) {
  if (frame.points.empty()) return 0;
  std::vector<float> sigmas;
  sigmas.reserve(frame.points.size());
  for (const auto& p : frame.points) sigmas.push_back(p.sigma_mm);
  std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
  return sigmas[sigmas.size() / 2];
}

FramesReport ComputeFrames(const DenseStereo& dense, size_t count,
                           const std::function<cv::Mat(size_t i)>& read,
                           const std::function<std::function<void()>(size_t i, const DepthFrame&)>& done,
                           const std::function<void(size_t i, const std::string& what)>& skipped,
                           std::future<cv::Mat> first) {
  FramesReport report;
  if (count == 0) return report;
  auto timed_read = [&](size_t i) {
    const auto start = std::chrono::steady_clock::now();
    cv::Mat image = read(i);
    report.read += SecondsSince(start);  // one reader at a time: each waits for the one before
    return image;
  };
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = ProcessCpuSeconds();
  std::future<cv::Mat> next =
      first.valid() ? std::move(first) : std::async(std::launch::async, timed_read, size_t{0});
  std::future<void> writing;  // the last frame's
  for (size_t i = 0; i < count; ++i) {
    cv::Mat image;
    try {
      image = next.get();
    } catch (const InputError& e) {
      if (report.first_error.empty()) report.first_error = e.what();
      if (i + 1 < count) next = std::async(std::launch::async, timed_read, i + 1);
      skipped(i, e.what());
      continue;
    }
    if (i + 1 < count) next = std::async(std::launch::async, timed_read, i + 1);
    const DepthFrame frame = dense.Compute(image);
    report.remap += frame.seconds_remap;
    report.sgbm += frame.seconds_sgbm;
    report.triangulation += frame.seconds_triangulation;
    report.points += frame.points.size();
    ++report.computed;
    std::function<void()> write = done(i, frame);
    if (writing.valid()) writing.get();
    writing = std::async(std::launch::async, [&report, write = std::move(write)] {
      const auto start = std::chrono::steady_clock::now();
      if (write) write();
      report.write += SecondsSince(start);
    });
  }
  if (writing.valid()) writing.get();
  report.loop = SecondsSince(t0);
  report.cpu = ProcessCpuSeconds() - cpu0;
  return report;
}

std::future<cv::Mat> StartReading(const std::function<cv::Mat(size_t i)>& read) {
  return std::async(std::launch::async, read, size_t{0});
}

std::string FrameLine(const std::string& name, const DepthFrame& frame) {
  char line[512];
  std::snprintf(line, sizeof(line), "%s: %zu points (median sigma %.1f mm); remap %.1f, SGBM "
                "%.1f, triangulation %.1f ms", name.c_str(), frame.points.size(),
                MedianSigma(frame), 1e3 * frame.seconds_remap, 1e3 * frame.seconds_sgbm,
                1e3 * frame.seconds_triangulation);
  return line;
}

std::string FrameSummary(const DepthFrame& frame, double sigma_px, double setup_s,
                         const std::string& cloud_path) {
  const int band_pixels = (frame.band_row_end - frame.band_row_begin) * frame.disparity.cols;
  char line[512];
  std::snprintf(line, sizeof(line), "depth: panoramas %dx%d, matched rows %d..%d, %zu points of "
                "%d band pixels (median sigma %.1f mm at sigma_px %g)\n",
                frame.disparity.cols, frame.disparity.rows, frame.band_row_begin,
                frame.band_row_end, frame.points.size(), band_pixels, MedianSigma(frame),
                sigma_px);
  std::string text = line;
  std::snprintf(line, sizeof(line), "time: setup (LUTs, ray tables) %.2f s; per frame: remap %.1f "
                "ms, SGBM %.1f ms, triangulation %.1f ms -> ", setup_s, 1e3 * frame.seconds_remap,
                1e3 * frame.seconds_sgbm, 1e3 * frame.seconds_triangulation);
  return text + line + cloud_path + "\n";
}

std::string FramesSummary(const FramesReport& r, size_t count, const DenseStereo& dense,
                          double setup_s) {
  const double n = static_cast<double>(r.computed);
  const size_t skipped = count - r.computed;
  char line[1024];
  std::snprintf(line, sizeof(line),
                "depth: %zu frames%s, panoramas %dx%d, %.0f points per frame; set-up %.2f s; per "
                "frame: remap %.1f, SGBM %.1f, triangulation %.1f ms (%.1f frames/s computing), "
                "reading %.1f and writing %.1f ms alongside; %.1f frames/s in all; process CPU "
                "%.0f ms per frame",
                r.computed, skipped ? (" (" + std::to_string(skipped) + " skipped)").c_str() : "",
                dense.luts().geometry.width, dense.luts().geometry.height, r.points / n, setup_s,
                1e3 * r.remap / n, 1e3 * r.sgbm / n, 1e3 * r.triangulation / n,
                n / (r.remap + r.sgbm + r.triangulation), 1e3 * r.read / n, 1e3 * r.write / n,
                n / r.loop, 1e3 * r.cpu / n);
  return line;
}

}  // namespace omni::stereo
