// `omnistereo depth --model M --image I --out DIR`: dense stereo on the panoramas
// (stereo/dense_stereo.h): writes DIR/panorama1.png, DIR/panorama2.png, DIR/disparity.png
// (8-bit view, brighter = nearer, black = no match), DIR/disparity16.png (16-bit, 16 x d, 0 = no
// match; d as in dense_stereo.h: v2 = v1 - d) and DIR/cloud.ply (points in C, mm, colour, per-point
// sigma_mm).
// `omnistereo depth --model M --images 'frames/*.jpg' --out DIR` (a video's frames; globs and
// lists): one set-up (maps, ray tables) for all frames, then DIR/<image name>.ply per frame, in
// order, with a progress line. A frame that cannot be read or is not the model's size is skipped
// with a warning naming it; when no frame can be used, exit 2.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <future>
#include <map>
#include <string>
#include <vector>

#include <gflags/gflags.h>
#include <opencv2/imgproc.hpp>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/progress.h"
#include "apps/stereo_cli.h"
#include "io/model_file.h"
#include "io/ply.h"
#include "stereo/dense_stereo.h"

DEFINE_int32(num_disparities, 64, "SGBM disparity range in panorama rows (multiple of 16)");
DEFINE_int32(block_size, 5, "SGBM block size (odd)");
DEFINE_double(max_sigma_mm, 0, "drop points whose sigma exceeds this (mm); 0 keeps all");
DEFINE_bool(ply_ascii, false, "write the PLY as text instead of binary");

namespace omni::apps {
namespace {

// The flags as dense-stereo options; throws io::InputError naming the flag.
stereo::DepthOptions OptionsFromFlags() {
  if (FLAGS_num_disparities < 16 || FLAGS_num_disparities % 16 != 0 ||
      FLAGS_num_disparities > 1024) {
    throw io::InputError("--num_disparities: expected a multiple of 16 in 16..1024, got " +
                         std::to_string(FLAGS_num_disparities));
  }
  if (FLAGS_block_size < 1 || FLAGS_block_size % 2 == 0 || FLAGS_block_size > 31) {
    throw io::InputError("--block_size: expected an odd number in 1..31, got " +
                         std::to_string(FLAGS_block_size));
  }
  if (!(FLAGS_sigma_px >= 0)) throw io::InputError("--sigma_px: expected a number >= 0");
  if (!(FLAGS_max_sigma_mm >= 0)) throw io::InputError("--max_sigma_mm: expected a number >= 0");
  stereo::DepthOptions options;
  options.num_disparities = FLAGS_num_disparities;
  options.block_size = FLAGS_block_size;
  options.sigma_px = FLAGS_sigma_px;
  options.max_sigma_mm = FLAGS_max_sigma_mm;
  return options;
}

// The frame's points as PLY vertices; *median_sigma: their median sigma (mm; 0 without points).
std::vector<io::PlyPoint> Cloud(const stereo::DepthFrame& frame, double* median_sigma) {
  std::vector<io::PlyPoint> cloud;
  cloud.reserve(frame.points.size());
  std::vector<float> sigmas;
  sigmas.reserve(frame.points.size());
  for (const auto& p : frame.points) {
    io::PlyPoint q;
    q.x = p.point_in_cam.x();
    q.y = p.point_in_cam.y();
    q.z = p.point_in_cam.z();
    q.blue = p.bgr[0];
    q.green = p.bgr[1];
    q.red = p.bgr[2];
    q.sigma_mm = p.sigma_mm;
    cloud.push_back(q);
    sigmas.push_back(p.sigma_mm);
  }
  *median_sigma = 0;
  if (!sigmas.empty()) {
    std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
    *median_sigma = sigmas[sigmas.size() / 2];
  }
  return cloud;
}

// Writes the panoramas, the disparity images (16-bit 16 d, and an 8-bit view scaled to the
// disparity range) and the cloud; returns the points' median sigma (mm; 0 without points).
double WriteDepthFrame(const stereo::DepthFrame& frame, const stereo::DepthOptions& options,
                       const std::string& dir) {
  cv::Mat valid = frame.disparity == frame.disparity;  // false at NaN
  cv::Mat d16, d8;
  cv::Mat scaled = frame.disparity * 16.0;
  scaled.setTo(0, ~valid);
  scaled.convertTo(d16, CV_16UC1);
  cv::Mat view = frame.disparity * (255.0 / options.num_disparities);
  view.setTo(0, ~valid);
  view.convertTo(d8, CV_8UC1);
  double median_sigma = 0;
  const std::vector<io::PlyPoint> cloud = Cloud(frame, &median_sigma);
  WriteImageAtomically(dir + "/panorama1.png", frame.panorama[0]);
  WriteImageAtomically(dir + "/panorama2.png", frame.panorama[1]);
  WriteImageAtomically(dir + "/disparity.png", d8);
  WriteImageAtomically(dir + "/disparity16.png", d16);
  io::WritePlyFile(dir + "/cloud.ply", cloud, !FLAGS_ply_ascii);
  return median_sigma;
}

double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// --images: the frames' paths with their output names (the image's stem); InputError if two
// images would write the same name or --image is also given.
std::vector<std::pair<std::string, std::string>> FramesFromFlags() {
  if (!FLAGS_image.empty()) {
    throw io::InputError("--image, --images: expected one of them (--image: one frame and its "
                         "panoramas, disparities and cloud; --images: a cloud per frame)");
  }
  std::vector<std::pair<std::string, std::string>> frames;
  std::map<std::string, std::string> path_of_name;
  for (const std::string& path : ImagesFromFlags()) {
    const std::string name = std::filesystem::path(path).stem().string() + ".ply";
    const auto [it, inserted] = path_of_name.emplace(name, path);
    if (!inserted) {
      throw io::InputError("--images: " + it->second + " and " + path + " would both write " +
                           name + "; expected images of distinct names");
    }
    frames.emplace_back(path, name);
  }
  return frames;
}

// The frames' times: the stages as DepthFrame reports them (main thread), reading and writing
// (their own threads), and the whole loop.
struct FrameTimes {
  double remap = 0, sgbm = 0, triangulation = 0, loop = 0;
  std::atomic<double> read{0}, write{0};
  size_t points = 0;

  void Add(const stereo::DepthFrame& frame) {
    remap += frame.seconds_remap;
    sgbm += frame.seconds_sgbm;
    triangulation += frame.seconds_triangulation;
    points += frame.points.size();
  }
  void Print(size_t frames, size_t skipped, const stereo::DenseStereo& dense, double setup_s,
             const std::string& dir) const {
    const double n = static_cast<double>(frames);
    std::printf("depth: %zu frames%s, panoramas %dx%d, %.0f points per frame; set-up %.2f s; per "
                "frame: remap %.1f, SGBM %.1f, triangulation %.1f ms (%.1f frames/s computing), "
                "reading %.1f and writing %.1f ms alongside; %.1f frames/s in all -> %s/*.ply\n",
                frames, skipped ? (" (" + std::to_string(skipped) + " skipped)").c_str() : "",
                dense.luts().geometry.width, dense.luts().geometry.height, points / n,
                setup_s, 1e3 * remap / n, 1e3 * sgbm / n, 1e3 * triangulation / n,
                n / (remap + sgbm + triangulation), 1e3 * read / n, 1e3 * write / n, n / loop,
                dir.c_str());
  }
};

// A frame's progress line.
std::string FrameLine(const std::string& name, const stereo::DepthFrame& frame,
                      double median_sigma) {
  char line[200];
  std::snprintf(line, sizeof(line), "%s: %zu points (median sigma %.1f mm); remap %.1f, SGBM "
                "%.1f, triangulation %.1f ms", name.c_str(), frame.points.size(), median_sigma,
                1e3 * frame.seconds_remap, 1e3 * frame.seconds_sgbm,
                1e3 * frame.seconds_triangulation);
  return line;
}

// Every frame through one DenseStereo; DIR/<name>.ply per frame, a summary of the stages' mean
// times and the frame rate. The next frame is read and the last cloud written on threads of their
// own while a frame is computed (decoding a frame costs about half its computing), so a frame's
// wall time is its computing plus what the three contend for.
int RunDepthFrames(const RigModel& model) {
  const auto frames = FramesFromFlags();
  stereo::DepthOptions options = OptionsFromFlags();
  options.full_panoramas = false;  // only the clouds are written
  const stereo::PanoramaOptions panorama = PanoramaOptionsFromFlags();
  const std::string dir = RequireOutputFolder();

  ProgressLine progress("depth", static_cast<int>(frames.size()));
  auto t0 = std::chrono::steady_clock::now();
  progress.Status("panorama maps and ray tables");
  const stereo::DenseStereo dense(model, panorama, options);
  const double setup_s = SecondsSince(t0);
  FrameTimes times;
  auto read = [&](size_t i) {
    const auto start = std::chrono::steady_clock::now();
    cv::Mat image = ReadModelImage(model, frames[i].first);
    times.read = times.read + SecondsSince(start);
    return image;
  };
  t0 = std::chrono::steady_clock::now();
  std::future<cv::Mat> next = std::async(std::launch::async, read, size_t{0});
  std::future<void> writing;  // the last frame's cloud
  // A frame that cannot be read (or has another size) is skipped with a warning: one bad frame of
  // a long recording does not stop the others. Every frame bad: an error.
  size_t computed = 0;
  std::string first_error;
  for (size_t i = 0; i < frames.size(); ++i) {
    cv::Mat image;
    try {
      image = next.get();
    } catch (const io::InputError& e) {
      if (first_error.empty()) first_error = e.what();
      if (i + 1 < frames.size()) next = std::async(std::launch::async, read, i + 1);
      progress.Done(std::string("warning: ") + e.what() + "; skipped");
      continue;
    }
    if (i + 1 < frames.size()) next = std::async(std::launch::async, read, i + 1);
    const stereo::DepthFrame frame = dense.Compute(image);
    times.Add(frame);
    ++computed;
    double median_sigma = 0;
    std::vector<io::PlyPoint> cloud = Cloud(frame, &median_sigma);
    if (writing.valid()) writing.get();
    writing = std::async(std::launch::async, [&times, path = dir + "/" + frames[i].second,
                                              cloud = std::move(cloud)] {
      const auto start = std::chrono::steady_clock::now();
      io::WritePlyFile(path, cloud, !FLAGS_ply_ascii);
      times.write = times.write + SecondsSince(start);
    });
    progress.Done(FrameLine(frames[i].second, frame, median_sigma));
  }
  if (writing.valid()) writing.get();
  times.loop = SecondsSince(t0);
  progress.Finish();
  if (computed == 0) {
    throw io::InputError("none of the " + std::to_string(frames.size()) +
                         " frames could be used (the first: " + first_error + ")");
  }
  times.Print(computed, frames.size() - computed, dense, setup_s, dir);
  return 0;
}

}  // namespace

int RunDepth() {
  const RigModel model(io::ReadModelFile(RequireStereoFlag(FLAGS_model, "model", "a model file")));
  if (!FLAGS_images.empty()) return RunDepthFrames(model);
  RequireStereoFlag(FLAGS_image, "image",
                    "a raw omnidirectional image (or --images: a video's frames, a glob or list)");
  const cv::Mat image = ReadModelImage(model);
  const std::string dir = RequireOutputFolder();
  const stereo::DepthOptions options = OptionsFromFlags();

  ProgressLine progress("depth", 0);
  auto t0 = std::chrono::steady_clock::now();
  progress.Status("panorama maps and ray tables");
  const stereo::DenseStereo dense(model, PanoramaOptionsFromFlags(), options);
  const double setup_s = SecondsSince(t0);
  progress.Status("matching and triangulation");
  const stereo::DepthFrame frame = dense.Compute(image);
  progress.Status("writing " + dir);
  const double median_sigma = WriteDepthFrame(frame, options, dir);
  progress.Finish();

  const int band_pixels =
      (frame.band_row_end - frame.band_row_begin) * frame.disparity.cols;
  std::printf("depth: panoramas %dx%d, matched rows %d..%d, %zu points of %d band pixels "
              "(median sigma %.1f mm at sigma_px %g)\n",
              frame.disparity.cols, frame.disparity.rows, frame.band_row_begin,
              frame.band_row_end, frame.points.size(), band_pixels, median_sigma,
              options.sigma_px);
  std::printf("time: setup (LUTs, ray tables) %.2f s; per frame: remap %.1f ms, SGBM %.1f ms, "
              "triangulation %.1f ms -> %s/cloud.ply\n",
              setup_s, 1e3 * frame.seconds_remap, 1e3 * frame.seconds_sgbm,
              1e3 * frame.seconds_triangulation, dir.c_str());
  if (frame.points.empty()) std::fprintf(stderr, "depth: warning: no stereo match in the image\n");
  return 0;
}

}  // namespace omni::apps
