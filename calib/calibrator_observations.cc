#include "calib/calibrator.h"

#include <map>

#include "model/triangulation.h"

namespace omni::calib {

void Calibrator::Collect(const Observations& detections) {
  n_images_ = static_cast<int>(detections.images.size());
  std::map<std::pair<int, int>, int> placement_of;
  std::vector<int> per_target(targets_.size(), 0);
  for (size_t i = 0; i < detections.images.size(); ++i) {
    const ImageObservations& image = detections.images[i];
    for (size_t k = 0; k < image.corners.size(); ++k) {
      const CornerObservation& c = image.corners[k];
      const std::string where = image.file + ": corner " + std::to_string(k);
      if (c.target < 0 || c.target >= static_cast<int>(targets_.size())) {
        throw InputError(where + ": target index " + std::to_string(c.target) +
                             " is not one of the session's " + std::to_string(targets_.size()) +
                             " targets");
      }
      if (!HasCorner(targets_[c.target], c.id)) {
        throw InputError(where + ": corner id " + std::to_string(c.id) +
                             " is not on target " + std::to_string(c.target) + " (" +
                             TargetTypeName(targets_[c.target].type) + ")");
      }
      if (!c.pixel.allFinite()) throw InputError(where + ": pixel is not finite");
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
      o.mirror = MirrorIndex(c.mirror);
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

void Calibrator::CollectLips(const Observations& detections) {
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
      const Lip& lip = LipOf(rig_, path);
      if (!(lip.r_outer > lip.r_inner && lip.r_inner >= 0)) {
        throw InputError(where + ": the starting model has no lip on mirror " +
                             std::to_string(MirrorIndex(edge.mirror)) + " (lip r_inner < r_outer expected)");
      }
      for (const Eigen::Vector2d& p : edge.points) {
        if (!p.allFinite()) throw InputError(where + ": a point is not finite");
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
  const RigBlocks<double> blocks = RigBlocksOf(rig_);
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

// Normal points: the lip edge points of all images binned by azimuth (bins at most
// kLipSpacingDeg wide, one per detector profile) on each edge (path and circle), each bin
// replaced by the mean of its points. The rig does not move, so every image shows the same edges
// at the same pixels: a bin's points are repeated measurements of one short piece of one curve
// (its sagitta over 0.25 deg is ~1e-6 px), and their mean keeps what they say across the edge
// (white noise averages as over the points; a detector's bias, the same in every image, stays
// what it is) while the solve carries one residual and one azimuth instead of one per image:
// issue 17's near session 55924 points -> ~2500 normal points, the lips were ~80% of the solve's
// time. A bin's mean is taken over the points within 5 robust sigmas (the edge's MAD about its
// bins' medians) of its median offset across the edge, so a point on the wrong curve in a few
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
    // Bins: runs of the azimuth-sorted points at most `bin` wide, split wherever neighbours lie
    // more than half of it apart. The detector measures every image on the same profiles, so
    // one profile's points across the images (~0.001 deg apart) share a bin wherever the
    // profiles fall; fixed bins split them when the profiles' azimuths sat on the bins' edges
    // (detections made with the calibrated model: 1814 -> 3311 normal points, the lips'
    // per-edge bias read 0.10 -> 0.21 px and the projection uncertainty 1.5x).
    std::vector<std::pair<double, size_t>> by_azimuth;
    for (size_t i : indices) {
      by_azimuth.emplace_back(lips_[i].phi[0] - 2 * M_PI * std::floor(lips_[i].phi[0] / (2 * M_PI)), i);
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
    // Each bin's median offset across the edge, and the edge's robust scatter about them.
    std::vector<double> bin_median(bins.size());
    std::vector<double> deviations;
    for (size_t b = 0; b < bins.size(); ++b) {
      const std::vector<size_t>& in_bin = bins[b];
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
    for (size_t b = 0; b < bins.size(); ++b) {
      const std::vector<size_t>& in_bin = bins[b];
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
                "lips: %zu normal points (means of %d edge points over the images, one per profile "
                "and edge, at most %.2f deg wide)",
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
  return ProjectLipEdge(RigBlocksOf(rig_), LipFixed(lip.path), lip.path, lip.radius, lip.z,
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
  const RigBlocks<double> blocks = RigBlocksOf(rig_);
  return obs.mirror == 1 ? ProjectViaMirror1(blocks, cost_fixed_[0], point, pixel)
                         : ProjectViaMirror2(blocks, cost_fixed_[1], point, pixel);
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
  Status("initial poses of " + std::to_string(placements_.size()) + " target placements");
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
      AddCorner(&problem, i, &loss);
    }
    if (n < 4) {
      placements_[p].failed = true;
      return;
    }
    for (const RigBlock& b : kRigBlocks) {
      double* block = BlockIn(&rig_, b.name);
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

void Calibrator::CheckTargetScales() const {
  // A target seen in both rings is measured by the rig itself: its corners' rays meet, so the
  // distances between them, over the distances the session's size gives, are the factor by
  // which that size is wrong. The mirrors' shapes (in mm, from the design) set the rig's scale,
  // so the calibrated rig measures it (a starting model's rays, a few tenths of a degree off,
  // gave factors 0.45-1.46 for right sizes). A board entered 10x too small is posed 10x too
  // near, and the solve bends the rig to fit it.
  const RigModel start(rig_);
  std::map<int, std::vector<double>> factors;  // target -> one median factor per placement
  // Every placement and corner as detected: a target whose size is wrong has its corners
  // rejected as outliers (or its placements fail) while the others calibrate the rig.
  for (size_t p = 0; p < placements_.size(); ++p) {
    std::map<int, Eigen::Vector2d> ring[2];
    for (const Observation& o : obs_) {
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
      points.emplace_back(point, CornerInTarget(targets_[placements_[p].target], id));
    }
    if (points.size() < 6) continue;
    // Not beyond the range where the rings' parallax (~0.04 rad at 3 m) is a few times the
    // calibrated rays' errors.
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const auto& pt : points) centre += pt.first / points.size();
    if (std::hypot(centre.x(), centre.y()) > options_.max_target_scale_range_mm) continue;
    std::vector<double> ratios;
    for (size_t i = 0; i < points.size(); ++i) {
      for (size_t j = i + 1; j < points.size(); ++j) {
        const double declared = (points[i].second - points[j].second).norm();
        if (declared > 0) ratios.push_back((points[i].first - points[j].first).norm() / declared);
      }
    }
    std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
    factors[placements_[p].target].push_back(ratios[ratios.size() / 2]);
  }
  for (auto& [t, f] : factors) {
    std::nth_element(f.begin(), f.begin() + f.size() / 2, f.end());
    const double factor = f[f.size() / 2];
    if (factor > 1.0 / options_.max_target_scale_error && factor < options_.max_target_scale_error) continue;
    const TargetSpec& spec = targets_[t];
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

}  // namespace omni::calib
