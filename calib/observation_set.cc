// The observation set: the detections' corners and lip points collected and checked, the
// placements' initial poses, the robust stages' corner subset, the lip points' azimuths and normal
// points; the reprojection of an observation at the current rig, and residual statistics.
#include <algorithm>
#include <atomic>
#include <map>
#include <thread>

#include "calib/calibration_steps.h"
#include "calib/corner_cost.h"
#include "model/single_rim.h"
#include "model/triangulation.h"
#include "pose/initial_pose.h"

namespace omni::calib {

namespace {

void CollectCorners(const Observations& detections, const std::vector<TargetSpec>& targets,
                    const CalibrationOptions& options, ObservationSet* set) {
  set->n_images = static_cast<int>(detections.images.size());
  std::map<std::pair<int, int>, int> placement_of;
  std::vector<int> per_target(targets.size(), 0);
  for (size_t i = 0; i < detections.images.size(); ++i) {
    const ImageObservations& image = detections.images[i];
    for (size_t k = 0; k < image.corners.size(); ++k) {
      const CornerObservation& c = image.corners[k];
      const std::string where = image.file + ": corner " + std::to_string(k);
      if (c.target < 0 || c.target >= static_cast<int>(targets.size())) {
        throw InputError(where + ": target index " + std::to_string(c.target) +
                             " is not one of the session's " + std::to_string(targets.size()) +
                             " targets");
      }
      if (!HasCorner(targets[c.target], c.id)) {
        throw InputError(where + ": corner id " + std::to_string(c.id) +
                             " is not on target " + std::to_string(c.target) + " (" +
                             TargetTypeName(targets[c.target].type) + ")");
      }
      if (!c.pixel.allFinite()) throw InputError(where + ": pixel is not finite");
      const auto key = std::make_pair(static_cast<int>(i), c.target);
      auto it = placement_of.find(key);
      if (it == placement_of.end()) {
        it = placement_of.emplace(key, static_cast<int>(set->placements.size())).first;
        Placement p;
        p.image = static_cast<int>(i);
        p.target = c.target;
        set->placements.push_back(p);
      }
      Observation o;
      o.image = static_cast<int>(i);
      o.target = c.target;
      o.id = c.id;
      o.mirror = MirrorIndex(c.mirror);
      o.placement = it->second;
      o.pixel = c.pixel;
      o.corner_in_target = CornerInTarget(targets[c.target], c.id);
      set->corners.push_back(o);
      ++per_target[c.target];
    }
  }
  if (set->corners.empty()) {
    std::string specs;
    for (size_t t = 0; t < targets.size(); ++t) {
      const TargetSpec& s = targets[t];
      specs += (t ? "; " : "") + std::string(TargetTypeName(s.type)) + " " +
               std::to_string(s.rows) + "x" + std::to_string(s.cols);
    }
    throw CalibrationError("no target corner was found in any of the " +
                           std::to_string(set->n_images) + " images: the session's targets (" + specs +
                           ") match nothing; check rows/cols (inner corners for chessboards), "
                           "the tag family and first_id");
  }
  for (size_t t = 0; t < targets.size(); ++t) {
    if (per_target[t] == 0) {
      Progress(options, "warning: session target " + std::to_string(t) + " (" +
               TargetTypeName(targets[t].type) + " " + std::to_string(targets[t].rows) + "x" +
               std::to_string(targets[t].cols) + ") was found in none of the images");
    }
  }
}

void CollectLips(const Observations& detections, const RigParams& rig,
                 std::vector<LipObservation>* lips) {
  for (size_t i = 0; i < detections.images.size(); ++i) {
    const ImageObservations& image = detections.images[i];
    for (size_t e = 0; e < image.lips.size(); ++e) {
      const LipEdgeObservation& edge = image.lips[e];
      const std::string where = image.file + ": lip edge " + std::to_string(e);
      if (!edge.path || !edge.circle) {
        throw InputError(where + ": the edge is not labelled with the lip circle and optical "
                             "path it images (circle: r_inner | r_outer, path: direct | "
                             "via_mirror1 | via_reflex | via_mirror2); `omnistereo detect` "
                             "labels its edges");
      }
      const LipPath path = *edge.path;
      const LipCircle circle = *edge.circle;
      if (LipOwner(path) != edge.mirror) {
        throw InputError(where + ": path " + LipPathName(path) + " images the lip of mirror " +
                             std::to_string(MirrorIndex(LipOwner(path))) + ", but mirror is " +
                             std::to_string(MirrorIndex(edge.mirror)));
      }
      const Lip& lip = LipOf(rig, path);
      // A single mirror's rim: a circle (r_inner = r_outer = r_sys) seen directly, no band.
      const bool rim = rig.Single() && path == LipPath::kDirect && circle == LipCircle::kOuter &&
                       lip.r_outer > 0;
      if (!rim && !(lip.r_outer > lip.r_inner && lip.r_inner >= 0)) {
        throw InputError(where + ": the starting model has no lip on mirror " +
                             std::to_string(MirrorIndex(edge.mirror)) + " (lip r_inner < r_outer expected)");
      }
      for (const Eigen::Vector2d& p : edge.points) {
        if (!p.allFinite()) throw InputError(where + ": a point is not finite");
        LipObservation l;
        l.image = static_cast<int>(i);
        l.path = path;
        l.radius = circle == LipCircle::kInner ? lip.r_inner : lip.r_outer;
        l.z = rim ? SingleRimZ(rig) : lip.z;
        l.pixel = p;
        lips->push_back(l);
      }
    }
  }
}

}  // namespace

ObservationSet CollectObservations(const Observations& detections,
                                   const std::vector<TargetSpec>& targets, const RigParams& rig,
                                   const CalibrationOptions& options) {
  ObservationSet set;
  CollectCorners(detections, targets, options, &set);
  if (options.use_lips) CollectLips(detections, rig, &set.lips);
  if (options.use_lips && options.rim_radius_free && rig.Single()) {
    set.rim_radius_free = true;
    set.rim_radius[0] = rig.r_sys;  // the points were labelled with the rim's circle
    SyncRimRadius(&set);
  }
  return set;
}

// Each point's azimuth: the nearest of a dense sampling of its circle's image at the starting
// model (the solve refines it; every stage frees the azimuths).
void InitialiseLipAzimuths(const RigState& rig, std::vector<LipObservation>* lips) {
  if (lips->empty()) return;
  constexpr int kSamples = 1440;
  std::map<std::pair<int, double>, std::vector<std::pair<double, Eigen::Vector2d>>> curves;
  const RigBlocks<double> blocks = RigBlocksOf(rig.params);
  const Eigen::Vector2d centre(rig.params.camera[kCx], rig.params.camera[kCy]);
  for (LipObservation& l : *lips) {
    auto key = std::make_pair(static_cast<int>(l.path), l.radius);
    auto it = curves.find(key);
    if (it == curves.end()) {
      std::vector<std::pair<double, Eigen::Vector2d>> curve;
      for (int k = 0; k < kSamples; ++k) {
        const double phi = 2 * M_PI * k / kSamples;
        Eigen::Vector2d px;
        if (ProjectLipEdge(blocks, *LipBounds(rig, l.path), l.path, l.radius,
                           CurrentLipZ(rig.params, l), phi,
                           rig.fixed->r_ref, &px) &&
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

namespace {

// One edge's points (indices into lips) in runs of the azimuth-sorted points at most `bin` wide.
std::vector<std::vector<size_t>> AzimuthBins(const std::vector<LipObservation>& lips,
                                             const std::vector<size_t>& indices, double bin) {
  // Bins: runs of the azimuth-sorted points at most `bin` wide, split wherever neighbours lie
  // more than half of it apart. The detector measures every image on the same profiles, so
  // one profile's points across the images (~0.001 deg apart) share a bin wherever the
  // profiles fall; fixed bins split them when the profiles' azimuths sat on the bins' edges
  // (detections made with the calibrated model: 1814 -> 3311 normal points, the lips'
  // per-edge bias read 0.10 -> 0.21 px and the projection uncertainty 1.5x).
  std::vector<std::pair<double, size_t>> by_azimuth;
  for (size_t i : indices) {
    by_azimuth.emplace_back(lips[i].phi[0] - 2 * M_PI * std::floor(lips[i].phi[0] / (2 * M_PI)), i);
  }
  std::sort(by_azimuth.begin(), by_azimuth.end());
  // The runs start after the widest gap round the circle, so no profile straddles the wrap.
  const size_t n = by_azimuth.size();
  size_t first = 0;
  double widest = by_azimuth.front().first + 2 * M_PI - by_azimuth.back().first;
  for (size_t k = 1; k < n; ++k) {
    if (by_azimuth[k].first - by_azimuth[k - 1].first > widest) {
      widest = by_azimuth[k].first - by_azimuth[k - 1].first;
      first = k;
    }
  }
  std::vector<std::vector<size_t>> bins;
  double start = 0, previous = 0;
  for (size_t k = 0; k < n; ++k) {
    const auto& [azimuth, i] = by_azimuth[(first + k) % n];
    const double phi = azimuth + (first + k >= n ? 2 * M_PI : 0);  // unwrapped along the runs
    if (bins.empty() || phi - previous > 0.5 * bin || phi - start > bin) {
      bins.emplace_back();
      start = phi;
    }
    bins.back().push_back(i);
    previous = phi;
  }
  return bins;
}

}  // namespace

// Normal points: the lip edge points of all images binned by azimuth (bins at most
// kLipSpacingDeg wide, one per detector profile) on each edge (path and circle), each bin
// replaced by the mean of its points. The rig does not move, so every image shows the same edges
// at the same pixels: a bin's points are repeated measurements of one short piece of one curve
// (its sagitta over 0.25 deg is ~1e-6 px), and their mean keeps what they say across the edge
// (white noise averages as over the points; a detector's bias, the same in every image, stays
// what it is) while the solve carries one residual and one azimuth instead of one per image:
// ~2500 normal points instead of ~56k lip points on a near session (docs/experiments.md). A bin's
// mean is taken over the points within 5 robust sigmas (the edge's MAD about its bins' medians)
// of its median offset across the edge, so a point on the wrong curve in a few images does not
// drag it; each normal point's residual group weight then comes from the variance components.
void NormalLipPoints(const CalibrationOptions& options, std::vector<LipObservation>* lip_points) {
  std::vector<LipObservation>& lips = *lip_points;
  std::map<std::pair<int, double>, std::vector<size_t>> edges;
  for (size_t i = 0; i < lips.size(); ++i) {
    if (!lips[i].Used() || !lips[i].projectable) continue;
    edges[{static_cast<int>(lips[i].path), lips[i].radius}].push_back(i);
  }
  const double bin = kLipSpacingDeg * kDeg;
  std::vector<LipObservation> normal;
  int members = 0;
  for (auto& [key, indices] : edges) {
    const std::vector<std::vector<size_t>> bins = AzimuthBins(lips, indices, bin);
    // Each bin's median offset across the edge, and the edge's robust scatter about them.
    std::vector<double> bin_median(bins.size());
    std::vector<double> deviations;
    for (size_t b = 0; b < bins.size(); ++b) {
      const std::vector<size_t>& in_bin = bins[b];
      std::vector<double> offsets;
      for (size_t i : in_bin) offsets.push_back(lips[i].across);
      std::sort(offsets.begin(), offsets.end());
      const size_t half = offsets.size() / 2;
      bin_median[b] = offsets.size() % 2 ? offsets[half] : 0.5 * (offsets[half - 1] + offsets[half]);
      if (in_bin.size() < 3) continue;  // two points: no consensus to judge either by
      for (size_t i : in_bin) deviations.push_back(std::abs(lips[i].across - bin_median[b]));
    }
    std::nth_element(deviations.begin(), deviations.begin() + deviations.size() / 2,
                     deviations.end());
    const double limit =
        deviations.empty() ? HUGE_VAL
                           : std::max(5 * 1.4826 * deviations[deviations.size() / 2], 1e-3);
    for (size_t b = 0; b < bins.size(); ++b) {
      const std::vector<size_t>& in_bin = bins[b];
      const double median = bin_median[b];
      LipObservation mean = lips[in_bin.front()];
      mean.pixel.setZero();
      mean.phi[0] = 0;
      mean.members = 0;
      const double phi_ref = lips[in_bin.front()].phi[0];
      for (size_t i : in_bin) {
        if (in_bin.size() >= 3 && std::abs(lips[i].across - median) > limit) {
          lips[i].rejected = true;  // off its bin's consensus: an outlier
          continue;
        }
        lips[i].unused = true;
        lips[i].normal = static_cast<int>(lips.size() + normal.size());
        mean.pixel += lips[i].pixel;
        mean.phi[0] += phi_ref + std::remainder(lips[i].phi[0] - phi_ref, 2 * M_PI);
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
  lips.insert(lips.end(), normal.begin(), normal.end());
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "lips: %zu normal points (means of %d edge points over the images, one per profile "
                "and edge, at most %.2f deg wide)",
                normal.size(), members, kLipSpacingDeg);
  Progress(options, buf);
}

// The robust stages only bring the rig into the basin of the weighted least-squares rounds, which
// then start within a few of their own sigmas and converge in 3-5 Gauss-Newton steps; so they
// solve with every k-th corner of each placement and ring (at least 6 of each), about
// kRobustStageCorners in all. bench_calibrate (12640 corners): the alignment stage was 70% of
// the solve.
void SelectRobustStageCorners(std::vector<Observation>* corners) {
  std::vector<Observation>& obs = *corners;
  std::map<std::pair<int, int>, std::vector<size_t>> groups;  // (placement, mirror)
  int n = 0;
  for (size_t i = 0; i < obs.size(); ++i) {
    if (obs[i].rejected) continue;
    groups[{obs[i].placement, obs[i].mirror}].push_back(i);
    ++n;
  }
  const int k = std::max(1, n / kRobustStageCorners);
  for (const auto& [key, members] : groups) {
    const int count = static_cast<int>(members.size());
    const int stride = std::max(1, std::min(k, count / 6));
    for (int j = 0; j < count; ++j) obs[members[j]].in_robust_stages = j % stride == 0;
  }
}

double CurrentLipZ(const RigParams& rig, const LipObservation& lip) {
  // A single mirror's rim moves with the refined conic (calib/lip_cost.h RimFollowsShape); so
  // does the circle its edge is where that is not the rim (RimCirclePointCost): the sag at the
  // point's radius (r_sys for the rim).
  if (!rig.Single() || lip.path != LipPath::kDirect) return lip.z;
  const Conic<double> conic{rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeK]};
  return rig.vertex_z + conic.Sag(lip.radius * lip.radius);
}

void SyncRimRadius(ObservationSet* observations) {
  for (LipObservation& l : observations->lips) {
    if (observations->RimRadiusFree(l)) l.radius = observations->rim_radius[0];
  }
}

bool ReprojectLip(const RigState& rig, const LipObservation& lip, Eigen::Vector2d* pixel) {
  // The band edge with the occlusion by the disc's rim followed (model/lip.h ProjectLipEdge).
  return ProjectLipEdge(RigBlocksOf(rig.params), *LipBounds(rig, lip.path), lip.path, lip.radius,
                        CurrentLipZ(rig.params, lip), lip.phi[0], rig.fixed->r_ref, pixel) &&
         pixel->allFinite();
}

double LipRms(const RigState& rig, const std::vector<LipObservation>& lips, int* count) {
  double ssr = 0;
  int n = 0;
  for (const auto& l : lips) {
    if (!l.Used()) continue;
    Eigen::Vector2d px;
    if (!ReprojectLip(rig, l, &px)) continue;
    ssr += (px - l.pixel).squaredNorm();
    ++n;
  }
  if (count) *count = n;
  return n ? std::sqrt(ssr / n) : 0.0;
}

bool Reproject(const RigState& rig, const ObservationSet& observations, const Observation& obs,
               Eigen::Vector2d* pixel) {
  const Eigen::Vector3d point =
      CornerInCam(observations.placements[obs.placement].cam_from_target.data(),
                  obs.corner_in_target);
  const RigBlocks<double> blocks = RigBlocksOf(rig.params);
  return obs.mirror == 1 ? ProjectViaMirror1(blocks, *rig.corner_bounds[0], point, pixel)
                         : ProjectViaMirror2(blocks, *rig.corner_bounds[1], point, pixel);
}

bool ReprojectOnMirror(const RigState& rig, const ObservationSet& observations,
                       const Observation& o, Eigen::Vector2d* pixel, double* radius) {
  const Eigen::Vector3d point =
      CornerInCam(observations.placements[o.placement].cam_from_target.data(), o.corner_in_target);
  const RigBlocks<double> blocks = RigBlocksOf(rig.params);
  ProjectionInfo info;
  const bool ok = o.mirror == 1
                      ? ProjectViaMirror1(blocks, *rig.corner_bounds[0], point, pixel, &info)
                      : ProjectViaMirror2(blocks, *rig.corner_bounds[1], point, pixel, &info);
  if (ok) *radius = info.point_on_mirror.head<2>().norm();
  return ok;
}

double CornerRms(const RigState& rig, const ObservationSet& observations, int mirror, int* count) {
  double ssr = 0;
  int n = 0;
  for (const auto& o : observations.corners) {
    if (o.rejected || (mirror && o.mirror != mirror)) continue;
    Eigen::Vector2d px;
    if (!Reproject(rig, observations, o, &px)) continue;
    ssr += (px - o.pixel).squaredNorm();
    ++n;
  }
  if (count) *count = n;
  return n ? std::sqrt(ssr / n) : 0.0;
}

double OuterRadius(const RigParams& rig, const std::vector<Observation>& corners) {
  double outer = 0;
  for (const auto& o : corners) {
    if (o.rejected || !o.projectable) continue;
    outer = std::max(outer, std::hypot((o.pixel.x() - rig.camera[kCx]) / rig.camera[kFx],
                                       (o.pixel.y() - rig.camera[kCy]) / rig.camera[kFy]));
  }
  return outer;
}

namespace {

// Placement p's pose: both rings' central guesses from the starting model `start`, the one that
// reprojects better through the full model kept, then refined pose-only (the rig constant).
// False: the placement failed.
bool PosePlacement(size_t p, const RigModel& start, RigState* rig, ObservationSet* observations,
                   CostCache* costs) {
  const std::vector<Observation>& obs = observations->corners;
  Placement& placement = observations->placements[p];
  std::vector<size_t> members;
  for (size_t i = 0; i < obs.size(); ++i) {
    if (obs[i].placement == static_cast<int>(p)) members.push_back(i);
  }
  double best_cost = HUGE_VAL;
  std::array<double, 6> best{};
  for (Mirror mirror : {Mirror::kOne, Mirror::kTwo}) {
    std::vector<Eigen::Vector3d> corners;
    std::vector<Eigen::Vector2d> pixels;
    for (size_t i : members) {
      if (obs[i].mirror != MirrorIndex(mirror)) continue;
      corners.push_back(obs[i].corner_in_target);
      pixels.push_back(obs[i].pixel);
    }
    PoseGuess guess;
    if (!CentralPoseFromRing(start, mirror, corners, pixels, &guess)) continue;
    std::copy(guess.rotation.data(), guess.rotation.data() + 3, placement.cam_from_target.begin());
    std::copy(guess.translation.data(), guess.translation.data() + 3,
              placement.cam_from_target.begin() + 3);
    double cost = 0;
    int n = 0;
    for (size_t i : members) {
      Eigen::Vector2d px;
      if (Reproject(*rig, *observations, obs[i], &px)) {
        cost += std::min((px - obs[i].pixel).squaredNorm(), 1e4);
        ++n;
      } else {
        cost += 1e4;
      }
    }
    if (n > 0 && cost < best_cost) {
      best_cost = cost;
      best = placement.cam_from_target;
    }
  }
  if (!(best_cost < HUGE_VAL)) return false;
  placement.cam_from_target = best;

  // Pose-only refinement with the full starting model (robust: a few bad corners must not
  // drag the pose), on the robust stages' corner subset: the stages refine it next, and with
  // every corner this took 0.25 s of bench_calibrate's 2.5 s.
  CalibrationProblem pose_problem;
  ceres::Problem& problem = pose_problem.problem;
  ceres::HuberLoss loss(3.0);
  int n = 0;
  for (size_t i : members) {
    Eigen::Vector2d px;
    if (!obs[i].in_robust_stages || !Reproject(*rig, *observations, obs[i], &px)) continue;
    ++n;
    AddCornerResidual(i, &loss, BlockMasks{}, rig, observations, costs, &problem);
  }
  if (n < 4) return false;
  for (int b = 0; b < kRigBlockCount; ++b) {
    double* block = BlockIn(&rig->params, static_cast<RigBlockId>(b));
    if (problem.HasParameterBlock(block)) problem.SetParameterBlockConstant(block);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 50;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  return summary.termination_type != ceres::FAILURE;
}

}  // namespace

void InitialisePoses(RigState* rig, const CalibrationOptions& options,
                     ObservationSet* observations, CostCache* costs) {
  std::vector<Placement>& placements = observations->placements;
  Status(options, "initial poses of " + std::to_string(placements.size()) + " target placements");
  const RigModel start(rig->params);
  SelectRobustStageCorners(&observations->corners);
  // Created here, read by the threads.
  for (size_t i = 0; i < observations->corners.size(); ++i) {
    CornerCost(*rig, observations->corners[i], i, BlockMasks{}, costs);
  }
  // Each placement is posed on its own (its observations, its pose block, the rig constant), so
  // the placements are shared out to the solver's threads.
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (size_t p = next++; p < placements.size(); p = next++) {
      if (!PosePlacement(p, start, rig, observations, costs)) placements[p].failed = true;
    }
  };
  std::vector<std::thread> threads;
  for (int t = 1; t < options.solver.threads; ++t) threads.emplace_back(worker);
  worker();
  for (auto& t : threads) t.join();
  int failed = 0;
  for (Observation& o : observations->corners) {
    if (!placements[o.placement].failed) continue;
    o.rejected = true;
    observations->rejected.push_back(
        {o.image, o.target, o.id, o.mirror, o.pixel, 0.0, "placement failed"});
  }
  for (const auto& p : placements) failed += p.failed;
  Progress(options, "initial poses: " + std::to_string(placements.size() - failed) + " of " +
                        std::to_string(placements.size()) +
                        " target placements posed from the starting model's rays" +
                        (failed ? " (" + std::to_string(failed) + " failed, left out)" : ""));
}

void CheckTargetScales(const RigParams& rig, const ObservationSet& observations,
                       const std::vector<TargetSpec>& targets, const CalibrationOptions& options) {
  // A target seen in both rings is measured by the rig itself: its corners' rays meet, so the
  // distances between them, over the distances the session's size gives, are the factor by
  // which that size is wrong. The mirrors' shapes (in mm, from the design) set the rig's scale,
  // so the calibrated rig measures it (a starting model's rays, a few tenths of a degree off,
  // gave factors 0.45-1.46 for right sizes). A board entered 10x too small is posed 10x too
  // near, and the solve bends the rig to fit it.
  const RigModel start(rig);
  std::map<int, std::vector<double>> factors;  // target -> one median factor per placement
  // Every placement and corner as detected: a target whose size is wrong has its corners
  // rejected as outliers (or its placements fail) while the others calibrate the rig.
  for (size_t p = 0; p < observations.placements.size(); ++p) {
    std::map<int, Eigen::Vector2d> ring[2];
    for (const Observation& o : observations.corners) {
      if (o.placement == static_cast<int>(p)) ring[o.mirror - 1][o.id] = o.pixel;
    }
    std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> points;  // (triangulated, in target)
    for (const auto& [id, pixel1] : ring[0]) {
      const auto it = ring[1].find(id);
      if (it == ring[1].end()) continue;
      const auto ray1 = start.Unproject(pixel1), ray2 = start.Unproject(it->second);
      if (!ray1 || !ray2 || ray1->mirror != Mirror::kOne || ray2->mirror != Mirror::kTwo) continue;
      Eigen::Vector3d point;
      if (!MidpointOnCommonPerpendicular(ray1->ray.origin, ray1->ray.direction, ray2->ray.origin,
                                         ray2->ray.direction, &point)) {
        continue;
      }
      points.emplace_back(point, CornerInTarget(targets[observations.placements[p].target], id));
    }
    if (points.size() < 6) continue;
    // Not beyond the range where the rings' parallax (~0.04 rad at 3 m) is a few times the
    // calibrated rays' errors.
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const auto& pt : points) centre += pt.first / points.size();
    if (std::hypot(centre.x(), centre.y()) > options.max_target_scale_range_mm) continue;
    std::vector<double> ratios;
    for (size_t i = 0; i < points.size(); ++i) {
      for (size_t j = i + 1; j < points.size(); ++j) {
        const double declared = (points[i].second - points[j].second).norm();
        if (declared > 0) ratios.push_back((points[i].first - points[j].first).norm() / declared);
      }
    }
    std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
    factors[observations.placements[p].target].push_back(ratios[ratios.size() / 2]);
  }
  for (auto& [t, f] : factors) {
    std::nth_element(f.begin(), f.begin() + f.size() / 2, f.end());
    const double factor = f[f.size() / 2];
    if (factor > 1.0 / options.max_target_scale_error && factor < options.max_target_scale_error) continue;
    const TargetSpec& spec = targets[t];
    const bool chessboard = spec.type == TargetType::kChessboard;
    const double size = chessboard ? spec.square_mm : spec.tag_size_mm;
    char buf[512];
    std::snprintf(buf, sizeof(buf),
                  "target %d (%s %dx%d, %s %g mm): seen in both rings, its corners triangulate %.2f "
                  "times as far apart as that size gives (median of %zu placements): the printed "
                  "size is likely ~%.3g mm; measure it and correct `%s:` in the session's targets "
                  "(mm), or check rows/cols and first_id; nothing written",
                  t, TargetTypeName(spec.type), spec.rows, spec.cols, chessboard ? "square" : "tag_size",
                  size, factor, f.size(), size * factor, chessboard ? "square" : "tag_size");
    throw CalibrationError(buf);
  }
}

void CheckDegeneracy(const ObservationSet& observations, const std::vector<TargetSpec>& targets,
                     const RigBlockSet& groups, const CalibrationOptions& options,
                     bool geometry_warns) {
  const std::vector<Placement>& placements = observations.placements;
  int n_placements = 0;
  std::vector<double> ranges, azimuths;
  for (size_t p = 0; p < placements.size(); ++p) {
    if (placements[p].failed) continue;
    ++n_placements;
    const TargetSpec& spec = targets[placements[p].target];
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    const std::vector<int> ids = CornerIds(spec);
    for (int id : ids) centre += CornerInTarget(spec, id);
    centre /= static_cast<double>(ids.size());
    const Eigen::Vector3d c = CornerInCam(placements[p].cam_from_target.data(), centre);
    ranges.push_back(std::hypot(c.x(), c.y()));
    azimuths.push_back(std::atan2(c.y(), c.x()));
  }
  int n_obs[2] = {0, 0};
  for (const auto& o : observations.corners) {
    if (!o.rejected) ++n_obs[o.mirror - 1];
  }
  int n_rig = 0;
  for (int b = 0; b < kRigBlockCount; ++b) n_rig += groups[b] ? kRigBlocks[b].size : 0;
  const int n_params = n_rig + 6 * n_placements;
  const int n_residuals = 2 * (n_obs[0] + n_obs[1]);
  if (n_placements < 3 || n_residuals < 2 * n_params) {
    throw CalibrationError(
        "too few observations: " + std::to_string(n_obs[0] + n_obs[1]) + " corners in " +
        std::to_string(n_placements) + " usable target placement(s) for " +
        std::to_string(n_params) + " unknowns; need at least 3 placements and " +
        std::to_string(n_params) + " corners (more images, or larger targets)");
  }
  auto estimated = [&](RigBlockId block) { return groups[block]; };
  if (estimated(kPose2Block) || estimated(kReflexBlock) || estimated(kShape2Block)) {
    if (n_obs[1] < 30) {
      throw CalibrationError("too few observations in the inner ring (mirror 2): " +
                             std::to_string(n_obs[1]) +
                             " corners; mirror 2 and the reflex plane need targets seen in both "
                             "rings (the stereo region)");
    }
  }
  if (estimated(kPose1Block) && n_obs[0] < 30) {
    throw CalibrationError("too few observations in the outer ring (mirror 1): " +
                           std::to_string(n_obs[0]) + " corners");
  }
  const double rmin = *std::min_element(ranges.begin(), ranges.end());
  const double rmax = *std::max_element(ranges.begin(), ranges.end());
  {
    char buf[160];
    std::snprintf(buf, sizeof(buf), "%d placements at ranges %.0f..%.0f mm from the axis",
                  n_placements, rmin, rmax);
    Progress(options, buf);
  }
  if (rmax < options.min_range_ratio * rmin) {
    char buf[256];
    std::snprintf(buf, sizeof(buf),
                  "degenerate session: all targets at one range (%.0f..%.0f mm from the axis); "
                  "place them at ranges differing by at least a factor %.1f (e.g. 0.5 m and 2 m) "
                  "so axial shifts and the focal length separate",
                  rmin, rmax, options.min_range_ratio);
    if (!geometry_warns) throw CalibrationError(buf);
    Progress(options, std::string("warning: ") + buf + "; the covariance says what it leaves open");
  }
  // Azimuth span: 360 deg minus the largest gap between neighbouring targets.
  std::sort(azimuths.begin(), azimuths.end());
  double largest_gap = 2 * M_PI - (azimuths.back() - azimuths.front());
  for (size_t i = 1; i < azimuths.size(); ++i) {
    largest_gap = std::max(largest_gap, azimuths[i] - azimuths[i - 1]);
  }
  const double span_deg = (2 * M_PI - largest_gap) / kDeg;
  if (span_deg < options.min_azimuth_span_deg) {
    char buf[256];
    std::snprintf(buf, sizeof(buf),
                  "degenerate session: all targets in one azimuth sector (%.0f deg wide); place "
                  "them all around the rig (a span of at least %.0f deg) so tilts and decentres "
                  "separate",
                  span_deg, options.min_azimuth_span_deg);
    if (!geometry_warns) throw CalibrationError(buf);
    Progress(options, std::string("warning: ") + buf + "; the covariance says what it leaves open");
  }
}

}  // namespace omni::calib
