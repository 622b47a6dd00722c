#include "detectors/lips/post_finder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "io/file_util.h"
#include "model/ideal_analysis.h"
#include "model/rig_frames.h"

namespace omni::detectors {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

float GreyAt(const cv::Mat& grey, const Eigen::Vector2d& p) {
  const int u = static_cast<int>(std::lround(p.x())), v = static_cast<int>(std::lround(p.y()));
  if (u < 0 || v < 0 || u >= grey.cols || v >= grey.rows) return -1;
  return grey.depth() == CV_16U ? grey.at<uint16_t>(v, u) / 257.0f : grey.at<uchar>(v, u);
}

// Pixels sampled per (ring, bin) for `rig` (the model without its mount): directions from the
// ring's viewpoint over its elevations (their middle 80%: the rims' dark bands are not scene).
// [ring][bin][elevation]; nullopt where the direction does not project.
using PostSamples = std::vector<std::vector<std::optional<Eigen::Vector2d>>>;
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
    samples[ring].assign(bins, std::vector<std::optional<Eigen::Vector2d>>(options.elevations));
    for (int b = 0; b < bins; ++b) {
      const double azimuth = (b + 0.5) * bin;
      for (int j = 0; j < options.elevations; ++j) {
        const double e = lo + (hi - lo) * (0.1 + 0.8 * j / (options.elevations - 1));
        const Eigen::Vector3d dir(std::cos(e) * std::cos(azimuth), std::cos(e) * std::sin(azimuth), std::sin(e));
        samples[ring][b][j] = rig.Project(viewpoint + 1000.0 * dir, mirror);
      }
    }
  }
  return samples;
}

// One photo's ring: each bin's spread along the elevations over the ring's median spread (1
// where the ring has no texture to tell a post from the scene: a dark room, a render without
// one). The spread is the mean step between successive elevations (a lit post's slow shading
// along its length is not texture), each step the smallest within +-`reach` bins: a model not
// yet calibrated (the design) places a post's image a few pixels off its azimuth, differently at
// each radius, and a line of samples would cross it obliquely.
std::vector<double> RingBinScores(const cv::Mat& grey, const PostSamples& samples, int bins, int reach,
                                  const PostFinderOptions& options) {
  const auto wrap = [bins](int b) { return ((b % bins) + bins) % bins; };
  // steps[b][j]: |level(j) - level(j - 1)| along bin b, -1 where either is not seen.
  std::vector<std::vector<float>> steps(bins, std::vector<float>(options.elevations, -1));
  for (int b = 0; b < bins; ++b) {
    float last = -1;
    for (int j = 0; j < options.elevations; ++j) {
      const float g = samples[b][j] ? GreyAt(grey, *samples[b][j]) : -1;
      if (g >= 0 && last >= 0) steps[b][j] = std::abs(g - last);
      last = g;
    }
  }
  std::vector<double> spread(bins, -1), valid;
  for (int b = 0; b < bins; ++b) {
    double sum = 0;
    int n = 0;
    for (int j = 1; j < options.elevations; ++j) {
      float smallest = -1;
      for (int k = -reach; k <= reach; ++k) {
        const float step = steps[wrap(b + k)][j];
        if (step >= 0 && (smallest < 0 || step < smallest)) smallest = step;
      }
      if (smallest < 0) continue;
      sum += smallest;
      ++n;
    }
    if (n < 6) continue;
    spread[b] = sum / n;
    valid.push_back(spread[b]);
  }
  const double median = Median(valid);
  std::vector<double> scores(bins);
  for (int b = 0; b < bins; ++b) {
    scores[b] = median >= options.min_texture && spread[b] >= 0 ? spread[b] / median : 1.0;
  }
  return scores;
}

// The posts from the bins' scores (median over the photos): runs of flat bins (circular),
// deepest first, at most `count`; a run wider than max_width_deg is a plain wall, not a post.
// A post is placed by the outer ring alone where it shows the post (`outer_score`): mirror 1
// carries the posts and the lips place its ring; the inner ring (mirror 2 and the reflex) is the
// one a model not yet calibrated registers worst.
std::vector<FoundPost> PostsFromScores(const std::vector<double>& score, const std::vector<double>& outer_score,
                                       int bins, double bin, int count, const PostFinderOptions& options) {
  std::vector<FoundPost> out;
  const auto wrap = [bins](int b) { return ((b % bins) + bins) % bins; };
  std::vector<bool> used(bins, false);
  const int max_run = static_cast<int>(std::ceil(options.max_width_deg / options.bin_deg));
  while (static_cast<int>(out.size()) < count) {
    int best = -1;
    for (int b = 0; b < bins; ++b) {
      if (!used[b] && score[b] < options.max_score && (best < 0 || score[b] < score[best])) best = b;
    }
    if (best < 0) break;
    int lo = best, hi = best;
    while (hi - lo + 1 < bins && score[((lo - 1) % bins + bins) % bins] < options.max_score &&
           !used[((lo - 1) % bins + bins) % bins]) {
      --lo;
    }
    while (hi - lo + 1 < bins && score[(hi + 1) % bins] < options.max_score && !used[(hi + 1) % bins]) ++hi;
    for (int b = lo; b <= hi; ++b) used[((b % bins) + bins) % bins] = true;
    if (hi - lo + 1 > max_run) continue;  // a plain wall, not a post
    double centre = 0.5 * (lo + hi);
    double weight = 0, sum = 0;
    for (int b = lo - max_run / 2; b <= hi + max_run / 2; ++b) {
      const double w = std::max(0.0, options.max_score - outer_score[wrap(b)]);
      weight += w;
      sum += w * b;
    }
    if (weight > 0) centre = sum / weight;
    FoundPost post;
    post.azimuth = std::remainder((centre + 0.5) * bin, 2 * M_PI);
    if (post.azimuth < 0) post.azimuth += 2 * M_PI;
    post.width = (hi - lo + 1) * bin;
    post.score = score[best];
    out.push_back(post);
  }
  return out;
}

}  // namespace

std::string PostFinderOptions::Check() const {
  const auto error = [](const std::string& field, const std::string& expected, double got) {
    return field + ": expected " + expected + ", got " + io::FormatDouble(got);
  };
  if (!(bin_deg > 0 && bin_deg <= 10)) return error("bin_deg", "a bin in (0, 10] degrees", bin_deg);
  if (!(max_score > 0)) return error("max_score", "a score > 0", max_score);
  if (!(max_width_deg > bin_deg)) return error("max_width_deg", "an angle above bin_deg", max_width_deg);
  if (elevations < 1) return error("elevations", "at least 1 sample", elevations);
  if (!(registration_deg >= 0)) return error("registration_deg", "an angle >= 0 degrees", registration_deg);
  if (!(min_texture >= 0)) return error("min_texture", "grey levels >= 0", min_texture);
  return "";
}

std::vector<FoundPost> FindPosts(const std::vector<cv::Mat>& grey_images, const RigModel& model,
                                 int count, const PostFinderOptions& options) {
  if (const std::string error = options.Check(); !error.empty()) throw std::invalid_argument(error);
  std::vector<FoundPost> out;
  if (grey_images.empty() || count <= 0) return out;
  // The model without its mount: the posts' own pixels are what is looked at.
  RigParams bare = model.params();
  bare.mount = Mount();
  const RigModel rig(bare);
  const int bins = static_cast<int>(std::lround(360.0 / options.bin_deg));
  const double bin = 2 * M_PI / bins;
  const std::array<PostSamples, 2> samples = RingSamples(rig, bare, bins, bin, options);
  // Per photo: the mean of both rings' bin scores, and the outer ring's alone.
  const int reach = static_cast<int>(std::lround(options.registration_deg / options.bin_deg));
  std::vector<std::vector<double>> per_photo(bins), outer_per_photo(bins);
  for (const cv::Mat& grey : grey_images) {
    if (grey.empty() || grey.channels() != 1 || grey.cols != bare.image_width || grey.rows != bare.image_height) {
      continue;
    }
    std::vector<double> photo_score(bins, 0), outer(bins, 1);
    for (int ring = 0; ring < 2; ++ring) {
      const std::vector<double> scores = RingBinScores(grey, samples[ring], bins, reach, options);
      for (int b = 0; b < bins; ++b) {
        photo_score[b] += 0.5 * scores[b];
        if (ring == 0) outer[b] = scores[b];
      }
    }
    for (int b = 0; b < bins; ++b) {
      per_photo[b].push_back(photo_score[b]);
      outer_per_photo[b].push_back(outer[b]);
    }
  }
  if (per_photo[0].empty()) return out;
  std::vector<double> score(bins);
  std::vector<double> outer_score(bins);
  for (int b = 0; b < bins; ++b) {
    score[b] = Median(per_photo[b]);
    outer_score[b] = Median(outer_per_photo[b]);
  }
  return PostsFromScores(score, outer_score, bins, bin, count, options);
}

std::optional<double> MountTurnInPhoto(const cv::Mat& grey, const RigModel& model, double min_turn_deg) {
  const Mount& mount = model.params().mount;
  if (!mount.present || mount.azimuths.empty()) return std::nullopt;
  const int n = static_cast<int>(mount.azimuths.size());
  const std::vector<FoundPost> found = FindPosts({grey}, model, n);
  if (static_cast<int>(found.size()) < n) return std::nullopt;
  std::vector<double> offsets;
  for (double a : mount.azimuths) {
    double best = M_PI;
    for (const FoundPost& post : found) {
      const double d = std::remainder(post.azimuth - a, 2 * M_PI);
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

}  // namespace omni::detectors
