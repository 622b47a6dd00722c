// `omnistereo depth --model M --image I --out DIR`: dense stereo on the panoramas
// (stereo/dense_stereo.h): writes DIR/panorama1.png, DIR/panorama2.png, DIR/disparity.png
// (8-bit view, brighter = nearer, black = no match), DIR/disparity16.png (16-bit, 16 x d, 0 = no
// match; d as in dense_stereo.h: v2 = v1 - d) and DIR/cloud.ply (points in C, mm, colour, per-point
// sigma_mm).
// `omnistereo depth --model M --images 'frames/*.jpg' --out DIR` (a video's frames; globs and
// lists): one set-up (maps, ray tables) for all frames, then DIR/<image name>.ply per frame, in
// order, with a progress line. A frame that cannot be read or is not the model's size is skipped
// with a warning naming it; when no frame can be used, exit 2.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <future>
#include <map>
#include <string>
#include <vector>

#include <gflags/gflags.h>
#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/progress.h"
#include "apps/stereo_cli.h"
#include "io/model_file.h"
#include "io/ply.h"
#include "stereo/dense_stereo.h"
#include "stereo/depth_frames.h"

DEFINE_int32(num_disparities, 64, "SGBM disparity range in panorama rows (multiple of 16)");
DEFINE_int32(block_size, 5, "SGBM block size (odd)");
DEFINE_double(max_sigma_mm, 0, "drop points whose sigma exceeds this (mm); 0 keeps all");
DEFINE_bool(ply_ascii, false, "write the PLY as text instead of binary");

namespace omni::apps {
namespace {

// The flags as dense-stereo options; throws io::InputError naming the flag.
stereo::DepthOptions OptionsFromFlags() {
  stereo::DepthOptions options;
  options.num_disparities = FLAGS_num_disparities;
  options.block_size = FLAGS_block_size;
  options.sigma_px = FLAGS_sigma_px;
  options.max_sigma_mm = FLAGS_max_sigma_mm;
  if (const std::string error = options.Check(); !error.empty()) {
    throw io::InputError("--" + error);  // the flags have the fields' names
  }
  return options;
}

// The frame's points as PLY vertices.
std::vector<io::PlyPoint> Cloud(const stereo::DepthFrame& frame) {
  std::vector<io::PlyPoint> cloud;
  cloud.reserve(frame.points.size());
  for (const auto& p : frame.points) {
    cloud.push_back({p.point_in_cam.x(), p.point_in_cam.y(), p.point_in_cam.z(), p.bgr[2],
                     p.bgr[1], p.bgr[0], p.sigma_mm});
  }
  return cloud;
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

// Every frame through one DenseStereo (stereo/depth_frames.h); DIR/<name>.ply per frame, a
// summary of the stages' mean times and the frame rate.
int RunDepthFrames(const RigModel& model) {
  const auto frames = FramesFromFlags();
  stereo::DepthOptions options = OptionsFromFlags();
  options.full_panoramas = false;  // only the clouds are written
  const stereo::PanoramaOptions panorama = PanoramaOptionsFromFlags();
  const std::string dir = RequireOutputFolder();

  ProgressLine progress("depth", static_cast<int>(frames.size()));
  const auto t0 = std::chrono::steady_clock::now();
  const auto read = [&](size_t i) { return ReadModelImage(model, frames[i].first); };
  std::future<cv::Mat> first;  // frame 0, read alongside the set-up
  if (!frames.empty()) first = stereo::StartReading(read);
  progress.Status("panorama maps and ray tables");
  const stereo::DenseStereo dense(model, panorama, options);
  const double setup_s = SecondsSince(t0);
  const stereo::FramesReport report = stereo::ComputeFrames(
      dense, frames.size(), read,
      [&](size_t i, const stereo::DepthFrame& frame) -> std::function<void()> {
        progress.Done(stereo::FrameLine(frames[i].second, frame));
        return [path = dir + "/" + frames[i].second, cloud = Cloud(frame)] {
          io::WritePlyFile(path, cloud, !FLAGS_ply_ascii);
        };
      },
      [&](size_t, const std::string& what) { progress.Done("warning: " + what + "; skipped"); },
      std::move(first));
  progress.Finish();
  if (report.computed == 0) {
    throw io::InputError("none of the " + std::to_string(frames.size()) +
                         " frames could be used (the first: " + report.first_error + ")");
  }
  std::printf("%s -> %s/*.ply\n",
              stereo::FramesSummary(report, frames.size(), dense, setup_s).c_str(), dir.c_str());
  return 0;
}

}  // namespace

int RunDepth() {
  const RigParams rig = io::ReadModelFile(RequireStereoFlag(FLAGS_model, "model", "a model file"));
  RequireTwoRings(rig, FLAGS_model, "depth matches two rings' panoramas (two viewpoints); "
                  "`panorama` unwarps its one ring");
  const RigModel model(rig);
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
  WriteImageAtomically(dir + "/panorama1.png", frame.panorama[0]);
  WriteImageAtomically(dir + "/panorama2.png", frame.panorama[1]);
  WriteImageAtomically(dir + "/disparity.png", stereo::DisparityView(frame, options.num_disparities));
  WriteImageAtomically(dir + "/disparity16.png", stereo::Disparity16(frame));
  io::WritePlyFile(dir + "/cloud.ply", Cloud(frame), !FLAGS_ply_ascii);
  progress.Finish();
  std::printf("%s", stereo::FrameSummary(frame, options.sigma_px, setup_s, dir + "/cloud.ply")
                        .c_str());
  if (frame.points.empty()) std::fprintf(stderr, "depth: warning: no stereo match in the image\n");
  return 0;
}

}  // namespace omni::apps
