#include "detectors/apriltag/tag_grid_check.h"

#include <algorithm>
#include <optional>
#include <set>
#include <stdexcept>

#include <opencv2/calib3d.hpp>

#include "detectors/common/option_check.h"

namespace omni::detectors {

std::string TagGridCheckOptions::Check() const {
  if (!(max_residual_px > 0)) return OptionError("max_residual_px", "a tolerance > 0 raw px", max_residual_px);
  if (min_corners < 4) return OptionError("min_corners", "at least 4 corners (a homography)", min_corners);
  return "";
}

std::vector<GridFit> CornersFittingTargetHomography(const std::vector<RingView>& views,
                                                    const RigModel& model,
                                                    const std::vector<GridCorner>& corners,
                                                    const TagGridCheckOptions& options) {
  if (const std::string error = options.Check(); !error.empty()) throw std::invalid_argument(error);
  const std::size_t n = corners.size();
  std::vector<GridFit> out(n);
  for (GridFit& f : out) f.keep = options.keep_unchecked;
  std::set<int> used_views;
  for (const GridCorner& c : corners) used_views.insert(c.view);
  for (const int v : used_views) {
    const RingView& view = views[v];
    // Every corner of the target that this view sees, back in the view.
    std::vector<std::size_t> index;
    std::vector<cv::Point2f> plane, in_view;
    for (std::size_t i = 0; i < n; ++i) {
      const auto p = view.RawToView(model, corners[i].raw);
      if (!p) continue;
      index.push_back(i);
      plane.emplace_back(static_cast<float>(corners[i].in_target.x()),
                         static_cast<float>(corners[i].in_target.y()));
      in_view.emplace_back(static_cast<float>(p->x()), static_cast<float>(p->y()));
    }
    const std::size_t m = index.size();
    if (static_cast<int>(m) < std::max(5, options.min_corners)) continue;  // unchecked
    // View pixels per raw pixel here (the median over corner pairs), for RANSAC's tolerance.
    std::vector<double> scale;
    for (std::size_t a = 0; a < m; ++a) {
      for (std::size_t b = a + 1; b < m; ++b) {
        const double raw = (corners[index[a]].raw - corners[index[b]].raw).norm();
        if (raw > 3) scale.push_back(cv::norm(in_view[a] - in_view[b]) / raw);
      }
    }
    if (scale.empty()) continue;
    std::nth_element(scale.begin(), scale.begin() + scale.size() / 2, scale.end());
    const double view_per_raw = scale[scale.size() / 2];
    cv::Mat inlier_mask;
    cv::Mat h = cv::findHomography(plane, in_view, cv::RANSAC,
                                   2 * options.max_residual_px * view_per_raw, inlier_mask, 500,
                                   0.999);
    if (h.empty()) continue;
    std::vector<bool> fits(m);
    for (std::size_t j = 0; j < m; ++j) fits[j] = inlier_mask.at<uchar>(static_cast<int>(j)) != 0;
    // Least squares on the corners within the tolerance, re-judged from each fit: a corner
    // pulled by the ring's edge must not pull the fit that judges it.
    std::vector<double> res(m, -1.0);
    std::vector<cv::Point2f> predicted;
    std::vector<Eigen::Vector2d> predicted_raw(m);
    for (int round = 0; round < 3; ++round) {
      std::vector<cv::Point2f> plane_in, view_in;
      for (std::size_t j = 0; j < m; ++j) {
        if (!fits[j]) continue;
        plane_in.push_back(plane[j]);
        view_in.push_back(in_view[j]);
      }
      if (plane_in.size() < 5) {
        res.assign(m, -1.0);
        break;
      }
      h = cv::findHomography(plane_in, view_in, 0);
      if (h.empty()) {
        res.assign(m, -1.0);
        break;
      }
      cv::perspectiveTransform(plane, predicted, h);
      for (std::size_t j = 0; j < m; ++j) {
        const auto raw = view.ViewToRawExact(model, Eigen::Vector2d(predicted[j].x, predicted[j].y));
        res[j] = raw ? (*raw - corners[index[j]].raw).norm() : 1e9;
        if (raw) predicted_raw[j] = *raw;
        fits[j] = res[j] <= options.max_residual_px;
      }
    }
    // Judged here: the corners whose tag was found in this view.
    for (std::size_t j = 0; j < m; ++j) {
      const std::size_t i = index[j];
      if (corners[i].view != v) continue;
      GridFit& f = out[i];
      f.residual_px = res[j];
      f.keep = res[j] >= 0 && res[j] <= options.max_residual_px;
      if (res[j] >= 0) {
        f.predicted_in_view = Eigen::Vector2d(predicted[j].x, predicted[j].y);
        f.predicted_raw = predicted_raw[j];
      }
    }
  }
  return out;
}

}  // namespace omni::detectors
