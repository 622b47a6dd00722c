#include "detectors/lip_detector.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <mutex>
#include <random>

#include <Eigen/Dense>

namespace omni::detectors {
namespace {

constexpr int kRadiusSamples = 7;  // samples across the annulus r_inner..r_outer per path

enum class Colour { kBlue, kRed };

// Colour score of a BGR pixel (bilinear), 0 outside the image: how much the lip's colour
// dominates the other two channels.
double Score(const cv::Mat& bgr, Colour colour, double u, double v) {
  if (!(u >= 0 && v >= 0 && u <= bgr.cols - 1.001 && v <= bgr.rows - 1.001)) return 0;
  const int x = static_cast<int>(u), y = static_cast<int>(v);
  const double fx = u - x, fy = v - y;
  double c[3];
  for (int k = 0; k < 3; ++k) {
    const double p00 = bgr.ptr<cv::Vec3b>(y)[x][k], p01 = bgr.ptr<cv::Vec3b>(y)[x + 1][k];
    const double p10 = bgr.ptr<cv::Vec3b>(y + 1)[x][k], p11 = bgr.ptr<cv::Vec3b>(y + 1)[x + 1][k];
    c[k] = (1 - fy) * ((1 - fx) * p00 + fx * p01) + fy * ((1 - fx) * p10 + fx * p11);
  }
  return colour == Colour::kBlue ? c[0] - std::max(c[1], c[2]) : c[2] - std::max(c[0], c[1]);
}

// One searched edge on one profile: where the model says the edge image lies.
struct EdgePrediction {
  Eigen::Vector2d pixel;  // predicted edge pixel
  Eigen::Vector2d outward;  // unit direction from the centre through it (increasing radius)
  double rho = 0;
};

// An edge kind (band, side) and its label, with the per-profile predictions where unambiguous.
struct EdgeTrack {
  Colour colour;
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

// The labelled edges a model predicts (computed once per model; projections are costly).
class LipPrediction {
 public:
  LipPrediction(const RigModel& model, const LipDetectorOptions& options) : params_(model.params()) {
    const RigParams& rig = model.params();
    const Eigen::Vector2d centre(rig.camera[2], rig.camera[3]);
    const LipBlocks<double> blocks = LipBlocksOf(rig);
    for (Colour colour : {Colour::kBlue, Colour::kRed}) {
      const std::array<LipPath, 2> paths =
          colour == Colour::kBlue ? std::array<LipPath, 2>{LipPath::kDirect, LipPath::kViaMirror1}
                                  : std::array<LipPath, 2>{LipPath::kViaReflex, LipPath::kViaMirror2};
      const Lip& lip = LipOf(rig, paths[0]);
      if (!(lip.r_outer > lip.r_inner)) continue;
      // Tracks keyed by (side, path, circle): 2 sides x 2 paths x 2 circles.
      std::vector<EdgeTrack> tracks;
      for (bool outer : {false, true})
        for (LipPath path : paths)
          for (LipCircle circle : {LipCircle::kInner, LipCircle::kOuter})
            tracks.push_back(EdgeTrack{colour, outer, path, circle, {}});
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
           a.image_height == b.image_height;
  }

  const std::vector<EdgeTrack>& tracks() const { return tracks_; }

 private:
  RigParams params_;
  std::vector<EdgeTrack> tracks_;
};

// The model's prediction, cached for the last model seen (detection runs image after image
// with one model).
std::shared_ptr<const LipPrediction> PredictionFor(const RigModel& model,
                                                   const LipDetectorOptions& options) {
  static std::mutex mutex;
  static std::shared_ptr<const LipPrediction> cached;
  static LipDetectorOptions cached_options;
  std::lock_guard<std::mutex> lock(mutex);
  if (!cached || !cached->SameModel(model) || cached_options.profiles != options.profiles ||
      cached_options.min_margin_px != options.min_margin_px ||
      cached_options.min_band_px != options.min_band_px) {
    cached = std::make_shared<const LipPrediction>(model, options);
    cached_options = options;
  }
  return cached;
}

// The sub-pixel edge along one profile: where the colour score crosses half-way between the
// band's level and the outside level, for the strongest transition of the right sign within
// the search window. False if none with enough contrast.
bool FindEdge(const cv::Mat& bgr, Colour colour, bool outer, const EdgePrediction& pred,
              const LipDetectorOptions& options, Eigen::Vector2d* edge) {
  constexpr double kStep = 0.25;
  constexpr double kLevelSpan = 3.0;  // px on each side where the levels are taken
  const double t0 = -options.search_px - kLevelSpan - 1, t1 = options.search_px + kLevelSpan + 1;
  const int n = static_cast<int>((t1 - t0) / kStep) + 1;
  std::vector<double> score(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d p = pred.pixel + (t0 + i * kStep) * pred.outward;
    score[i] = Score(bgr, colour, p.x(), p.y());
  }
  // Band side: inside (smaller radius) for an outer edge. Sign: +1 if the score rises outward.
  const double sign = outer ? -1 : 1;
  const int d = static_cast<int>(std::round(0.5 / kStep));  // derivative over 1 px
  int best = -1;
  double best_slope = 0;
  for (int i = d; i + d < n; ++i) {
    const double t = t0 + i * kStep;
    if (std::abs(t) > options.search_px) continue;
    const double slope = sign * (score[i + d] - score[i - d]);
    if (slope > best_slope) {
      best_slope = slope;
      best = i;
    }
  }
  if (best < 0) return false;
  const int span = static_cast<int>(kLevelSpan / kStep);
  double band = -1e9, outside = 1e9;
  for (int i = std::max(0, best - span); i <= std::min(n - 1, best + span); ++i) {
    const bool band_side = outer ? i <= best : i >= best;
    if (band_side) band = std::max(band, score[i]);
    else outside = std::min(outside, score[i]);
  }
  if (!(band - outside >= options.min_contrast)) return false;
  const double half = 0.5 * (band + outside);
  // The crossing nearest to the steepest point.
  for (int off = 0; off <= span; ++off) {
    for (int i : {best - off, best + off - 1}) {
      if (i < 0 || i + 1 >= n) continue;
      const double a = score[i] - half, b = score[i + 1] - half;
      if ((a <= 0 && b > 0) || (a >= 0 && b < 0)) {
        const double t = t0 + kStep * (i + a / (a - b));
        // The band must be at least min_band_px wide in the image too (the model may not know
        // where an occluder narrows it).
        const double band_dir = outer ? -1 : 1;
        for (double w = 0.5; w <= options.min_band_px; w += kStep) {
          const int k = static_cast<int>(std::lround((t + band_dir * w - t0) / kStep));
          if (k < 0 || k >= n || score[k] < half) return false;
        }
        *edge = pred.pixel + t * pred.outward;
        return true;
      }
    }
  }
  return false;
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
  const int n = static_cast<int>(points.size());
  if (n < std::max(options.min_points, 5)) return false;
  std::mt19937 rng(12345);  // deterministic
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::vector<int> best;
  for (int it = 0; it < options.ransac_iterations; ++it) {
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
    if (in.size() > best.size()) best.swap(in);
    if (static_cast<int>(best.size()) == n) break;
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

std::vector<LipEdgeFit> DetectLipEdges(const cv::Mat& raw_bgr, const RigModel& model,
                                       const LipDetectorOptions& options) {
  std::vector<LipEdgeFit> out;
  const RigParams& rig = model.params();
  if (raw_bgr.empty() || raw_bgr.type() != CV_8UC3 || raw_bgr.cols != rig.image_width ||
      raw_bgr.rows != rig.image_height) {
    return out;
  }
  const std::shared_ptr<const LipPrediction> prediction = PredictionFor(model, options);
  for (const EdgeTrack& track : prediction->tracks()) {
    LipEdgeFit fit;
    fit.path = track.path;
    fit.circle = track.circle;
    fit.edge.mirror = track.colour == Colour::kBlue ? 1 : 2;
    fit.edge.edge = track.outer ? "outer" : "inner";
    fit.edge.circle = LipCircleName(track.circle);
    fit.edge.path = LipPathName(track.path);
    fit.n_profiles = static_cast<int>(track.predictions.size());
    std::vector<Eigen::Vector2d> found;
    for (const EdgePrediction& pred : track.predictions) {
      Eigen::Vector2d edge;
      if (FindEdge(raw_bgr, track.colour, track.outer, pred, options, &edge)) found.push_back(edge);
    }
    fit.n_found = static_cast<int>(found.size());
    std::vector<int> inliers;
    if (!FitEllipseRobust(found, options, &fit.ellipse, &inliers)) continue;
    double sum2 = 0;
    for (int i : inliers) {
      fit.edge.points.push_back(found[i]);
      sum2 += std::pow(fit.ellipse.Distance(found[i]), 2);
    }
    fit.rms_px = std::sqrt(sum2 / inliers.size());
    out.push_back(std::move(fit));
  }
  return out;
}

std::vector<io::LipEdge> DetectLips(const cv::Mat& raw_bgr, const RigModel& model) {
  std::vector<io::LipEdge> out;
  for (LipEdgeFit& fit : DetectLipEdges(raw_bgr, model)) out.push_back(std::move(fit.edge));
  return out;
}

}  // namespace omni::detectors
