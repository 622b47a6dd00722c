#include "detectors/lips/rim_edge.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "model/conic.h"
#include "model/lip.h"
#include "model/single_rim.h"

namespace omni::detectors {
namespace {

// Bilinear grey level at (x, y) of a CV_32F image; false outside.
bool Sample(const cv::Mat& img, double x, double y, double* value) {
  if (!(x >= 0 && y >= 0 && x <= img.cols - 1 && y <= img.rows - 1)) return false;
  const int x0 = std::min(static_cast<int>(x), img.cols - 2);
  const int y0 = std::min(static_cast<int>(y), img.rows - 2);
  const double fx = x - x0, fy = y - y0;
  const float* r0 = img.ptr<float>(y0);
  const float* r1 = img.ptr<float>(y0 + 1);
  *value = (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) +
           fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
  return true;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

struct RayEdge {
  Eigen::Vector2d point;
  double offset = 0;  // along the ray from the model's rim point (px, + outwards)
  double drop = 0;
};

}  // namespace

std::string RimEdgeOptions::Check() const {
  if (rays < 16) return "rays: expected at least 16";
  if (!(band_fraction > 0) || !(min_band_px > 0)) return "band_fraction, min_band_px: expected > 0";
  if (!(min_drop_fraction >= 0 && min_drop_fraction < 1)) return "min_drop_fraction: expected 0..1";
  if (!(min_coverage > 0 && min_coverage <= 1)) return "min_coverage: expected 0..1";
  return "";
}

std::optional<LipEdgeObservation> DetectRimEdge(const cv::Mat& grey, const RigModel& model,
                                                const RimEdgeOptions& options, std::string* why) {
  if (const std::string error = options.Check(); !error.empty()) throw std::invalid_argument(error);
  const RigParams& rig = model.params();
  if (!rig.Single()) throw std::invalid_argument("DetectRimEdge: a single-mirror rig expected");
  if (grey.channels() != 1) throw std::invalid_argument("DetectRimEdge: one channel expected");
  auto fail = [&](const std::string& text) -> std::optional<LipEdgeObservation> {
    if (why) *why = text;
    return std::nullopt;
  };
  cv::Mat img;
  grey.convertTo(img, CV_32F, grey.depth() == CV_16U ? 1.0 / 257.0 : 1.0);

  // The model's rim curve and its centre.
  const RigBlocks<double> blocks = RigBlocksOf(rig);
  const double z = SingleRimZ(rig);
  std::vector<Eigen::Vector2d> curve(options.rays);
  std::vector<bool> seen(options.rays, false);
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  int n_seen = 0;
  for (int k = 0; k < options.rays; ++k) {
    const double phi = 2 * M_PI * (k + 0.5) / options.rays;
    Eigen::Vector2d px;
    if (!ProjectLipPoint(blocks, model.fixed(), LipPath::kDirect, rig.r_sys, z, phi, &px)) continue;
    curve[k] = px;
    seen[k] = true;
    centre += px;
    ++n_seen;
  }
  if (n_seen < options.rays / 2) return fail("the model's rim does not project into the image");
  centre /= n_seen;
  double radius = 0;
  for (int k = 0; k < options.rays; ++k) {
    if (seen[k]) radius += (curve[k] - centre).norm() / n_seen;
  }
  const double band = std::max(options.min_band_px, options.band_fraction * radius);

  // Per ray: the steepest drop (inside minus outside, +-1 px apart) within +-band.
  constexpr double kStep = 0.25;
  std::vector<RayEdge> edges;
  for (int k = 0; k < options.rays; ++k) {
    if (!seen[k]) continue;
    const Eigen::Vector2d dir = (curve[k] - centre).normalized();
    std::vector<double> d;
    for (double t = -band; t <= band + 1e-9; t += kStep) {
      const Eigen::Vector2d p = curve[k] + t * dir;
      double in = 0, out = 0;
      const bool ok = Sample(img, p.x() - dir.x(), p.y() - dir.y(), &in) &&
                      Sample(img, p.x() + dir.x(), p.y() + dir.y(), &out);
      d.push_back(ok ? (in - out) / 2 : -HUGE_VAL);
    }
    int at = -1;
    double best = 0;
    for (int i = 1; i + 1 < static_cast<int>(d.size()); ++i) {
      if (d[i] > best && d[i] >= d[i - 1] && d[i] >= d[i + 1]) best = d[i], at = i;
    }
    if (at < 0) continue;
    const double prev = d[at - 1], next = d[at + 1];
    const double curvature = prev - 2 * best + next;
    const double shift = curvature < 0 ? std::clamp(0.5 * (prev - next) / curvature, -0.5, 0.5) : 0;
    const double t = -band + (at + shift) * kStep;
    edges.push_back({curve[k] + t * dir, t, best});
  }
  std::vector<double> drops;
  for (const RayEdge& e : edges) drops.push_back(e.drop);
  const double median_drop = Median(drops);
  std::vector<RayEdge> strong;
  for (const RayEdge& e : edges) {
    if (e.drop >= options.min_drop_fraction * median_drop) strong.push_back(e);
  }
  // The curve's offset is smooth over the azimuth (the model a little off): points far from the
  // median offset by more than 3 robust sigmas are a holder, a reflection or the scene's own edge.
  std::vector<double> offsets;
  for (const RayEdge& e : strong) offsets.push_back(e.offset);
  const double median_offset = Median(offsets);
  std::vector<double> deviations;
  for (double o : offsets) deviations.push_back(std::abs(o - median_offset));
  const double sigma = std::max(0.1, 1.4826 * Median(deviations));
  LipEdgeObservation out;
  out.mirror = Mirror::kOne;
  out.edge = BandEdge::kOuter;
  out.circle = LipCircle::kOuter;
  out.path = LipPath::kDirect;
  for (const RayEdge& e : strong) {
    if (std::abs(e.offset - median_offset) <= 3 * sigma) out.points.push_back(e.point);
  }
  if (out.points.size() < options.min_coverage * options.rays) {
    return fail("the rim's edge found on " + std::to_string(out.points.size()) + " of " +
                std::to_string(options.rays) + " rays");
  }
  return out;
}

}  // namespace omni::detectors
