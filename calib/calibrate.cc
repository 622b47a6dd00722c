#include "calib/calibrator.h"

namespace omni::calib {

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
  // Each mirror's profile: freed where the corners cover its radii (calibrator_profile.cc).
  DecideProfiles(&result);
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
        Progress("weights settled, no new outliers: the last solve stands");
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
  FinishProfiles(&result);
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
                  "carried into the sigmas: across the edge sigma %s px (at least %.3g, or the RMS "
                  "of the edge's residuals across it if larger), the whole edge's move along u and "
                  "v %.3g px",
                  result.lip_edges_considered, sigmas.c_str(), options_.lip_edge_bias_sigma_px,
                  options_.lip_edge_bias_sigma_px);
    result.notes.push_back(buf);
  }
  if (result.corner_offsets_considered > 0) {
    char buf[320];
    std::snprintf(buf, sizeof(buf),
                  "corners: a detector offset common to each ring's corners, the same in every "
                  "image, is carried into the sigmas: sigma %.3g px per axis (many corners average "
                  "their noise, not such an offset; the reflex tilt reads it most)",
                  options_.corner_offset_sigma_px);
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
  CheckTargetScales();
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
    Eigen::Vector2d projected;
    if (o.rejected || !Reproject(o, &projected)) continue;
    result.residuals.push_back({o.image, o.target, o.id, o.mirror, o.pixel, projected - o.pixel});
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
  info.targets = TargetsDescription(targets_);
  result.rig = rig_;
  result.rig.calibration = info;
  return result;
}

CalibrationResult Calibrate(const RigParams& start, const std::vector<TargetSpec>& targets,
                            const Observations& detections, const CalibrationOptions& options) {
  for (const auto& g : options.estimate) {
    if (BlockParameterNames(g).empty()) {
      throw InputError("estimate: unknown parameter group '" + g + "'");
    }
  }
  if (options.estimate.empty()) {
    throw CalibrationError("nothing to estimate: the session's estimate: names no parameter "
                           "group (usually [camera, distortion, mirror1_pose, mirror2_pose, "
                           "reflex])");
  }
  Calibrator calibrator(start, targets, detections, options);
  return calibrator.Run();
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
