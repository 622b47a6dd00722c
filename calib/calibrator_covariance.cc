#include "calib/calibrator.h"

namespace omni::calib {

namespace {

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

}  // namespace

void Calibrator::Covariance(CalibrationResult* result) {
  Status("covariance");
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
  result->considered_column_names.clear();
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
        result->considered_column_names.push_back(all[k]);
        considered_sigma.push_back(consider->second);
        considered_cols.push_back(col++);
      } else if (all[k] == "dist_k3" && !options_.refine_dist_k3) {
        probe_col = col++;
      } else {
        still_held.push_back(static_cast<int>(k));
      }
    }
    if (still_held.size() != held_coords.size()) {
      // A block held whole is constant in the problem (BuildProblem): its considered columns
      // need it variable.
      if (problem.IsParameterBlockConstant(block)) problem.SetParameterBlockVariable(block);
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

  // Each lip edge's detector bias as considered parameters: the rig does not move, so an edge
  // is detected with the same bias (blur, anti-aliasing) in every image and it does not average
  // out over the images; the solve's rig parameters absorb most of it (the residuals do not show
  // it: correlation factor 1.04 with a 0.03 px offset per edge). Three columns per edge (after
  // the considered coordinates, before the nuisance blocks): each of the edge's points moved
  // across the edge, and the whole edge moved along u and along v (a bias that differs round the
  // edge, from the light's side or the raster's order: the demo's reflex tilt read 2.6 / 2.8
  // sigma off without them, 1.7 / 2.1 with them at lip_edge_bias_sigma_px).
  std::vector<Eigen::Triplet<double>> triplets;
  std::map<std::pair<int, double>, int> edge_column;  // (path, circle radius) -> column
  std::vector<std::pair<double, int>> edge_ssr;         // per column: across-edge SSR, count
  if (options_.lip_edge_bias_sigma_px > 0) {
    const Eigen::Vector2d centre(rig_.camera[2], rig_.camera[3]);
    int row = 2 * n_obs;
    for (const auto& l : lips_) {
      if (!l.Used() || !l.projectable) continue;
      const auto key = std::make_pair(static_cast<int>(l.path), l.radius);
      const int e = edge_column.emplace(key, static_cast<int>(edge_column.size())).first->second;
      const int c = n_rig + n_probe + n_considered + 3 * e;
      const Eigen::Vector2d across = (l.pixel - centre).normalized();
      triplets.emplace_back(row, c, row_weight[row] * across.x());
      triplets.emplace_back(row + 1, c, row_weight[row + 1] * across.y());
      // The whole edge's move, as the detector reports it (observed = true + move: the residual,
      // predicted - observed, moves by minus it).
      triplets.emplace_back(row, c + 1, -row_weight[row]);
      triplets.emplace_back(row + 1, c + 2, -row_weight[row + 1]);
      const double r = residuals[row] * across.x() + residuals[row + 1] * across.y();
      edge_ssr.resize(edge_column.size(), {0.0, 0});
      edge_ssr[e].first += r * r;
      ++edge_ssr[e].second;
      row += 2;
    }
    // Each edge's bias sigma: the option's, or the RMS of the edge's residuals across it if
    // larger. The lips' residuals are means over the images (normal points), so what remains of
    // them is mostly the detector's systematic error along the edge (a band edge reported on the
    // wrong curve over part of the azimuths, a colour-dependent offset); its constant part is
    // absorbed by the rig parameters and cannot show, and is taken to be as large as the part
    // that shows.
    // The whole edge's move: the option's sigma (the residuals' spread along the edge is mostly
    // local, e.g. a room's texture beside the band, and averages down round the edge).
    lip_edge_sigma_.clear();
    std::vector<std::string> edge_names(edge_column.size());
    for (const auto& [key, e] : edge_column) {
      char name[64];
      std::snprintf(name, sizeof(name), "lip %s r %g", LipPathName(static_cast<LipPath>(key.first)),
                    key.second);
      edge_names[e] = name;
    }
    for (size_t e = 0; e < edge_ssr.size(); ++e) {
      const auto& [ssr, count] = edge_ssr[e];
      lip_edge_sigma_.push_back(
          std::max(options_.lip_edge_bias_sigma_px, count ? std::sqrt(ssr / count) : 0.0));
      considered_sigma.push_back(lip_edge_sigma_.back());
      considered_sigma.push_back(options_.lip_edge_bias_sigma_px);
      considered_sigma.push_back(options_.lip_edge_bias_sigma_px);
      for (const char* what : {" across", " u", " v"}) {
        result->considered_column_names.push_back(edge_names[e] + what);
      }
    }
    result->lip_edges_considered = static_cast<int>(edge_column.size());
  }
  const int n_edges = 3 * static_cast<int>(edge_column.size());
  // Each ring's corners' common offset along u and along v as considered parameters (after the
  // lip edges): the detector's bias where it is the same everywhere, which no number of corners
  // averages out. Columns ring 1 u, v, then ring 2 u, v (rings without corners left out); each
  // is the offset of the reported pixels (observed = true + offset: the residual, predicted -
  // observed, moves by minus it).
  int n_offsets = 0;
  if (options_.corner_offset_sigma_px > 0) {
    bool ring_seen[2] = {false, false};
    for (const auto& o : obs_) ring_seen[o.mirror - 1] |= !o.rejected && o.projectable;
    int first_column[2] = {-1, -1};
    for (int ring = 0; ring < 2; ++ring) {
      if (!ring_seen[ring]) continue;
      first_column[ring] = n_rig + n_probe + n_considered + n_edges + n_offsets;
      n_offsets += 2;
      for (const char* axis : {"u", "v"}) {
        considered_sigma.push_back(options_.corner_offset_sigma_px);
        result->considered_column_names.push_back("corners ring " + std::to_string(ring + 1) + " " + axis);
      }
    }
    int row = 0;
    for (const auto& o : obs_) {
      if (o.rejected || !o.projectable) continue;
      for (int axis = 0; axis < 2; ++axis) {
        triplets.emplace_back(row + axis, first_column[o.mirror - 1] + axis, -row_weight[row + axis]);
      }
      row += 2;
    }
    result->corner_offsets_considered = n_offsets;
  }
  const int n_extra = n_edges + n_offsets;
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) {
      const int c = crs.cols[k] < col ? column_of[crs.cols[k]] : crs.cols[k] + n_extra;
      triplets.emplace_back(r, c, row_weight[r] * crs.values[k]);
    }
  }
  Eigen::SparseMatrix<double, Eigen::RowMajor> jacobian(crs.num_rows, crs.num_cols + n_extra);
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

}  // namespace omni::calib
