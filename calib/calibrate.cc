#include "calib/calibrate.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <sstream>
#include <thread>

#include <Eigen/Geometry>

#include "calib/corner_cost.h"
#include "calib/covariance.h"
#include "calib/initial_pose.h"
#include "calib/lip_cost.h"
#include "calib/variance_components.h"
#include "model/lip.h"
#include "model/rig_parameters.h"
#include "model/rig_model.h"

namespace omni::calib {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kBoundSlackMm = 2.0;
constexpr double kLipSpacingDeg = 0.25;  // see Calibrator::NormalLipPoints
constexpr int kRobustStageCorners = 2000;  // see Calibrator::SelectRobustStageCorners

// The rig's parameter groups in covariance order.
// A radial distortion coefficient (dist_k1, dist_k2, dist_k3) is nearly unobservable when its
// sigma moves the outermost corner by more than this. A fixed bound on the coefficient ignored
// the radii: the rings reach only r = 0.28 (normalised), where dist_k2 moves a pixel r^2 = 0.08
// times as much as dist_k1. realistic_scene at 0.1 px determines dist_k2 = 0.05 to 0.085 (0.25 px
// at the rings' edge), and the old fixed 0.05 named it unobservable; dist_k1's bound stays about
// where it was (0.063 at r = 0.28, f = 1450).
constexpr double kDistortionBoundPx = 2.0;

// dist_k3 is refined when freeing it grows the sigmas of dist_k1 and dist_k2 by at most this
// factor (DecideDistK3): then the session's radii tell the three apart. Over a narrow range of
// radii r^6 is nearly a combination of r^2 and r^4 and the three trade: realistic_scene's rings
// reach r = 0.28, where freeing it grows dist_k2's sigma 3.3x and its own would be 1.7.
constexpr double kMaxK3SigmaGrowth = 2.0;

// The power of r by which the radial coefficient `name` moves a pixel at normalised radius r
// (the pixel moves by f * k * r^power), 0 for other parameters.
int RadialPower(const std::string& name) {
  if (name == "dist_k1") return 3;
  if (name == "dist_k2") return 5;
  if (name == "dist_k3") return 7;
  return 0;
}

// A parameter's bound above which its sigma means "nearly unobservable" (internal units): the
// table's (model/rig_parameters.h), or for a radial coefficient the one that moves the outermost
// corner (normalised radius `outer_radius`) by kDistortionBoundPx at focal length `f`.
double NearlyUnobservableSigma(const std::string& name, double f, double outer_radius) {
  if (RadialPower(name) > 0) {
    return f > 0 && outer_radius > 0
               ? kDistortionBoundPx / (f * std::pow(outer_radius, RadialPower(name)))
               : 0.05;
  }
  return FindRigParameter(name)->unobservable_sigma;
}

struct Observation {
  int image = 0, target = 0, id = 0, mirror = 1;
  int placement = -1;
  Eigen::Vector2d pixel;
  Eigen::Vector3d corner_in_target;
  bool rejected = false;     // outlier or its placement failed: out for good
  bool projectable = true;   // at the current parameters (re-checked each stage)
  bool in_robust_stages = true;  // one of the corners the robust stages solve with
};

// One lip edge point: the image of the point at azimuth phi (unknown, refined) on a lip circle
// along a path.
struct LipObservation {
  int image = 0;
  LipPath path = LipPath::kDirect;
  double radius = 0, z = 0;  // the circle in its mirror's body frame
  Eigen::Vector2d pixel;
  std::array<double, 1> phi{};
  bool rejected = false;
  bool unused = false;  // a detected point replaced by its bin's normal point (NormalLipPoints)
  int members = 1;      // a normal point: the detected points it is the mean of
  int normal = -1;      // a detected point: index of the normal point it went into
  double across = 0;    // signed distance across the edge from the curve (InitialiseLipAzimuths)
  bool projectable = true;
  bool Used() const { return !rejected && !unused; }
};

struct Placement {
  int image = 0, target = 0;
  std::array<double, 6> cam_from_target{};
  bool failed = false;
};

class Calibrator {
 public:
  Calibrator(const RigParams& start, const std::vector<TargetSpec>& targets,
             const io::Detections& detections, const CalibrationOptions& options)
      : rig_(start), targets_(targets), options_(options) {
    rig_.kind = ModelKind::kNoncentral;
    rig_.calibration.reset();
    fixed_ = FixedOf(rig_);
    // A detected corner IS seen, so the costs only need the validity bounds to keep the solver
    // on the right sheet and path: they use bounds relaxed by kBoundSlackMm (mirror 1: larger
    // rim, smaller disc; mirror 2: larger rim, smaller hole, larger disc), so a corner near a
    // ring's edge does not fail a trial step while the parameters are still off.
    cost_fixed_[0] = cost_fixed_[1] = fixed_;
    for (RigFixed& f : cost_fixed_) f.r_sys += kBoundSlackMm;
    cost_fixed_[0].r_ref = std::max(0.0, fixed_.r_ref - kBoundSlackMm);
    cost_fixed_[0].reflex_side_slack = kBoundSlackMm;
    cost_fixed_[1].r_ref += kBoundSlackMm;
    cost_fixed_[1].r_cam = std::max(0.0, fixed_.r_cam - kBoundSlackMm);
    constexpr double kLipSlackMm = 30.0;
    lip_fixed_[0] = lip_fixed_[1] = fixed_;
    for (RigFixed& f : lip_fixed_) f.r_sys += kLipSlackMm;
    lip_fixed_[0].r_ref = 0;  // direct, via_mirror1: no occlusion by the disc
    lip_fixed_[1].r_ref += kLipSlackMm;
    lip_fixed_[1].r_cam = 0;
    for (const auto& g : options_.estimate) estimate_.insert(g);
    refine_k3_ = options_.refine_dist_k3;
    Collect(detections);
    if (options_.use_lips) CollectLips(detections);
  }

  CalibrationResult Run();

 private:
  // Coordinates of a refined block that stay at their starting values.
  std::vector<int> HeldCoordinates(const std::string& group) const {
    std::vector<int> held;
    auto hold = [&](const char* name) {
      const RigParameter* p = FindRigParameter(name);
      if (group == p->block) held.push_back(p->index);
    };
    if (!options_.refine_skew) hold("skew");
    if (!options_.refine_tangential) hold("dist_p1"), hold("dist_p2");
    if (!refine_k3_) hold("dist_k3");
    return held;
  }
  void Progress(const std::string& line) const {
    if (options_.progress) options_.progress(line);
  }
  void Collect(const io::Detections& detections);
  void InitialisePoses();
  void CheckDegeneracy() const;
  bool Reproject(const Observation& obs, Eigen::Vector2d* pixel) const;
  bool ReprojectLip(const LipObservation& lip, Eigen::Vector2d* pixel) const;
  const RigFixed& LipFixed(LipPath path) const {
    // The detector labelled each edge's path already, and the lips lie at the mirrors' rims, so
    // the rim and disc bounds would only wall the solver in (an edge point whose reflection
    // leaves the rim by a hair fails a trial step): lip residuals use the bounds far relaxed.
    return path == LipPath::kDirect || path == LipPath::kViaMirror1 ? lip_fixed_[0]
                                                                     : lip_fixed_[1];
  }
  void CollectLips(const io::Detections& detections);
  void InitialiseLipAzimuths();
  void NormalLipPoints();
  void SelectRobustStageCorners();
  double LipRms(int* count) const;
  double* PoseBlock(int placement) { return placements_[placement].cam_from_target.data(); }
  ceres::CostFunction* CostOf(size_t i);
  // Adds every usable observation (and the shape priors) to `problem`; returns the count.
  int BuildProblem(ceres::Problem* problem, const std::set<std::string>& groups,
                   ceres::LossFunction* loss, std::vector<ceres::ResidualBlockId>* corner_blocks,
                   std::vector<ceres::ResidualBlockId>* prior_blocks);
  StageReport Solve(const std::string& name, const std::set<std::string>& groups, bool robust);
  // lips false: corners only (the lips' residuals are not fitted yet).
  int RejectOutliers(bool lips = true);
  // Variance components from the current residuals (see variance_components.h); sets the
  // groups' weights and robust noise.
  // lip_correlation false: the lips weighted as if independent (tau 1), see Run().
  void EstimateVarianceComponents(bool lip_correlation = true);
  double Rms(int mirror, int* count) const;  // mirror 0: both
  void Covariance(CalibrationResult* result);
  // The outermost used corner's radius in normalised image coordinates (at the current camera).
  double OuterRadius() const;
  // After Covariance(): frees dist_k3 when the session's radii tell it from dist_k1, dist_k2
  // (true: solve again); otherwise it stays held. Says which in result->notes.
  bool DecideDistK3(CalibrationResult* result);
  void CheckDiverged() const;

  RigParams rig_;
  RigFixed fixed_;
  RigFixed cost_fixed_[2];  // per mirror path, relaxed bounds (see the constructor)
  RigFixed lip_fixed_[2];   // for the lip paths of mirror 1 / mirror 2 (see LipFixed)
  std::vector<TargetSpec> targets_;
  CalibrationOptions options_;
  std::set<std::string> estimate_;
  bool refine_k3_ = false;  // dist_k3 refined (options_.refine_dist_k3, or DecideDistK3)
  // What the last Covariance() found for a held dist_k3 if it were freed: its sigma and the
  // largest factor by which dist_k1's and dist_k2's sigmas would grow.
  struct {
    bool evaluated = false;
    double sigma = HUGE_VAL, growth = 0;
  } k3_probe_;
  std::vector<Observation> obs_;
  std::vector<LipObservation> lips_;
  std::vector<std::unique_ptr<ceres::CostFunction>> lip_costs_;
  int last_n_lips_ = 0;  // lip residuals added by the last BuildProblem
  // Lip points enter the problem only once the corners have solved the rig and the groups'
  // noise is estimated (Run()).
  bool lips_in_solve_ = false;
  // The robust stages solve with a subset of the corners (SelectRobustStageCorners).
  bool robust_subset_only_ = false;
  std::vector<Placement> placements_;
  std::vector<std::unique_ptr<ceres::CostFunction>> costs_;
  // The coordinates of the camera and distortion blocks the running solve holds (bit k:
  // coordinate k): the costs give them no Jet slot (calib/slot_autodiff.h). Set by Solve() for
  // its solve only; 0 otherwise, so other evaluations (the covariance) get every column.
  uint32_t held_camera_ = 0, held_distortion_ = 0;
  std::vector<std::unique_ptr<ceres::CostFunction>> prior_costs_;
  std::vector<RejectedObservation> rejected_;
  int n_images_ = 0;
  // Per residual group (0: corners ring 1, 1: corners ring 2, 2: lips): the sigma each group is
  // weighted with (px; 1 until the first variance component estimate, so the robust stages weigh
  // every pixel alike) and the robust noise estimate behind the relative outlier threshold.
  double weight_sigma_[3] = {1, 1, 1};
  double robust_sigma_[3] = {0, 0, 0};  // 0: not estimated yet (outlier_px alone)
  std::vector<std::unique_ptr<ceres::LossFunction>> group_losses_;
  std::map<int, std::unique_ptr<ceres::LossFunction>> lip_losses_;  // per normal point's members
  std::vector<VarianceComponent> components_;
  std::vector<double> lip_edge_sigma_;  // the lip edges' considered bias sigmas (Covariance())
};

void Calibrator::Collect(const io::Detections& detections) {
  n_images_ = static_cast<int>(detections.images.size());
  std::map<std::pair<int, int>, int> placement_of;
  std::vector<int> per_target(targets_.size(), 0);
  for (size_t i = 0; i < detections.images.size(); ++i) {
    const io::ImageDetections& image = detections.images[i];
    for (size_t k = 0; k < image.corners.size(); ++k) {
      const io::CornerObservation& c = image.corners[k];
      const std::string where = image.file + ": corner " + std::to_string(k);
      if (c.target < 0 || c.target >= static_cast<int>(targets_.size())) {
        throw io::InputError(where + ": target index " + std::to_string(c.target) +
                             " is not one of the session's " + std::to_string(targets_.size()) +
                             " targets");
      }
      if (!HasCorner(targets_[c.target], c.id)) {
        throw io::InputError(where + ": corner id " + std::to_string(c.id) +
                             " is not on target " + std::to_string(c.target) + " (" +
                             TargetTypeName(targets_[c.target].type) + ")");
      }
      if (c.mirror != 1 && c.mirror != 2) {
        throw io::InputError(where + ": mirror must be 1 or 2, got " + std::to_string(c.mirror));
      }
      if (!c.pixel.allFinite()) throw io::InputError(where + ": pixel is not finite");
      const auto key = std::make_pair(static_cast<int>(i), c.target);
      auto it = placement_of.find(key);
      if (it == placement_of.end()) {
        it = placement_of.emplace(key, static_cast<int>(placements_.size())).first;
        Placement p;
        p.image = static_cast<int>(i);
        p.target = c.target;
        placements_.push_back(p);
      }
      Observation o;
      o.image = static_cast<int>(i);
      o.target = c.target;
      o.id = c.id;
      o.mirror = c.mirror;
      o.placement = it->second;
      o.pixel = c.pixel;
      o.corner_in_target = CornerInTarget(targets_[c.target], c.id);
      obs_.push_back(o);
      ++per_target[c.target];
    }
  }
  if (obs_.empty()) {
    std::string specs;
    for (size_t t = 0; t < targets_.size(); ++t) {
      const TargetSpec& s = targets_[t];
      specs += (t ? "; " : "") + std::string(TargetTypeName(s.type)) + " " +
               std::to_string(s.rows) + "x" + std::to_string(s.cols);
    }
    throw CalibrationError("no target corner was found in any of the " +
                           std::to_string(n_images_) + " images: the session's targets (" + specs +
                           ") match nothing; check rows/cols (inner corners for chessboards), "
                           "the tag family and first_id");
  }
  for (size_t t = 0; t < targets_.size(); ++t) {
    if (per_target[t] == 0) {
      Progress("warning: session target " + std::to_string(t) + " (" +
               TargetTypeName(targets_[t].type) + " " + std::to_string(targets_[t].rows) + "x" +
               std::to_string(targets_[t].cols) + ") was found in none of the images");
    }
  }
}

void Calibrator::CollectLips(const io::Detections& detections) {
  for (size_t i = 0; i < detections.images.size(); ++i) {
    const io::ImageDetections& image = detections.images[i];
    for (size_t e = 0; e < image.lips.size(); ++e) {
      const io::LipEdge& edge = image.lips[e];
      const std::string where = image.file + ": lip edge " + std::to_string(e);
      LipPath path;
      LipCircle circle;
      if (!ParseLipPath(edge.path, &path)) {
        throw io::InputError(where + ": path must be direct, via_mirror1, via_reflex or "
                             "via_mirror2, got '" + edge.path + "'");
      }
      if (!ParseLipCircle(edge.circle, &circle)) {
        throw io::InputError(where + ": circle must be r_inner or r_outer, got '" + edge.circle +
                             "'");
      }
      if (edge.mirror != MirrorIndex(LipOwner(path))) {
        throw io::InputError(where + ": path " + edge.path + " images the lip of mirror " +
                             std::to_string(MirrorIndex(LipOwner(path))) + ", but mirror is " +
                             std::to_string(edge.mirror));
      }
      const Lip& lip = LipOf(rig_, path);
      if (!(lip.r_outer > lip.r_inner && lip.r_inner >= 0)) {
        throw io::InputError(where + ": the starting model has no lip on mirror " +
                             std::to_string(edge.mirror) + " (lip r_inner < r_outer expected)");
      }
      for (const Eigen::Vector2d& p : edge.points) {
        if (!p.allFinite()) throw io::InputError(where + ": a point is not finite");
        LipObservation l;
        l.image = static_cast<int>(i);
        l.path = path;
        l.radius = circle == LipCircle::kInner ? lip.r_inner : lip.r_outer;
        l.z = lip.z;
        l.pixel = p;
        lips_.push_back(l);
      }
    }
  }
}

// Each point's azimuth: the nearest of a dense sampling of its circle's image at the starting
// model (the solve refines it; every stage frees the azimuths).
void Calibrator::InitialiseLipAzimuths() {
  if (lips_.empty()) return;
  constexpr int kSamples = 1440;
  std::map<std::pair<int, double>, std::vector<std::pair<double, Eigen::Vector2d>>> curves;
  const LipBlocks<double> blocks = LipBlocksOf(rig_);
  const Eigen::Vector2d centre(rig_.camera[2], rig_.camera[3]);
  for (LipObservation& l : lips_) {
    auto key = std::make_pair(static_cast<int>(l.path), l.radius);
    auto it = curves.find(key);
    if (it == curves.end()) {
      std::vector<std::pair<double, Eigen::Vector2d>> curve;
      for (int k = 0; k < kSamples; ++k) {
        const double phi = 2 * M_PI * k / kSamples;
        Eigen::Vector2d px;
        if (ProjectLipEdge(blocks, LipFixed(l.path), l.path, l.radius, l.z, phi, fixed_.r_ref,
                           &px) &&
            px.allFinite()) {
          curve.emplace_back(phi, px);
        }
      }
      it = curves.emplace(key, std::move(curve)).first;
    }
    const auto& curve = it->second;
    double best = HUGE_VAL;
    size_t best_k = 0;
    for (size_t k = 0; k < curve.size(); ++k) {
      const double d = (curve[k].second - l.pixel).squaredNorm();
      if (d < best) {
        best = d;
        best_k = k;
      }
    }
    l.projectable = best < HUGE_VAL;
    if (!l.projectable) continue;
    l.phi[0] = curve[best_k].first;
    Eigen::Vector2d foot = curve[best_k].second;
    // The foot of the perpendicular on the neighbouring chords (adjacent samples only), so that
    // the residual before the solve is across the edge, not up to half a sample along it (~1 px).
    for (const size_t other : {best_k + 1, best_k + curve.size() - 1}) {
      const auto& [phi_b, px_b] = curve[other % curve.size()];
      const auto& [phi_a, px_a] = curve[best_k];
      double dphi = std::remainder(phi_b - phi_a, 2 * M_PI);
      if (!(std::abs(std::abs(dphi) - 2 * M_PI / kSamples) < 1e-9)) continue;
      const Eigen::Vector2d chord = px_b - px_a;
      const double t = chord.dot(l.pixel - px_a) / std::max(chord.squaredNorm(), 1e-12);
      if (t > 0 && t <= 1) {
        l.phi[0] = phi_a + t * dphi;
        foot = px_a + t * chord;
      }
    }
    l.across = (l.pixel - foot).dot((foot - centre).normalized());
  }
}

// Normal points: the lip edge points of all images binned by azimuth (kLipSpacingDeg) on each
// edge (path and circle), each bin replaced by the mean of its points. The rig does not move, so
// every image shows the same edges at the same pixels: a bin's points are repeated measurements
// of one short piece of one curve (its sagitta over 0.25 deg is ~1e-6 px), and their mean keeps
// what they say across the edge (white noise averages as over the points; a detector's bias,
// the same in every image, stays what it is) while the solve carries one residual and one
// azimuth instead of one per image: issue 17's near session 55924 points -> ~2500 normal points,
// the lips were ~80% of the solve's time. A bin's mean is taken over the points within 5 robust
// sigmas (the edge's MAD about its bins' medians) of its median offset across the edge, so a point on the wrong curve in a few
// images does not drag it; each normal point's residual group weight then comes from the
// variance components as before.
void Calibrator::NormalLipPoints() {
  std::map<std::pair<int, double>, std::vector<size_t>> edges;
  for (size_t i = 0; i < lips_.size(); ++i) {
    if (!lips_[i].Used() || !lips_[i].projectable) continue;
    edges[{static_cast<int>(lips_[i].path), lips_[i].radius}].push_back(i);
  }
  const double bin = kLipSpacingDeg * kDeg;
  std::vector<LipObservation> normal;
  int members = 0;
  for (auto& [key, indices] : edges) {
    std::map<long, std::vector<size_t>> bins;
    for (size_t i : indices) {
      const double phi = lips_[i].phi[0] - 2 * M_PI * std::floor(lips_[i].phi[0] / (2 * M_PI));
      bins[static_cast<long>(phi / bin)].push_back(i);
    }
    // Each bin's median offset across the edge, and the edge's robust scatter about them.
    std::map<long, double> bin_median;
    std::vector<double> deviations;
    for (auto& [b, in_bin] : bins) {
      std::vector<double> offsets;
      for (size_t i : in_bin) offsets.push_back(lips_[i].across);
      std::sort(offsets.begin(), offsets.end());
      const size_t half = offsets.size() / 2;
      bin_median[b] = offsets.size() % 2 ? offsets[half] : 0.5 * (offsets[half - 1] + offsets[half]);
      if (in_bin.size() < 3) continue;  // two points: no consensus to judge either by
      for (size_t i : in_bin) deviations.push_back(std::abs(lips_[i].across - bin_median[b]));
    }
    std::nth_element(deviations.begin(), deviations.begin() + deviations.size() / 2,
                     deviations.end());
    const double limit =
        deviations.empty() ? HUGE_VAL
                           : std::max(5 * 1.4826 * deviations[deviations.size() / 2], 1e-3);
    for (auto& [b, in_bin] : bins) {
      const double median = bin_median[b];
      LipObservation mean = lips_[in_bin.front()];
      mean.pixel.setZero();
      mean.phi[0] = 0;
      mean.members = 0;
      const double phi_ref = lips_[in_bin.front()].phi[0];
      for (size_t i : in_bin) {
        if (in_bin.size() >= 3 && std::abs(lips_[i].across - median) > limit) {
          lips_[i].rejected = true;  // off its bin's consensus: an outlier
          continue;
        }
        lips_[i].unused = true;
        lips_[i].normal = static_cast<int>(lips_.size() + normal.size());
        mean.pixel += lips_[i].pixel;
        mean.phi[0] += phi_ref + std::remainder(lips_[i].phi[0] - phi_ref, 2 * M_PI);
        ++mean.members;
      }
      mean.pixel /= mean.members;
      mean.phi[0] /= mean.members;
      mean.unused = false;
      mean.image = -1;
      members += mean.members;
      normal.push_back(mean);
    }
  }
  lips_.insert(lips_.end(), normal.begin(), normal.end());
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "lips: %zu normal points (means of %d edge points over the images, one per %.2f "
                "deg of azimuth per edge)",
                normal.size(), members, kLipSpacingDeg);
  Progress(buf);
}

// The robust stages only bring the rig into the basin of the weighted least-squares rounds, which
// then start within a few of their own sigmas and converge in 3-5 Gauss-Newton steps; so they
// solve with every k-th corner of each placement and ring (at least 6 of each), about
// kRobustStageCorners in all. bench_calibrate (12640 corners): the alignment stage was 70% of
// the solve.
void Calibrator::SelectRobustStageCorners() {
  std::map<std::pair<int, int>, std::vector<size_t>> groups;  // (placement, mirror)
  int n = 0;
  for (size_t i = 0; i < obs_.size(); ++i) {
    if (obs_[i].rejected) continue;
    groups[{obs_[i].placement, obs_[i].mirror}].push_back(i);
    ++n;
  }
  const int k = std::max(1, n / kRobustStageCorners);
  for (const auto& [key, members] : groups) {
    const int count = static_cast<int>(members.size());
    const int stride = std::max(1, std::min(k, count / 6));
    for (int j = 0; j < count; ++j) obs_[members[j]].in_robust_stages = j % stride == 0;
  }
}

bool Calibrator::ReprojectLip(const LipObservation& lip, Eigen::Vector2d* pixel) const {
  // The band edge with the occlusion by the disc's rim followed (model/lip.h ProjectLipEdge).
  return ProjectLipEdge(LipBlocksOf(rig_), LipFixed(lip.path), lip.path, lip.radius, lip.z,
                        lip.phi[0], fixed_.r_ref, pixel) &&
         pixel->allFinite();
}

double Calibrator::LipRms(int* count) const {
  double ssr = 0;
  int n = 0;
  for (const auto& l : lips_) {
    if (!l.Used()) continue;
    Eigen::Vector2d px;
    if (!ReprojectLip(l, &px)) continue;
    ssr += (px - l.pixel).squaredNorm();
    ++n;
  }
  if (count) *count = n;
  return n ? std::sqrt(ssr / n) : 0.0;
}

bool Calibrator::Reproject(const Observation& obs, Eigen::Vector2d* pixel) const {
  const Eigen::Vector3d point =
      CornerInCam(placements_[obs.placement].cam_from_target.data(), obs.corner_in_target);
  if (obs.mirror == 1) {
    return ProjectViaMirror1(rig_.camera.data(), rig_.distortion.data(), rig_.mirror1_shape.data(),
                             rig_.mirror1_pose.data(), rig_.reflex.data(), cost_fixed_[0], point,
                             pixel);
  }
  return ProjectViaMirror2(rig_.camera.data(), rig_.distortion.data(), rig_.mirror1_pose.data(),
                           rig_.reflex.data(), rig_.mirror2_shape.data(),
                           rig_.mirror2_pose.data(), cost_fixed_[1], point, pixel);
}

ceres::CostFunction* Calibrator::CostOf(size_t i) {
  if (costs_.size() < obs_.size()) costs_.resize(obs_.size());
  if (!costs_[i]) {
    const Observation& o = obs_[i];
    costs_[i].reset(o.mirror == 1
                        ? Mirror1CornerCost::Create(o.pixel, o.corner_in_target, cost_fixed_[0],
                                                    &held_camera_, &held_distortion_)
                        : Mirror2CornerCost::Create(o.pixel, o.corner_in_target, cost_fixed_[1],
                                                    &held_camera_, &held_distortion_));
  }
  return costs_[i].get();
}

void Calibrator::InitialisePoses() {
  const RigModel start(rig_);
  SelectRobustStageCorners();
  for (size_t i = 0; i < obs_.size(); ++i) CostOf(i);  // created here, read by the threads
  // Each placement is posed on its own (its observations, its pose block, the rig constant), so
  // the placements are shared out to the solver's threads.
  auto pose_placement = [&](size_t p) {
    // Both rings' central guesses; keep the one that reprojects better through the full model.
    std::vector<size_t> members;
    for (size_t i = 0; i < obs_.size(); ++i) {
      if (obs_[i].placement == static_cast<int>(p)) members.push_back(i);
    }
    double best_cost = HUGE_VAL;
    std::array<double, 6> best{};
    for (Mirror mirror : {Mirror::kOne, Mirror::kTwo}) {
      std::vector<Eigen::Vector3d> corners;
      std::vector<Eigen::Vector2d> pixels;
      for (size_t i : members) {
        if (obs_[i].mirror != MirrorIndex(mirror)) continue;
        corners.push_back(obs_[i].corner_in_target);
        pixels.push_back(obs_[i].pixel);
      }
      PoseGuess guess;
      if (!CentralPoseFromRing(start, mirror, corners, pixels, &guess)) continue;
      std::copy(guess.rotation.data(), guess.rotation.data() + 3,
                placements_[p].cam_from_target.begin());
      std::copy(guess.translation.data(), guess.translation.data() + 3,
                placements_[p].cam_from_target.begin() + 3);
      double cost = 0;
      int n = 0;
      for (size_t i : members) {
        Eigen::Vector2d px;
        if (Reproject(obs_[i], &px)) {
          cost += std::min((px - obs_[i].pixel).squaredNorm(), 1e4);
          ++n;
        } else {
          cost += 1e4;
        }
      }
      if (n > 0 && cost < best_cost) {
        best_cost = cost;
        best = placements_[p].cam_from_target;
      }
    }
    if (!(best_cost < HUGE_VAL)) {
      placements_[p].failed = true;
      return;
    }
    placements_[p].cam_from_target = best;

    // Pose-only refinement with the full starting model (robust: a few bad corners must not
    // drag the pose), on the robust stages' corner subset: the stages refine it next, and with
    // every corner this took 0.25 s of bench_calibrate's 2.5 s.
    ceres::Problem::Options po;
    po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    ceres::HuberLoss loss(3.0);
    int n = 0;
    for (size_t i : members) {
      Eigen::Vector2d px;
      if (!obs_[i].in_robust_stages || !Reproject(obs_[i], &px)) continue;
      ++n;
      double* pose = PoseBlock(static_cast<int>(p));
      if (obs_[i].mirror == 1) {
        problem.AddResidualBlock(CostOf(i), &loss, rig_.camera.data(), rig_.distortion.data(),
                                 rig_.mirror1_shape.data(), rig_.mirror1_pose.data(),
                                 rig_.reflex.data(), pose);
      } else {
        problem.AddResidualBlock(CostOf(i), &loss, rig_.camera.data(), rig_.distortion.data(),
                                 rig_.mirror1_pose.data(), rig_.reflex.data(),
                                 rig_.mirror2_shape.data(), rig_.mirror2_pose.data(), pose);
      }
    }
    if (n < 4) {
      placements_[p].failed = true;
      return;
    }
    for (double* block : {rig_.camera.data(), rig_.distortion.data(), rig_.mirror1_shape.data(),
                          rig_.mirror2_shape.data(), rig_.mirror1_pose.data(),
                          rig_.mirror2_pose.data(), rig_.reflex.data()}) {
      if (problem.HasParameterBlock(block)) problem.SetParameterBlockConstant(block);
    }
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 50;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    if (summary.termination_type == ceres::FAILURE) placements_[p].failed = true;
  };
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (size_t p = next++; p < placements_.size(); p = next++) pose_placement(p);
  };
  std::vector<std::thread> threads;
  for (int t = 1; t < options_.solver.threads; ++t) threads.emplace_back(worker);
  worker();
  for (auto& t : threads) t.join();
  int failed = 0;
  for (size_t i = 0; i < obs_.size(); ++i) {
    if (!placements_[obs_[i].placement].failed) continue;
    obs_[i].rejected = true;
    rejected_.push_back({obs_[i].image, obs_[i].target, obs_[i].id, obs_[i].mirror, obs_[i].pixel,
                         0.0, "placement failed"});
  }
  for (const auto& p : placements_) failed += p.failed;
  Progress("initial poses: " + std::to_string(placements_.size() - failed) + " of " +
           std::to_string(placements_.size()) + " target placements posed from the starting " +
           "model's rays" + (failed ? " (" + std::to_string(failed) + " failed, left out)" : ""));
}

void Calibrator::CheckDegeneracy() const {
  int n_placements = 0;
  std::vector<double> ranges, azimuths;
  for (size_t p = 0; p < placements_.size(); ++p) {
    if (placements_[p].failed) continue;
    ++n_placements;
    const TargetSpec& spec = targets_[placements_[p].target];
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    const std::vector<int> ids = CornerIds(spec);
    for (int id : ids) centre += CornerInTarget(spec, id);
    centre /= static_cast<double>(ids.size());
    const Eigen::Vector3d c = CornerInCam(placements_[p].cam_from_target.data(), centre);
    ranges.push_back(std::hypot(c.x(), c.y()));
    azimuths.push_back(std::atan2(c.y(), c.x()));
  }
  int n_obs[2] = {0, 0};
  for (const auto& o : obs_) {
    if (!o.rejected) ++n_obs[o.mirror - 1];
  }
  int n_rig = 0;
  for (const auto& g : estimate_) n_rig += static_cast<int>(BlockParameterNames(g).size());
  const int n_params = n_rig + 6 * n_placements;
  const int n_residuals = 2 * (n_obs[0] + n_obs[1]);
  if (n_placements < 3 || n_residuals < 2 * n_params) {
    throw CalibrationError(
        "too few observations: " + std::to_string(n_obs[0] + n_obs[1]) + " corners in " +
        std::to_string(n_placements) + " usable target placement(s) for " +
        std::to_string(n_params) + " unknowns; need at least 3 placements and " +
        std::to_string(n_params) + " corners (more images, or larger targets)");
  }
  if (estimate_.count("mirror2_pose") || estimate_.count("reflex") ||
      estimate_.count("mirror2_shape")) {
    if (n_obs[1] < 30) {
      throw CalibrationError("too few observations in the inner ring (mirror 2): " +
                             std::to_string(n_obs[1]) +
                             " corners; mirror 2 and the reflex plane need targets seen in both "
                             "rings (the stereo region)");
    }
  }
  if (estimate_.count("mirror1_pose") && n_obs[0] < 30) {
    throw CalibrationError("too few observations in the outer ring (mirror 1): " +
                           std::to_string(n_obs[0]) + " corners");
  }
  const double rmin = *std::min_element(ranges.begin(), ranges.end());
  const double rmax = *std::max_element(ranges.begin(), ranges.end());
  {
    char buf[160];
    std::snprintf(buf, sizeof(buf), "%d placements at ranges %.0f..%.0f mm from the axis",
                  n_placements, rmin, rmax);
    Progress(buf);
  }
  if (rmax < options_.min_range_ratio * rmin) {
    char buf[256];
    std::snprintf(buf, sizeof(buf),
                  "degenerate session: all targets at one range (%.0f..%.0f mm from the axis); "
                  "place them at ranges differing by at least a factor %.1f (e.g. 0.5 m and 2 m) "
                  "so axial shifts and the focal length separate",
                  rmin, rmax, options_.min_range_ratio);
    throw CalibrationError(buf);
  }
  // Azimuth span: 360 deg minus the largest gap between neighbouring targets.
  std::sort(azimuths.begin(), azimuths.end());
  double largest_gap = 2 * M_PI - (azimuths.back() - azimuths.front());
  for (size_t i = 1; i < azimuths.size(); ++i) {
    largest_gap = std::max(largest_gap, azimuths[i] - azimuths[i - 1]);
  }
  const double span_deg = (2 * M_PI - largest_gap) / kDeg;
  if (span_deg < options_.min_azimuth_span_deg) {
    char buf[256];
    std::snprintf(buf, sizeof(buf),
                  "degenerate session: all targets in one azimuth sector (%.0f deg wide); place "
                  "them all around the rig (a span of at least %.0f deg) so tilts and decentres "
                  "separate",
                  span_deg, options_.min_azimuth_span_deg);
    throw CalibrationError(buf);
  }
}

int Calibrator::BuildProblem(ceres::Problem* problem, const std::set<std::string>& groups,
                             ceres::LossFunction* loss,
                             std::vector<ceres::ResidualBlockId>* corner_blocks,
                             std::vector<ceres::ResidualBlockId>* prior_blocks) {
  // Each group's residuals weighted with 1 / weight_sigma^2 (a scaled loss keeps the robust
  // loss's threshold in pixels).
  group_losses_.clear();
  ceres::LossFunction* group_loss[3];
  for (int g = 0; g < 3; ++g) {
    group_losses_.emplace_back(new ceres::ScaledLoss(
        loss, 1.0 / (weight_sigma_[g] * weight_sigma_[g]), ceres::DO_NOT_TAKE_OWNERSHIP));
    group_loss[g] = group_losses_.back().get();
  }
  // A normal point weighs as its members would: members / weight_sigma^2 (one loss per count).
  lip_losses_.clear();
  auto LipLoss = [&](ceres::LossFunction* base, int members) {
    auto& slot = lip_losses_[members];
    if (!slot) {
      slot.reset(new ceres::ScaledLoss(base, members / (weight_sigma_[2] * weight_sigma_[2]),
                                       ceres::DO_NOT_TAKE_OWNERSHIP));
    }
    return slot.get();
  };
  int n = 0;
  for (size_t i = 0; i < obs_.size(); ++i) {
    Observation& o = obs_[i];
    if (o.rejected || (robust_subset_only_ && !o.in_robust_stages)) continue;
    Eigen::Vector2d px;
    o.projectable = Reproject(o, &px);
    if (!o.projectable) continue;
    double* pose = PoseBlock(o.placement);
    ceres::ResidualBlockId id;
    if (o.mirror == 1) {
      id = problem->AddResidualBlock(CostOf(i), group_loss[0], rig_.camera.data(),
                                     rig_.distortion.data(), rig_.mirror1_shape.data(),
                                     rig_.mirror1_pose.data(), rig_.reflex.data(), pose);
    } else {
      id = problem->AddResidualBlock(CostOf(i), group_loss[1], rig_.camera.data(), rig_.distortion.data(),
                                     rig_.mirror1_pose.data(), rig_.reflex.data(),
                                     rig_.mirror2_shape.data(), rig_.mirror2_pose.data(), pose);
    }
    if (corner_blocks) corner_blocks->push_back(id);
    ++n;
  }
  // Lip edge points (pixel rows too: appended to corner_blocks after the corners).
  if (lip_costs_.size() < lips_.size()) lip_costs_.resize(lips_.size());
  last_n_lips_ = 0;
  for (size_t i = 0; i < (lips_in_solve_ ? lips_.size() : 0); ++i) {
    LipObservation& l = lips_[i];
    if (!l.Used()) continue;
    Eigen::Vector2d px;
    l.projectable = ReprojectLip(l, &px);
    if (!l.projectable) continue;
    if (!lip_costs_[i]) {
      lip_costs_[i].reset(LipPointCost::Create(l.pixel, l.path, l.radius, l.z, LipFixed(l.path),
                                               &held_camera_, &held_distortion_, fixed_.r_ref));
    }
    const auto id = problem->AddResidualBlock(
        lip_costs_[i].get(), LipLoss(loss, l.members), rig_.camera.data(), rig_.distortion.data(),
        rig_.mirror1_shape.data(), rig_.mirror1_pose.data(), rig_.reflex.data(),
        rig_.mirror2_shape.data(), rig_.mirror2_pose.data(), l.phi.data());
    if (corner_blocks) corner_blocks->push_back(id);
    ++last_n_lips_;
  }
  // Shape priors (only where the shape is refined).
  prior_costs_.clear();
  for (const char* shape : {"mirror1_shape", "mirror2_shape"}) {
    const auto prior = options_.priors.find(shape);
    if (!groups.count(shape) || prior == options_.priors.end()) continue;
    double* block = BlockIn(&rig_, shape);
    const double sigmas[2] = {prior->second.sigma_c, prior->second.sigma_k};
    for (int k = 0; k < 2; ++k) {
      if (!(sigmas[k] > 0)) continue;
      prior_costs_.emplace_back(new ceres::AutoDiffCostFunction<ScalarPriorCost, 1, 2>(
          new ScalarPriorCost{k, block[k], sigmas[k]}));
      const auto id = problem->AddResidualBlock(prior_costs_.back().get(), nullptr, block);
      if (prior_blocks) prior_blocks->push_back(id);
    }
  }
  for (const RigBlock& b : kRigBlocks) {
    const std::string g = b.name;
    double* block = BlockIn(&rig_, g);
    if (!problem->HasParameterBlock(block)) continue;
    if (!groups.count(g)) {
      problem->SetParameterBlockConstant(block);
    } else if (!HeldCoordinates(g).empty()) {
      problem->SetManifold(block, new ceres::SubsetManifold(5, HeldCoordinates(g)));
    }
  }
  return n;
}

double Calibrator::Rms(int mirror, int* count) const {
  double ssr = 0;
  int n = 0;
  for (const auto& o : obs_) {
    if (o.rejected || (mirror && o.mirror != mirror)) continue;
    Eigen::Vector2d px;
    if (!Reproject(o, &px)) continue;
    ssr += (px - o.pixel).squaredNorm();
    ++n;
  }
  if (count) *count = n;
  return n ? std::sqrt(ssr / n) : 0.0;
}

StageReport Calibrator::Solve(const std::string& name, const std::set<std::string>& groups,
                              bool robust) {
  const auto t0 = std::chrono::steady_clock::now();
  // What the stage starts from, to undo it if it ends worse.
  const RigParams rig_before = rig_;
  std::vector<std::array<double, 6>> poses_before;
  for (const auto& p : placements_) poses_before.push_back(p.cam_from_target);
  std::vector<double> phi_before;
  for (const auto& l : lips_) phi_before.push_back(l.phi[0]);
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  std::unique_ptr<ceres::LossFunction> loss;
  const double scale = options_.solver.loss_scale_px;
  if (robust && options_.solver.loss == "huber") loss.reset(new ceres::HuberLoss(scale));
  if (robust && options_.solver.loss == "cauchy") loss.reset(new ceres::CauchyLoss(scale));
  StageReport report;
  report.name = name;
  report.n_observations = BuildProblem(&problem, groups, loss.get(), nullptr, nullptr);
  report.initial_rms_px = Rms(0, nullptr);

  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  auto* ordering = new ceres::ParameterBlockOrdering;
  for (auto& p : placements_) {
    if (problem.HasParameterBlock(p.cam_from_target.data())) {
      ordering->AddElementToGroup(p.cam_from_target.data(), 0);
    }
  }
  for (auto& l : lips_) {
    if (problem.HasParameterBlock(l.phi.data())) ordering->AddElementToGroup(l.phi.data(), 0);
  }
  for (const RigBlock& b : kRigBlocks) {
    const std::string g = b.name;
    double* block = BlockIn(&rig_, g);
    if (problem.HasParameterBlock(block)) ordering->AddElementToGroup(block, 1);
  }
  so.linear_solver_ordering.reset(ordering);
  so.num_threads = std::max(1, options_.solver.threads);
  // The pinhole stage only brings the corners within reach of the alignment stage (the ideal
  // geometry cannot fit them: 7 px rms); beyond a few iterations it traded failed steps for 1% of
  // its cost (bench_calibrate: 7.04 px after 4 iterations, 7.17 after 8, 7.23 after 15).
  so.max_num_iterations = name == "pinhole" ? std::min(options_.solver.max_iterations, 8)
                                            : options_.solver.max_iterations;
  // The later stages start at (all) or next to (final) the previous stage's optimum, where the
  // Gauss-Newton step is good: Ceres' default initial trust region (1e4: Levenberg-Marquardt
  // damping 1e-4 of the Jacobi-scaled diagonal) crawled along the flat camera-rotation valley
  // while the region grew x3 per step (final rounds 8 + 6 iterations; with these 3 + 1 and
  // the same answer to 1e-5 sigma). A step that fails only shrinks the region.
  if (name == "all") so.initial_trust_region_radius = 1e6;
  if (name == "final" || name == "reweight") so.initial_trust_region_radius = 1e8;
  // Tight tolerances: the camera's rotation against the mirror bodies is a long, nearly flat
  // valley (a principal-point shift plus tilts of both mirrors); with looser ones the robust
  // stages stopped ~4 sigma short along it (the cost still falling by 1e-10 relative per step).
  // But not below the cost's rounding: near the optimum a step changes the cost by ~1e-10
  // absolute (~5e-15 relative) either way, so with 1e-15 half of all iterations were failed
  // steps at that noise floor (bench_calibrate: 99-115 iterations). The robust stages only feed
  // the next stage.
  // The weighted rounds are whitened: their cost is chi^2 / 2 (about half the residual rows), so
  // a Gauss-Newton step that lowers it by d moved the parameters by ~sqrt(2 d) sigma, and here
  // each step is ~10x shorter than the one before (bench_calibrate: the cost fell by 2e3, 17,
  // 3e-2, 1e-4, 1e-6). They stop once a step lowers it by less than kWeightedStepCost: the
  // answer is then within ~0.01 sigma of the converged one (measured: <= 8e-4 sigma from a 1e-14
  // relative tolerance, with 4 fewer full iterations: 0.5 s).
  constexpr double kWeightedStepCost = 1e-2;
  const bool weighted = name == "final" || name == "reweight";
  so.function_tolerance =
      weighted ? kWeightedStepCost / (0.5 * std::max(1, problem.NumResiduals())) : 1e-11;
  so.gradient_tolerance = 1e-16;
  so.parameter_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  auto mask = [&](const std::string& group) {
    uint32_t m = 0;
    if (groups.count(group)) {
      for (int k : HeldCoordinates(group)) m |= 1u << k;
    }
    return m;
  };
  held_camera_ = mask("camera");
  held_distortion_ = mask("distortion");
  ceres::Solve(so, &problem, &summary);
  held_camera_ = held_distortion_ = 0;
  report.iterations = static_cast<int>(summary.iterations.size()) - 1;
  report.converged = summary.termination_type == ceres::CONVERGENCE;
  report.termination = summary.message;
  report.final_rms_px = Rms(0, nullptr);
  // Worse: the solver's own cost rose (it never accepts such a step; a cost that fails to
  // evaluate at the end would show here), or the corners' RMS rose by more than 2%: the corners
  // are what the rig is calibrated from, and a stage that trades them for other residuals has
  // been pulled off by them (issue 17: lip points on the wrong curve took a stage from 0.56 to
  // 1.38 px). Such a stage is undone and said so; the calibration goes on from where it began.
  const bool worse = summary.final_cost > summary.initial_cost ||
                     report.final_rms_px > 1.02 * report.initial_rms_px + 1e-3;
  if (worse) {
    rig_ = rig_before;
    for (size_t p = 0; p < placements_.size(); ++p) placements_[p].cam_from_target = poses_before[p];
    for (size_t i = 0; i < lips_.size(); ++i) lips_[i].phi[0] = phi_before[i];
    report.undone = true;
  }
  report.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  char buf[384];
  std::snprintf(buf, sizeof(buf),
                "stage %-11s %6d obs  rms %8.3f -> %7.3f px  %3d iterations  %s  %.2f s "
                "(residuals %.2f, jacobians %.2f, linear solver %.2f)",
                name.c_str(), report.n_observations, report.initial_rms_px, report.final_rms_px,
                report.iterations,
                report.undone      ? "ENDED WORSE: undone"
                : report.converged ? "converged"
                                   : ("NOT converged: " + summary.message).c_str(),
                report.seconds, summary.residual_evaluation_time_in_seconds,
                summary.jacobian_evaluation_time_in_seconds, summary.linear_solver_time_in_seconds);
  Progress(buf);
  if (summary.termination_type == ceres::FAILURE) {
    throw CalibrationError("the solve failed in stage '" + name + "': " + summary.message);
  }
  return report;
}

// An observation is an outlier when its residual exceeds outlier_px or, once the groups' noise is
// known, 5 robust sigmas of its group (a 2-D Gaussian residual exceeds 5 sigma with probability
// 4e-6; a wrong corner id ~1 px off with corner noise ~0.1-0.2 px does).
double OutlierThreshold(double outlier_px, double robust_sigma) {
  return robust_sigma > 0 ? std::min(outlier_px, 5.0 * robust_sigma) : outlier_px;
}

int Calibrator::RejectOutliers(bool lips) {
  int n = 0;
  for (auto& o : obs_) {
    // On the corner subset only its corners are fitted (the others' poses are the subset's).
    if (o.rejected || (robust_subset_only_ && !o.in_robust_stages)) continue;
    Eigen::Vector2d px;
    if (!Reproject(o, &px)) continue;
    const double r = (px - o.pixel).norm();
    if (r > OutlierThreshold(options_.solver.outlier_px, robust_sigma_[o.mirror - 1])) {
      o.rejected = true;
      rejected_.push_back({o.image, o.target, o.id, o.mirror, o.pixel, r, "outlier"});
      ++n;
    }
  }
  for (auto& l : lips_) {
    if (!lips || !l.Used()) continue;
    Eigen::Vector2d px;
    if (!ReprojectLip(l, &px)) continue;
    const double scaled = std::sqrt(static_cast<double>(l.members)) * (px - l.pixel).norm();
    if (scaled > OutlierThreshold(options_.solver.outlier_px, robust_sigma_[2])) {
      l.rejected = true;
      ++n;
    }
  }
  return n;
}

void Calibrator::EstimateVarianceComponents(bool lip_correlation) {
  // Residuals per group, and each placement's corners per ring (its 6 pose unknowns are shared
  // between the rings in proportion).
  double ssr[3] = {0, 0, 0};
  int count[3] = {0, 0, 0};
  std::vector<std::vector<double>> norms(3);
  std::vector<std::array<int, 2>> per_placement(placements_.size(), {0, 0});
  for (const auto& o : obs_) {
    Eigen::Vector2d px;
    if (o.rejected || (robust_subset_only_ && !o.in_robust_stages) || !Reproject(o, &px)) continue;
    const int g = o.mirror - 1;
    ssr[g] += (px - o.pixel).squaredNorm();
    norms[g].push_back((px - o.pixel).norm());
    ++count[g];
    ++per_placement[o.placement][g];
  }
  std::vector<LipResidual> lip_residuals;
  const Eigen::Vector2d centre(rig_.camera[2], rig_.camera[3]);
  for (const auto& l : lips_) {
    Eigen::Vector2d px;
    if (!l.Used() || !ReprojectLip(l, &px)) continue;
    // A normal point's residual scaled by sqrt(members): the noise of one detected point.
    const Eigen::Vector2d r = std::sqrt(static_cast<double>(l.members)) * (px - l.pixel);
    ssr[2] += r.squaredNorm();
    norms[2].push_back(r.norm());
    ++count[2];
    // Across the edge ~ radially about the principal point (the lips' images are near-circles
    // about it); the along-edge part is absorbed by the point's azimuth.
    lip_residuals.push_back({static_cast<int>(l.path) * 100000 + static_cast<int>(l.radius * 100),
                             l.phi[0], r.dot((px - centre).normalized())});
  }
  // Unknowns: poses to the corner groups, one azimuth per lip point to the lips, the rig
  // parameters to every group in proportion to its residual rows.
  double pose_share[2] = {0, 0};
  for (const auto& c : per_placement) {
    const int total = c[0] + c[1];
    if (total == 0) continue;
    for (int g = 0; g < 2; ++g) pose_share[g] += 6.0 * c[g] / total;
  }
  int n_rig = 0;
  for (const auto& g : estimate_) {
    n_rig += static_cast<int>(BlockParameterNames(g).size()) -
             static_cast<int>(HeldCoordinates(g).size());
  }
  const double rows_total = 2.0 * (count[0] + count[1] + count[2]);
  const char* names[3] = {"corners ring 1", "corners ring 2", "lips"};
  components_.clear();
  for (int g = 0; g < 3; ++g) {
    if (count[g] == 0) continue;
    VarianceComponent c;
    c.group = names[g];
    c.count = count[g];
    c.ssr_px2 = ssr[g];
    const double nuisance = g < 2 ? pose_share[g] : count[g];
    c.redundancy = 2.0 * count[g] - nuisance - n_rig * 2.0 * count[g] / rows_total;
    if (!(c.redundancy > 0)) continue;
    // Per-axis sigma; lips: two rows per point but one is absorbed by the azimuth, so this is the
    // noise across the edge.
    c.sigma_px = std::sqrt(ssr[g] / c.redundancy);
    if (g == 2 && lip_correlation) c.correlation_factor = LipCorrelationFactor(lip_residuals);
    c.weight_sigma_px = c.sigma_px * std::sqrt(c.correlation_factor);
    weight_sigma_[g] = std::max(c.weight_sigma_px, 1e-3);
    // Robust per-axis sigma from the median residual norm (2-D: Rayleigh median 1.1774 sigma;
    // lips 1-D across the edge: 0.6745 sigma).
    std::nth_element(norms[g].begin(), norms[g].begin() + norms[g].size() / 2, norms[g].end());
    robust_sigma_[g] = norms[g][norms[g].size() / 2] / (g < 2 ? 1.1774 : 0.6745);
    components_.push_back(c);
  }
}

void Calibrator::CheckDiverged() const {
  for (const RigParameter& p : RigParameterTable()) {
    const double value = *ParameterOf(rig_, p.name);
    if (p.diverged_beyond > 0 && !(std::abs(value) <= p.diverged_beyond)) {
      throw CalibrationError(std::string("the solve diverged: ") + p.name + " went to " +
                             std::to_string(value) +
                             " (beyond any assembly error); check the starting model and the "
                             "target definitions (square size)");
    }
  }
  for (int i = 0; i < 5; ++i) {
    if (!std::isfinite(rig_.camera[i]) || !std::isfinite(rig_.distortion[i])) {
      throw CalibrationError("the solve diverged: the camera parameters are not finite");
    }
  }
}

void Calibrator::Covariance(CalibrationResult* result) {
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  std::vector<ceres::ResidualBlockId> corner_blocks, prior_blocks;
  const int n_obs = BuildProblem(&problem, estimate_, nullptr, &corner_blocks, &prior_blocks);

  // Columns: the refined rig blocks (tangent coordinates) in kRigBlocks order, then the poses.
  // Held coordinates with a considered sigma are freed in this problem so that their columns are
  // evaluated; `column_of` then moves them after the refined ones (ComputeRigCovariance's order).
  // A held dist_k3 without one is evaluated too (the probe column, right after the refined
  // ones), so that the same Jacobian says what freeing it would give (DecideDistK3).
  result->values.resize(0);
  result->considered.clear();
  result->unobservable.clear();
  k3_probe_ = {};
  ceres::Problem::EvaluateOptions eo;
  std::vector<std::string> names;
  std::vector<int> refined_cols, considered_cols;  // Ceres' column of each, in order
  std::vector<double> considered_sigma;
  int probe_col = -1;
  int col = 0;
  for (const RigBlock& b : kRigBlocks) {
    const std::string g = b.name;
    double* block = BlockIn(&rig_, g);
    if (!estimate_.count(g) || !problem.HasParameterBlock(block)) continue;
    eo.parameter_blocks.push_back(block);
    const auto& all = BlockParameterNames(g);
    const std::vector<int> held_coords = HeldCoordinates(g);
    std::vector<int> still_held;
    for (size_t k = 0; k < all.size(); ++k) {
      const bool held = std::count(held_coords.begin(), held_coords.end(), static_cast<int>(k));
      const auto consider = options_.considered_sigma.find(all[k]);
      if (!held) {
        names.push_back(all[k]);
        result->values.conservativeResize(names.size());
        result->values(names.size() - 1) = block[k];
        refined_cols.push_back(col++);
      } else if (consider != options_.considered_sigma.end() && consider->second > 0) {
        result->considered.push_back({all[k], block[k], consider->second});
        considered_sigma.push_back(consider->second);
        considered_cols.push_back(col++);
      } else if (all[k] == "dist_k3" && !options_.refine_dist_k3) {
        probe_col = col++;
      } else {
        still_held.push_back(static_cast<int>(k));
      }
    }
    if (still_held.size() != held_coords.size()) {
      problem.SetManifold(block, still_held.empty() ? nullptr
                                                    : new ceres::SubsetManifold(
                                                          static_cast<int>(all.size()), still_held));
    }
  }
  const int n_rig = static_cast<int>(names.size());
  const int n_probe = probe_col >= 0 ? 1 : 0;
  const int n_considered = static_cast<int>(considered_cols.size());
  std::vector<int> column_of(col);
  for (int i = 0; i < n_rig; ++i) column_of[refined_cols[i]] = i;
  if (n_probe) column_of[probe_col] = n_rig;
  for (int i = 0; i < n_considered; ++i) column_of[considered_cols[i]] = n_rig + n_probe + i;
  int n_poses = 0;
  for (auto& p : placements_) {
    if (problem.HasParameterBlock(p.cam_from_target.data())) {
      eo.parameter_blocks.push_back(p.cam_from_target.data());
      ++n_poses;
    }
  }
  std::vector<int> nuisance_sizes(n_poses, 6);
  for (auto& l : lips_) {
    if (problem.HasParameterBlock(l.phi.data())) {
      eo.parameter_blocks.push_back(l.phi.data());
      nuisance_sizes.push_back(1);
    }
  }
  const int n_lips = last_n_lips_;
  eo.residual_blocks = corner_blocks;
  eo.residual_blocks.insert(eo.residual_blocks.end(), prior_blocks.begin(), prior_blocks.end());
  eo.apply_loss_function = false;
  eo.num_threads = std::max(1, options_.solver.threads);
  double cost = 0;
  std::vector<double> residuals;
  ceres::CRSMatrix crs;
  problem.Evaluate(eo, &cost, &residuals, nullptr, &crs);

  // Rows: the corners (in obs_ order, each ring's weight), the lip points, the priors (whitened
  // already). Each pixel row is whitened with its group's weight sigma, so cov = (J^T W J)^-1.
  const int n_pixel_rows = 2 * (n_obs + n_lips);
  std::vector<double> row_weight(crs.num_rows, 1.0);
  {
    int row = 0;
    for (const auto& o : obs_) {
      if (o.rejected || !o.projectable) continue;
      row_weight[row] = row_weight[row + 1] = 1.0 / weight_sigma_[o.mirror - 1];
      row += 2;
    }
    for (const auto& l : lips_) {
      if (!l.Used() || !l.projectable) continue;
      row_weight[row] = row_weight[row + 1] =
          std::sqrt(static_cast<double>(l.members)) / weight_sigma_[2];
      row += 2;
    }
  }
  double ssr_weighted = 0;
  for (int i = 0; i < crs.num_rows; ++i) {
    const double r = row_weight[i] * residuals[i];
    ssr_weighted += r * r;
  }
  const int n_prior = static_cast<int>(prior_blocks.size());
  const int n_params = n_rig + 6 * n_poses + n_lips;
  const int dof = n_pixel_rows + n_prior - n_params;
  result->n_parameters = n_params;
  result->variance_factor = dof > 0 ? ssr_weighted / dof : 1.0;

  // Each lip edge's detector bias as a considered parameter: the rig does not move, so an edge
  // is detected with the same bias (blur, anti-aliasing) in every image and it does not average
  // out over the images; the solve's rig parameters absorb most of it (the residuals do not show
  // it: correlation factor 1.04 with a 0.03 px offset per edge). Its column (after the considered
  // coordinates, before the nuisance blocks) moves each of the edge's points across the edge.
  std::vector<Eigen::Triplet<double>> triplets;
  std::map<std::pair<int, double>, int> edge_column;  // (path, circle radius) -> column
  std::vector<std::pair<double, int>> edge_ssr;         // per column: across-edge SSR, count
  if (options_.lip_edge_bias_sigma_px > 0) {
    const Eigen::Vector2d centre(rig_.camera[2], rig_.camera[3]);
    int row = 2 * n_obs;
    for (const auto& l : lips_) {
      if (!l.Used() || !l.projectable) continue;
      const auto key = std::make_pair(static_cast<int>(l.path), l.radius);
      const int c = n_rig + n_probe + n_considered +
                    edge_column.emplace(key, static_cast<int>(edge_column.size())).first->second;
      const Eigen::Vector2d across = (l.pixel - centre).normalized();
      triplets.emplace_back(row, c, row_weight[row] * across.x());
      triplets.emplace_back(row + 1, c, row_weight[row + 1] * across.y());
      const double r = residuals[row] * across.x() + residuals[row + 1] * across.y();
      edge_ssr.resize(edge_column.size(), {0.0, 0});
      edge_ssr[c - n_rig - n_probe - n_considered].first += r * r;
      ++edge_ssr[c - n_rig - n_probe - n_considered].second;
      row += 2;
    }
    // Each edge's bias sigma: the option's, or the RMS of the edge's residuals across it if
    // larger. The lips' residuals are means over the images (normal points), so what remains of
    // them is mostly the detector's systematic error along the edge (a band edge reported on the
    // wrong curve over part of the azimuths, a colour-dependent offset); its constant part is
    // absorbed by the rig parameters and cannot show, and is taken to be as large as the part
    // that shows.
    lip_edge_sigma_.clear();
    for (const auto& [ssr, count] : edge_ssr) {
      lip_edge_sigma_.push_back(
          std::max(options_.lip_edge_bias_sigma_px, count ? std::sqrt(ssr / count) : 0.0));
      considered_sigma.push_back(lip_edge_sigma_.back());
    }
    result->lip_edges_considered = static_cast<int>(edge_column.size());
  }
  const int n_edges = static_cast<int>(edge_column.size());
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) {
      const int c = crs.cols[k] < col ? column_of[crs.cols[k]] : crs.cols[k] + n_edges;
      triplets.emplace_back(r, c, row_weight[r] * crs.values[k]);
    }
  }
  Eigen::SparseMatrix<double, Eigen::RowMajor> jacobian(crs.num_rows, crs.num_cols + n_edges);
  jacobian.setFromTriplets(triplets.begin(), triplets.end());

  RigCovarianceOptions co;
  co.variance_factor = 1.0;  // the weights are the groups' estimated variances
  co.nuisance_sizes = nuisance_sizes;
  co.considered_sigma = considered_sigma;
  const double outer_radius = OuterRadius();
  for (const auto& name : names) {
    co.nearly_unobservable_sigma.push_back(
        NearlyUnobservableSigma(name, rig_.camera[0], outer_radius));
  }
  const int n_front = n_rig + n_probe + static_cast<int>(considered_sigma.size());
  const Eigen::MatrixXd schur_all = RigSchurComplement(jacobian, n_front, nuisance_sizes);
  // Held dist_k3: the probe's row and column left out.
  std::vector<int> kept;
  for (int i = 0; i < n_front; ++i) {
    if (!(n_probe && i == n_rig)) kept.push_back(i);
  }
  Eigen::MatrixXd schur_held(kept.size(), kept.size());
  for (size_t i = 0; i < kept.size(); ++i) {
    for (size_t j = 0; j < kept.size(); ++j) schur_held(i, j) = schur_all(kept[i], kept[j]);
  }
  const RigCovariance cov = RigCovarianceFromSchur(schur_held, n_rig, co);
  if (n_probe) {
    // Freed: the radial coefficients' sigmas, and dist_k3's (HUGE_VAL if it is unobservable).
    RigCovarianceOptions freed_options = co;
    freed_options.nearly_unobservable_sigma.push_back(
        NearlyUnobservableSigma("dist_k3", rig_.camera[0], outer_radius));
    const RigCovariance freed = RigCovarianceFromSchur(schur_all, n_rig + 1, freed_options);
    auto sigma_of = [&](const RigCovariance& c, int index) {
      for (size_t i = 0; i < c.observable.size(); ++i) {
        if (c.observable[i] == index) return std::sqrt(std::max(c.covariance(i, i), 0.0));
      }
      return HUGE_VAL;
    };
    k3_probe_.evaluated = true;
    k3_probe_.sigma = sigma_of(freed, n_rig);
    for (int i = 0; i < n_rig; ++i) {
      if (names[i] != "dist_k1" && names[i] != "dist_k2") continue;
      const double held = sigma_of(cov, i);
      k3_probe_.growth =
          std::max(k3_probe_.growth, held < HUGE_VAL ? sigma_of(freed, i) / held : HUGE_VAL);
    }
  }
  const Eigen::VectorXd all_values = result->values;
  result->refined_names = names;
  result->schur_eigenvalues = cov.eigenvalues;
  result->schur_eigenvectors = cov.eigenvectors;
  result->names.clear();
  result->values.resize(cov.observable.size());
  for (size_t i = 0; i < cov.observable.size(); ++i) {
    result->names.push_back(names[cov.observable[i]]);
    result->values(i) = all_values(cov.observable[i]);
  }
  for (int i : cov.unobservable) result->unobservable.push_back({names[i], FindRigParameter(names[i])->hint});
  result->covariance = cov.covariance;
  result->considered_sensitivity = cov.considered_sensitivity;
  result->considered_column_sigma =
      Eigen::Map<const Eigen::VectorXd>(considered_sigma.data(), considered_sigma.size());
  result->sigma = cov.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  result->noise_sigma = cov.noise_covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  const int m = static_cast<int>(result->sigma.size());
  result->correlation = Eigen::MatrixXd::Identity(m, m);
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) {
      const double d = result->sigma(i) * result->sigma(j);
      if (d > 0) result->correlation(i, j) = result->covariance(i, j) / d;
    }
  }
}

// The camera's rotation against the mirror bodies (the principal point with equal tilts of both
// mirrors) is a flat valley of the cost, and the held tangential distortion lies along it
// (docs/design.md, Calibration): the camera frame C's pointing is uncertain by about the sigma of
// mirror 1's tilt, which is C's rotation against M1. Said in words, since a table of sigmas does
// not tell a user that C is the uncertain frame and M1 the one to measure in.
void AddPointingNote(CalibrationResult* result) {
  int rx = -1, ry = -1;
  for (size_t i = 0; i < result->names.size(); ++i) {
    if (result->names[i] == "mirror1.rx") rx = static_cast<int>(i);
    if (result->names[i] == "mirror1.ry") ry = static_cast<int>(i);
  }
  if (rx < 0 || ry < 0) return;
  std::string held;
  for (const auto& c : result->considered) {
    if (c.name == "dist_p1" || c.name == "dist_p2") held += (held.empty() ? "" : ", ") + c.name;
  }
  char buf[768];
  std::snprintf(buf, sizeof(buf),
                "camera pointing: the camera frame's rotation against the mirror bodies is "
                "weakly determined (it trades with the principal point and equal tilts of both "
                "mirrors%s): sigma %.3f / %.3f deg about x / y (mirror1.rx, ry; pixel noise alone "
                "%.3f / %.3f deg). Points in the camera frame carry it, distances and shapes do "
                "not: measure in mirror 1's body (triangulate --frame mirror1)",
                held.empty() ? "" : (", where the held " + held + " go").c_str(),
                result->sigma(rx) / kDeg, result->sigma(ry) / kDeg,
                result->noise_sigma(rx) / kDeg, result->noise_sigma(ry) / kDeg);
  result->notes.push_back(buf);
}

double Calibrator::OuterRadius() const {
  double outer = 0;
  for (const auto& o : obs_) {
    if (o.rejected || !o.projectable) continue;
    outer = std::max(outer, std::hypot((o.pixel.x() - rig_.camera[2]) / rig_.camera[0],
                                       (o.pixel.y() - rig_.camera[3]) / rig_.camera[1]));
  }
  return outer;
}

bool Calibrator::DecideDistK3(CalibrationResult* result) {
  if (!k3_probe_.evaluated) return false;
  const double outer = OuterRadius();
  char buf[512];
  if (k3_probe_.growth <= kMaxK3SigmaGrowth) {
    refine_k3_ = true;
    std::snprintf(buf, sizeof(buf),
                  "dist_k3 refined: this session's corners reach r = %.3f (normalised), where it "
                  "is told from dist_k1, dist_k2 (their sigmas grow %.2fx with it)",
                  outer, k3_probe_.growth);
  } else {
    char sigma[64] = "it would not be determined";
    char growth[64] = "dist_k1, dist_k2 would not be determined";
    if (k3_probe_.sigma < HUGE_VAL) {
      std::snprintf(sigma, sizeof(sigma), "its sigma would be %.3g", k3_probe_.sigma);
    }
    if (k3_probe_.growth < HUGE_VAL) {
      std::snprintf(growth, sizeof(growth), "theirs would grow %.1fx", k3_probe_.growth);
    }
    std::snprintf(buf, sizeof(buf),
                  "dist_k3 held at %g: over the radii this session's corners reach (r <= %.3f "
                  "normalised) it is nearly a combination of dist_k1 and dist_k2 (freed, %s and "
                  "%s); corners farther out would determine it",
                  rig_.distortion[4], outer, sigma, growth);
  }
  result->notes.push_back(buf);
  Progress(buf);
  return refine_k3_;
}

CalibrationResult Calibrator::Run() {
  InitialisePoses();
  CheckDegeneracy();
  if (!lips_.empty()) Progress("lips: " + std::to_string(lips_.size()) + " edge points");

  CalibrationResult result;
  // Stages: the pinhole first (the misalignment is small, so the ideal geometry with refined
  // fx, fy, cx, cy brings every corner within a few pixels), then the misalignment with the
  // pinhole and the lens distortion, then every group of `estimate` (the mirror shapes, if
  // asked). The pinhole stage holds the distortion: over the rings' narrow radii radial
  // distortion trades with the focal length, and freed there from 0 it went to dist_k1 -0.30,
  // dist_k2 +1.16 on big_rig_real_lens (truth -0.12, 0.05; the first version saw -1.6 with fx 3%
  // off). Held in the alignment stage too, that lens (the rings' outer edge 1.3% in) was
  // emulated by the mirrors' heights (tz +5.3 / +5.8 mm, reflex dz +2.2 mm, fx +2.6%: 0.38 px
  // rms after 65 iterations, 41 of them failed steps) until the next stage walked back. Freed
  // with the misalignment it reaches the same optimum directly (realistic_scene: 20 iterations
  // instead of 65 + 22; bench_calibrate's answer unchanged to 1e-8 sigma).
  std::vector<std::pair<std::string, std::set<std::string>>> stages;
  auto subset = [&](std::initializer_list<const char*> groups) {
    std::set<std::string> out;
    for (const char* g : groups) {
      if (estimate_.count(g)) out.insert(g);
    }
    return out;
  };
  stages.emplace_back("pinhole", subset({"camera"}));
  stages.emplace_back("alignment", subset({"camera", "distortion", "mirror1_pose",
                                           "mirror2_pose", "reflex"}));
  stages.emplace_back("all", estimate_);
  std::set<std::string> done;
  SelectRobustStageCorners();
  robust_subset_only_ = true;
  for (const auto& [name, groups] : stages) {
    if (groups.empty() || groups == done) continue;
    result.stages.push_back(Solve(name, groups, true));
    done = groups;
  }
  robust_subset_only_ = false;
  // Then: estimate each group's noise from the residuals (variance components), reject what lies
  // beyond outlier_px or 5 robust sigmas of its group, re-weight, re-solve without the robust
  // loss (its covariance is then the weighted least-squares one), until the weights settle and
  // no outlier is left (below).
  //
  // The lip edge points enter here, not in the robust stages: there every pixel weighed alike,
  // and tens of thousands of lip points (correlated along each edge and over the images, and
  // biased where the detector reports a band edge on the wrong curve) outweighed a few thousand
  // corners: on issue 17's near session (2821 corners, 55924 lip points) the alignment stage ran
  // 100 iterations to 4.8 px and the re-weighting then rejected 1115 corners; corners alone
  // converge there in 17 iterations to 0.155 px. So the corners solve the rig, the azimuths of
  // the lip points are found at that rig, and the lips come in with the weight their own
  // residuals give them.
  if (!lips_.empty()) {
    lips_in_solve_ = true;
    InitialiseLipAzimuths();
    NormalLipPoints();
  }
  // The first round weighs the lips as independent points: their residuals at the corners'
  // solution still carry the smooth trace of the rig's remaining error along each edge, which
  // the correlation factor would read as correlated noise (tau 600 on the near session's exact
  // fast-path lips, 1.0 once fitted) and weigh them down until later rounds walked it back. As
  // normal points they are few (~2500 against ~3000 corners) and their sigma then includes that
  // trace, so they cannot take over; from the second round on tau is measured on fitted
  // residuals. Rounds go on until no outlier is found and every weight is within 5% of the one
  // solved with (a weight 5% off moves the optimum by ~5% of the two groups' disagreement), at
  // most kMaxRounds.
  //
  // While the weights still move, a round's solve only feeds the next estimate, so those rounds
  // use the robust stages' corner subset (every placement and ring, ~2000 corners) with every
  // lip normal point: the rig they give is the full one's to within the subset's noise, and
  // each costs a fifth of a full round (bench_calibrate: the lips' weight went 5.29 -> 0.324 ->
  // 0.0875 -> 0.0502 px over four full rounds, 1.8 s of a 2.8 s solve). Once the weights settle
  // on the subset, the rounds go on with every corner until they settle there (usually one).
  constexpr int kMaxRounds = 6;
  robust_subset_only_ = false;
  for (const auto& o : obs_) robust_subset_only_ |= !o.rejected && !o.in_robust_stages;
  double solved_weights[3] = {0, 0, 0};
  for (int round = 0, full_rounds = 0; full_rounds < kMaxRounds; ++round) {
    // Round 0: the lips' residuals are those of the corners' rig (px off where the corners do
    // not fix fx against the distortion), so only corners are judged.
    EstimateVarianceComponents(/*lip_correlation=*/round > 0);
    const int n = RejectOutliers(/*lips=*/round > 0);
    bool weights_moved = false;
    for (int g = 0; g < 3; ++g) {
      weights_moved |= !(std::abs(weight_sigma_[g] - solved_weights[g]) <= 0.05 * weight_sigma_[g]);
    }
    if (n == 0 && !weights_moved) {
      if (!robust_subset_only_) {
        Progress("weights settled, no outliers: the last solve stands");
        break;
      }
      robust_subset_only_ = false;
      Progress("weights settled on the corner subset: every corner from here");
    } else if (robust_subset_only_ && round + 1 >= kMaxRounds) {
      robust_subset_only_ = false;
    }
    if (n > 0) Progress("rejected " + std::to_string(n) + " outlier(s)");
    std::string weights = "weights (sigma px):";
    for (const auto& c : components_) {
      char buf[160];
      std::snprintf(buf, sizeof(buf), " %s %.4f%s", c.group.c_str(), c.weight_sigma_px,
                    c.correlation_factor > 1 ? (" (tau " + std::to_string(c.correlation_factor).substr(0, 6) + ")").c_str() : "");
      weights += buf;
    }
    Progress(weights);
    full_rounds += !robust_subset_only_;
    result.stages.push_back(Solve(robust_subset_only_ ? "reweight" : "final", estimate_, false));
    std::copy(weight_sigma_, weight_sigma_ + 3, solved_weights);
  }
  robust_subset_only_ = false;
  // As reported, and the covariance's weights: the groups' noise at the final solution.
  EstimateVarianceComponents();
  CheckDiverged();
  Covariance(&result);
  if (DecideDistK3(&result)) {
    result.stages.push_back(Solve("final", estimate_, false));
    EstimateVarianceComponents();
    CheckDiverged();
    Covariance(&result);
  }
  AddPointingNote(&result);
  if (result.lip_edges_considered > 0) {
    std::string sigmas;
    for (double s : lip_edge_sigma_) {
      char one[32];
      std::snprintf(one, sizeof(one), "%s%.3g", sigmas.empty() ? "" : ", ", s);
      sigmas += one;
    }
    char buf[512];
    std::snprintf(buf, sizeof(buf),
                  "lips: a detector bias on each of the %d lip edges, the same in every image, is "
                  "carried into the sigmas: sigma %s px (at least %.3g, or the RMS of the edge's "
                  "residuals across it if larger)",
                  result.lip_edges_considered, sigmas.c_str(), options_.lip_edge_bias_sigma_px);
    result.notes.push_back(buf);
  }

  const int n_total = static_cast<int>(obs_.size());
  int n_outliers = 0;
  for (const auto& r : rejected_) n_outliers += r.reason == "outlier";
  for (const auto& o : obs_) {
    if (!o.rejected && !o.projectable) {
      rejected_.push_back({o.image, o.target, o.id, o.mirror, o.pixel, 0.0, "not projectable"});
    }
  }
  result.rms_px = Rms(0, &result.n_observations);
  result.per_mirror_rms_px[0] = Rms(1, nullptr);
  result.per_mirror_rms_px[1] = Rms(2, nullptr);
  // The lips as detected: each point's distance across the edge from the calibrated curve, over
  // the points whose normal point stayed in the solve.
  if (lips_in_solve_) {
    LipRms(&result.n_lip_normal_points);
    InitialiseLipAzimuths();
    double ssr = 0;
    int detected = 0;
    for (const auto& l : lips_) {
      if (l.image < 0) continue;  // a normal point
      ++detected;
      if (l.normal < 0 || !lips_[l.normal].Used() || !l.projectable) continue;
      ssr += l.across * l.across;
      ++result.n_lip_points;
    }
    result.lip_rms_px = result.n_lip_points ? std::sqrt(ssr / result.n_lip_points) : 0.0;
    result.n_lip_rejected = detected - result.n_lip_points;
  }
  if (result.n_observations < n_total / 2) {
    throw CalibrationError("the solve diverged or the model does not fit: only " +
                           std::to_string(result.n_observations) + " of " +
                           std::to_string(n_total) + " observations remain within " +
                           std::to_string(options_.solver.outlier_px) + " px");
  }
  result.converged = result.stages.back().converged;
  if (!result.converged) {
    Progress("warning: the final stage did not converge in " +
             std::to_string(options_.solver.max_iterations) + " iterations");
  }
  result.variance_components = components_;
  result.rejected = rejected_;
  for (const auto& p : placements_) {
    if (p.failed) continue;
    TargetPlacementEstimate e;
    e.image = p.image;
    e.target = p.target;
    e.rotation = Eigen::Vector3d(p.cam_from_target[0], p.cam_from_target[1], p.cam_from_target[2]);
    e.translation =
        Eigen::Vector3d(p.cam_from_target[3], p.cam_from_target[4], p.cam_from_target[5]);
    result.placements.push_back(e);
  }
  for (const auto& o : obs_) {
    if (o.rejected || !o.projectable) continue;
    for (auto& e : result.placements) {
      if (e.image == o.image && e.target == o.target) ++e.observations[o.mirror - 1];
    }
  }

  CalibrationInfo info;
  info.parameters = result.names;
  info.values.assign(result.values.data(), result.values.data() + result.values.size());
  info.sigma.assign(result.sigma.data(), result.sigma.data() + result.sigma.size());
  const int m = static_cast<int>(result.names.size());
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) info.covariance.push_back(result.covariance(i, j));
  }
  info.rms_px = result.rms_px;
  info.n_observations = result.n_observations;
  info.n_outliers = n_outliers;
  info.per_mirror_rms_px = {result.per_mirror_rms_px[0], result.per_mirror_rms_px[1]};
  info.images = n_images_;
  info.n_rejected = static_cast<int>(result.rejected.size()) + result.n_lip_rejected;
  info.n_lip_points = result.n_lip_points;
  info.lip_rms_px = result.lip_rms_px;
  for (const auto& u : result.unobservable) {
    info.unobservable.push_back(u.name);
    info.unobservable_hints.push_back(u.hint);
  }
  std::string targets;
  for (size_t t = 0; t < targets_.size(); ++t) {
    const TargetSpec& s = targets_[t];
    targets += (t ? ", " : "") + std::string(TargetTypeName(s.type)) + " " +
               std::to_string(s.rows) + "x" + std::to_string(s.cols);
  }
  info.targets = targets;
  result.rig = rig_;
  result.rig.calibration = info;
  return result;
}

}  // namespace

CalibrationOptions OptionsFromSession(const io::Session& session) {
  CalibrationOptions options;
  options.estimate = session.estimate;
  options.priors = session.priors;
  options.solver = session.solver;
  options.use_lips = session.use_lips;
  if (session.consider) options.considered_sigma = *session.consider;
  return options;
}

CalibrationResult Calibrate(const RigParams& start, const std::vector<TargetSpec>& targets,
                            const io::Detections& detections, const CalibrationOptions& options) {
  for (const auto& g : options.estimate) {
    if (BlockParameterNames(g).empty()) {
      throw io::InputError("estimate: unknown parameter group '" + g + "'");
    }
  }
  Calibrator calibrator(start, targets, detections, options);
  return calibrator.Run();
}

namespace {

// Value and unit of a parameter in assembly units (deg for tilts).
double Display(const std::string& name, double value, const char** unit) {
  const RigParameter* p = FindRigParameter(name);
  *unit = DisplayUnit(*p);
  return DisplayValue(*p, value);
}

double TruthOf(const RigParams& rig, const std::string& name) {
  const double* value = ParameterOf(rig, name);
  return value ? *value : NAN;
}

}  // namespace

std::string ResultTable(const CalibrationResult& result, const RigParams* truth) {
  std::ostringstream out;
  char line[256];
  // With considered parameters, `sigma` includes their share and `noise` is the pixel noise's.
  const bool with_noise = !result.considered.empty() &&
                          result.noise_sigma.size() == static_cast<long>(result.names.size());
  std::snprintf(line, sizeof(line), "%-12s %14s %12s %-4s", "parameter", "value", "sigma", "unit");
  out << line;
  if (with_noise) out << "        noise";
  if (truth) out << "         truth   (value-truth)/sigma";
  out << "\n";
  for (size_t i = 0; i < result.names.size(); ++i) {
    const char* unit = "";
    const double value = Display(result.names[i], result.values(i), &unit);
    const double sigma = Display(result.names[i], result.sigma(i), &unit);
    std::snprintf(line, sizeof(line), "%-12s %14.6f %12.6f %-4s", result.names[i].c_str(), value,
                  sigma, unit);
    out << line;
    if (with_noise) {
      std::snprintf(line, sizeof(line), " %12.6f", Display(result.names[i], result.noise_sigma(i), &unit));
      out << line;
    }
    if (truth) {
      const double t = Display(result.names[i], TruthOf(*truth, result.names[i]), &unit);
      std::snprintf(line, sizeof(line), " %14.6f %8.2f", t, sigma > 0 ? (value - t) / sigma : 0.0);
      out << line;
    }
    out << "\n";
  }
  for (const auto& c : result.considered) {
    std::snprintf(line, sizeof(line),
                  "%s: held at %.6g; its uncertainty (sigma %.3g) is carried into the sigmas\n",
                  c.name.c_str(), c.value, c.sigma);
    out << line;
  }
  for (const auto& u : result.unobservable) {
    out << u.name << ": not determined by this session (unobservable); needs " << u.hint << "\n";
  }
  for (const auto& note : result.notes) out << note << "\n";
  std::snprintf(line, sizeof(line),
                "residuals: rms %.4f px (mirror 1: %.4f, mirror 2: %.4f) over %d observations, "
                "%zu left out, weighted variance factor %.4g\n",
                result.rms_px, result.per_mirror_rms_px[0], result.per_mirror_rms_px[1],
                result.n_observations, result.rejected.size(), result.variance_factor);
  out << line;
  if (result.n_lip_points > 0 || result.n_lip_rejected > 0) {
    std::snprintf(line, sizeof(line),
                  "lips: rms %.4f px across the edge over %d edge points (in the solve as %d "
                  "normal points: their means over the images per %.2f deg of azimuth per edge), "
                  "%d left out\n",
                  result.lip_rms_px, result.n_lip_points, result.n_lip_normal_points,
                  kLipSpacingDeg, result.n_lip_rejected);
    out << line;
  }
  for (const auto& c : result.variance_components) {
    std::snprintf(line, sizeof(line),
                  "noise %-15s s = %.4f px per axis over %d (redundancy %.0f)%s, weighted as "
                  "%.4f px\n",
                  c.group.c_str(), c.sigma_px, c.count, c.redundancy,
                  c.correlation_factor > 1
                      ? (", correlation factor " + std::to_string(c.correlation_factor).substr(0, 6)).c_str()
                      : "",
                  c.weight_sigma_px);
    out << line;
  }
  return out.str();
}

}  // namespace omni::calib
