#include "detectors/lips/lip_detector.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>

#include <Eigen/Dense>

#include "detectors/lips/grey_sampling.h"
#include "detectors/lips/luma_edge.h"
#include "io/file_util.h"

namespace omni::detectors {
namespace {

constexpr int kRadiusSamples = 7;  // samples across the annulus r_inner..r_outer per path

// How much a linear BGR colour looks like the lip's paint, whatever the light on it: the colour's
// chroma (minus its grey mean) split along the paint's own chroma direction (a) and across it
// (c_perp); likeness = a - 2 |c_perp|, positive within 27 degrees of the paint's hue. The room's
// light scales a paint's chroma but keeps its direction, and grey surroundings (a black
// background, white walls, the rim) score 0 at any brightness, so a dark, weakly coloured paint
// (navy: chroma 0.08 of full scale) stands out as a bright one does, and a room's patches of a
// nearby but more saturated hue do not pass for it (a plain projection on the chroma direction
// scored a light-blue wall 7 times the navy band). Achromatic paints have no chroma: along
// grey (+ light paints, - dark ones), any chroma counting against.
class PaintLikeness {
 public:
  explicit PaintLikeness(const Eigen::Vector3d& paint_rgb) {
    const Eigen::Vector3d bgr(paint_rgb[2], paint_rgb[1], paint_rgb[0]);
    const double grey = bgr.mean();
    const Eigen::Vector3d chroma = bgr - Eigen::Vector3d::Constant(grey);
    chromatic_ = chroma.norm() > 0.25 * grey;
    direction_ = chromatic_ ? chroma.normalized()
                            : Eigen::Vector3d::Constant((grey >= 0.4 ? 1 : -1) / std::sqrt(3.0));
  }
  double operator()(const Eigen::Vector3d& bgr) const {
    const Eigen::Vector3d chroma = bgr - Eigen::Vector3d::Constant(bgr.mean());
    if (!chromatic_) return direction_.dot(bgr) - 2 * chroma.norm();
    const double a = direction_.dot(chroma);
    return a - 2 * (chroma - a * direction_).norm();
  }

 private:
  bool chromatic_ = false;
  Eigen::Vector3d direction_;
};

// A BGR pixel (bilinear) in 8-bit levels; black outside the image.
template <typename Pixel>
Eigen::Vector3d ColourOf(const cv::Mat& bgr, const Eigen::Vector2d& p, double scale) {
  const double u = p.x(), v = p.y();
  if (!(u >= 0 && v >= 0 && u <= bgr.cols - 1.001 && v <= bgr.rows - 1.001)) {
    return Eigen::Vector3d::Zero();
  }
  const int x = static_cast<int>(u), y = static_cast<int>(v);
  const double fx = u - x, fy = v - y;
  const Pixel* row0 = bgr.ptr<Pixel>(y) + x;
  const Pixel* row1 = bgr.ptr<Pixel>(y + 1) + x;
  Eigen::Vector3d c;
  for (int k = 0; k < 3; ++k) {
    c[k] = scale * ((1 - fy) * ((1 - fx) * row0[0][k] + fx * row0[1][k]) +
                    fy * ((1 - fx) * row1[0][k] + fx * row1[1][k]));
  }
  return c;
}

Eigen::Vector3d Colour(const cv::Mat& bgr, const Eigen::Vector2d& p) {
  return bgr.depth() == CV_8U ? ColourOf<cv::Vec3b>(bgr, p, 1.0)
                              : ColourOf<cv::Vec3w>(bgr, p, 1.0 / 257.0);
}

// One searched edge on one profile: where the model says the edge image lies.
struct EdgePrediction {
  Eigen::Vector2d pixel;  // predicted edge pixel
  Eigen::Vector2d outward;  // unit direction from the centre through it (increasing radius)
  double rho = 0;
};

// An edge kind (band, side) and its label, with the per-profile predictions where unambiguous.
struct EdgeTrack {
  Mirror owner;  // whose lip: its paint is the band's colour
  bool outer;  // the band's outer (larger radius) boundary
  LipPath path;
  LipCircle circle;
  std::vector<EdgePrediction> predictions;
};

struct Sample {
  LipPath path;
  int j;  // radius index (0: r_inner, kRadiusSamples-1: r_outer)
  bool valid;
  Eigen::Vector2d pixel;
  double rho;
};

// Labels the band's outermost / innermost covered radius on one profile (see the header).
// Returns the index into `samples` of the labelled endpoint sample, or -1 if ambiguous.
int LabelExtreme(const std::vector<Sample>& samples, bool outer, double min_margin_px,
                 double min_band_px) {
  int best = -1;
  for (int i = 0; i < static_cast<int>(samples.size()); ++i) {
    if (!samples[i].valid) continue;
    if (best < 0 || (outer ? samples[i].rho > samples[best].rho : samples[i].rho < samples[best].rho))
      best = i;
  }
  if (best < 0) return -1;
  const Sample& e = samples[best];
  if (e.j != 0 && e.j != kRadiusSamples - 1) return -1;  // clipped by an occluder
  // The lip must be seen on the band side of the edge along the same path, over at least
  // min_band_px (where an occluder's rim narrows the band, the edge's blur meets the rim's).
  const int j_step = e.j == 0 ? 1 : -1;
  double band_px = 0;
  for (int j = e.j + j_step; j >= 0 && j < kRadiusSamples; j += j_step) {
    bool valid = false;
    for (const Sample& s : samples) {
      if (s.path == e.path && s.j == j && s.valid) {
        valid = true;
        band_px = std::abs(s.rho - e.rho);
      }
    }
    if (!valid) break;
  }
  if (band_px < min_band_px) return -1;
  // No image of the band along another path near the edge.
  for (const Sample& s : samples) {
    if (!s.valid || s.path == e.path) continue;
    if (std::abs(s.rho - e.rho) < min_margin_px) return -1;
  }
  return best;
}

// Whether pixels across an edge (along `radial`, out to the edge search's reach, and a post's
// width to each side along the edge) see a post of the model's mount: 9 x 7 samples every
// kMountStepPerFocal radians of the camera's view (2 px at f 1452 px: +-8 px across, +-6 along),
// never closer than 2 px.
constexpr double kMountStepPerFocal = 0.001377;
bool NearMount(const RigModel& model, const Eigen::Vector2d& pixel, const Eigen::Vector2d& radial) {
  const Eigen::Vector2d along(-radial.y(), radial.x());
  const RigParams& rig = model.params();
  const double step = std::max(2.0, kMountStepPerFocal * 0.5 * (rig.camera[kFx] + rig.camera[kFy]));
  for (int a = -3; a <= 3; ++a) {
    for (int r = -4; r <= 4; ++r) {
      if (model.PixelSeesMount(pixel + step * (r * radial + a * along))) return true;
    }
  }
  return false;
}

}  // namespace

// The labelled edges a model predicts (computed once per model; projections are costly).
// Outside the unnamed namespace: LipPredictionCache (lip_detector.h) holds one.
class LipPrediction {
 public:
  LipPrediction(const RigModel& model, const LipDetectorOptions& options) : params_(model.params()) {
    const RigParams& rig = model.params();
    const Eigen::Vector2d centre(rig.camera[kCx], rig.camera[kCy]);
    const RigBlocks<double> blocks = RigBlocksOf(rig);
    for (Mirror owner : {Mirror::kOne, Mirror::kTwo}) {
      const std::array<LipPath, 2> paths =
          owner == Mirror::kOne ? std::array<LipPath, 2>{LipPath::kDirect, LipPath::kViaMirror1}
                                : std::array<LipPath, 2>{LipPath::kViaReflex, LipPath::kViaMirror2};
      const Lip& lip = LipOf(rig, paths[0]);
      if (!(lip.r_outer > lip.r_inner)) continue;
      // Tracks keyed by (side, path, circle): 2 sides x 2 paths x 2 circles.
      std::vector<EdgeTrack> tracks;
      for (bool outer : {false, true})
        for (LipPath path : paths)
          for (LipCircle circle : {LipCircle::kInner, LipCircle::kOuter})
            tracks.push_back(EdgeTrack{owner, outer, path, circle, {}});
      for (int k = 0; k < options.profiles; ++k) {
        const double phi = 2 * M_PI * k / options.profiles;
        std::vector<Sample> samples;
        for (LipPath path : paths) {
          for (int j = 0; j < kRadiusSamples; ++j) {
            const double r = lip.r_inner + (lip.r_outer - lip.r_inner) * j / (kRadiusSamples - 1);
            Sample s{path, j, false, Eigen::Vector2d::Zero(), 0};
            s.valid = ProjectLipPoint(blocks, model.fixed(), path, r, lip.z, phi, &s.pixel) &&
                      s.pixel.allFinite();
            if (s.valid) s.rho = (s.pixel - centre).norm();
            samples.push_back(s);
          }
        }
        for (bool outer : {false, true}) {
          const int i = LabelExtreme(samples, outer, options.min_margin_px, options.min_band_px);
          if (i < 0) continue;
          const Sample& e = samples[i];
          // A post of the mount (model/mount.h) beside the edge: the band meets the post's grey
          // there, not the background, and its edge is not the lip's. Skipped where the model
          // says pixels across the edge (the search's reach) see a post.
          if (rig.mount.present && NearMount(model, e.pixel, (e.pixel - centre) / e.rho)) continue;
          const LipCircle circle = e.j == 0 ? LipCircle::kInner : LipCircle::kOuter;
          for (EdgeTrack& t : tracks) {
            if (t.outer == outer && t.path == e.path && t.circle == circle) {
              t.predictions.push_back(
                  EdgePrediction{e.pixel, (e.pixel - centre) / e.rho, e.rho});
            }
          }
        }
      }
      for (EdgeTrack& t : tracks) {
        if (!t.predictions.empty()) tracks_.push_back(std::move(t));
      }
    }
  }

  bool SameModel(const RigModel& model) const {
    const RigParams& a = params_;
    const RigParams& b = model.params();
    return a.camera == b.camera && a.distortion == b.distortion &&
           a.mirror1_shape == b.mirror1_shape && a.mirror2_shape == b.mirror2_shape &&
           a.mirror1_pose == b.mirror1_pose && a.mirror2_pose == b.mirror2_pose &&
           a.reflex == b.reflex && a.d == b.d && a.r_sys == b.r_sys && a.r_ref == b.r_ref &&
           a.r_cam == b.r_cam && a.lip1.r_inner == b.lip1.r_inner &&
           a.lip1.r_outer == b.lip1.r_outer && a.lip1.z == b.lip1.z &&
           a.lip2.r_inner == b.lip2.r_inner && a.lip2.r_outer == b.lip2.r_outer &&
           a.lip2.z == b.lip2.z && a.image_width == b.image_width &&
           a.image_height == b.image_height && a.mount.present == b.mount.present &&
           a.mount.azimuths == b.mount.azimuths && a.mount.radius == b.mount.radius &&
           a.mount.width == b.mount.width && a.mount.widths == b.mount.widths;
  }

  const std::vector<EdgeTrack>& tracks() const { return tracks_; }

 private:
  RigParams params_;
  std::vector<EdgeTrack> tracks_;
};

namespace {

// The model's prediction: the one in `cache` if it was made for this model and these options
// (detection runs image after image with one model), else a new one (kept there).
std::shared_ptr<const LipPrediction> PredictionFor(const RigModel& model, const LipDetectorOptions& options,
                                                   LipPredictionCache* cache) {
  if (!cache) return std::make_shared<const LipPrediction>(model, options);
  if (!cache->prediction || !cache->prediction->SameModel(model) || cache->profiles != options.profiles ||
      cache->min_margin_px != options.min_margin_px || cache->min_band_px != options.min_band_px) {
    cache->prediction = std::make_shared<const LipPrediction>(model, options);
    cache->profiles = options.profiles;
    cache->min_margin_px = options.min_margin_px;
    cache->min_band_px = options.min_band_px;
  }
  return cache->prediction;
}

// An edge point on one profile and what it was found between.
struct EdgeCandidate {
  Eigen::Vector2d pixel;
  double band = 0;      // paint likeness of the band's colour
  double contrast = 0;  // |band colour - outside colour| (8-bit levels)
  double noise = 0;     // spread of the band side's samples along that difference (levels)
  // The arc the profile's samples followed: its centre, the point's radius and direction.
  Eigen::Vector2d centre, outward;
  double rho = 0;
  double sign = 1;  // +1: the band lies outward
};

// The coarse edge along one profile: the sample (every kCoarseStep px from t0 outward) where the
// paint likeness rises most steeply towards the band (`sign`) within the search window; -1 where
// there is no rise, or it lies at the window's border: the edge itself lies beyond it (the prior
// is that far off), and the profile around the border is its slope, not its two sides (demo3
// from the ideal design: via_mirror2 points 1-4 px off where the edge lay 16 px from the
// prediction).
constexpr double kCoarseStep = 0.5;
int CoarseEdge(const cv::Mat& bgr, const PaintLikeness& likeness, const EdgePrediction& pred, double sign,
               double t0, const LipDetectorOptions& options) {
  const int n_coarse = static_cast<int>(2 * (options.search_px + 1) / kCoarseStep) + 1;
  std::vector<double> coarse(n_coarse);
  for (int i = 0; i < n_coarse; ++i) {
    coarse[i] = likeness(Colour(bgr, pred.pixel + (t0 + i * kCoarseStep) * pred.outward));
  }
  int best = -1;
  double best_slope = 0;
  for (int i = 1; i + 1 < n_coarse; ++i) {
    if (std::abs(t0 + i * kCoarseStep) > options.search_px) continue;
    const double slope = sign * (coarse[i + 1] - coarse[i - 1]);
    if (slope > best_slope) {
      best_slope = slope;
      best = i;
    }
  }
  if (best < 0 || std::abs(t0 + best * kCoarseStep) > options.search_px - kCoarseStep) return -1;
  return best;
}

// The fine colour profile around a coarse edge: n samples every kStep px from radius
// pred.rho + tc, each the mean over kTangential points on the arc about the profiles' centre
// within +-tangential_px (a straight tangent would average a curved edge inwards by a third of
// its sagitta: 0.01 px for +-3 px at the inner ring's 200 px radius), and the side means and the
// projection on the colour difference read from it.
struct ColourProfile {
  static constexpr double kStep = 0.25;
  std::vector<Eigen::Vector3d> colour;
  double sign = 1;  // +1: the band lies outward
  int near = static_cast<int>(1.5 / kStep), far = static_cast<int>(3.0 / kStep);

  ColourProfile(const cv::Mat& bgr, const EdgePrediction& pred, double tc, int n, double sign,
                const LipDetectorOptions& options)
      : colour(n, Eigen::Vector3d::Zero()), sign(sign) {
    constexpr int kTangential = 5;
    const Eigen::Vector2d centre = pred.pixel - pred.rho * pred.outward;
    const Eigen::Vector2d tangent(-pred.outward.y(), pred.outward.x());
    for (int k = 0; k < kTangential; ++k) {
      const double angle = options.tangential_px * (2.0 * k / (kTangential - 1) - 1) / pred.rho;
      const Eigen::Vector2d dir = std::cos(angle) * pred.outward + std::sin(angle) * tangent;
      for (int i = 0; i < n; ++i) {
        colour[i] += Colour(bgr, centre + (pred.rho + tc + i * kStep) * dir) / kTangential;
      }
    }
  }
  int size() const { return static_cast<int>(colour.size()); }

  // Mean colours 1.5-3 px on the band side (mean[1]) and the outside (mean[0]) of sample `at`;
  // false where they run off the profile.
  bool SideColours(int at, Eigen::Vector3d mean[2]) const {
    const int n = size();
    mean[0].setZero();
    mean[1].setZero();
    int count = 0;
    for (int off = near; off <= far; ++off) {
      const int band_i = at + static_cast<int>(sign) * off;
      const int out_i = at - static_cast<int>(sign) * off;
      if (band_i < 0 || band_i >= n || out_i < 0 || out_i >= n) return false;
      mean[1] += colour[band_i];
      mean[0] += colour[out_i];
      ++count;
    }
    mean[0] /= count;
    mean[1] /= count;
    return true;
  }

  // The profile along the colour difference w from level0: 0 outside, 1 in the band.
  void Project(const Eigen::Vector3d& level0, const Eigen::Vector3d& w, std::vector<double>* score) const {
    for (int i = 0; i < size(); ++i) (*score)[i] = (colour[i] - level0).dot(w) / w.squaredNorm();
  }
};

// The steepest point of the projected profile within 1 px of sample `mid` (derivative over
// 1 px); -1 where it does not rise towards the band.
int SteepestSample(const std::vector<double>& score, int mid, double sign) {
  const int n = static_cast<int>(score.size());
  const int d = 2;  // derivative over 1 px
  const int reach = static_cast<int>(1.0 / ColourProfile::kStep);
  int steep = -1;
  double best_slope = 0;
  for (int i = std::max(d, mid - reach); i <= std::min(n - 1 - d, mid + reach); ++i) {
    const double slope = sign * (score[i + d] - score[i - d]);
    if (slope > best_slope) {
      best_slope = slope;
      steep = i;
    }
  }
  return steep;
}

// The sub-pixel edge along one profile. The steepest rise of the paint likeness towards the band
// within the search window is found on single samples. Around it the colour profile is sampled
// again, each sample the mean over +-tangential_px along arcs about the profiles' centre (the
// edges nearly follow them; noise and texture average out), and the band's and the outside's
// colours are the means 1.5-3 px either side. The edge is where the colour, projected on their
// difference, crosses half-way between them, nearest to the steepest point: a linear image's
// blurred edge mixes exactly those two colours, so the half-way point stays where it is whatever
// they are. A projection on the paint's chroma alone did not: against the textured room the
// outside's chroma varies as much as the navy band's (realistic camera, JPEG: edges 0.53 px
// into the room, 0.5 px mean error; this way 0.00 px and 0.07 px on the direct path). False if
// there is no rise, or the band is narrower than min_measured_band_px there (the model may not know
// where an occluder narrows it). Thresholds are the caller's (ScreenCandidates).
bool FindEdge(const cv::Mat& bgr, const PaintLikeness& likeness, bool outer,
              const EdgePrediction& pred, const LipDetectorOptions& options, EdgeCandidate* out) {
  const double sign = outer ? -1 : 1;  // +1: the band lies outward
  const double t0 = -options.search_px - 1;
  const int best = CoarseEdge(bgr, likeness, pred, sign, t0, options);
  if (best < 0) return false;
  // Fine colour samples at kStep from kOutside px outside the coarse edge to kOutside or
  // min_measured_band_px + 2 px (whichever is more) into the band: the side means need 3 px, the
  // steepest point may lie 1 px from the coarse edge and the crossing 1 px from that.
  constexpr double kStep = ColourProfile::kStep, kOutside = 4.0;
  const double inside = std::max(kOutside, options.min_measured_band_px + 2.0);
  const int n = static_cast<int>((kOutside + inside) / kStep) + 1;
  const int mid = static_cast<int>((sign > 0 ? kOutside : inside) / kStep);  // the coarse edge
  const double tc = t0 + best * kCoarseStep - mid * kStep;
  const ColourProfile profile(bgr, pred, tc, n, sign, options);
  const int near = profile.near, far = profile.far;
  Eigen::Vector3d level[2];
  if (!profile.SideColours(mid, level)) return false;
  Eigen::Vector3d w = level[1] - level[0];
  if (!(w.squaredNorm() > 0)) return false;
  std::vector<double> score(n);
  profile.Project(level[0], w, &score);
  const int steep = SteepestSample(score, mid, sign);
  if (steep < 0 || !profile.SideColours(steep, level)) return false;
  w = level[1] - level[0];
  if (!(w.squaredNorm() > 0)) return false;
  profile.Project(level[0], w, &score);
  out->band = likeness(level[1]);
  if (!(out->band > likeness(level[0]))) return false;
  out->contrast = w.norm();
  double sum = 0, sum2 = 0;
  int count = 0;
  for (int off = near; off <= far; ++off) {
    const double x = score[steep + static_cast<int>(sign) * off];
    sum += x;
    sum2 += x * x;
    ++count;
  }
  out->noise =
      out->contrast * std::sqrt(std::max(0.0, sum2 / count - (sum / count) * (sum / count)));
  // The crossing of 1/2 nearest to the steepest point.
  for (int off = 0; off <= far; ++off) {
    for (int i : {steep - off, steep + off - 1}) {
      if (i < 0 || i + 1 >= n) continue;
      const double a = score[i] - 0.5, b = score[i + 1] - 0.5;
      if ((a <= 0 && b > 0) || (a >= 0 && b < 0)) {
        double t = i + a / (a - b);  // in fine samples
        // The band's own colour over min_measured_band_px: where the band's other edge comes
        // nearer, its blur reaches the band side's samples (1.5-3 px in), the band's level reads
        // low and the crossing moves into the band (0.4-0.5 px at 3.5-4 px wide: the via_mirror2
        // band where the reflex disc's rim narrows it more than the prior model says).
        for (double width = 0.5; width <= options.min_measured_band_px; width += kStep) {
          const int k = static_cast<int>(std::lround(t + sign * width / kStep));
          if (k < 0 || k >= n || score[k] < 0.5) return false;
        }
        out->pixel = pred.pixel + (tc + kStep * t) * pred.outward;
        out->centre = pred.pixel - pred.rho * pred.outward;
        out->outward = pred.outward;
        out->rho = pred.rho + tc + kStep * t;
        out->sign = sign;
        return true;
      }
    }
  }
  return false;
}

// Keeps the candidates (in profile order along one edge) whose contrast stands out of the image
// noise (min_snr times the larger of the edge's median band-side spread and the candidate's own:
// a band side that is not flat is a band narrower than the level span or a foreign edge; and at
// least min_contrast levels)
// and whose contrast and band level are like their neighbours' along the edge (at least
// min_relative times the median of the 2 * kNeighbours nearest candidates): the levels vary with
// the paint, the lighting and the camera, so no absolute level is right for every image, while
// a background of the paint's hue or a foreign edge differs from the lip's own profiles.
std::vector<int> ScreenCandidates(const std::vector<EdgeCandidate>& c,
                                  const LipDetectorOptions& options) {
  constexpr int kNeighbours = 10;
  std::vector<int> kept;
  if (c.empty()) return kept;
  std::vector<double> noise;
  for (const EdgeCandidate& e : c) noise.push_back(e.noise);
  const double floor = std::max(options.min_contrast, options.min_snr * MedianOf(noise));
  const int n = static_cast<int>(c.size());
  for (int i = 0; i < n; ++i) {
    const double contrast = c[i].contrast;
    if (contrast < std::max(floor, options.min_snr * c[i].noise)) continue;
    std::vector<double> contrasts, bands;
    for (int k = std::max(0, i - kNeighbours); k <= std::min(n - 1, i + kNeighbours); ++k) {
      if (k == i) continue;
      contrasts.push_back(c[k].contrast);
      bands.push_back(c[k].band);
    }
    if (!contrasts.empty() && (contrast < options.min_relative * MedianOf(contrasts) ||
                               c[i].band < options.min_relative * MedianOf(bands))) {
      continue;
    }
    kept.push_back(i);
  }
  return kept;
}

// The candidates moved onto the image's luma (detectors/lips/luma_edge.h): the sensor noise's variance
// estimated from every band side of the image, then each point placed where the pixels' band
// share crosses 1/2; a point whose Y' contrast is too low for it keeps its colour crossing.
void PlaceOnLuma(const cv::Mat& bgr, const LipDetectorOptions& options,
                 std::vector<std::vector<EdgeCandidate>>* candidates) {
  auto gather = [&](const EdgeCandidate& c, double side_from_px, double side_to_px) {
    return GatherLumaProfile(bgr, options.luma, c.centre, c.outward, c.rho, c.sign,
                             options.luma_tangential_px, side_from_px, side_to_px);
  };
  // The noise from the bands' sides 2.5-3.5 px in (nearer, a bright room's chroma smeared by the
  // JPEG into a saturated band's near-black channels read as 10 times the variance), every 4th
  // point: one variance per image.
  std::vector<std::pair<Eigen::Vector3d, double>> band_sides;
  for (const auto& on_track : *candidates) {
    for (size_t i = 0; i < on_track.size(); i += 4) {
      const LumaProfile p = gather(on_track[i], 2.5, 3.5);
      if (p.side_count[1] >= 3) band_sides.emplace_back(p.side_colour[1], p.side_luma[1]);
    }
  }
  const NoisyLevels noise(EstimateEncodingNoise(band_sides));
  for (auto& on_track : *candidates) {
    for (EdgeCandidate& c : on_track) {
      const std::optional<double> offset =
          LumaEdgeOffset(gather(c, 1.5, 3.0), noise, options.luma_min_snr);
      if (offset) c.pixel += c.sign * *offset * c.outward;
    }
  }
}

// Conic through points (least squares on Hartley-normalised coordinates, smallest singular
// vector); false if degenerate or not an ellipse.
bool FitConic(const std::vector<Eigen::Vector2d>& points, const std::vector<int>& use,
              Ellipse* out) {
  if (use.size() < 5) return false;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int i : use) mean += points[i];
  mean /= use.size();
  double spread = 0;
  for (int i : use) spread += (points[i] - mean).norm();
  spread /= use.size();
  if (!(spread > 0)) return false;
  const double s = std::sqrt(2.0) / spread;
  Eigen::MatrixXd A(std::max<int>(use.size(), 6), 6);
  A.setZero();
  for (std::size_t k = 0; k < use.size(); ++k) {
    const Eigen::Vector2d x = s * (points[use[k]] - mean);
    A.row(k) << x.x() * x.x(), x.x() * x.y(), x.y() * x.y(), x.x(), x.y(), 1;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::Matrix<double, 6, 1> c = svd.matrixV().col(5);
  Eigen::Matrix3d Cx;
  Cx << c(0), c(1) / 2, c(3) / 2, c(1) / 2, c(2), c(4) / 2, c(3) / 2, c(4) / 2, c(5);
  Eigen::Matrix3d T;
  T << s, 0, -s * mean.x(), 0, s, -s * mean.y(), 0, 0, 1;
  const Eigen::Matrix3d C = T.transpose() * Cx * T;
  Ellipse e;
  e.conic << C(0, 0), 2 * C(0, 1), C(1, 1), 2 * C(0, 2), 2 * C(1, 2), C(2, 2);
  e.conic.normalize();
  const double a = e.conic(0), b = e.conic(1), cc = e.conic(2), d = e.conic(3), f = e.conic(4);
  if (!(b * b - 4 * a * cc < 0)) return false;
  Eigen::Matrix2d M;
  M << 2 * a, b, b, 2 * cc;
  e.center = M.inverse() * Eigen::Vector2d(-d, -f);
  const double at_center = e.conic(0) * e.center.x() * e.center.x() +
                           e.conic(1) * e.center.x() * e.center.y() +
                           e.conic(2) * e.center.y() * e.center.y() + e.conic(3) * e.center.x() +
                           e.conic(4) * e.center.y() + e.conic(5);
  Eigen::Matrix2d Q;
  Q << a, b / 2, b / 2, cc;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(Q);
  const double l0 = eig.eigenvalues()(0), l1 = eig.eigenvalues()(1);
  if (!(-at_center / l0 > 0) || !(-at_center / l1 > 0)) return false;
  const double ax0 = std::sqrt(-at_center / l0), ax1 = std::sqrt(-at_center / l1);
  const int major = ax0 >= ax1 ? 0 : 1;
  e.semi_major = std::max(ax0, ax1);
  e.semi_minor = std::min(ax0, ax1);
  e.angle = std::atan2(eig.eigenvectors()(1, major), eig.eigenvectors()(0, major));
  if (!e.center.allFinite() || !std::isfinite(e.semi_major)) return false;
  *out = e;
  return true;
}

}  // namespace

double Ellipse::Distance(const Eigen::Vector2d& p) const {
  const double u = p.x(), v = p.y();
  const double F = conic(0) * u * u + conic(1) * u * v + conic(2) * v * v + conic(3) * u +
                   conic(4) * v + conic(5);
  const Eigen::Vector2d grad(2 * conic(0) * u + conic(1) * v + conic(3),
                             conic(1) * u + 2 * conic(2) * v + conic(4));
  const double g = grad.norm();
  return g > 0 ? std::abs(F) / g : std::abs(F) * 1e30;
}

bool FitEllipseRobust(const std::vector<Eigen::Vector2d>& points, const LipDetectorOptions& options,
                      Ellipse* ellipse, std::vector<int>* inliers) {
  constexpr int kMinRansacIterations = 60;
  const int n = static_cast<int>(points.size());
  if (n < std::max(options.min_points, 5)) return false;
  std::mt19937 rng(12345);  // deterministic
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::vector<int> best;
  // Adaptive: stop once a sample of 5 inliers had a 1 - 1e-6 chance (at the best inlier share so
  // far; an edge is mostly inliers, so ~10-40 samples instead of all 300: lips were 17% of
  // their CPU in the ellipse's samples).
  int needed = options.ransac_iterations;
  for (int it = 0; it < needed; ++it) {
    std::vector<int> sample;
    while (sample.size() < 5) {
      const int k = pick(rng);
      if (std::find(sample.begin(), sample.end(), k) == sample.end()) sample.push_back(k);
    }
    Ellipse e;
    if (!FitConic(points, sample, &e)) continue;
    std::vector<int> in;
    for (int i = 0; i < n; ++i) {
      if (e.Distance(points[i]) < options.ransac_inlier_px) in.push_back(i);
    }
    if (in.size() > best.size()) {
      best.swap(in);
      const double all_in = std::pow(static_cast<double>(best.size()) / n, 5);
      if (all_in >= 1) break;
      needed = std::min(options.ransac_iterations,
                        std::max(kMinRansacIterations,
                                 static_cast<int>(std::ceil(std::log(1e-6) / std::log1p(-all_in)))));
    }
  }
  if (static_cast<int>(best.size()) < options.min_points) return false;
  // Least squares on the inliers, then once more on the inliers of that fit.
  Ellipse e;
  for (int round = 0; round < 2; ++round) {
    if (!FitConic(points, best, &e)) return false;
    std::vector<int> in;
    for (int i = 0; i < n; ++i) {
      if (e.Distance(points[i]) < options.ransac_inlier_px) in.push_back(i);
    }
    if (static_cast<int>(in.size()) < options.min_points) return false;
    best.swap(in);
  }
  if (!FitConic(points, best, &e)) return false;
  *ellipse = e;
  *inliers = best;
  return true;
}

// "<field>: expected <what>, got <value>" (the lips do not link detectors/common's OptionError).
std::string LipOptionError(const std::string& field, const std::string& expected, double got) {
  return field + ": expected " + expected + ", got " + io::FormatDouble(got);
}

std::string LipDetectorOptions::Check() const {
  if (profiles < 8) return LipOptionError("profiles", "at least 8 radial profiles", profiles);
  if (!(search_px >= 0)) return LipOptionError("search_px", "a half-width >= 0 px (0: from f)", search_px);
  if (!(min_margin_px >= 0)) return LipOptionError("min_margin_px", "a margin >= 0 px", min_margin_px);
  if (!(min_band_px >= 0)) return LipOptionError("min_band_px", "a width >= 0 px", min_band_px);
  if (!(min_measured_band_px >= 0)) {
    return LipOptionError("min_measured_band_px", "a width >= 0 px", min_measured_band_px);
  }
  if (!(tangential_px >= 0)) return LipOptionError("tangential_px", "a half-width >= 0 px", tangential_px);
  if (!(min_snr > 0)) return LipOptionError("min_snr", "a ratio > 0", min_snr);
  if (!(min_relative >= 0 && min_relative <= 1)) {
    return LipOptionError("min_relative", "a fraction in [0, 1]", min_relative);
  }
  if (!(min_contrast >= 0)) return LipOptionError("min_contrast", "grey levels >= 0", min_contrast);
  if (!(ransac_inlier_px > 0)) return LipOptionError("ransac_inlier_px", "a distance > 0 px", ransac_inlier_px);
  if (ransac_iterations < 1) return LipOptionError("ransac_iterations", "at least 1", ransac_iterations);
  if (min_points < 5) return LipOptionError("min_points", "at least 5 points (an ellipse)", min_points);
  if (!(luma_min_snr > 0)) return LipOptionError("luma_min_snr", "a ratio > 0", luma_min_snr);
  if (!(luma_tangential_px >= 0)) {
    return LipOptionError("luma_tangential_px", "a half-width >= 0 px", luma_tangential_px);
  }
  return "";
}

std::vector<LipEdgeFit> DetectLipEdges(const cv::Mat& raw_bgr, const RigModel& model,
                                       const LipDetectorOptions& options_in, LipPredictionCache* cache) {
  if (const std::string error = options_in.Check(); !error.empty()) throw std::invalid_argument(error);
  std::vector<LipEdgeFit> out;
  const RigParams& rig = model.params();
  LipDetectorOptions options = options_in;
  if (options.search_px <= 0) {
    options.search_px = std::max(20.0, kLipSearchPerFocal * 0.5 * (rig.camera[kFx] + rig.camera[kFy]));
  }
  if (raw_bgr.empty() || (raw_bgr.type() != CV_8UC3 && raw_bgr.type() != CV_16UC3) ||
      raw_bgr.cols != rig.image_width ||
      raw_bgr.rows != rig.image_height) {
    return out;
  }
  const std::shared_ptr<const LipPrediction> prediction = PredictionFor(model, options, cache);
  const std::vector<EdgeTrack>& tracks = prediction->tracks();
  std::vector<std::vector<EdgeCandidate>> found_on(tracks.size());
  for (size_t k = 0; k < tracks.size(); ++k) {
    const EdgeTrack& track = tracks[k];
    const PaintLikeness likeness(
        LipPaintOf(track.owner == Mirror::kOne ? rig.lip1.color : rig.lip2.color, track.owner));
    for (const EdgePrediction& pred : track.predictions) {
      EdgeCandidate c;
      if (FindEdge(raw_bgr, likeness, track.outer, pred, options, &c)) found_on[k].push_back(c);
    }
  }
  if (options.chroma_halved) PlaceOnLuma(raw_bgr, options, &found_on);
  for (size_t k = 0; k < tracks.size(); ++k) {
    const EdgeTrack& track = tracks[k];
    LipEdgeFit fit;
    fit.edge.mirror = track.owner;
    fit.edge.edge = track.outer ? BandEdge::kOuter : BandEdge::kInner;
    fit.edge.circle = track.circle;
    fit.edge.path = track.path;
    fit.n_profiles = static_cast<int>(track.predictions.size());
    const std::vector<EdgeCandidate>& candidates = found_on[k];
    const std::vector<int> kept = ScreenCandidates(candidates, options);
    std::vector<Eigen::Vector2d> found;
    for (int i : kept) found.push_back(candidates[i].pixel);
    fit.n_found = static_cast<int>(found.size());
    std::vector<int> inliers;
    if (!FitEllipseRobust(found, options, &fit.ellipse, &inliers)) continue;
    double sum2 = 0;
    for (int i : inliers) {
      fit.edge.points.push_back(found[i]);
      sum2 += std::pow(fit.ellipse.Distance(found[i]), 2);
    }
    fit.rms_px = std::sqrt(sum2 / inliers.size());
    std::vector<double> band, contrast, noise;
    for (int i : inliers) {
      const EdgeCandidate& c = candidates[kept[i]];
      band.push_back(c.band);
      contrast.push_back(c.contrast);
      noise.push_back(c.noise);
    }
    fit.band = MedianOf(band);
    fit.contrast = MedianOf(contrast);
    fit.noise = MedianOf(noise);
    out.push_back(std::move(fit));
  }
  return out;
}

std::vector<LipEdgeObservation> DetectLips(const cv::Mat& raw_bgr, const RigModel& model,
                                    const LipDetectorOptions& options, LipPredictionCache* cache) {
  std::vector<LipEdgeObservation> out;
  for (LipEdgeFit& fit : DetectLipEdges(raw_bgr, model, options, cache)) out.push_back(std::move(fit.edge));
  return out;
}

}  // namespace omni::detectors
