#include "calib/central_decision.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>

#include <Eigen/Cholesky>

#include "calib/chi2_quantile.h"

namespace omni::calib {
namespace {

std::string Fixed1(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f", v);
  return buf;
}

}  // namespace

bool TestsNonCentral(const RigParams& start, const CalibrationOptions& options) {
  const std::string pose = kRigBlocks[kPose1Block].name;
  return start.Single() && options.noncentral == "auto" && options.estimate.size() > 1 &&
         std::find(options.estimate.begin(), options.estimate.end(), pose) != options.estimate.end();
}

void TestNonCentral(const RigParams& start, const CalibrationResult& fit,
                    NonCentralDecision* decision) {
  std::vector<int> index;
  std::vector<double> departure;
  for (const std::string& name : BlockParameterNames(kRigBlocks[kPose1Block].name)) {
    bool open = false;
    for (const auto& u : fit.uncertainty.unobservable) open |= u.name == name;
    if (open) {
      decision->open.push_back(name);
      continue;
    }
    const auto it = std::find(fit.estimate.names.begin(), fit.estimate.names.end(), name);
    if (it == fit.estimate.names.end()) continue;  // held (a telecentric lens's shifts)
    const int i = static_cast<int>(it - fit.estimate.names.begin());
    index.push_back(i);
    departure.push_back(fit.estimate.values(i) - *ParameterOf(start, name));
  }
  const int n = static_cast<int>(index.size());
  decision->dof = n;
  // Beyond chance (the 1% level) is not enough to predict better: on Mei's fold 1 a free
  // perspective camera's departure had chi^2 16.5 for 4 (the 1% level 13.3) and predicted the
  // held-out photos 0.52 px against the central model's 0.35. The Wald statistic approximates
  // the likelihood ratio 2 dlogL, which Schwarz's criterion asks to exceed k ln n (n the
  // residuals: two per corner) before the k extra parameters are worth having.
  const int residuals = 2 * fit.residuals.n_observations;
  decision->threshold =
      n > 0 ? std::max(Chi2Quantile99(n), n * std::log(std::max(residuals, 2))) : 0;
  decision->chi2 = 0;
  // No determined coordinate: nothing to test; the fit stands in the valley the covariance
  // names (held at the start, the telecentric paraboloid's 0.5 deg tilt that the fit found put
  // points at 1 m 5.7 px off in the mirror's body, against 0.55 px with it free).
  decision->decided = n == 0;
  if (n == 0) return;
  Eigen::VectorXd d(n);
  for (int a = 0; a < n; ++a) d(a) = departure[a];
  // d' C^-1 d over the determined coordinates; 0 where C is not positive definite.
  const auto wald = [&](const Eigen::MatrixXd& full) {
    if (full.rows() != fit.estimate.values.size()) return 0.0;
    Eigen::MatrixXd covariance(n, n);
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b) covariance(a, b) = full(index[a], index[b]);
    }
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(covariance);
    const bool positive = ldlt.info() == Eigen::Success && ldlt.isPositive() &&
                          (ldlt.vectorD().array() > 0).all();
    return positive ? d.dot(ldlt.solve(d)) : 0.0;
  };
  decision->chi2 = wald(fit.uncertainty.covariance);
  decision->chi2_noise = wald(fit.uncertainty.noise_covariance);
  decision->decided = decision->chi2 > decision->threshold;
}

bool NeedsCrossValidation(const NonCentralDecision& decision, size_t photos) {
  if (decision.dof == 0) return !decision.open.empty() && photos >= 3;
  return !decision.decided && decision.chi2_noise > decision.threshold;
}

namespace {

// The detections' images in fold `fold` of `folds` (image i in fold i % folds), or the others.
Observations FoldOf(const Observations& all, int fold, int folds, bool held_out) {
  Observations part;
  part.session = all.session;
  for (size_t i = 0; i < all.images.size(); ++i) {
    if ((static_cast<int>(i % folds) == fold) == held_out) part.images.push_back(all.images[i]);
  }
  return part;
}

}  // namespace

void CrossValidateNonCentral(const RigParams& start, const std::vector<TargetSpec>& targets,
                             const Observations& detections, const CalibrationOptions& options,
                             const CalibrateFunction& calibrate, NonCentralDecision* decision) {
  constexpr int kFolds = 3;
  CalibrationOptions quiet = options;
  quiet.progress = nullptr;
  quiet.status = nullptr;
  CalibrationOptions score = quiet;
  score.estimate = {};
  score.use_lips = false;
  double ssr[2] = {0, 0};
  int count[2] = {0, 0};
  bool failed[2] = {false, false};
  std::map<int, double> photo_ssr[2];  // per held-out photo (fold * 100000 + image)
  for (int fold = 0; fold < kFolds; ++fold) {
    const Observations train = FoldOf(detections, fold, kFolds, false);
    const Observations held = FoldOf(detections, fold, kFolds, true);
    if (held.images.empty()) continue;
    for (int m = 0; m < 2; ++m) {  // 0: non-central, 1: central
      if (failed[m]) continue;
      try {
        const CalibrationResult fit =
            calibrate(start, targets, train, m == 0 ? quiet : CentralOptions(quiet));
        const CalibrationResult scored = calibrate(fit.estimate.rig, targets, held, score);
        const double rms = scored.residuals.rms_px;
        ssr[m] += rms * rms * scored.residuals.n_observations;
        count[m] += scored.residuals.n_observations;
        for (const CornerResidual& c : scored.residuals.corners) {
          photo_ssr[m][fold * 100000 + c.image] += c.residual.squaredNorm();
        }
      } catch (const CalibrationError&) {
        failed[m] = true;  // a fold that diverges or is refused: that model loses
      }
    }
  }
  decision->cross_validated = true;
  for (int m = 0; m < 2; ++m) {
    const double rms = failed[m] || count[m] == 0 ? std::numeric_limits<double>::infinity()
                                                  : std::sqrt(ssr[m] / count[m]);
    (m == 0 ? decision->cv_rms_noncentral_px : decision->cv_rms_central_px) = rms;
  }
  // The one-standard-error rule (the simpler model unless the other predicts better by more
  // than the spread of the photos says): the non-central model's held-out squared error less the
  // central's, photo by photo, must fall below minus its standard error. On the public VMR set a
  // fold of 6 training photos preferred the non-central fit by 0.353 against 0.366 px within
  // them, and it then predicted its 3 held-out photos at 0.468 px against 0.315.
  double sum = 0, sum2 = 0;
  int photos = 0;
  if (!failed[0] && !failed[1]) {
    for (const auto& [key, ssr_noncentral] : photo_ssr[0]) {
      const auto it = photo_ssr[1].find(key);
      if (it == photo_ssr[1].end()) continue;
      const double d = ssr_noncentral - it->second;
      sum += d;
      sum2 += d * d;
      ++photos;
    }
  }
  if (photos >= 2) {
    const double mean = sum / photos;
    const double variance = std::max(0.0, (sum2 - photos * mean * mean) / (photos - 1));
    decision->cv_gain_px2 = -sum;
    decision->cv_gain_se_px2 = std::sqrt(photos * variance);
    decision->decided = -sum > decision->cv_gain_se_px2;
  } else {
    decision->decided = decision->cv_rms_noncentral_px < decision->cv_rms_central_px;
  }
}

std::string NonCentralNote(const NonCentralDecision& d) {
  if (!d.tested) return "";
  char buf[640];
  if (!d.failure.empty()) {
    std::snprintf(buf, sizeof(buf),
                  "non-central part (mirror1_pose) not determined by these photos: its solve "
                  "failed (%s); the central model stands (mirror1_pose held at the start's), and "
                  "the camera's offset from the mirror's focus is unknown",
                  d.failure.c_str());
    return buf;
  }
  std::string open;
  for (const std::string& name : d.open) open += (open.empty() ? "" : ", ") + name;
  char chi2[200] = "";
  if (d.dof > 0) {
    std::snprintf(chi2, sizeof(chi2),
                  "its departure from the central assembly, chi^2 %.1f for %d determined "
                  "coordinate(s), is %s the larger of the 1%% level and Schwarz's k ln n (%.1f)",
                  d.chi2, d.dof, d.chi2 > d.threshold ? "beyond" : "within", d.threshold);
  }
  std::string text = "non-central part (mirror1_pose) " +
                     std::string(d.decided && (d.dof > 0 || d.cross_validated) ? "decided" : "not decided") +
                     " by these photos: " +
                     chi2;
  if (!open.empty()) text += std::string(d.dof > 0 ? "; " : "") + open + " not determined";
  if (d.cross_validated) {
    const std::string why =
        d.dof == 0 ? "; with no coordinate determined the photos arbitrate"
                   : "; with the pixel noise alone it would be (chi^2 " + Fixed1(d.chi2_noise) +
                         "): the tilt lies in the valley the held tangential distortion opens, so "
                         "the photos arbitrate";
    const auto rms = [](double px) {
      if (!std::isfinite(px)) return std::string("(a fold's solve failed)");
      char one[32];
      std::snprintf(one, sizeof(one), "%.4f px", px);
      return std::string(one);
    };
    char cv[520];
    std::snprintf(cv, sizeof(cv),
                  ": 3-fold cross-validation, every photo held out once, predicts them at %s "
                  "non-central against %s central",
                  rms(d.cv_rms_noncentral_px).c_str(), rms(d.cv_rms_central_px).c_str());
    if (std::isfinite(d.cv_rms_noncentral_px) && std::isfinite(d.cv_rms_central_px)) {
      char gain[200];
      std::snprintf(gain, sizeof(gain),
                    " (its squared error %.3g px^2 lower over the photos, where it must beat the "
                    "photos' standard error %.3g)",
                    d.cv_gain_px2, d.cv_gain_se_px2);
      std::strncat(cv, gain, sizeof(cv) - std::strlen(cv) - 1);
    }
    text += why + cv;
  }
  if (d.decided && d.dof == 0 && !d.cross_validated) {
    return text + ": nothing to test; the non-central fit stands (its pose where the fit put it "
                  "in the valley those coordinates lie in)";
  }
  if (d.decided) return text + ": the non-central model stands (noncentral: auto)";
  return text + "; the central model stands (mirror1_pose held at the start's); the non-central "
                "fit's offset is given with its sigma (session noncentral: free keeps that fit)";
}

CalibrationOptions CentralOptions(const CalibrationOptions& options) {
  CalibrationOptions central = options;
  const std::string pose = kRigBlocks[kPose1Block].name;
  central.estimate.erase(std::remove(central.estimate.begin(), central.estimate.end(), pose),
                         central.estimate.end());
  return central;
}

}  // namespace omni::calib
