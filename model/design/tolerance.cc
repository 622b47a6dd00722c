#include "model/design/tolerance.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include "model/model_compare.h"
#include "model/rig_model.h"

namespace omni::design {
namespace {

// The covariance of named parameters, if the model carries one.
class NamedCovariance {
 public:
  explicit NamedCovariance(const RigParams& rig) {
    if (!rig.calibration) return;
    const CalibrationInfo& c = *rig.calibration;
    const size_t n = c.parameters.size();
    if (c.covariance.size() != n * n) return;
    for (size_t i = 0; i < n; ++i) index_[c.parameters[i]] = static_cast<int>(i);
    cov_ = &c.covariance;
    n_ = static_cast<int>(n);
  }
  bool Has(const std::vector<std::string>& names) const {
    if (!cov_) return false;
    return std::all_of(names.begin(), names.end(),
                       [&](const std::string& s) { return index_.count(s) > 0; });
  }
  // sigma of g . x over the named parameters.
  double Sigma(const std::vector<std::string>& names, const std::vector<double>& g) const {
    double var = 0;
    for (size_t a = 0; a < names.size(); ++a) {
      for (size_t b = 0; b < names.size(); ++b) {
        var += g[a] * g[b] * (*cov_)[index_.at(names[a]) * n_ + index_.at(names[b])];
      }
    }
    return std::sqrt(std::max(0.0, var));
  }

 private:
  std::map<std::string, int> index_;
  const std::vector<double>* cov_ = nullptr;
  int n_ = 0;
};

// |(x, y)| and its first-order sigma; at the origin the gradient is undefined, so the larger
// principal sigma of (x, y) is used.
ToleranceCheck Magnitude2(const NamedCovariance& cov, const std::string& name,
                          const std::string& unit, const std::string& px, const std::string& py,
                          double x, double y, double limit) {
  ToleranceCheck check{name, unit, std::hypot(x, y), std::nullopt, limit, Verdict::kUndecided};
  if (cov.Has({px, py})) {
    if (check.value > 1e-12) {
      check.sigma = cov.Sigma({px, py}, {x / check.value, y / check.value});
    } else {
      check.sigma = std::max(cov.Sigma({px}, {1.0}), cov.Sigma({py}, {1.0}));
    }
  }
  return check;
}

ToleranceCheck Magnitude1(const NamedCovariance& cov, const std::string& name,
                          const std::string& unit, const std::string& p, double x, double limit) {
  ToleranceCheck check{name, unit, std::abs(x), std::nullopt, limit, Verdict::kUndecided};
  if (cov.Has({p})) check.sigma = cov.Sigma({p}, {1.0});
  return check;
}

void Decide(double k, ToleranceCheck* c) {
  const double s = c->sigma.value_or(0.0) * k;
  if (c->value + s <= c->limit) {
    c->verdict = Verdict::kPass;
  } else if (c->value - s > c->limit) {
    c->verdict = Verdict::kFail;
  } else {
    c->verdict = Verdict::kUndecided;
  }
}

// A uniform sample in a disc of radius r, or in +-r.
Eigen::Vector2d InDisc(std::mt19937& rng, double r) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double rho = r * std::sqrt(u(rng)), phi = 2 * M_PI * u(rng);
  return Eigen::Vector2d(rho * std::cos(phi), rho * std::sin(phi));
}
double InRange(std::mt19937& rng, double r) {
  return std::uniform_real_distribution<double>(-r, r)(rng);
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

}  // namespace

const char* VerdictName(Verdict verdict) {
  switch (verdict) {
    case Verdict::kPass: return "PASS";
    case Verdict::kFail: return "FAIL";
    case Verdict::kUndecided: return "UNDECIDED";
  }
  return "?";
}

std::vector<ToleranceCheck> CheckTolerances(const RigParams& rig, const ToleranceSpec& spec) {
  const NamedCovariance cov(rig);
  std::vector<ToleranceCheck> checks;
  for (int m = 0; m < 2; ++m) {
    const auto& pose = m == 0 ? rig.mirror1_pose : rig.mirror2_pose;
    const BodyTolerance& tol = spec.mirror[m];
    const std::string body = m == 0 ? "mirror1" : "mirror2";
    if (tol.decentre_mm >= 0) {
      checks.push_back(Magnitude2(cov, body + ".decentre", "mm", body + ".tx", body + ".ty",
                                  pose[2], pose[3], tol.decentre_mm));
    }
    if (tol.tilt_rad >= 0) {
      checks.push_back(Magnitude2(cov, body + ".tilt", "rad", body + ".rx", body + ".ry", pose[0],
                                  pose[1], tol.tilt_rad));
    }
    if (tol.axial_mm >= 0) {
      checks.push_back(Magnitude1(cov, body + ".axial", "mm", body + ".tz", pose[4], tol.axial_mm));
    }
  }
  if (spec.reflex_tilt_rad >= 0) {
    checks.push_back(Magnitude2(cov, "reflex.tilt", "rad", "reflex.rx", "reflex.ry",
                                rig.reflex[0], rig.reflex[1], spec.reflex_tilt_rad));
  }
  if (spec.reflex_dz_mm >= 0) {
    checks.push_back(Magnitude1(cov, "reflex.dz", "mm", "reflex.dz", rig.reflex[2],
                                spec.reflex_dz_mm));
  }
  for (ToleranceCheck& c : checks) Decide(spec.confidence_sigmas, &c);
  return checks;
}

ImageEffect SimulateImageEffect(const RigParams& nominal, const ToleranceSpec& spec, int samples,
                                double range_mm, unsigned seed,
                                const std::function<void(int, int)>& progress) {
  // Points at the given range that the nominal rig sees in both rings.
  const std::vector<BandPoint> seen = StereoBandPoints(RigModel(nominal), range_mm);
  ImageEffect effect;
  effect.points = static_cast<int>(seen.size());
  effect.samples = samples;
  std::mt19937 rng(seed);
  std::vector<double> shifts[2];
  long lost = 0, total = 0;
  auto limit = [](double v) { return std::max(0.0, v); };
  for (int s = 0; s < samples; ++s) {
    RigParams rig = nominal;
    for (int m = 0; m < 2; ++m) {
      auto& pose = m == 0 ? rig.mirror1_pose : rig.mirror2_pose;
      const BodyTolerance& tol = spec.mirror[m];
      const Eigen::Vector2d tilt = InDisc(rng, limit(tol.tilt_rad));
      const Eigen::Vector2d decentre = InDisc(rng, limit(tol.decentre_mm));
      pose[0] += tilt.x();
      pose[1] += tilt.y();
      pose[2] += decentre.x();
      pose[3] += decentre.y();
      pose[4] += InRange(rng, limit(tol.axial_mm));
    }
    const Eigen::Vector2d reflex_tilt = InDisc(rng, limit(spec.reflex_tilt_rad));
    rig.reflex[0] += reflex_tilt.x();
    rig.reflex[1] += reflex_tilt.y();
    rig.reflex[2] += InRange(rng, limit(spec.reflex_dz_mm));
    rig.kind = ModelKind::kNoncentral;
    const RigModel model(rig);
    for (const BandPoint& p : seen) {
      for (int m = 0; m < 2; ++m) {
        ++total;
        const auto px = model.Project(p.point_in_cam, m == 0 ? Mirror::kOne : Mirror::kTwo);
        if (!px) {
          ++lost;
          continue;
        }
        shifts[m].push_back((*px - p.pixel[m]).norm());
      }
    }
    if (progress) progress(s + 1, samples);
  }
  for (int m = 0; m < 2; ++m) {
    effect.p50_px[m] = Percentile(shifts[m], 0.5);
    effect.p95_px[m] = Percentile(shifts[m], 0.95);
    effect.max_px[m] = shifts[m].empty() ? 0 : *std::max_element(shifts[m].begin(), shifts[m].end());
  }
  effect.lost_fraction = total ? static_cast<double>(lost) / total : 0;
  return effect;
}

}  // namespace omni::design
