#include "detectors/lips/rim_edge.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "detectors/lips/grey_sampling.h"
#include "model/conic.h"
#include "model/lip.h"
#include "model/single_rim.h"

namespace omni::detectors {
namespace {

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
  // The rim circle (lip1: r_sys at the conic's sag; or, for `check`, the mirror circle that the
  // edge is where it is not the rim, model/single_rim.h WithRimCircleAt).
  const double z = rig.lip1.z;
  const double rim_radius = rig.lip1.r_outer;
  std::vector<Eigen::Vector2d> curve(options.rays);
  std::vector<bool> seen(options.rays, false);
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  int n_seen = 0;
  for (int k = 0; k < options.rays; ++k) {
    const double phi = 2 * M_PI * (k + 0.5) / options.rays;
    Eigen::Vector2d px;
    if (!ProjectLipPoint(blocks, model.fixed(), LipPath::kDirect, rim_radius, z, phi, &px)) continue;
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

  // Per ray: the rim is the step from the mirror's image to what lies beyond it. Its sign is the
  // photo's: the mirror's outermost band often reflects the camera's own dark body (renders, most
  // real rigs) against a brighter room beyond, or a bright reflection meets a dark housing; so
  // both signs are measured and the photo's is the one most rays show. A texture edge in the
  // reflection next to the rim can be as steep over +-1 px, but not over a few pixels, so the step
  // between the means over 1..kWide px either side picks the rim, and the steepest +-1 px step of
  // that sign within 1.5 px of it places it (sub-pixel, by a parabola: a blurred step's steepest
  // point in linear light is at its halfway level).
  constexpr double kStep = 0.25;
  constexpr int kWide = 4;
  struct Profile {
    std::vector<double> narrow, wide;  // inside minus outside
  };
  std::vector<Profile> profiles(options.rays);
  std::vector<Eigen::Vector2d> dirs(options.rays, Eigen::Vector2d::Zero());
  int votes[2] = {0, 0};  // rays whose strongest wide step is a drop (inside brighter), a rise
  for (int k = 0; k < options.rays; ++k) {
    if (!seen[k]) continue;
    dirs[k] = (curve[k] - centre).normalized();
    auto step = [&](double t, double half) {
      const Eigen::Vector2d p = curve[k] + t * dirs[k];
      double in = 0, out = 0;
      return SampleBilinear(img, p.x() - half * dirs[k].x(), p.y() - half * dirs[k].y(), &in) &&
                     SampleBilinear(img, p.x() + half * dirs[k].x(), p.y() + half * dirs[k].y(), &out)
                 ? (in - out) / 2
                 : std::nan("");
    };
    Profile& profile = profiles[k];
    double strongest = 0;
    for (double t = -band; t <= band + 1e-9; t += kStep) {
      profile.narrow.push_back(step(t, 1));
      double sum = 0;
      for (int s = 1; s <= kWide; ++s) sum += step(t, s);
      profile.wide.push_back(sum / kWide);
      if (std::abs(profile.wide.back()) > std::abs(strongest)) strongest = profile.wide.back();
    }
    if (strongest != 0) ++votes[strongest > 0 ? 0 : 1];
  }
  const double sign = votes[0] >= votes[1] ? 1.0 : -1.0;
  std::vector<RayEdge> edges;
  for (int k = 0; k < options.rays; ++k) {
    if (!seen[k]) continue;
    const std::vector<double>& narrow = profiles[k].narrow;
    const std::vector<double>& wide = profiles[k].wide;
    int wide_at = -1;
    double wide_best = 0;
    for (int i = 0; i < static_cast<int>(wide.size()); ++i) {
      if (sign * wide[i] > wide_best) wide_best = sign * wide[i], wide_at = i;
    }
    if (wide_at < 0) continue;
    const int reach = static_cast<int>(1.5 / kStep);
    int at = -1;
    double best = 0;
    for (int i = std::max(1, wide_at - reach);
         i <= std::min(static_cast<int>(narrow.size()) - 2, wide_at + reach); ++i) {
      const double v = sign * narrow[i];
      if (v > best && v >= sign * narrow[i - 1] && v >= sign * narrow[i + 1]) best = v, at = i;
    }
    if (at < 0) continue;
    const double prev = sign * narrow[at - 1], next = sign * narrow[at + 1];
    const double curvature = prev - 2 * best + next;
    const double shift = curvature < 0 ? std::clamp(0.5 * (prev - next) / curvature, -0.5, 0.5) : 0;
    const double t = -band + (at + shift) * kStep;
    edges.push_back({curve[k] + t * dirs[k], t, wide_best});
  }
  std::vector<double> drops;
  for (const RayEdge& e : edges) drops.push_back(e.drop);
  const double median_drop = MedianOf(drops);
  std::vector<RayEdge> strong;
  for (const RayEdge& e : edges) {
    if (e.drop >= options.min_drop_fraction * median_drop) strong.push_back(e);
  }
  // The edge's offset from the start's curve is smooth over the azimuth: a start off in centre,
  // scale or tilt moves it by a constant plus first and second harmonics (a 2 px decentre alone
  // swings it +-2 px). Points farther than 3 robust sigmas (MAD) from that fit are a holder, a
  // reflection or the scene's own edge; fitted twice, the second time on the kept points.
  std::vector<bool> keep(strong.size(), true);
  Eigen::Matrix<double, 5, 1> harmonics = Eigen::Matrix<double, 5, 1>::Zero();
  auto basis = [&](const RayEdge& e) {
    const double phi = std::atan2(e.point.y() - centre.y(), e.point.x() - centre.x());
    Eigen::Matrix<double, 5, 1> b;
    b << 1, std::cos(phi), std::sin(phi), std::cos(2 * phi), std::sin(2 * phi);
    return b;
  };
  double sigma = 0;
  for (int round = 0; round < 3; ++round) {
    Eigen::Matrix<double, 5, 5> normal = Eigen::Matrix<double, 5, 5>::Zero();
    Eigen::Matrix<double, 5, 1> rhs = Eigen::Matrix<double, 5, 1>::Zero();
    int used = 0;
    for (size_t i = 0; i < strong.size(); ++i) {
      if (!keep[i]) continue;
      const auto b = basis(strong[i]);
      normal += b * b.transpose();
      rhs += b * strong[i].offset;
      ++used;
    }
    if (used < 10) break;
    harmonics = normal.ldlt().solve(rhs);
    std::vector<double> deviations;
    for (size_t i = 0; i < strong.size(); ++i) {
      if (keep[i]) deviations.push_back(std::abs(strong[i].offset - basis(strong[i]).dot(harmonics)));
    }
    sigma = std::max(0.1, 1.4826 * MedianOf(deviations));
    for (size_t i = 0; i < strong.size(); ++i) {
      keep[i] = std::abs(strong[i].offset - basis(strong[i]).dot(harmonics)) <= 3 * sigma;
    }
  }
  LipEdgeObservation out;
  out.mirror = Mirror::kOne;
  out.edge = BandEdge::kOuter;
  out.circle = LipCircle::kOuter;
  out.path = LipPath::kDirect;
  for (size_t i = 0; i < strong.size(); ++i) {
    if (keep[i]) out.points.push_back(strong[i].point);
  }
  if (out.points.size() < options.min_coverage * options.rays) {
    return fail("the rim's edge found on " + std::to_string(out.points.size()) + " of " +
                std::to_string(options.rays) + " rays");
  }
  return out;
}

}  // namespace omni::detectors
