// Calibrate(): the calibration as a sequence of steps over its data (calibration_data.h,
// calibration_steps.h): the observations collected and posed, the robust stages, the profiles'
// decision, the weighted rounds with the lip points, the covariance (and dist_k3's decision), and
// the result.
#include <cstdio>

#include "calib/calibration_steps.h"
#include "calib/central_decision.h"
#include "model/single_rim.h"

namespace omni::calib {

Refinement RefinementOf(const CalibrationOptions& options) {
  Refinement refined;
  for (const std::string& name : options.estimate) {
    const RigBlock* block = FindRigBlock(name);  // the names are checked (CalibrationOptions)
    if (block) refined.groups.set(block - kRigBlocks.data());
  }
  refined.skew = options.refine_skew;
  refined.tangential = options.refine_tangential;
  refined.dist_k3 = options.refine_dist_k3;
  refined.considered_sigma = options.considered_sigma;
  refined.shape_priors = options.priors;
  refined.profile_sigma_mm = options.profile_sigma_mm;
  return refined;
}

// Whether a single mirror's rim, of its measured diameter, is observed (a scale); not where its
// edge is fitted as a circle of free radius (CalibrationOptions::rim_radius_free).
bool RimObserved(const Observations& detections, const CalibrationOptions& options) {
  if (!options.use_lips || options.rim_radius_free) return false;
  for (const ImageObservations& image : detections.images) {
    for (const LipEdgeObservation& e : image.lips) {
      if (e.mirror == Mirror::kOne && e.path == LipPath::kDirect && e.circle == LipCircle::kOuter &&
          !e.points.empty()) {
        return true;
      }
    }
  }
  return false;
}

void RestrictToRig(const RigParams& rig, Refinement* refined, const CalibrationOptions& options,
                   bool rim_observed) {
  if (!rig.Single()) return;
  // A single-mirror rig has mirror 1's path only: nothing else can be refined.
  for (RigBlockId block : {kShape2Block, kPose2Block, kReflexBlock, kProfile2Block}) {
    if (refined->groups[block]) {
      refined->groups.reset(block);
      Progress(options, std::string("single-mirror rig: ") + kRigBlocks[block].name +
                            " is not part of it (left out of estimate)");
    }
  }
  refined->telecentric = rig.lens == LensKind::kTelecentric;
  const auto prior = refined->shape_priors.find(kRigBlocks[kShape1Block].name);
  const bool size_prior = prior != refined->shape_priors.end() && prior->second.sigma_c > 0;
  refined->hold_mirror_size = !rim_observed && !size_prior;
  if (rim_observed && refined->groups[kShape1Block]) {
    Progress(options, "single-mirror rig: the rim's edge in the photos is observed: R is refined "
                      "(the rim's diameter in the start is the scale: measured, or init's nominal one)");
  }
}

RigState RigStateOf(const RigParams& params) {
  RigState rig;
  rig.params = params;
  const RigFixed fixed = FixedOf(params);
  rig.fixed = std::make_shared<const RigFixed>(fixed);
  // Corners: bounds relaxed by kBoundSlackMm (mirror 1: larger rim, smaller disc; mirror 2: larger
  // rim, smaller hole, larger disc), so a corner near a ring's edge does not fail a trial step
  // while the parameters are still off. A detected point is seen: the mount's posts would only
  // wall trial steps in.
  RigFixed corner[2] = {fixed, fixed};
  for (RigFixed& f : corner) f.mount.present = false;
  for (RigFixed& f : corner) f.r_sys += kBoundSlackMm;
  corner[0].r_ref = std::max(0.0, fixed.r_ref - kBoundSlackMm);
  if (params.Single()) {
    // A mirror nobody designed for us starts far from its shape: the rim and the centre walled
    // every trial step of the corners the start puts just beyond them (a K 0.2 off put a corner
    // at the slackened rim). The conic goes on beyond both, and a detected corner is seen.
    corner[0].r_cam = 0;
    corner[0].r_sys = 2 * fixed.r_sys;
  }
  corner[0].reflex_side_slack = kBoundSlackMm;
  corner[1].r_ref += kBoundSlackMm;
  corner[1].r_cam = std::max(0.0, fixed.r_cam - kBoundSlackMm);
  // Lips: far relaxed (LipBounds).
  constexpr double kLipSlackMm = 30.0;
  RigFixed lip[2] = {fixed, fixed};
  for (RigFixed& f : lip) f.mount.present = false;
  for (RigFixed& f : lip) f.r_sys += kLipSlackMm;
  lip[0].r_ref = 0;  // direct, via_mirror1: no occlusion by the disc
  lip[1].r_ref += kLipSlackMm;
  lip[1].r_cam = 0;
  for (int m = 0; m < 2; ++m) {
    rig.corner_bounds[m] = std::make_shared<const RigFixed>(corner[m]);
    rig.lip_bounds[m] = std::make_shared<const RigFixed>(lip[m]);
  }
  return rig;
}

namespace {

// The calibration's state between its steps.
struct Calibration {
  RigState rig;
  ObservationSet observations;
  Refinement refined;
  ProfileState profiles;
  Weights weights;
  CostCache costs;
};

StageReport Solve(const Stage& stage, const CalibrationOptions& options, Calibration* c) {
  return SolveStage(stage, options, c->weights, c->refined, &c->rig, &c->observations, &c->costs);
}

// The robust stages of kRobustStages in order, on the corner subset, each from the last's answer.
void RunRobustStages(const CalibrationOptions& options, Calibration* c,
                     CalibrationResult* result) {
  SelectRobustStageCorners(&c->observations.corners);
  // A single mirror's rim is in from the start: the corners alone let the focal length, the
  // conic and the axial distance slide along one valley (and the rim end tens of pixels off,
  // its points then left out as outliers); the rim is what holds them.
  const bool rim = c->rig.params.Single() && !c->observations.lips.empty();
  RigBlockSet done;
  for (Stage stage : kRobustStages) {
    const RigBlockSet groups = StageGroups(stage, c->refined);
    if (groups.none() || groups == done) continue;
    stage.selection.lips = stage.selection.lips || rim;
    result->solve.stages.push_back(Solve(stage, options, c));
    done = groups;
  }
}

// The progress line of the groups' weights.
std::string WeightsLine(const Weights& weights) {
  std::string line = "weights (sigma px):";
  for (const auto& c : weights.components) {
    char buf[160];
    std::snprintf(buf, sizeof(buf), " %s %.4f%s", c.group.c_str(), c.weight_sigma_px,
                  c.correlation_factor > 1
                      ? (" (tau " + std::to_string(c.correlation_factor).substr(0, 6) + ")").c_str()
                      : "");
    line += buf;
  }
  return line;
}

// After the robust stages: estimate each group's noise from the residuals (variance
// components), reject what lies beyond outlier_px or 5 robust sigmas of its group, re-weight,
// re-solve without the robust loss (its covariance is then the weighted least-squares one),
// until the weights settle and no outlier is left.
//
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
// use the robust stages' corner subset (kReweightStage: every placement and ring, ~2000
// corners) with every lip normal point: the rig they give is the full one's to within the
// subset's noise, and each costs a fifth of a full round (bench_calibrate: the lips' weight went
// 5.29 -> 0.324 -> 0.0875 -> 0.0502 px over four full rounds, 1.8 s of a 2.8 s solve). Once the
// weights settle on the subset, the rounds go on with every corner (kFinalStage) until they
// settle there (usually one).
void RunWeightedRounds(const CalibrationOptions& options, Calibration* c,
                       CalibrationResult* result) {
  constexpr int kMaxRounds = 6;
  bool subset = false;
  for (const auto& o : c->observations.corners) subset |= !o.rejected && !o.in_robust_stages;
  double solved_weights[3] = {0, 0, 0};
  for (int round = 0, full_rounds = 0; full_rounds < kMaxRounds; ++round) {
    // Round 0: the lips' residuals are those of the corners' rig (px off where the corners do
    // not fix fx against the distortion), so only corners are judged.
    EstimateVarianceComponents(c->rig, c->observations, c->refined, subset,
                               /*lip_correlation=*/round > 0, &c->weights);
    const int n = RejectOutliers(c->rig, c->weights, {subset, /*lips=*/round > 0},
                                 options.solver.outlier_px, &c->observations);
    bool weights_moved = false;
    for (int g = 0; g < 3; ++g) {
      const double w = c->weights.sigma[g];
      weights_moved |= !(std::abs(w - solved_weights[g]) <= 0.05 * w);
    }
    if (n == 0 && !weights_moved) {
      if (!subset) {
        Progress(options, "weights settled, no new outliers: the last solve stands");
        break;
      }
      subset = false;
      Progress(options, "weights settled on the corner subset: every corner from here");
    } else if (subset && round + 1 >= kMaxRounds) {
      subset = false;
    }
    if (n > 0) Progress(options, "rejected " + std::to_string(n) + " outlier(s)");
    Progress(options, WeightsLine(c->weights));
    full_rounds += !subset;
    result->solve.stages.push_back(Solve(subset ? kReweightStage : kFinalStage, options, c));
    std::copy(c->weights.sigma, c->weights.sigma + 3, solved_weights);
  }
}

// The groups' noise at the final solution (as reported, and the covariance's weights), then the
// covariance; solved again with dist_k3 if the covariance says the session tells it apart. Then
// the notes: the camera's pointing, the profiles (FinishProfiles), the considered biases.
void FinalCovariance(const CalibrationOptions& options, Calibration* c,
                     CalibrationResult* result) {
  auto covariance = [&] {
    EstimateVarianceComponents(c->rig, c->observations, c->refined, /*corner_subset=*/false,
                               /*lip_correlation=*/true, &c->weights);
    CheckDiverged(c->rig.params);
    return ComputeCovariance(c->weights, c->refined, options, &c->rig, &c->observations,
                             &c->costs, result);
  };
  CovarianceFindings findings = covariance();
  if (DecideDistK3(findings, c->rig.params, c->observations.corners, options, &c->refined,
                   result)) {
    result->solve.stages.push_back(Solve(kFinalStage, options, c));
    findings = covariance();
  }
  AddPointingNote(c->rig.params.rig, result);
  if (c->observations.rim_radius_free) {
    result->solve.rim_edge_radius_mm = c->observations.rim_radius[0];
    result->solve.rim_edge_radius_sigma_mm = findings.rim_radius_sigma;
  }
  FinishProfiles(c->observations, c->profiles, options, &c->rig, result);
  if (result->uncertainty.lip_edges_considered > 0) {
    std::string sigmas;
    for (size_t e = 0; e < findings.lip_edge_sigma.size(); ++e) {
      const AlongEdgePattern& p = result->uncertainty.lip_edge_patterns[e];
      char one[96];
      std::snprintf(one, sizeof(one), "%s%.3g (rms %.3g over %.0f deg, correlated over %.1f)",
                    e ? ", " : "", findings.lip_edge_sigma[e], p.rms_px, p.coverage_deg,
                    p.correlation_deg);
      sigmas += one;
    }
    char buf[768];
    std::snprintf(buf, sizeof(buf),
                  "lips: a detector bias on each of the %d lip edges, the same in every image, is "
                  "carried into the sigmas: across the edge sigma %s px (at least %.3g, or the "
                  "constant part of the edge's residual pattern along it if larger: rms x "
                  "sqrt(correlation length / azimuth covered)), the whole edge's move along u "
                  "and v %.3g px",
                  result->uncertainty.lip_edges_considered, sigmas.c_str(),
                  options.lip_edge_offset_floor_px, options.lip_edge_bias_sigma_px);
    result->solve.notes.push_back(buf);
  }
  if (result->uncertainty.corner_offsets_considered > 0) {
    char buf[320];
    std::snprintf(buf, sizeof(buf),
                  "corners: a detector offset common to each ring's corners, the same in every "
                  "image, is carried into the sigmas: sigma %.3g px per axis (many corners average "
                  "their noise, not such an offset%s)",
                  options.corner_offset_sigma_px,
                  c->rig.params.Single() ? "" : "; the reflex tilt reads it most");
    result->solve.notes.push_back(buf);
  }
}

// The residual statistics of the corners and (as detected: each point's distance across the
// edge from the calibrated curve, over the points whose normal point stayed in the solve) the
// lips; throws if too few corners remain.
void ResidualStatistics(const CalibrationOptions& options, Calibration* c,
                        CalibrationResiduals* residuals) {
  ObservationSet& obs = c->observations;
  for (const auto& o : obs.corners) {
    if (!o.rejected && !o.projectable) {
      obs.rejected.push_back({o.image, o.target, o.id, o.mirror, o.pixel, 0.0, "not projectable"});
    }
  }
  residuals->rms_px = CornerRms(c->rig, obs, 0, &residuals->n_observations);
  residuals->per_mirror_rms_px[0] = CornerRms(c->rig, obs, 1, nullptr);
  residuals->per_mirror_rms_px[1] = CornerRms(c->rig, obs, 2, nullptr);
  if (!obs.lips.empty()) {
    LipRms(c->rig, obs.lips, &residuals->n_lip_normal_points);
    InitialiseLipAzimuths(c->rig, &obs.lips);
    double ssr = 0;
    int detected = 0;
    for (const auto& l : obs.lips) {
      if (l.image < 0) continue;  // a normal point
      ++detected;
      if (l.normal < 0 || !obs.lips[l.normal].Used() || !l.projectable) continue;
      ssr += l.across * l.across;
      ++residuals->n_lip_points;
    }
    residuals->lip_rms_px =
        residuals->n_lip_points ? std::sqrt(ssr / residuals->n_lip_points) : 0.0;
    residuals->n_lip_rejected = detected - residuals->n_lip_points;
  }
  const int n_total = static_cast<int>(obs.corners.size());
  if (residuals->n_observations < n_total / 2) {
    throw CalibrationError("the solve diverged or the model does not fit: only " +
                           std::to_string(residuals->n_observations) + " of " +
                           std::to_string(n_total) + " observations remain within " +
                           std::to_string(options.solver.outlier_px) + " px");
  }
}

// The result's placements, corner residuals, the data solved, and the rig with its calibration
// record.
void FillResult(const std::vector<TargetSpec>& targets, const Calibration& c,
                CalibrationResult* result) {
  const ObservationSet& obs = c.observations;
  CalibrationResiduals& residuals = result->residuals;
  result->uncertainty.variance_components = c.weights.components;
  residuals.rejected = obs.rejected;
  for (const auto& p : obs.placements) {
    if (p.failed) continue;
    TargetPlacementEstimate e;
    e.image = p.image;
    e.target = p.target;
    e.rotation = Eigen::Vector3d(p.cam_from_target[0], p.cam_from_target[1], p.cam_from_target[2]);
    e.translation =
        Eigen::Vector3d(p.cam_from_target[3], p.cam_from_target[4], p.cam_from_target[5]);
    residuals.placements.push_back(e);
  }
  for (const auto& o : obs.corners) {
    Eigen::Vector2d projected;
    if (o.rejected || !Reproject(c.rig, obs, o, &projected)) continue;
    residuals.corners.push_back({o.image, o.target, o.id, o.mirror, o.pixel, projected - o.pixel});
  }
  for (const auto& o : obs.corners) {
    if (o.rejected || !o.projectable) continue;
    for (auto& e : residuals.placements) {
      if (e.image == o.image && e.target == o.target) ++e.observations[o.mirror - 1];
    }
  }
  result->solve.images = obs.n_images;
  result->solve.targets = TargetsDescription(targets);
  result->estimate.rig = c.rig.params;
  // A single mirror's rim lies where its refined conic ends (SingleRimZ), as the model file puts it
  // when read back: the rim's reference for `check` is learnt on this rig (apps/cmd_calibrate.cc).
  RigParams& rig = result->estimate.rig;
  if (rig.Single() && !HasLip(rig, Mirror::kOne)) rig.lip1.z = SingleRimZ(rig);
  result->estimate.rig.calibration = CalibrationInfoOf(*result);
}

// estimate: []: the model held, every placement's pose solved by least squares on all its
// corners (no robust loss, no rejection): the residuals of photos the model was not fit to, as
// BabelCalib and mrcal score a calibration on held-out photos.
CalibrationResult ScoreWithModelHeld(const std::vector<TargetSpec>& targets,
                                     const CalibrationOptions& options, Calibration* c) {
  Progress(options, "estimate: [] -- the model held, only the targets' poses solved");
  CalibrationResult result;
  result.solve.stages.push_back(Solve(kScoreStage, options, c));
  ResidualStatistics(options, c, &result.residuals);
  result.solve.converged = result.solve.stages.back().converged;
  result.solve.notes.push_back(
      "scored with the model held (estimate: []): only the targets' poses were solved, so the "
      "residuals are those of photos the model was not fit to when none of these photos were in "
      "its calibration");
  FillResult(targets, *c, &result);
  return result;
}

}  // namespace

std::string CalibrationOptions::Check() const {
  for (const auto& g : estimate) {
    if (BlockParameterNames(g).empty()) return "estimate: unknown parameter group '" + g + "'";
  }
  if (profile != "auto" && profile != "free" && profile != "hold" && profile != "off") {
    return "profile: expected auto, free, hold or off, got '" + profile + "'";
  }
  if (noncentral != "auto" && noncentral != "free") {
    return "noncentral: expected auto or free, got '" + noncentral + "'";
  }
  if (profile != "off" && !(profile_sigma_mm > 0)) {
    return "profile_sigma_mm: expected a tolerance > 0 mm, got " + std::to_string(profile_sigma_mm);
  }
  return "";
}

std::map<std::string, double> DefaultConsideredSigmas() {
  std::map<std::string, double> sigmas;
  for (const RigParameter* p : ParametersWithRole(SolveRole::kTangential)) sigmas[p->name] = 5e-4;
  return sigmas;
}

namespace {

CalibrationResult CalibrateOnce(const RigParams& start, const std::vector<TargetSpec>& targets,
                                const Observations& detections, const CalibrationOptions& options) {
  // The rig from the start (every mirror with a profile), what is refined, the observations.
  Calibration c;
  c.refined = RefinementOf(options);
  RestrictToRig(start, &c.refined, options, RimObserved(detections, options));
  c.refined.shape_mean[0] = start.mirror1_shape;
  c.refined.shape_mean[1] = start.mirror2_shape;
  RigParams params = start;
  params.kind = ModelKind::kNoncentral;
  params.calibration.reset();
  c.profiles = SetUpProfiles(start, options, &params, &c.refined);
  if (options.estimate.empty()) c.refined.groups.reset();  // scoring: nothing refined
  c.rig = RigStateOf(params);
  c.observations = CollectObservations(detections, targets, c.rig.params, options);
  InitialisePoses(&c.rig, options, &c.observations, &c.costs);
  if (c.refined.groups.none()) return ScoreWithModelHeld(targets, options, &c);
  // A single-mirror camera is often calibrated from boards at one range in one sector (the
  // toolboxes' sample sets): said, not refused; the covariance names what it leaves open.
  CheckDegeneracy(c.observations, targets, c.refined.groups, options,
                  /*geometry_warns=*/params.Single());
  if (!c.observations.lips.empty()) {
    Progress(options, "lips: " + std::to_string(c.observations.lips.size()) + " edge points");
  }

  CalibrationResult result;
  // A single mirror's rim is in the robust stages too (RunRobustStages): its azimuths first.
  if (params.Single() && !c.observations.lips.empty()) {
    InitialiseLipAzimuths(c.rig, &c.observations.lips);
  }
  RunRobustStages(options, &c, &result);
  // Each mirror's profile: freed where the corners cover its radii (profiles.cc).
  DecideProfiles(c.observations, options, &c.rig, &c.profiles, &c.refined, &result);
  // The lip edge points enter now, not in the robust stages: there every pixel weighed alike,
  // and tens of thousands of lip points (correlated along each edge and over the images, and
  // biased where the detector reports a band edge on the wrong curve) outweighed a few thousand
  // corners and pulled the rig off them (docs/experiments.md). So the corners solve the rig, the
  // azimuths of the lip points are found at that rig, and the lips come in with the weight their
  // own residuals give them.
  if (!c.observations.lips.empty()) {
    InitialiseLipAzimuths(c.rig, &c.observations.lips);
    NormalLipPoints(options, &c.observations.lips);
  }
  RunWeightedRounds(options, &c, &result);
  FinalCovariance(options, &c, &result);

  ResidualStatistics(options, &c, &result.residuals);
  CheckTargetScales(c.rig.params, c.observations, targets, options);
  result.solve.converged = result.solve.stages.back().converged;
  if (!result.solve.converged) {
    Progress(options, "warning: the final stage did not converge in " +
                          std::to_string(options.solver.max_iterations) + " iterations");
  }
  FillResult(targets, c, &result);
  return result;
}

// CalibrateOnce, and again with a single mirror's rim points as a mirror circle of free radius
// where its image's edge is not the rim.
CalibrationResult CalibrateJudgingRim(const RigParams& start, const std::vector<TargetSpec>& targets,
                                      const Observations& detections,
                                      const CalibrationOptions& options) {
  CalibrationResult result = CalibrateOnce(start, targets, detections, options);
  // A single mirror's rim is its image's edge only where the mirror's outer zone does not look
  // back over the rim (model/single_rim.h): that is known once the mirror is (a bought mirror's
  // start guesses its shape), so it is judged at the calibrated mirror.
  if (!start.Single() || !RimObserved(detections, options) || options.estimate.empty()) {
    return result;
  }
  double elevation = 0;
  if (RimEdgeIsTheRim(RigModel(result.estimate.rig), &elevation)) return result;
  // The edge is then what the holder at the rim makes of the mirror: still a circle on the mirror
  // (its reflected rays graze the holder's edge), of unknown radius, so through a perspective
  // lens its centre and ellipse still place the mirror against the camera (the circle's near and
  // far sides seen at different distances tell its tilt from its decentre); its size, not being
  // the rim's, sets no scale. Through a telecentric lens a tilted circle's image is the untilted
  // one shifted (its ellipse differs by cos(tilt): 0.02 px at 0.5 deg), which the principal
  // point does as well: the edge decides nothing there (the sample paraboloid's tilt stayed
  // undetermined with it, and its points at 1 m were no closer), so the rim is left out.
  if (start.lens == LensKind::kTelecentric) {
    char why[480];
    std::snprintf(why, sizeof(why),
                  "the mirror's rim left out: at the calibrated mirror its outer zone reflects rays "
                  "%.1f deg past the rim's plane, where whatever holds the mirror at its rim is "
                  "seen, so the edge of its image need not be the rim; through a telecentric lens "
                  "a circle inside it would place nothing the principal point does not "
                  "(calibrated without it)",
                  elevation);
    Progress(options, std::string(why) + "; calibrating again");
    CalibrationOptions without = options;
    without.use_lips = false;
    result = CalibrateOnce(start, targets, detections, without);
    result.solve.notes.push_back(why);
    result.solve.rim_left_out = true;
    return result;
  }
  char why[480];
  std::snprintf(why, sizeof(why),
                "the mirror's rim diameter left out: at the calibrated mirror its outer zone "
                "reflects rays %.1f deg past the rim's plane, where whatever holds the mirror at "
                "its rim is seen, so the edge of its image need not be the rim; the edge is "
                "fitted as a circle on the mirror of free radius (its centre and shape place the "
                "mirror; its size sets no scale)",
                elevation);
  Progress(options, std::string(why) + "; calibrating again");
  CalibrationOptions as_circle = options;
  as_circle.rim_radius_free = true;
  CalibrationResult circle = CalibrateOnce(start, targets, detections, as_circle);
  // The flange seen in the outer zone puts the edge inside the rim (the sample renders: 29.4 and
  // 28.85 of 30 mm). A circle at or beyond the rim (OCamCalib's VMR set: at its bound, twice the
  // rim, the corners' rms 0.30 -> 0.47 px) is no such edge: the rim is left out instead.
  const double fitted = circle.solve.rim_edge_radius_mm;
  if (!(fitted < start.r_sys && fitted > 0.25 * start.r_sys)) {
    char none[640];
    std::snprintf(none, sizeof(none),
                  "the mirror's rim left out: at the calibrated mirror its outer zone reflects "
                  "rays %.1f deg past the rim's plane, so the edge of its image need not be the "
                  "rim, and it fits no circle inside the rim either (radius %.2f mm against the "
                  "rim's %.2f) (calibrated without it)",
                  elevation, fitted, start.r_sys);
    Progress(options, std::string(none) + "; calibrating again");
    CalibrationOptions without = options;
    without.use_lips = false;
    result = CalibrateOnce(start, targets, detections, without);
    result.solve.notes.push_back(none);
    result.solve.rim_left_out = true;
    return result;
  }
  result = std::move(circle);
  char radius[200];
  std::snprintf(radius, sizeof(radius),
                "the edge of the mirror's image: the mirror circle of radius %.3f mm (sigma %.3f "
                "mm at the calibrated mirror's scale; the rim: %.3f mm)",
                result.solve.rim_edge_radius_mm, result.solve.rim_edge_radius_sigma_mm,
                start.r_sys);
  result.solve.notes.push_back(why);
  result.solve.notes.push_back(radius);
  result.solve.rim_left_out = true;
  return result;
}

}  // namespace

CalibrationResult Calibrate(const RigParams& start, const std::vector<TargetSpec>& targets,
                            const Observations& detections, const CalibrationOptions& options) {
  if (const std::string error = options.Check(); !error.empty()) throw CalibrationError(error);
  if (!TestsNonCentral(start, options)) {
    return CalibrateJudgingRim(start, targets, detections, options);
  }
  // A single mirror's non-central part stands only where the photos decide it
  // (central_decision.h); a diverged non-central solve is never the calibration.
  NonCentralDecision decision;
  decision.tested = true;
  std::shared_ptr<CalibrationResult> fit;
  try {
    fit = std::make_shared<CalibrationResult>(
        CalibrateJudgingRim(start, targets, detections, options));
    TestNonCentral(start, *fit, &decision);
    if (NeedsCrossValidation(decision, detections.images.size())) {
      Progress(options, decision.dof == 0
                            ? "non-central part (mirror1_pose): no coordinate determined: 3-fold "
                              "cross-validation"
                            : "non-central part (mirror1_pose): decided by the pixel noise alone, "
                              "not with the held tangential distortion: 3-fold cross-validation");
      // Where the fit left the rim out, each fold would find that again after a solve with it.
      CalibrationOptions folds = options;
      if (fit->solve.rim_left_out) folds.use_lips = false;
      CrossValidateNonCentral(start, targets, detections, folds, CalibrateJudgingRim, &decision);
    }
  } catch (const CalibrationError& e) {
    decision.failure = e.what();
  }
  if (decision.decided) {
    fit->solve.noncentral = decision;
    fit->solve.notes.push_back(NonCentralNote(decision));
    return *fit;
  }
  Progress(options, NonCentralNote(decision) + "; calibrating again with mirror1_pose held");
  CalibrationResult result = CalibrateJudgingRim(start, targets, detections, CentralOptions(options));
  decision.fit = fit;
  result.solve.noncentral = decision;
  result.solve.notes.push_back(NonCentralNote(decision));
  return result;
}

CalibrationInfo CalibrationInfoOf(const CalibrationResult& result,
                                  const CalibrationProvenance& provenance) {
  const CalibrationEstimate& estimate = result.estimate;
  const CalibrationUncertainty& uncertainty = result.uncertainty;
  const CalibrationResiduals& residuals = result.residuals;
  CalibrationInfo info;
  info.parameters = estimate.names;
  info.values.assign(estimate.values.data(), estimate.values.data() + estimate.values.size());
  info.sigma.assign(uncertainty.sigma.data(), uncertainty.sigma.data() + uncertainty.sigma.size());
  const int m = static_cast<int>(estimate.names.size());
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) info.covariance.push_back(uncertainty.covariance(i, j));
  }
  if (uncertainty.noise_covariance.rows() == m && uncertainty.noise_covariance.cols() == m) {
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j < m; ++j) info.noise_covariance.push_back(uncertainty.noise_covariance(i, j));
    }
  }
  info.rms_px = residuals.rms_px;
  info.n_observations = residuals.n_observations;
  for (const auto& r : residuals.rejected) info.n_outliers += r.reason == "outlier";
  info.per_mirror_rms_px = {residuals.per_mirror_rms_px[0], residuals.per_mirror_rms_px[1]};
  info.n_rejected = static_cast<int>(residuals.rejected.size()) + residuals.n_lip_rejected;
  info.n_lip_points = residuals.n_lip_points;
  info.lip_rms_px = residuals.lip_rms_px;
  for (const auto& u : uncertainty.unobservable) {
    info.unobservable.push_back(u.name);
    info.unobservable_hints.push_back(u.hint);
  }
  info.held_profiles = uncertainty.held_profiles;
  info.session = provenance.session;
  info.images = result.solve.images;
  info.targets = result.solve.targets;
  info.tool_version = provenance.tool_version;
  info.date = provenance.date;
  return info;
}

std::string TargetsDescription(const std::vector<TargetSpec>& targets) {
  std::string text;
  for (size_t t = 0; t < targets.size(); ++t) {
    const TargetSpec& s = targets[t];
    text += (t ? ", " : "") + std::string(TargetTypeName(s.type)) + " " +
            std::to_string(s.rows) + "x" + std::to_string(s.cols);
  }
  return text;
}

}  // namespace omni::calib
