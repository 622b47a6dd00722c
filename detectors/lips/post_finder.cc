#include "detectors/lips/post_finder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <cstdio>

#include "detectors/lips/grey_sampling.h"
#include "detectors/lips/post_bands.h"
#include "io/file_util.h"
#include "model/ideal_analysis.h"
#include "model/rig_frames.h"

namespace omni::detectors {
namespace {

// Bilinear grey level at p; -1 outside the image.
float GreyAt(const cv::Mat& grey, const Eigen::Vector2d& p) {
  const int u = static_cast<int>(std::floor(p.x())), v = static_cast<int>(std::floor(p.y()));
  if (u < 0 || v < 0 || u + 1 >= grey.cols || v + 1 >= grey.rows) return -1;
  const double fu = p.x() - u, fv = p.y() - v;
  const auto g = [&grey](int x, int y) {
    return grey.depth() == CV_16U ? grey.at<uint16_t>(y, x) / 257.0 : static_cast<double>(grey.at<uchar>(y, x));
  };
  return static_cast<float>((1 - fv) * ((1 - fu) * g(u, v) + fu * g(u + 1, v)) +
                            fv * ((1 - fu) * g(u, v + 1) + fu * g(u + 1, v + 1)));
}

constexpr int kProjectEvery = 4;

// Pixels sampled per (ring, bin) for `rig` (the model without its mount): directions from the
// ring's viewpoint over its elevations (their middle 80%: the rims' dark bands are not scene).
// [ring][bin * elevations + j]; nullopt where the direction does not project.
using PostSamples = std::vector<std::optional<Eigen::Vector2d>>;
std::array<PostSamples, 2> RingSamples(const RigModel& rig, const RigParams& bare, int bins, double bin,
                                       const PostFinderOptions& options) {
  const IdealModel ideal = bare.Ideal();
  const FieldOfView fov = ComputeFieldOfView(bare.Design(), ideal.r_ref, ideal.r_cam);
  std::array<PostSamples, 2> samples;
  for (int ring = 0; ring < 2; ++ring) {
    const Mirror mirror = ring == 0 ? Mirror::kOne : Mirror::kTwo;
    const double lo = ring == 0 ? std::min(fov.theta1_min, fov.theta1_max) : std::min(fov.theta2_min, fov.theta2_max);
    const double hi = ring == 0 ? std::max(fov.theta1_min, fov.theta1_max) : std::max(fov.theta2_min, fov.theta2_max);
    const Eigen::Vector3d viewpoint = mirror == Mirror::kOne
        ? Focus1InCam(bare.mirror1_pose.data(), bare.mirror1_shape.data())
        : Focus2InCam(bare.mirror2_pose.data(), bare.mirror2_shape.data(), bare.d);
    samples[ring].assign(static_cast<size_t>(bins) * options.elevations, std::nullopt);
    // Projected every kProjectEvery bins (a projection through the rig is what costs: 92k of them
    // at 0.25 deg took ~1 s of a 5 MP photo's detection), the bins between interpolated along
    // the ring: over 1 deg the curve's chord is within 0.03 px of it at 900 px from the centre.
    const int every = bins % kProjectEvery == 0 ? kProjectEvery : 1;
    const auto project = [&](int b, int j) {
      const double azimuth = (b + 0.5) * bin;
      const double e = lo + (hi - lo) * (0.1 + 0.8 * j / (options.elevations - 1));
      const Eigen::Vector3d dir(std::cos(e) * std::cos(azimuth), std::cos(e) * std::sin(azimuth), std::sin(e));
      return rig.Project(viewpoint + 1000.0 * dir, mirror);
    };
    std::vector<std::optional<Eigen::Vector2d>> row(bins / every);
    for (int j = 0; j < options.elevations; ++j) {
      for (int m = 0; m < bins / every; ++m) row[m] = project(m * every, j);
      for (int b = 0; b < bins; b += every) {
        const std::optional<Eigen::Vector2d>& a = row[b / every];
        const std::optional<Eigen::Vector2d>& c = row[((b + every) % bins) / every];
        for (int k = 0; k < every; ++k) {
          std::optional<Eigen::Vector2d>& s = samples[ring][static_cast<size_t>(b + k) * options.elevations + j];
          if (k == 0) {
            s = a;
          } else if (a && c) {
            const double t = static_cast<double>(k) / every;
            s = (1 - t) * *a + t * *c;
          }
        }
      }
    }
  }
  return samples;
}

RingGrid SampleRing(const cv::Mat& grey, const PostSamples& samples, int bins, int elevations) {
  RingGrid grid;
  grid.bins = bins;
  grid.elevations = elevations;
  grid.levels.resize(samples.size());
  for (size_t i = 0; i < samples.size(); ++i) grid.levels[i] = samples[i] ? GreyAt(grey, *samples[i]) : -1.0f;
  return grid;
}

// The azimuths where both rings' samples are seen (a bin whose both rings see at least half of
// their elevations), as ranges "a-b deg, ...".
std::string SearchedAzimuths(const std::array<PostSamples, 2>& samples, int bins, int elevations, double bin_deg) {
  std::vector<bool> seen(bins, true);
  for (int ring = 0; ring < 2; ++ring) {
    for (int b = 0; b < bins; ++b) {
      int n = 0;
      for (int j = 0; j < elevations; ++j) n += samples[ring][static_cast<size_t>(b) * elevations + j] ? 1 : 0;
      if (2 * n < elevations) seen[b] = false;
    }
  }
  if (std::all_of(seen.begin(), seen.end(), [](bool x) { return x; })) return "0-360 deg";
  std::string out;
  for (int b = 0; b < bins; ++b) {
    if (!seen[b] || (b > 0 && seen[b - 1])) continue;
    int e = b;
    while (e + 1 < bins && seen[e + 1]) ++e;
    char range[64];
    std::snprintf(range, sizeof range, "%s%.1f-%.1f", out.empty() ? "" : ", ", b * bin_deg, (e + 1) * bin_deg);
    out += range;
  }
  return out.empty() ? "no azimuth (the model's rings do not project)" : out + " deg";
}

double Wrap2Pi(double a) {
  a = std::remainder(a, 2 * M_PI);
  return a < 0 ? a + 2 * M_PI : a;
}

// The spread of values about their median (1.4826 MAD), 0 for fewer than 2.
double Spread(std::vector<double> v) {
  if (v.size() < 2) return 0;
  const double m = MedianOf(v);
  for (double& x : v) x = std::abs(x - m);
  return 1.4826 * MedianOf(v);
}

// The post a band of the outer ring makes: its edges placed in each photo (PlaceBandEdges), the
// medians of those that place them; the band's own bins where none does.
FoundPost PlacePost(const std::vector<RingGrid>& outer, const Band& band, int gap, double bin) {
  std::vector<double> lefts, rights, centres, widths;
  for (const RingGrid& grid : outer) {
    const BandEdges edges = PlaceBandEdges(grid, band, gap);
    if (!edges.ok) continue;
    lefts.push_back(edges.left);
    rights.push_back(edges.right);
    centres.push_back(0.5 * (edges.left + edges.right));
    widths.push_back(edges.right - edges.left);
  }
  FoundPost post;
  post.score = band.score;
  post.photos_placed = static_cast<int>(lefts.size());
  // A bin's quantum (uniform over a bin: bin / sqrt 12) for the crossings' interpolation.
  const double quantum = bin / std::sqrt(12.0);
  if (lefts.empty()) {
    post.azimuth = Wrap2Pi((band.lo + 0.5 * band.width) * bin);
    post.width = band.width * bin;
    post.sigma_azimuth = post.sigma_width = gap * bin;  // the band's ends are this uncertain
    return post;
  }
  const double left = MedianOf(lefts), right = MedianOf(rights);
  const double n = static_cast<double>(lefts.size());
  post.azimuth = Wrap2Pi(0.5 * (left + right) * bin);
  post.width = (right - left) * bin;
  post.sigma_azimuth = std::hypot(Spread(centres) * bin / std::sqrt(n), quantum);
  post.sigma_width = std::hypot(Spread(widths) * bin / std::sqrt(n), quantum);
  return post;
}

}  // namespace

std::string PostFinderOptions::Check() const {
  const auto error = [](const std::string& field, const std::string& expected, double got) {
    return field + ": expected " + expected + ", got " + io::FormatDouble(got);
  };
  if (!(bin_deg > 0 && bin_deg <= 2)) return error("bin_deg", "a bin in (0, 2] degrees", bin_deg);
  if (!(min_width_deg >= 2 * bin_deg)) return error("min_width_deg", "at least two bins", min_width_deg);
  if (!(max_width_deg >= min_width_deg && max_width_deg <= 45)) {
    return error("max_width_deg", "an angle in [min_width_deg, 45] degrees", max_width_deg);
  }
  if (!(gap_deg >= 0)) return error("gap_deg", "an angle >= 0 degrees", gap_deg);
  if (elevations < 8) return error("elevations", "at least 8 samples", elevations);
  if (!(min_score > 0)) return error("min_score", "a score > 0", min_score);
  if (!(min_inner_score >= 0)) return error("min_inner_score", "a score >= 0", min_inner_score);
  if (!(inner_reach_deg >= 0)) return error("inner_reach_deg", "an angle >= 0 degrees", inner_reach_deg);
  if (!(noise_floor > 0)) return error("noise_floor", "grey levels > 0", noise_floor);
  return "";
}

double PostSideFromBand(double band_width, double radius) {
  const double t = std::tan(0.5 * band_width);
  return 2 * radius * t / (1 + t);
}

PostSearch SearchPosts(const std::vector<cv::Mat>& grey_images, const RigModel& model, int count,
                       const PostFinderOptions& options) {
  if (const std::string error = options.Check(); !error.empty()) throw std::invalid_argument(error);
  PostSearch out;
  if (grey_images.empty() || count <= 0) return out;
  // The model without its mount: the posts' own pixels are what is looked at.
  RigParams bare = model.params();
  bare.mount = Mount();
  const RigModel rig(bare);
  const int bins = static_cast<int>(std::lround(360.0 / options.bin_deg));
  const double bin = 2 * M_PI / bins;
  const auto in_bins = [&](double deg) { return std::max(1, static_cast<int>(std::lround(deg / options.bin_deg))); };
  const int min_width = in_bins(options.min_width_deg), max_width = in_bins(options.max_width_deg);
  const int gap = in_bins(options.gap_deg);
  const std::array<PostSamples, 2> samples = RingSamples(rig, bare, bins, bin, options);
  out.searched = SearchedAzimuths(samples, bins, options.elevations, options.bin_deg);
  std::vector<RingGrid> outer;
  std::vector<BandScores> outer_scores, inner_scores;
  for (const cv::Mat& grey : grey_images) {
    if (grey.empty() || grey.channels() != 1 || grey.cols != bare.image_width || grey.rows != bare.image_height) {
      continue;
    }
    outer.push_back(SampleRing(grey, samples[0], bins, options.elevations));
    outer_scores.push_back(ScoreBands(outer.back(), min_width, max_width, gap, options.noise_floor));
    inner_scores.push_back(ScoreBands(SampleRing(grey, samples[1], bins, options.elevations), min_width,
                                      max_width, gap, options.noise_floor));
  }
  out.photos = static_cast<int>(outer.size());
  if (outer.empty()) return out;
  const BandScores outer_score = MedianScores(outer_scores), inner_score = MedianScores(inner_scores);
  // The outer ring's best bands, half the threshold and up: those under min_score are said as
  // refused (the user asked for more posts than scored).
  const std::vector<Band> bands = BestBands(outer_score, gap, 0.5 * options.min_score, count + 6);
  const int reach = in_bins(options.inner_reach_deg);
  for (const Band& band : bands) {
    const Band inner = BestBandNear(inner_score, band.lo + 0.5 * band.width, reach, band.width / 2,
                                    band.width + band.width / 2 + in_bins(1.0));
    // A band the outer ring shows strongly needs less of the inner ring, whose image of a post is
    // a third as wide and which the design registers worst (a 640x480 photo: outer 38.7, inner 2.1).
    const bool scores = band.score >= options.min_score;
    const bool confirmed = inner.score >= options.min_inner_score ||
                           (band.score >= 3 * options.min_score && inner.score >= 0.5 * options.min_inner_score);
    if (scores && confirmed && static_cast<int>(out.found.size()) < count) {
      FoundPost post = PlacePost(outer, band, gap, bin);
      post.inner_score = inner.score;
      out.found.push_back(post);
      continue;
    }
    RefusedPost refused;
    refused.azimuth = Wrap2Pi((band.lo + 0.5 * band.width) * bin);
    refused.width = band.width * bin;
    refused.score = band.score;
    refused.inner_score = inner.score;
    char why[200];
    if (!scores) {
      std::snprintf(why, sizeof why, "too faint in the outer ring (contrast over roughness %.1f < %.1f)",
                    band.score, options.min_score);
    } else if (!confirmed) {
      std::snprintf(why, sizeof why, "not in the inner ring within %.0f deg (score %.1f < %.1f; outer ring %.1f)",
                    options.inner_reach_deg, inner.score, options.min_inner_score, band.score);
    } else {
      std::snprintf(why, sizeof why, "weaker than the %d posts asked for (score %.1f)", count, band.score);
    }
    refused.why = why;
    out.refused.push_back(refused);
  }
  return out;
}

std::vector<FoundPost> FindPosts(const std::vector<cv::Mat>& grey_images, const RigModel& model, int count,
                                 const PostFinderOptions& options) {
  return SearchPosts(grey_images, model, count, options).found;
}

namespace {

// The mount turned as a whole: the model's n posts each matched to the nearest of `found` (the
// n best), all offsets within 0.5 deg of each other and their mean at least min_turn_deg.
std::optional<double> TurnOf(const Mount& mount, const std::vector<FoundPost>& found,
                             double min_turn_deg) {
  const int n = static_cast<int>(mount.azimuths.size());
  if (static_cast<int>(found.size()) < n) return std::nullopt;
  std::vector<double> offsets;
  for (double a : mount.azimuths) {
    double best = M_PI;
    for (int k = 0; k < n; ++k) {
      const double d = std::remainder(found[k].azimuth - a, 2 * M_PI);
      if (std::abs(d) < std::abs(best)) best = d;
    }
    offsets.push_back(best);
  }
  const auto [lo, hi] = std::minmax_element(offsets.begin(), offsets.end());
  double mean = 0;
  for (double d : offsets) mean += d / n;
  constexpr double kDeg = M_PI / 180;
  if (*hi - *lo > 0.5 * kDeg || std::abs(mean) < min_turn_deg * kDeg) return std::nullopt;
  return mean;
}

}  // namespace

std::optional<double> MountTurnInPhoto(const cv::Mat& grey, const RigModel& model, double min_turn_deg) {
  const Mount& mount = model.params().mount;
  if (!mount.present || mount.azimuths.empty()) return std::nullopt;
  return TurnOf(mount, FindPosts({grey}, model, static_cast<int>(mount.azimuths.size())),
                min_turn_deg);
}

MountInPhoto CompareMountWithPhoto(const cv::Mat& grey, const RigModel& model, double tolerance_deg,
                                   double min_turn_deg) {
  MountInPhoto out;
  const Mount& mount = model.params().mount;
  if (!mount.present || mount.azimuths.empty()) return out;
  const int n = static_cast<int>(mount.azimuths.size());
  // Best first: the n best are MountTurnInPhoto's.
  const std::vector<FoundPost> found = FindPosts({grey}, model, n + 2);
  out.turn = TurnOf(mount, found, min_turn_deg);
  if (out.turn) return out;
  const double tolerance = tolerance_deg * M_PI / 180;
  auto near = [&](const FoundPost& post, double azimuth) {
    return std::abs(std::remainder(post.azimuth - azimuth, 2 * M_PI)) <=
           tolerance + 0.5 * post.width;
  };
  for (const FoundPost& post : found) {
    bool in_model = false;
    for (double a : mount.azimuths) in_model = in_model || near(post, a);
    if (!in_model) out.unexpected.push_back(post);
  }
  for (int i = 0; i < n; ++i) {
    bool seen = false;
    for (const FoundPost& post : found) seen = seen || near(post, mount.azimuths[i]);
    if (!seen) out.unseen.push_back(i);
  }
  return out;
}

}  // namespace omni::detectors
