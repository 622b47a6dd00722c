#include "health/check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <opencv2/core.hpp>

#include "health/consistency.h"
#include "health/drift.h"
#include "health/lip_reference.h"
#include "health/residuals.h"
#include "model/rig_model.h"
#include "model/rig_parameters.h"

namespace omni::health {
namespace {

// Regularised lower incomplete gamma P(a, x) by its series (x < a + 1) and the upper Q by its
// continued fraction (otherwise; modified Lentz).
double GammaQ(double a, double x) {
  if (x <= 0) return 1;
  const double log_prefix = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1) {
    double term = 1 / a, sum = term;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-15) break;
    }
    return std::max(0.0, 1 - sum * std::exp(log_prefix));
  }
  constexpr double kTiny = 1e-300;
  double b = x + 1 - a, c = 1 / kTiny, d = 1 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1) < 1e-15) break;
  }
  return std::exp(log_prefix) * h;
}

}  // namespace

const char* VerdictName(Verdict verdict) {
  switch (verdict) {
    case Verdict::kOk: return "OK";
    case Verdict::kDrifted: return "DRIFTED";
    case Verdict::kCannotTell: return "CANNOT TELL";
  }
  return "?";
}

double ChiSquareSurvival(double x, int dof) {
  if (dof <= 0) return 1;
  return GammaQ(0.5 * dof, 0.5 * x);
}

CheckResult CheckRig(const RigParams& stored, const std::vector<ImageEvidence>& images,
                     const CheckOptions& options) {
  const RigParams observed = AsObserved(stored);
  const LipReference reference(observed, options.azimuth_bins);
  return CheckSamples(observed, CollectSamples(RigModel(observed), images, options, reference),
                      static_cast<int>(images.size()), options);
}

namespace {

// The bins as the result reports them, the sectors the matches cover and the kept samples' rms
// per kind; the bins in `used` order.
void SummariseBins(const SampleSet& set, const CheckOptions& options, CheckResult* result) {
  const int nb = options.azimuth_bins;
  std::vector<bool> azimuth_covered(nb, false);
  for (const SampleBin& bin : set.bins) {
    const bool is_match = bin.kind == "matches";
    ResidualBin r;
    r.kind = bin.kind;
    r.azimuth_deg = bin.azimuth_deg;
    r.count = static_cast<int>(bin.members.size());
    r.mean = bin.mean;
    r.standard_error = bin.standard_error;
    r.referenced = bin.reference.has_value();
    r.reference_photos = bin.reference ? bin.reference->photos : 0;
    result->referenced_lip_bins += r.referenced;
    result->bins.push_back(r);
    if (is_match) {
      ++result->match_bins;
      azimuth_covered[AzimuthBin(bin.azimuth_deg * M_PI / 180, nb)] = true;
    } else {
      ++result->lip_bins;
    }
  }
  result->covered_azimuth_bins = static_cast<int>(std::count(azimuth_covered.begin(),
                                                             azimuth_covered.end(), true));
  double ss_gap = 0, ss_lip = 0;
  int n_gap = 0, n_lip = 0;
  for (const Sample& s : set.samples) {
    if (!s.kept) continue;
    (s.is_match ? ss_gap : ss_lip) += s.value * s.value;
    ++(s.is_match ? n_gap : n_lip);
  }
  result->gap_rms_px = n_gap ? std::sqrt(ss_gap / n_gap) : 0;
  result->lip_rms_px = n_lip ? std::sqrt(ss_lip / n_lip) : 0;
}

// The bins' derivatives by every drift coordinate (forward differences), at a subsample of each
// bin's points; rows in set.bins' order.
Eigen::MatrixXd BinJacobian(const RigParams& stored, const SampleSet& set,
                            const CheckOptions& options) {
  const RigModel model(stored);
  const auto& coordinates = DriftCoordinates();
  const int nc = static_cast<int>(coordinates.size());
  const int m = static_cast<int>(set.bins.size());
  std::vector<RigModel> moved;
  for (int c = 0; c < nc; ++c) {
    Eigen::VectorXd step(1);
    step[0] = coordinates[c].step;
    moved.emplace_back(ApplyDrift(stored, {c}, step));
  }
  Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(m, nc);
  cv::parallel_for_(cv::Range(0, m), [&](const cv::Range& range) {
    for (int b = range.start; b < range.end; ++b) {
      const std::vector<int>& members = set.bins[b].members;
      const int take = std::min<int>(options.jacobian_samples, static_cast<int>(members.size()));
      Eigen::VectorXd sum = Eigen::VectorXd::Zero(nc);
      int n = 0;
      for (int k = 0; k < take; ++k) {
        const Sample& s = set.samples[members[k * members.size() / take]];
        Eigen::VectorXd row(nc);
        const auto base = ResidualUnder(model, s);
        bool ok = base.has_value();
        for (int c = 0; c < nc && ok; ++c) {
          const auto v = ResidualUnder(moved[c], s);
          ok = v.has_value();
          if (ok) row[c] = (*v - *base) / coordinates[c].step;
        }
        if (!ok) continue;
        sum += row;
        ++n;
      }
      if (n) jacobian.row(b) = (sum / n).transpose();
    }
  });
  return jacobian;
}

// J Sigma J^T: the stored calibration's covariance carried into the bins, over the coordinates
// it has (false, nothing added, without one). Not into bins measured from the calibration
// photos' own: the stored parameters' error is in that reference as much as in the bin.
bool AddModelCovariance(const RigParams& stored, const std::vector<ResidualBin>& bins,
                        const Eigen::MatrixXd& jacobian, Eigen::MatrixXd* bin_covariance) {
  if (!stored.calibration || stored.calibration->covariance.empty()) return false;
  const auto& coordinates = DriftCoordinates();
  const int nc = static_cast<int>(coordinates.size());
  const CalibrationInfo& info = *stored.calibration;
  const int np = static_cast<int>(info.parameters.size());
  std::vector<int> column(np, -1);  // drift coordinate of each covariance parameter
  for (int p = 0; p < np; ++p) {
    const RigParameter* parameter = FindRigParameter(info.parameters[p]);
    for (int c = 0; c < nc && parameter; ++c) {
      if (coordinates[c].rig_parameter && coordinates[c].name == parameter->name) column[p] = c;
    }
  }
  Eigen::MatrixXd J_stored = Eigen::MatrixXd::Zero(jacobian.rows(), np);
  for (int p = 0; p < np; ++p) {
    if (column[p] >= 0) J_stored.col(p) = jacobian.col(column[p]);
  }
  for (size_t b = 0; b < bins.size(); ++b) {
    if (bins[b].referenced) J_stored.row(static_cast<int>(b)).setZero();
  }
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
      sigma(info.covariance.data(), np, np);
  *bin_covariance += J_stored * sigma * J_stored.transpose();
  return true;
}

// Texture enough for the matches to tell: min_matches over min_match_coverage of the sectors.
bool EnoughMatches(const CheckResult& result, const CheckOptions& options) {
  return result.n_matches >= options.min_matches &&
         result.covered_azimuth_bins >= options.min_match_coverage * options.azimuth_bins;
}

// Whether the lip bins measured from the calibration photos' own reject the stored model by
// themselves. Too few matches leave a check CANNOT TELL because unreferenced lips cannot tell a
// moved rig from their detector's bias; referenced ones can: what they show is change since
// calibration, so they alone may say DRIFTED (not OK: a move the lips do not see needs the
// matches). Their bins carry no model covariance, so their chi^2 is a sum over them.
bool LipsMovedSinceCalibration(const CheckResult& result, const CheckOptions& options) {
  double chi2 = 0;
  int bins = 0;
  for (const ResidualBin& bin : result.bins) {
    if (!bin.referenced) continue;
    chi2 += bin.mean * bin.mean / (bin.standard_error * bin.standard_error);
    ++bins;
  }
  return bins > 0 && ChiSquareSurvival(chi2, bins) < options.significance;
}

// Sets the verdict where the evidence decides without naming a group: too little texture (or a
// model that does not fit the lips), or residuals within the uncertainty. False: DRIFTED.
bool DecidedWithoutGroups(const RigParams& stored, const CheckOptions& options,
                          CheckResult* result) {
  const int nb = options.azimuth_bins;
  const bool enough = EnoughMatches(*result, options);
  const double f = 0.5 * (stored.camera[kFx] + stored.camera[kFy]);
  if (!enough && result->n_lip_points > 0 && result->lip_rms_px > options.lip_misfit_per_f * f) {
    result->verdict = Verdict::kCannotTell;
    result->model_misfit = true;
    char buf[400];
    std::snprintf(buf, sizeof(buf),
                  "the model does not fit these photos: their lips lie %.1f px rms from where it "
                  "puts them (a rig it describes: under %.1f px), and under it only %d "
                  "ring-to-ring matches were found: a model of another rig or an uncalibrated "
                  "start, or a rig knocked far",
                  result->lip_rms_px, options.lip_misfit_per_f * f, result->n_matches);
    result->reason = buf;
    return true;
  }
  if (!enough && LipsMovedSinceCalibration(*result, options)) return false;
  if (!enough) {
    result->verdict = Verdict::kCannotTell;
    result->reason = "too little texture seen by both rings: " + std::to_string(result->n_matches) +
                     " matches over " + std::to_string(result->covered_azimuth_bins) + " of " +
                     std::to_string(nb) + " azimuth sectors (needs " +
                     std::to_string(options.min_matches) + " over " +
                     std::to_string(static_cast<int>(std::ceil(options.min_match_coverage * nb))) +
                     ")";
    result->reason += result->referenced_lip_bins > 0
                          ? "; the lips have not moved since calibration, but a move they do not "
                            "show needs the matches"
                          : "; the lips alone cannot tell a moved rig from their own bias";
    return true;
  }
  if (result->p_value >= options.significance) {
    result->verdict = Verdict::kOk;
    result->reason = "the matches and lips agree with the stored model within its uncertainty";
    return true;
  }
  return false;
}


// The verdicts a single mirror's rim decides without naming a group (DecidedWithoutGroups for two
// rings): no usable bin, or bins within their scatter about the calibration photos'. False:
// DRIFTED.
bool DecidedOneRing(const RigParams& stored, const CheckOptions& options, CheckResult* result) {
  const int bins = static_cast<int>(result->bins.size());
  if (bins < kRimHarmonics + options.min_rim_bins_beyond_harmonics) {
    result->verdict = Verdict::kCannotTell;
    const bool has_reference = stored.calibration && !stored.calibration->lip_reference.empty();
    result->reason =
        !has_reference ? "the model holds no record of the mirror's rim as its calibration photos "
                         "showed it (calibration.lip_reference): calibrate with this version to "
                         "check a single mirror"
        : result->n_lip_points == 0 ? "the mirror's rim was not found in these photos"
                                    : "the rim was found in too few of the sectors the "
                                      "calibration photos showed (" +
                                          std::to_string(bins) + ")";
    return true;
  }
  if (result->p_value >= options.significance) {
    result->verdict = Verdict::kOk;
    result->reason = "the mirror's rim is where the calibration photos showed it: no shift, "
                     "scale or tilt of it beyond its sectors' scatter (what the rim cannot show: "
                     "a change of the lens's distortion, or a turn of the camera that a shift of "
                     "its principal point undoes)";
    return true;
  }
  return false;
}

// A single mirror's rim moves as a whole when the camera and the mirror move against each other:
// its image scales (the zeroth harmonic of the azimuth), shifts (the first) and, tilted, turns
// elliptic (the second). Those five coefficients are fitted to the bins (weighted by their
// errors) and tested against their covariance: the fit's, widened by the bins' scatter about it
// where that exceeds their errors (as a refinement scales its covariance by chi^2 / dof), plus
// what the scene behind the rim moves them by, independently in each photo (a dark sleeve along
// one side: the edge's blurred step moves with what lies inside it): sigma_s^2 / k for the k
// photos checked and sigma_s^2 / n for the n calibration photos' mean. Sets chi2, dof, p_value,
// rim_move and rim_scatter_factor.
void RimHarmonicsTest(const RigParams& stored, CheckResult* result) {
  const int m = static_cast<int>(result->bins.size());
  Eigen::MatrixXd X(m, kRimHarmonics);
  Eigen::VectorXd y(m);
  for (int b = 0; b < m; ++b) {
    const ResidualBin& bin = result->bins[b];
    const double w = 1 / bin.standard_error;
    X.row(b) = w * RimHarmonicsRow(bin.azimuth_deg).transpose();
    y[b] = w * bin.mean;
  }
  const Eigen::MatrixXd normal = X.transpose() * X;
  const Eigen::VectorXd move = normal.ldlt().solve(X.transpose() * y);
  result->rim_move = move;
  result->rim_scatter_factor = (y - X * move).squaredNorm() / (m - kRimHarmonics);
  Eigen::MatrixXd covariance =
      normal.inverse() * std::max(1.0, result->rim_scatter_factor);
  covariance.diagonal().array() += RimSceneVariance(stored, *result);
  result->chi2 = move.dot(covariance.ldlt().solve(move));
  result->dof = kRimHarmonics;
  result->p_value = ChiSquareSurvival(result->chi2, kRimHarmonics);
}

// One group's generalised least-squares fit of the whitened residuals.
GroupFit FitGroup(const std::string& group, const Eigen::MatrixXd& J_white,
                  const Eigen::VectorXd& r_white) {
  const auto& coordinates = DriftCoordinates();
  const int m = static_cast<int>(r_white.size());
  const std::vector<int> cols = CoordinatesOf(group);
  Eigen::MatrixXd A(m, cols.size());
  Eigen::VectorXd scale(cols.size());
  for (size_t k = 0; k < cols.size(); ++k) {
    scale[k] = std::max(J_white.col(cols[k]).norm(), 1e-300);
    A.col(k) = J_white.col(cols[k]) / scale[k];  // unit columns: rank by relative size
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
  svd.setThreshold(1e-6);
  GroupFit fit;
  fit.group = group;
  fit.bins = m;
  fit.rank = static_cast<int>(svd.rank());
  const Eigen::VectorXd x = svd.solve(r_white);
  fit.chi2 = (r_white - A * x).squaredNorm();
  fit.dof = m - fit.rank;
  fit.p_value = ChiSquareSurvival(fit.chi2, fit.dof);
  // Covariance of x: V S^-2 V^T over the kept singular values.
  const Eigen::VectorXd s = svd.singularValues();
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(cols.size(), cols.size());
  for (int k = 0; k < fit.rank; ++k) {
    cov += svd.matrixV().col(k) * svd.matrixV().col(k).transpose() / (s[k] * s[k]);
  }
  fit.amounts.resize(cols.size());
  fit.sigma.resize(cols.size());
  for (size_t k = 0; k < cols.size(); ++k) {
    fit.names.push_back(coordinates[cols[k]].name);
    // r = observed - predicted by the stored model, so the rig moved by -x (r + J x = 0).
    fit.amounts[k] = -x[k] / scale[k];
    fit.sigma[k] = std::sqrt(cov(k, k)) / scale[k];
  }
  return fit;
}

}  // namespace

SampleSet ReferencedBinsOnly(const SampleSet& set) {
  SampleSet out = set;
  out.bins.clear();
  for (const SampleBin& bin : set.bins) {
    if (bin.reference) {
      out.bins.push_back(bin);
    } else {
      for (int member : bin.members) out.samples[member].kept = false;
    }
  }
  return out;
}

Eigen::Matrix<double, kRimHarmonics, 1> RimHarmonicsRow(double azimuth_deg) {
  const double phi = azimuth_deg * M_PI / 180;
  Eigen::Matrix<double, kRimHarmonics, 1> row;
  row << 1, std::cos(phi), std::sin(phi), std::cos(2 * phi), std::sin(2 * phi);
  return row;
}

double RimSceneVariance(const RigParams& stored, const CheckResult& result) {
  int reference_photos = 0;
  for (const ResidualBin& bin : result.bins) {
    reference_photos = std::max(reference_photos, bin.reference_photos);
  }
  const double scene = stored.calibration ? stored.calibration->lip_reference_rim_scene_px : 0;
  const int photos = std::max(1, result.n_images);
  return scene * scene * (1.0 / photos + (reference_photos > 0 ? 1.0 / reference_photos : 0.0));
}

CheckResult CheckSamples(const RigParams& stored, const SampleSet& all, int n_images,
                         const CheckOptions& options) {
  const bool one_ring = stored.Paths() < 2;
  const SampleSet referenced = one_ring ? ReferencedBinsOnly(all) : SampleSet{};
  const SampleSet& set = one_ring ? referenced : all;
  CheckResult result;
  result.n_images = n_images;
  result.n_matches = set.n_matches;
  result.n_lip_points = set.n_lip_points;
  SummariseBins(set, options, &result);
  const int m = static_cast<int>(set.bins.size());
  result.dof = m;
  if (one_ring && m < kRimHarmonics + options.min_rim_bins_beyond_harmonics) {
    DecidedOneRing(stored, options, &result);
    return result;
  }
  if (m == 0) {
    result.verdict = Verdict::kCannotTell;
    result.reason = "no ring-to-ring matches and no lip edges were found";
    return result;
  }

  // C = diag(se^2) + J Sigma J^T over the coordinates the stored covariance has.
  result.jacobian = BinJacobian(stored, set, options);
  result.residual.resize(m);
  Eigen::VectorXd se2(m);
  for (int b = 0; b < m; ++b) {
    result.residual[b] = result.bins[b].mean;
    se2[b] = result.bins[b].standard_error * result.bins[b].standard_error;
  }
  result.bin_covariance = se2.asDiagonal();
  result.model_covariance = AddModelCovariance(stored, result.bins, result.jacobian,
                                                &result.bin_covariance);
  const Eigen::LLT<Eigen::MatrixXd> llt(result.bin_covariance);
  const Eigen::MatrixXd L = llt.matrixL();
  const Eigen::VectorXd r_white = L.triangularView<Eigen::Lower>().solve(result.residual);
  result.chi2 = r_white.squaredNorm();
  result.p_value = ChiSquareSurvival(result.chi2, m);
  if (one_ring) RimHarmonicsTest(stored, &result);
  if (one_ring ? DecidedOneRing(stored, options, &result)
               : DecidedWithoutGroups(stored, options, &result)) {
    return result;
  }
  result.verdict = Verdict::kDrifted;

  // Which group explains the residuals: generalised least squares per group (a single mirror's
  // rim sees the camera and the mirror only).
  const Eigen::MatrixXd J_white = L.triangularView<Eigen::Lower>().solve(result.jacobian);
  for (const std::string& group : DriftGroups()) {
    if (one_ring && group != "camera" && group != "mirror1") continue;
    result.groups.push_back(FitGroup(group, J_white, r_white));
  }
  // Ranked by Schwarz's Bayesian criterion, chi^2 + rank ln(bins): a group with more coordinates
  // (the camera's ten) fits any pattern a little better, and must fit it better by more than its
  // extra freedom to be named (Akaike's chi^2 + 2 rank named the camera for a mirror's move:
  // docs/experiments.md).
  std::sort(result.groups.begin(), result.groups.end(), [](const GroupFit& a, const GroupFit& b) {
    return a.Score() < b.Score();
  });
  result.named_group = result.groups[0].group;
  // A group within 4 of the best score has considerable support too (a Bayes factor under
  // e^2 ~ 7): the data cannot tell the two apart.
  if (result.groups.size() > 1 && result.groups[1].Score() - result.groups[0].Score() < 4) {
    result.runner_up = result.groups[1].group;
  }
  result.reason = result.groups[0].p_value >= options.significance
                      ? "a move of " + result.named_group + " explains the residuals"
                      : "no single group explains the residuals; " + result.named_group +
                            " comes closest";
  if (one_ring) {
    // The groups' chi^2 is against the reference's scatter, which the rim's scene-bound bias
    // exceeds (RimHarmonicsTest): the harmonics decided, the groups only say what moved.
    result.reason = "the mirror's rim shifted, scaled or tilted since calibration: the camera "
                    "moved against the mirror (the rim cannot tell which of the two moved)";
  } else if (!EnoughMatches(result, options)) {
    result.reason += " (few ring-to-ring matches: the lips, measured from the calibration "
                     "photos', moved)";
  }
  return result;
}

}  // namespace omni::health
