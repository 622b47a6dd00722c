// Dense stereo over many frames (a video's, `depth --images`) through one DenseStereo, and the
// images a frame's disparity is shown as.
#pragma once

#include <cstddef>
#include <functional>
#include <future>
#include <string>

#include <opencv2/core.hpp>

#include "stereo/dense_stereo.h"

namespace omni::stereo {

// The disparity as a 16-bit image, 16 x d (0 = no match; d as in dense_stereo.h: v2 = v1 - d).
cv::Mat Disparity16(const DepthFrame& frame);
// The disparity as an 8-bit view: 255 at num_disparities (brighter = nearer), 0 = no match.
cv::Mat DisparityView(const DepthFrame& frame, int num_disparities);
// The frame's points' median sigma (mm; 0 without points).
double MedianSigma(const DepthFrame& frame);

// What a frame loop took: the stages as DepthFrame reports them (the computing thread), reading
// and writing (their own threads), the whole loop (s); the frames computed and their points.
struct FramesReport {
  size_t computed = 0;
  std::string first_error;  // the first frame's read error (what() of its InputError)
  double remap = 0, sgbm = 0, triangulation = 0, read = 0, write = 0, loop = 0;
  // The process's CPU time (all threads: computing, reading, writing) over the loop: the figure a
  // machine shared with other work does not inflate the way it does the wall time; frames/s on
  // N idle cores is at most N / (cpu / computed).
  double cpu = 0;
  size_t points = 0;
};

// Every frame i < count through `dense`. read(i) gives frame i (the model's size) and runs on a
// thread of its own while the frame before is computed (decoding costs about half a frame's
// computing); an InputError from it skips the frame (skipped(i, what)): one bad frame of a long
// recording does not stop the others. done(i, frame) runs on the calling thread after frame i is
// computed and returns its writing, run on a thread of its own while the next frame is computed
// (one at a time). A frame's wall time is then its computing plus what the three contend for.
// first: frame 0 when valid, read(0) started by the caller (StartReading) so that it overlaps the
// caller's set-up (a 5 MP PNG decodes in ~0.1 s: a fifth of a 5-frame loop's frame rate); its
// time is then not in report.read. Otherwise frame 0 is read here, in the loop's time.
FramesReport ComputeFrames(const DenseStereo& dense, size_t count,
                           const std::function<cv::Mat(size_t i)>& read,
                           const std::function<std::function<void()>(size_t i, const DepthFrame&)>& done,
                           const std::function<void(size_t i, const std::string& what)>& skipped,
                           std::future<cv::Mat> first = {});
// read(0) on a thread of its own: ComputeFrames' `first`.
std::future<cv::Mat> StartReading(const std::function<cv::Mat(size_t i)>& read);

// A frame's progress line: "NAME: N points (median sigma S mm); remap R, SGBM G, triangulation
// T ms".
std::string FrameLine(const std::string& name, const DepthFrame& frame);
// One frame's summary (`depth --image`): panorama size, matched rows, points of the band's
// pixels with their median sigma at sigma_px; then the set-up's and the stages' times and the
// cloud's path.
std::string FrameSummary(const DepthFrame& frame, double sigma_px, double setup_s,
                         const std::string& cloud_path);
// The loop's summary (`depth --images`): frames computed (and skipped of `count`), panorama
// size, points per frame, the set-up's time, the stages' mean times, the frame rates and the
// process CPU per frame.
std::string FramesSummary(const FramesReport& report, size_t count, const DenseStereo& dense,
                          double setup_s);

}  // namespace omni::stereo
