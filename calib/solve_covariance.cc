// The covariance of a solved calibration (ComputeCovariance): the refined rig parameters'
// columns of the whitened Jacobian at the solution, with the held coordinates, the lip edges'
// and the corner rings' detector biases as considered columns and the poses and azimuths as
// nuisance blocks; the dist_k3 decision it informs; the camera-pointing note.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <Eigen/SparseCore>

#include "calib/calibration_steps.h"
#include "calib/covariance.h"

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

// The highest radial term (dist_k3: held unless DecideDistK3 frees it) and whether `name` is one
// of the lower ones (dist_k1, dist_k2), from the table's roles and radial powers.
const RigParameter& HighRadial() {
  static const RigParameter& k3 = *ParametersWithRole(SolveRole::kHighRadial).front();
  return k3;
}
bool IsLowerRadial(const std::string& name) {
  const RigParameter* p = FindRigParameter(name);
  return p && p->radial_power > 0 && p->role != SolveRole::kHighRadial;
}
// The lower radial terms' names joined by `separator` ("dist_k1, dist_k2").
std::string LowerRadialNames(const char* separator) {
  std::string names;
  for (const RigParameter& p : RigParameterTable()) {
    if (IsLowerRadial(p.name)) names += (names.empty() ? "" : separator) + std::string(p.name);
  }
  return names;
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

namespace {

// The covariance's columns before the nuisance blocks: the refined rig coordinates, a held
// dist_k3's probe, the considered held coordinates, then (added later) the lip edges' and the
// corner rings' bias columns.
struct Columns {
  std::vector<std::string> names;  // the refined coordinates
  std::vector<double> values;
  int n_rig = 0, n_probe = 0, n_considered = 0;
  int n_ceres = 0;              // Ceres' rig columns (tangent coordinates of the evaluated blocks)
  std::vector<int> column_of;   // Ceres' rig column -> ours
  std::vector<double> considered_sigma;  // per considered column, in order
  // The considered columns (indices among them) of profiles held for want of evidence, whose
  // tolerance the data update (Refinement::profile_updated).
  std::vector<int> updated_considered;
  int n_poses = 0;  // the pose blocks among the nuisance blocks after these columns (Evaluate)
  // A free rim circle radius (ObservationSet::rim_radius_free): one column after all these,
  // before the nuisance blocks (it is shared by the azimuths, so not eliminated with them).
  bool rim_radius = false;
};

// The refined rig blocks (tangent coordinates) in kRigBlocks order. Held coordinates with a
// considered sigma are freed in `problem` so that their columns are evaluated; column_of then
// moves them after the refined ones (ComputeRigCovariance's order). A held dist_k3 without one is
// evaluated too (the probe column, right after the refined ones), so that the same Jacobian says
// what freeing it would give (DecideDistK3). Appends the blocks to `evaluated`.
Columns RigColumns(const Refinement& refined, const CalibrationOptions& options, RigParams* rig,
                   ceres::Problem* problem, std::vector<double*>* evaluated,
                   CalibrationResult* result) {
  Columns c;
  std::vector<int> refined_cols, considered_cols;  // Ceres' column of each, in order
  int probe_col = -1;
  int col = 0;
  for (int id = 0; id < kRigBlockCount; ++id) {
    const RigBlockId g = static_cast<RigBlockId>(id);
    double* block = BlockIn(rig, g);
    if (!refined.groups[g] || !problem->HasParameterBlock(block)) continue;
    evaluated->push_back(block);
    const auto& all = BlockParameterNames(kRigBlocks[g].name);
    const std::vector<int> held_coords = HeldCoordinates(refined, g);
    std::vector<int> still_held;
    for (size_t k = 0; k < all.size(); ++k) {
      const bool held = std::count(held_coords.begin(), held_coords.end(), static_cast<int>(k));
      const auto consider = refined.considered_sigma.find(all[k]);
      if (!held) {
        c.names.push_back(ParameterName(BlockParameters(g)[k], rig->rig));
        c.values.push_back(block[k]);
        refined_cols.push_back(col++);
      } else if (consider != refined.considered_sigma.end() && consider->second > 0) {
        for (int m = 0; m < 2; ++m) {
          if (g == kProfileGroups[m] && refined.profile_updated[m]) {
            c.updated_considered.push_back(static_cast<int>(c.considered_sigma.size()));
          }
        }
        result->uncertainty.considered.push_back({all[k], block[k], consider->second});
        result->uncertainty.considered_column_names.push_back(all[k]);
        c.considered_sigma.push_back(consider->second);
        considered_cols.push_back(col++);
      } else if (all[k] == HighRadial().name && !options.refine_dist_k3) {
        probe_col = col++;
      } else {
        still_held.push_back(static_cast<int>(k));
      }
    }
    if (still_held.size() != held_coords.size()) {
      // A block held whole is constant in the problem (BuildProblem): its considered columns
      // need it variable.
      if (problem->IsParameterBlockConstant(block)) problem->SetParameterBlockVariable(block);
      problem->SetManifold(block, still_held.empty()
                                      ? nullptr
                                      : new ceres::SubsetManifold(static_cast<int>(all.size()),
                                                                  still_held));
    }
  }
  c.n_rig = static_cast<int>(c.names.size());
  c.n_probe = probe_col >= 0 ? 1 : 0;
  c.n_considered = static_cast<int>(considered_cols.size());
  c.n_ceres = col;
  c.column_of.resize(col);
  for (int i = 0; i < c.n_rig; ++i) c.column_of[refined_cols[i]] = i;
  if (c.n_probe) c.column_of[probe_col] = c.n_rig;
  for (int i = 0; i < c.n_considered; ++i) {
    c.column_of[considered_cols[i]] = c.n_rig + c.n_probe + i;
  }
  return c;
}

// Rows: the corners (in the observations' order, each ring's weight), the lip points, the priors
// (whitened already). Each pixel row is whitened with its group's weight sigma, so
// cov = (J^T W J)^-1.
std::vector<double> RowWeights(const ObservationSet& observations, const Weights& weights,
                               int n_rows) {
  std::vector<double> row_weight(n_rows, 1.0);
  int row = 0;
  for (const auto& o : observations.corners) {
    if (o.rejected || !o.projectable) continue;
    row_weight[row] = row_weight[row + 1] = 1.0 / weights.sigma[o.mirror - 1];
    row += 2;
  }
  for (const auto& l : observations.lips) {
    if (!l.Used() || !l.projectable) continue;
    row_weight[row] = row_weight[row + 1] =
        std::sqrt(static_cast<double>(l.members)) / weights.sigma[2];
    row += 2;
  }
  return row_weight;
}

// Each lip edge's detector bias as considered parameters: the rig does not move, so an edge is
// detected with the same bias (blur, anti-aliasing) in every image and it does not average out
// over the images; the solve's rig parameters absorb most of it (the residuals do not show it:
// correlation factor 1.04 with a 0.03 px offset per edge). Three columns per edge from column
// `first`: each of the edge's points moved across the edge, and the whole edge moved along u and
// along v (a bias that differs round the edge, from the light's side or the raster's order: the
// demo's reflex tilt read 2.6 / 2.8 sigma off without them, 1.7 / 2.1 with them at
// lip_edge_bias_sigma_px). Returns the number of edges; their sigmas in *edge_sigma, the residual
// patterns along them in *edge_pattern.
int LipEdgeColumns(const ObservationSet& observations, const RigParams& rig,
                   const CalibrationOptions& options, const std::vector<double>& residuals,
                   const std::vector<double>& row_weight, int first_row, int first,
                   std::vector<Eigen::Triplet<double>>* triplets, Columns* columns,
                   std::vector<double>* edge_sigma, std::vector<AlongEdgePattern>* edge_pattern,
                   CalibrationResult* result) {
  std::map<std::pair<int, double>, int> edge_column;  // (path, circle radius) -> column
  // Per edge: its points' azimuths about the principal point and residuals across the edge.
  std::vector<std::vector<double>> edge_azimuth, edge_across;
  const Eigen::Vector2d centre(rig.camera[kCx], rig.camera[kCy]);
  int row = first_row;
  for (const auto& l : observations.lips) {
    if (!l.Used() || !l.projectable) continue;
    const auto key = std::make_pair(static_cast<int>(l.path), l.radius);
    const int e = edge_column.emplace(key, static_cast<int>(edge_column.size())).first->second;
    const int c = first + 3 * e;
    const Eigen::Vector2d outward = l.pixel - centre;
    const Eigen::Vector2d across = outward.normalized();
    triplets->emplace_back(row, c, row_weight[row] * across.x());
    triplets->emplace_back(row + 1, c, row_weight[row + 1] * across.y());
    // The whole edge's move, as the detector reports it (observed = true + move: the residual,
    // predicted - observed, moves by minus it).
    triplets->emplace_back(row, c + 1, -row_weight[row]);
    triplets->emplace_back(row + 1, c + 2, -row_weight[row + 1]);
    edge_azimuth.resize(edge_column.size());
    edge_across.resize(edge_column.size());
    edge_azimuth[e].push_back(std::atan2(outward.y(), outward.x()));
    edge_across[e].push_back(residuals[row] * across.x() + residuals[row + 1] * across.y());
    row += 2;
  }
  // Each edge's bias sigma across it: lip_edge_offset_floor_px (the detector's constant offset,
  // which no pattern shows: 0.004-0.07 px on renders against the exact lip images), or the
  // constant part of the edge's residual pattern along it if larger
  // (CommonPartOfAlongEdgePattern). The residuals are means over the images (normal points), so
  // what remains of them is mostly the detector's systematic error along the edge; its constant
  // part is absorbed by the rig parameters and cannot show. It was taken as large as the whole
  // pattern's RMS (0.10-0.12 px on renders), which overstated it 3-30x: a pattern correlated
  // over a few degrees averages round the edge.
  // The whole edge's move: the option's sigma (the residuals' spread along the edge is mostly
  // local, e.g. a room's texture beside the band, and averages down round the edge).
  edge_sigma->clear();
  edge_pattern->clear();
  std::vector<std::string> edge_names(edge_column.size());
  for (const auto& [key, e] : edge_column) {
    char name[64];
    std::snprintf(name, sizeof(name), "lip %s r %g", LipPathName(static_cast<LipPath>(key.first)),
                  key.second);
    edge_names[e] = name;
  }
  for (size_t e = 0; e < edge_azimuth.size(); ++e) {
    edge_pattern->push_back(CommonPartOfAlongEdgePattern(edge_azimuth[e], edge_across[e]));
    edge_sigma->push_back(
        std::max(options.lip_edge_offset_floor_px, edge_pattern->back().common_sigma_px));
    columns->considered_sigma.push_back(edge_sigma->back());
    columns->considered_sigma.push_back(options.lip_edge_bias_sigma_px);
    columns->considered_sigma.push_back(options.lip_edge_bias_sigma_px);
    for (const char* what : {" across", " u", " v"}) {
      result->uncertainty.considered_column_names.push_back(edge_names[e] + what);
    }
  }
  return static_cast<int>(edge_column.size());
}

// Each ring's corners' common offset along u and along v as considered parameters (from column
// `first`): the detector's bias where it is the same everywhere, which no number of corners
// averages out. Columns ring 1 u, v, then ring 2 u, v (rings without corners left out); each is
// the offset of the reported pixels (observed = true + offset: the residual, predicted -
// observed, moves by minus it). Returns the number of columns.
int CornerOffsetColumns(const ObservationSet& observations, const CalibrationOptions& options,
                        const std::vector<double>& row_weight, int first,
                        std::vector<Eigen::Triplet<double>>* triplets, Columns* columns,
                        CalibrationResult* result) {
  int n_offsets = 0;
  bool ring_seen[2] = {false, false};
  for (const auto& o : observations.corners) {
    ring_seen[o.mirror - 1] |= !o.rejected && o.projectable;
  }
  int first_column[2] = {-1, -1};
  for (int ring = 0; ring < 2; ++ring) {
    if (!ring_seen[ring]) continue;
    first_column[ring] = first + n_offsets;
    n_offsets += 2;
    for (const char* axis : {"u", "v"}) {
      columns->considered_sigma.push_back(options.corner_offset_sigma_px);
      result->uncertainty.considered_column_names.push_back("corners ring " +
                                                            std::to_string(ring + 1) + " " + axis);
    }
  }
  int row = 0;
  for (const auto& o : observations.corners) {
    if (o.rejected || !o.projectable) continue;
    for (int axis = 0; axis < 2; ++axis) {
      triplets->emplace_back(row + axis, first_column[o.mirror - 1] + axis,
                             -row_weight[row + axis]);
    }
    row += 2;
  }
  return n_offsets;
}

// For a held dist_k3 (the probe column): what freeing it would give, from the Schur complement
// with the probe (`schur_all`) against the covariance without it (`held`).
void ProbeDistK3(const Eigen::MatrixXd& schur_all, const Columns& c, const RigCovariance& held,
                 const RigCovarianceOptions& options, const RigParams& rig, double outer_radius,
                 CovarianceFindings* findings) {
  // Freed: the radial coefficients' sigmas, and dist_k3's (HUGE_VAL if it is unobservable).
  RigCovarianceOptions freed_options = options;
  freed_options.nearly_unobservable_sigma.push_back(
      NearlyUnobservableSigma(HighRadial().name, rig.camera[kFx], outer_radius));
  const RigCovariance freed = RigCovarianceFromSchur(schur_all, c.n_rig + 1, freed_options);
  auto sigma_of = [&](const RigCovariance& cov, int index) {
    for (size_t i = 0; i < cov.observable.size(); ++i) {
      if (cov.observable[i] == index) return std::sqrt(std::max(cov.covariance(i, i), 0.0));
    }
    return HUGE_VAL;
  };
  findings->k3_evaluated = true;
  findings->k3_sigma = sigma_of(freed, c.n_rig);
  for (int i = 0; i < c.n_rig; ++i) {
    if (!IsLowerRadial(c.names[i])) continue;
    const double h = sigma_of(held, i);
    findings->k3_growth =
        std::max(findings->k3_growth, h < HUGE_VAL ? sigma_of(freed, i) / h : HUGE_VAL);
  }
}

// The result's names, values, sigmas, covariance and correlation from `cov`.
void FillCovarianceResult(const RigCovariance& cov, const Columns& c, RigKind rig,
                          CalibrationResult* result) {
  result->uncertainty.refined_names = c.names;
  result->uncertainty.schur_eigenvalues = cov.eigenvalues;
  result->uncertainty.schur_eigenvectors = cov.eigenvectors;
  result->estimate.names.clear();
  result->estimate.values.resize(cov.observable.size());
  for (size_t i = 0; i < cov.observable.size(); ++i) {
    result->estimate.names.push_back(c.names[cov.observable[i]]);
    result->estimate.values(i) = c.values[cov.observable[i]];
  }
  for (int i : cov.unobservable) {
    result->uncertainty.unobservable.push_back(
        {c.names[i], ParameterHint(*FindRigParameter(c.names[i]), rig)});
  }
  result->uncertainty.covariance = cov.covariance;
  result->uncertainty.considered_sensitivity = cov.considered_sensitivity;
  result->uncertainty.considered_column_sigma = cov.considered_column_sigma;
  result->uncertainty.considered_column_mix = cov.considered_column_mix;
  // A held profile's tolerance updated by the data: its columns are the factors of the updated
  // covariance, combinations of its terms.
  for (size_t k = 0; k < c.updated_considered.size(); ++k) {
    result->uncertainty.considered_column_names[c.updated_considered[k]] =
        std::string(kHeldProfileColumn) + " " + std::to_string(k + 1);
  }
  result->uncertainty.sigma = cov.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  result->uncertainty.noise_sigma = cov.noise_covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  result->uncertainty.noise_covariance = cov.noise_covariance;
  const int m = static_cast<int>(result->uncertainty.sigma.size());
  result->uncertainty.correlation = Eigen::MatrixXd::Identity(m, m);
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) {
      const double d = result->uncertainty.sigma(i) * result->uncertainty.sigma(j);
      if (d > 0) result->uncertainty.correlation(i, j) = result->uncertainty.covariance(i, j) / d;
    }
  }
}

// Each mirror profile held and considered whole: its prior (the machining tolerance or a scan's
// fit) and, where profile: auto held it for want of evidence, what the data tell of its terms
// (S_c|x over its columns), for the model file (design/tolerance.h decides its peak-to-valley).
void RecordHeldProfiles(const Refinement& refined, const Columns& c, const RigCovariance& cov,
                        const RigParams& rig, CalibrationResult* result) {
  result->uncertainty.held_profiles.clear();
  const auto& considered = result->uncertainty.considered;
  for (int m = 0; m < 2; ++m) {
    const std::vector<std::string>& names = BlockParameterNames(kRigBlocks[kProfileGroups[m]].name);
    std::vector<int> column(kProfileTerms, -1);  // each term's considered column
    for (int k = 0; k < kProfileTerms; ++k) {
      for (size_t i = 0; i < considered.size(); ++i) {
        if (considered[i].name == names[k]) column[k] = static_cast<int>(i);
      }
    }
    if (std::count(column.begin(), column.end(), -1) > 0) continue;  // refined, or not considered
    HeldProfileInfo held;
    held.mirror = m + 1;
    held.prior = refined.profile_covariance[m] ? "scan" : "tolerance";
    const ProfileShape& shape = m == 0 ? rig.profile1 : rig.profile2;
    held.r_min = shape.r_min;
    held.r_max = shape.r_max;
    for (int a = 0; a < kProfileTerms; ++a) {
      for (int b = 0; b < kProfileTerms; ++b) {
        held.prior_covariance.push_back(
            refined.profile_covariance[m] ? (*refined.profile_covariance[m])(a, b)
                                          : (a == b ? std::pow(considered[column[a]].sigma, 2) : 0.0));
      }
    }
    if (refined.profile_updated[m] && cov.updated_information.rows() ==
                                          static_cast<int>(c.updated_considered.size())) {
      std::vector<int> at(kProfileTerms, -1);  // each term's place among the updated columns
      for (int k = 0; k < kProfileTerms; ++k) {
        const auto it = std::find(c.updated_considered.begin(), c.updated_considered.end(), column[k]);
        if (it != c.updated_considered.end()) at[k] = static_cast<int>(it - c.updated_considered.begin());
      }
      if (std::count(at.begin(), at.end(), -1) == 0) {
        for (int a = 0; a < kProfileTerms; ++a) {
          for (int b = 0; b < kProfileTerms; ++b) {
            held.data_information.push_back(cov.updated_information(at[a], at[b]));
          }
        }
      }
    }
    result->uncertainty.held_profiles.push_back(std::move(held));
  }
}

// The problem's residuals and Jacobian at the solution: the rig's columns (RigColumns), then the
// poses' and the azimuths' (the nuisance blocks, their sizes in *nuisance_sizes); rows the pixel
// blocks', then the priors'. No loss: the weights are applied by the caller.
Columns Evaluate(const Refinement& refined, const CalibrationOptions& options, RigParams* rig,
                 ObservationSet* observations, CalibrationProblem* built,
                 std::vector<int>* nuisance_sizes, std::vector<double>* residuals,
                 ceres::CRSMatrix* crs, CalibrationResult* result) {
  ceres::Problem& problem = built->problem;
  ceres::Problem::EvaluateOptions eo;
  Columns c = RigColumns(refined, options, rig, &problem, &eo.parameter_blocks, result);
  if (problem.HasParameterBlock(observations->rim_radius.data())) {
    eo.parameter_blocks.push_back(observations->rim_radius.data());
    c.rim_radius = true;
  }
  int n_poses = 0;
  for (auto& p : observations->placements) {
    if (problem.HasParameterBlock(p.cam_from_target.data())) {
      eo.parameter_blocks.push_back(p.cam_from_target.data());
      ++n_poses;
    }
  }
  c.n_poses = n_poses;
  nuisance_sizes->assign(n_poses, 6);
  for (auto& l : observations->lips) {
    if (problem.HasParameterBlock(l.phi.data())) {
      eo.parameter_blocks.push_back(l.phi.data());
      nuisance_sizes->push_back(1);
    }
  }
  eo.residual_blocks = built->pixel_blocks;
  eo.residual_blocks.insert(eo.residual_blocks.end(), built->prior_blocks.begin(),
                            built->prior_blocks.end());
  eo.apply_loss_function = false;
  eo.num_threads = std::max(1, options.solver.threads);
  double cost = 0;
  problem.Evaluate(eo, &cost, residuals, nullptr, crs);
  return c;
}

// The covariance from the whitened Jacobian (columns: c's, then the nuisance blocks). With a held
// dist_k3's probe column: the covariance without it, and in *findings what freeing it would give.
RigCovariance CovarianceOf(const Eigen::SparseMatrix<double, Eigen::RowMajor>& jacobian,
                           const Columns& c, const std::vector<int>& nuisance_sizes,
                           const RigParams& rig, const std::vector<Observation>& corners,
                           CovarianceFindings* findings) {
  RigCovarianceOptions co;
  co.variance_factor = 1.0;  // the weights are the groups' estimated variances
  co.nuisance_sizes = nuisance_sizes;
  co.considered_sigma = c.considered_sigma;
  co.updated_considered = c.updated_considered;
  const double outer_radius = OuterRadius(rig, corners);
  for (const auto& name : c.names) {
    co.nearly_unobservable_sigma.push_back(
        NearlyUnobservableSigma(name, rig.camera[kFx], outer_radius));
  }
  const int n_front = c.n_rig + c.n_probe + static_cast<int>(c.considered_sigma.size());
  Eigen::MatrixXd schur_all =
      RigSchurComplement(jacobian, n_front + (c.rim_radius ? 1 : 0), nuisance_sizes);
  // The rim circle's radius, a nuisance shared by the azimuths: eliminated last, densely.
  Eigen::VectorXd radius_coupling;  // S_front,radius / S_radius,radius
  double radius_information = 0;
  if (c.rim_radius) {
    schur_all = EliminateLastColumn(schur_all, &radius_coupling, &radius_information);
  }
  // Held dist_k3: the probe's row and column left out.
  std::vector<int> kept;
  for (int i = 0; i < n_front; ++i) {
    if (!(c.n_probe && i == c.n_rig)) kept.push_back(i);
  }
  Eigen::MatrixXd schur_held(kept.size(), kept.size());
  for (size_t i = 0; i < kept.size(); ++i) {
    for (size_t j = 0; j < kept.size(); ++j) schur_held(i, j) = schur_all(kept[i], kept[j]);
  }
  const RigCovariance cov = RigCovarianceFromSchur(schur_held, c.n_rig, co);
  if (c.n_probe) ProbeDistK3(schur_all, c, cov, co, rig, outer_radius, findings);
  if (c.rim_radius && radius_information > 0) {
    // Var(radius) = 1/S_rr + g^T Cov g, g = S_rr^-1 S_r,rig (block inverse; the considered
    // columns' share left out). Over the determined coordinates only: where the scale (R, fx,
    // tz) is not determined, this is the radius at the calibrated scale.
    Eigen::VectorXd g(cov.observable.size());
    for (size_t i = 0; i < cov.observable.size(); ++i) g(i) = radius_coupling(cov.observable[i]);
    findings->rim_radius_sigma =
        std::sqrt(1.0 / radius_information + g.dot(cov.covariance * g));
  }
  return cov;
}

}  // namespace

CovarianceFindings ComputeCovariance(const Weights& weights, const Refinement& refined,
                                     const CalibrationOptions& options, RigState* rig,
                                     ObservationSet* observations, CostCache* costs,
                                     CalibrationResult* result) {
  Status(options, "covariance");
  ProblemOptions po;
  po.groups = refined.groups;
  po.selection.lips = true;
  MarkProjectable(*rig, po.selection, observations);
  const std::unique_ptr<CalibrationProblem> built =
      BuildProblem(rig, observations, weights, refined, po, costs);
  result->estimate.values.resize(0);
  result->uncertainty.considered.clear();
  result->uncertainty.considered_column_names.clear();
  result->uncertainty.unobservable.clear();
  CovarianceFindings findings;

  std::vector<int> nuisance_sizes;
  std::vector<double> residuals;
  ceres::CRSMatrix crs;
  Columns c = Evaluate(refined, options, &rig->params, observations, built.get(), &nuisance_sizes,
                       &residuals, &crs, result);
  const int n_obs = built->n_corners, n_lips = built->n_lips;

  const std::vector<double> row_weight = RowWeights(*observations, weights, crs.num_rows);
  double ssr_weighted = 0;
  for (int i = 0; i < crs.num_rows; ++i) {
    const double r = row_weight[i] * residuals[i];
    ssr_weighted += r * r;
  }
  const int n_prior = static_cast<int>(built->prior_blocks.size());
  const int n_params = c.n_rig + 6 * c.n_poses + n_lips + (c.rim_radius ? 1 : 0);
  const int dof = 2 * (n_obs + n_lips) + n_prior - n_params;
  result->solve.n_parameters = n_params;
  result->uncertainty.variance_factor = dof > 0 ? ssr_weighted / dof : 1.0;

  // The detector's biases as considered columns after the held coordinates: the lip edges', then
  // the corner rings'.
  std::vector<Eigen::Triplet<double>> triplets;
  int n_edges = 0;
  if (options.lip_edge_bias_sigma_px > 0) {
    const int edges = LipEdgeColumns(*observations, rig->params, options, residuals, row_weight,
                                     2 * n_obs, c.n_rig + c.n_probe + c.n_considered, &triplets,
                                     &c, &findings.lip_edge_sigma,
                                     &result->uncertainty.lip_edge_patterns, result);
    result->uncertainty.lip_edges_considered = edges;
    n_edges = 3 * edges;
  }
  int n_offsets = 0;
  if (options.corner_offset_sigma_px > 0) {
    n_offsets = CornerOffsetColumns(*observations, options, row_weight,
                                    c.n_rig + c.n_probe + c.n_considered + n_edges, &triplets, &c,
                                    result);
    result->uncertainty.corner_offsets_considered = n_offsets;
  }
  const int n_extra = n_edges + n_offsets;
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) {
      const int col = crs.cols[k] < c.n_ceres ? c.column_of[crs.cols[k]] : crs.cols[k] + n_extra;
      triplets.emplace_back(r, col, row_weight[r] * crs.values[k]);
    }
  }
  Eigen::SparseMatrix<double, Eigen::RowMajor> jacobian(crs.num_rows, crs.num_cols + n_extra);
  jacobian.setFromTriplets(triplets.begin(), triplets.end());

  const RigCovariance cov = CovarianceOf(jacobian, c, nuisance_sizes, rig->params,
                                         observations->corners, &findings);
  FillCovarianceResult(cov, c, rig->params.rig, result);
  RecordHeldProfiles(refined, c, cov, rig->params, result);
  return findings;
}

// The camera's rotation against the mirror bodies (the principal point with equal tilts of both
// mirrors) is a flat valley of the cost, and the held tangential distortion lies along it
// (docs/design.md, Calibration): the camera frame C's pointing is uncertain by about the sigma of
// mirror 1's tilt, which is C's rotation against M1. Said in words, since a table of sigmas does
// not tell a user that C is the uncertain frame and M1 the one to measure in.
void AddPointingNote(RigKind rig, CalibrationResult* result) {
  // Mirror 1's tilt: its pose block's parameters in the rotation valley (rx, ry).
  int tilt[2] = {-1, -1};
  for (size_t i = 0; i < result->estimate.names.size(); ++i) {
    const RigParameter* p = FindRigParameter(result->estimate.names[i]);
    if (p && BlockOf(*p) == kPose1Block && p->valley == RotationValley::kTilt && p->index < 2) {
      tilt[p->index] = static_cast<int>(i);
    }
  }
  const int rx = tilt[0], ry = tilt[1];
  if (rx < 0 || ry < 0) return;
  std::string held;
  for (const auto& c : result->uncertainty.considered) {
    const RigParameter* p = FindRigParameter(c.name);
    if (p && p->role == SolveRole::kTangential) held += (held.empty() ? "" : ", ") + c.name;
  }
  // A single-mirror rig: one mirror's tilt, no triangulation (its rays go out in M1 by export).
  const bool single = rig == RigKind::kSingle;
  char buf[768];
  std::snprintf(buf, sizeof(buf),
                single ? "camera pointing: the camera frame's rotation against the mirror's body "
                         "is weakly determined (it trades with the principal point and the "
                         "mirror's tilt%s): sigma %.3f / %.3f deg about x / y (%s, %s; pixel noise "
                         "alone %.3f / %.3f deg). Directions in the camera frame carry it, the "
                         "mirror's shape does not: take rays in the mirror's body (export --frame "
                         "mirror1)"
                       : "camera pointing: the camera frame's rotation against the mirror bodies is "
                         "weakly determined (it trades with the principal point and equal tilts of "
                         "both mirrors%s): sigma %.3f / %.3f deg about x / y (%s, %s; pixel noise "
                         "alone %.3f / %.3f deg). Points in the camera frame carry it, distances "
                         "and shapes do not: measure in mirror 1's body (triangulate --frame "
                         "mirror1)",
                held.empty() ? "" : (", where the held " + held + " go").c_str(),
                result->uncertainty.sigma(rx) / kDeg, result->uncertainty.sigma(ry) / kDeg,
                result->estimate.names[rx].c_str(),
                FindRigParameter(result->estimate.names[ry])->Key().c_str(),
                result->uncertainty.noise_sigma(rx) / kDeg,
                result->uncertainty.noise_sigma(ry) / kDeg);
  result->solve.notes.push_back(buf);
}

bool DecideDistK3(const CovarianceFindings& findings, const RigParams& rig,
                  const std::vector<Observation>& corners, const CalibrationOptions& options,
                  Refinement* refined, CalibrationResult* result) {
  if (!findings.k3_evaluated) return false;
  const double outer = OuterRadius(rig, corners);
  const RigParameter& k3 = HighRadial();
  const std::string lower = LowerRadialNames(", ");
  char buf[512];
  if (findings.k3_growth <= kMaxK3SigmaGrowth) {
    refined->dist_k3 = true;
    std::snprintf(buf, sizeof(buf),
                  "%s refined: this session's corners reach r = %.3f (normalised), where it "
                  "is told from %s (their sigmas grow %.2fx with it)",
                  k3.name, outer, lower.c_str(), findings.k3_growth);
  } else {
    char sigma[64] = "it would not be determined";
    char growth[64];
    std::snprintf(growth, sizeof(growth), "%s would not be determined", lower.c_str());
    if (findings.k3_sigma < HUGE_VAL) {
      std::snprintf(sigma, sizeof(sigma), "its sigma would be %.3g", findings.k3_sigma);
    }
    if (findings.k3_growth < HUGE_VAL) {
      std::snprintf(growth, sizeof(growth), "theirs would grow %.1fx", findings.k3_growth);
    }
    std::snprintf(buf, sizeof(buf),
                  "%s held at %g: over the radii this session's corners reach (r <= %.3f "
                  "normalised) it is nearly a combination of %s (freed, %s and "
                  "%s); corners farther out would determine it",
                  k3.name, BlockIn(rig, kDistortionBlock)[k3.index], outer,
                  LowerRadialNames(" and ").c_str(), sigma, growth);
  }
  result->solve.notes.push_back(buf);
  Progress(options, buf);
  return refined->dist_k3;
}

}  // namespace omni::calib
