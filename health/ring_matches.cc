#include "health/ring_matches.h"

#include <algorithm>

#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "stereo/dense_stereo.h"

namespace omni::health {
namespace {

// The raw pixel of panorama point (u, v) of `mirror`: the LUTs interpolated bilinearly; false
// where a neighbouring entry is invalid (-1) or outside.
bool RawPixel(const stereo::PanoramaLuts& luts, Mirror mirror, double u, double v,
              Eigen::Vector2d* pixel) {
  const int i = mirror == Mirror::kOne ? 0 : 1;
  const cv::Mat& mx = luts.map_x[i];
  const cv::Mat& my = luts.map_y[i];
  const int u0 = static_cast<int>(std::floor(u)), v0 = static_cast<int>(std::floor(v));
  if (u0 < 0 || v0 < 0 || u0 + 1 >= mx.cols || v0 + 1 >= mx.rows) return false;
  const double fu = u - u0, fv = v - v0;
  double x = 0, y = 0;
  for (int dv = 0; dv < 2; ++dv) {
    for (int du = 0; du < 2; ++du) {
      const float ex = mx.at<float>(v0 + dv, u0 + du), ey = my.at<float>(v0 + dv, u0 + du);
      if (ex < 0 || ey < 0) return false;
      const double w = (du ? fu : 1 - fu) * (dv ? fv : 1 - fv);
      x += w * ex;
      y += w * ey;
    }
  }
  *pixel = Eigen::Vector2d(x, y);
  return true;
}

cv::Mat Grey(const cv::Mat& panorama) {
  if (panorama.channels() == 1) return panorama;
  cv::Mat grey;
  cv::cvtColor(panorama, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

// Columns of a panorama whose window reaches into a post's sector (or any other obstruction
// that crosses the band): a column is blocked where more than a fifth of `rows` is invalid in the
// LUT (the posts cross both rings from lip to lip; the ring's own edges invalidate a few rows of
// some columns at most), and the flag is spread `reach` columns either way, around the azimuth.
// Why: a track whose window straddles a post's edge follows the post's silhouette, which lies on
// no epipolar curve of the scene behind it (the post is millimetres from the mirrors and each
// ring sees its edge against another part of the room); those matches bordered every post at
// 10+ sigma on a mounted rig's own calibration photos.
std::vector<bool> BlockedColumns(const cv::Mat& map_x, cv::Range rows, int reach) {
  const int w = map_x.cols;
  std::vector<bool> blocked(w, false);
  rows.start = std::max(rows.start, 0);
  rows.end = std::min(rows.end, map_x.rows);
  if (rows.empty()) return blocked;
  std::vector<int> invalid(w, 0);
  for (int v = rows.start; v < rows.end; ++v) {
    const float* x = map_x.ptr<float>(v);
    for (int u = 0; u < w; ++u) invalid[u] += x[u] < 0;
  }
  for (int u = 0; u < w; ++u) {
    if (5 * invalid[u] <= rows.size()) continue;
    for (int k = -reach; k <= reach; ++k) blocked[((u + k) % w + w) % w] = true;
  }
  return blocked;
}

}  // namespace

struct RingMatcher::Impl {
  Impl(const RigModel& model, const RingMatchOptions& o)
      : options(o), stereo(model, PanoramaOf(model, o), stereo::DepthOptions{}) {}
  static stereo::PanoramaOptions PanoramaOf(const RigModel& model, const RingMatchOptions& o) {
    stereo::PanoramaOptions p;
    p.width = o.panorama_width > 0 ? o.panorama_width
                                   : std::min(model.params().image_width, o.max_panorama_width);
    return p;
  }
  RingMatchOptions options;
  stereo::DenseStereo stereo;
};

RingMatcher::RingMatcher(const RigModel& model, const RingMatchOptions& options)
    : impl_(std::make_unique<Impl>(model, options)) {}
RingMatcher::~RingMatcher() = default;

std::vector<RingMatch> RingMatcher::Match(const cv::Mat& image) const {
  const RingMatchOptions& o = impl_->options;
  const stereo::DepthFrame frame = impl_->stereo.Disparity(image);
  const stereo::PanoramaLuts& luts = impl_->stereo.luts();
  const cv::Mat grey1 = Grey(frame.panorama[0]), grey2 = Grey(frame.panorama[1]);

  // Features of Xi_1 where SGBM found a disparity, away from the panorama's sides (the track's
  // window does not wrap around the azimuth).
  const int margin = o.window_px;
  cv::Mat mask = cv::Mat::zeros(grey1.size(), CV_8U);
  for (int v = frame.band_row_begin; v < frame.band_row_end; ++v) {
    const float* d = frame.disparity.ptr<float>(v);
    for (int u = margin; u < grey1.cols - margin; ++u) {
      if (std::isfinite(d[u]) && v - d[u] >= margin) mask.at<std::uint8_t>(v, u) = 255;
    }
  }
  std::vector<cv::Point2f> features;
  cv::goodFeaturesToTrack(grey1, features, o.max_features, o.quality_level, o.min_distance_px,
                          mask, 5);
  std::vector<RingMatch> matches;
  if (features.empty()) return matches;

  std::vector<cv::Point2f> start(features.size()), tracked, back;
  for (size_t k = 0; k < features.size(); ++k) {
    const float d = frame.disparity.at<float>(cvRound(features[k].y), cvRound(features[k].x));
    start[k] = cv::Point2f(features[k].x, features[k].y - d);
  }
  tracked = start;
  back = features;
  std::vector<std::uint8_t> status, status_back;
  std::vector<float> error;
  const cv::Size window(o.window_px, o.window_px);
  const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 40, 1e-3);
  cv::calcOpticalFlowPyrLK(grey1, grey2, features, tracked, status, error, window,
                           o.pyramid_levels, stop, cv::OPTFLOW_USE_INITIAL_FLOW);
  cv::calcOpticalFlowPyrLK(grey2, grey1, tracked, back, status_back, error, window,
                           o.pyramid_levels, stop, cv::OPTFLOW_USE_INITIAL_FLOW);
  const stereo::PanoramaGeometry& g = luts.geometry;
  // Posts' sectors: half the track's window plus the mount's margin either side.
  const int reach = o.window_px / 2 + static_cast<int>(std::ceil(o.mount_margin_deg * M_PI / 180 /
                                                                 (2 * M_PI / g.width)));
  const std::vector<bool> blocked1 = BlockedColumns(
      luts.map_x[0], cv::Range(frame.band_row_begin, frame.band_row_end), reach);
  const std::vector<bool> blocked2 = BlockedColumns(
      luts.map_x[1], cv::Range(frame.band_row_begin - static_cast<int>(o.max_offset_px) - margin,
                               frame.band_row_end), reach);
  auto column = [&](float u) { return std::clamp(cvRound(u), 0, g.width - 1); };
  for (size_t k = 0; k < features.size(); ++k) {
    if (!status[k] || !status_back[k]) continue;
    if (blocked1[column(features[k].x)] || blocked2[column(tracked[k].x)]) continue;
    const cv::Point2f offset = tracked[k] - start[k];
    if (std::abs(offset.x) > o.max_offset_px || std::abs(offset.y) > o.max_offset_px) continue;
    if (cv::norm(back[k] - features[k]) > o.max_round_trip_px) continue;
    RingMatch m;
    if (!RawPixel(luts, Mirror::kOne, features[k].x, features[k].y, &m.pixel1) ||
        !RawPixel(luts, Mirror::kTwo, tracked[k].x, tracked[k].y, &m.pixel2)) {
      continue;
    }
    m.azimuth = g.Azimuth(features[k].x);
    m.elevation = g.Elevation(features[k].y);
    m.sideways_px = offset.x;
    matches.push_back(m);
  }
  return matches;
}

}  // namespace omni::health
