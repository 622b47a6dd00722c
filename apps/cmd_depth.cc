// `omnistereo depth --model M --image I --out DIR`: dense stereo on the panoramas
// (model/stereo/dense_stereo.h): writes DIR/panorama1.png, DIR/panorama2.png, DIR/disparity.png
// (8-bit view, brighter = nearer, black = no match), DIR/disparity16.png (16-bit, 16 x d, 0 = no
// match; d as in dense_stereo.h: v2 = v1 - d) and DIR/cloud.ply (points in C, mm, colour, per-point
// sigma_mm).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gflags/gflags.h>
#include <opencv2/imgproc.hpp>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/progress.h"
#include "apps/stereo_cli.h"
#include "model/io/model_file.h"
#include "model/io/ply.h"
#include "model/stereo/dense_stereo.h"

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

  std::vector<io::PlyPoint> cloud;
  cloud.reserve(frame.points.size());
  std::vector<float> sigmas;
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
  WriteImageAtomically(dir + "/panorama1.png", frame.panorama[0]);
  WriteImageAtomically(dir + "/panorama2.png", frame.panorama[1]);
  WriteImageAtomically(dir + "/disparity.png", d8);
  WriteImageAtomically(dir + "/disparity16.png", d16);
  io::WritePlyFile(dir + "/cloud.ply", cloud, !FLAGS_ply_ascii);
  if (sigmas.empty()) return 0;
  std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
  return sigmas[sigmas.size() / 2];
}

}  // namespace

int RunDepth() {
  const RigModel model(io::ReadModelFile(RequireStereoFlag(FLAGS_model, "model", "a model file")));
  const cv::Mat image = ReadModelImage(model);
  const std::string dir = RequireOutputFolder();
  const stereo::DepthOptions options = OptionsFromFlags();

  ProgressLine progress("depth", 0);
  auto t0 = std::chrono::steady_clock::now();
  progress.Status("panorama maps and ray tables");
  const stereo::DenseStereo dense(model, PanoramaOptionsFromFlags(), options);
  const double setup_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
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
