#include "design/tolerance.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>

#include "design/held_profile.h"
#include "design/named_covariance.h"
#include "design/rig_body.h"
#include "model/model_compare.h"
#include "model/rig_model.h"
#include "model/rig_parameters.h"
#include "model/triangulation.h"

namespace omni::design {
namespace {

// A check of `value` against `limit`, no sigma yet, UNDECIDED.
ToleranceCheck UndecidedCheck(const std::string& name, const std::string& unit, double value,
                              double limit) {
  ToleranceCheck check;
  check.name = name;
  check.unit = unit;
  check.value = value;
  check.limit = limit;
  return check;
}

// |(x, y)| and its first-order sigma; at the origin the gradient is undefined, so the larger
// principal sigma of (x, y) is used.
ToleranceCheck Magnitude2(const NamedCovariance& cov, const std::string& name,
                          const std::string& unit, const std::string& px, const std::string& py,
                          double x, double y, double limit) {
  ToleranceCheck check = UndecidedCheck(name, unit, std::hypot(x, y), limit);
  check.parameters = {px, py};
  check.components = {x, y};
  if (cov.Has({px, py})) {
    check.gradient_names = {px, py};
    if (check.value > 1e-12) {
      check.gradient = {x / check.value, y / check.value};
      check.sigma = cov.Sigma({px, py}, check.gradient);
    } else {
      check.sigma = std::max(cov.Sigma({px}, {1.0}), cov.Sigma({py}, {1.0}));
      check.gradient = cov.Sigma({px}, {1.0}) >= cov.Sigma({py}, {1.0}) ? std::vector<double>{1, 0}
                                                                         : std::vector<double>{0, 1};
    }
  }
  return check;
}

ToleranceCheck Magnitude1(const NamedCovariance& cov, const std::string& name,
                          const std::string& unit, const std::string& p, double x, double limit) {
  ToleranceCheck check = UndecidedCheck(name, unit, std::abs(x), limit);
  check.parameters = {p};
  check.components = {x};
  if (cov.Has({p})) {
    check.sigma = cov.Sigma({p}, {1.0});
    check.gradient_names = {p};
    check.gradient = {x >= 0 ? 1.0 : -1.0};
  }
  return check;
}

// The sag of a profile (coefficients c) at (x, y) and its derivative by each coefficient.
double SagAt(const std::array<double, kProfileTerms>& c, const ProfileShape& shape, double x,
             double y) {
  return ProfileSag(c.data(), shape, x, y, false).z;
}

// A mirror's profile peak-to-valley, with its first-order sigma from the refined coefficients'
// covariance (the difference of the sag at the two extreme points is linear in them). A held
// profile (its terms not in the covariance) gets no sigma here: DecideHeldProfile decides it.
ToleranceCheck ProfileCheck(const NamedCovariance& cov, const RigParams& rig, int m, double limit) {
  const RigParameter* terms = BlockParameters(ProfileBlock(m == 0 ? Mirror::kOne : Mirror::kTwo));
  ToleranceCheck check =
      UndecidedCheck(GroupOf(terms[0]) + std::string(".profile"), "mm", 0.0, limit);
  const ProfileShape& shape = m == 0 ? rig.profile1 : rig.profile2;
  const auto& c = m == 0 ? rig.mirror1_profile : rig.mirror2_profile;
  if (!shape.present) return check;
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  Eigen::Vector2d at_lo(0, 0), at_hi(0, 0);
  for (int i = 0; i <= 200; ++i) {
    const double r = shape.r_min + (shape.r_max - shape.r_min) * i / 200;
    for (int deg = 0; deg < 360; deg += 2) {
      const double x = r * std::cos(deg * M_PI / 180), y = r * std::sin(deg * M_PI / 180);
      const double z = SagAt(c, shape, x, y);
      if (z < lo) lo = z, at_lo = Eigen::Vector2d(x, y);
      if (z > hi) hi = z, at_hi = Eigen::Vector2d(x, y);
    }
  }
  check.value = hi - lo;
  std::vector<std::string> names;
  std::vector<double> gradient;
  for (int k = 0; k < kProfileTerms; ++k) {
    std::array<double, kProfileTerms> unit{};
    unit[k] = 1;
    ProfileShape smooth = shape;
    smooth.ripple_amplitude = 0;
    // Only the refined terms carry uncertainty (held ones are not in the covariance).
    const std::string name = terms[k].name;
    if (!cov.Has({name})) continue;
    names.push_back(name);
    gradient.push_back(SagAt(unit, smooth, at_hi.x(), at_hi.y()) - SagAt(unit, smooth, at_lo.x(), at_lo.y()));
  }
  if (!names.empty()) {
    check.sigma = cov.Sigma(names, gradient);
    check.gradient_names = names;
    check.gradient = gradient;
  }
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

// "+0.123, -0.045" of values scaled by k.
std::string Signed(const std::vector<double>& values, double k, const char* format) {
  std::string out;
  char one[32];
  for (double v : values) {
    std::snprintf(one, sizeof one, format, v * k);
    out += (out.empty() ? "" : ", ") + std::string(one);
  }
  return out;
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

std::string Correction(const ToleranceCheck& c) {
  if (c.verdict != Verdict::kFail) return "";
  // In the camera-rotation valley no move of a part can be told from the camera's turn.
  if (std::abs(c.valley_correlation) > kRotationValleyCorrelation) return "";
  if (c.frame == "mirror1") return RigBodyCorrection(c);
  const bool deg = c.unit == "rad";
  const double k = deg ? 180.0 / M_PI : 1.0;
  const char* unit = deg ? "deg" : "mm";
  const double excess = c.value - c.limit;
  const std::string part = c.name.substr(0, c.name.find('.'));
  char line[400];
  if (c.components.empty()) {
    std::snprintf(line, sizeof line,
                  "%.4f %s beyond the limit: the machined surface departs from the conic, which "
                  "no move of the part corrects",
                  excess * k, unit);
    return line;
  }
  std::vector<double> move;
  for (double v : c.components) move.push_back(c.value > 0 ? -excess * v / c.value : 0.0);
  const std::string is = Signed(c.components, k, "%+.3f");
  const std::string by = Signed(move, k, "%+.3f");
  if (c.components.size() == 1) {
    const bool up = move[0] > 0;
    std::snprintf(line, sizeof line,
                  "%s is %s %s, %.3f %s beyond +-%.3f: move %s %.3f %s along %sz (%s the camera)",
                  c.parameters[0].c_str(), is.c_str(), unit, excess * k, unit, c.limit * k,
                  part == "reflex" ? "the reflex plane" : part.c_str(), excess * k, unit,
                  up ? "+" : "-", up ? "away from" : "towards");
  } else if (deg) {
    std::snprintf(line, sizeof line,
                  "(%s, %s) is (%s) deg, |.| %.3f beyond %.3f by %.3f: turn %s back by (%s) deg "
                  "about C's x, y",
                  c.parameters[0].c_str(), c.parameters[1].c_str(), is.c_str(), c.value * k,
                  c.limit * k, excess * k, part == "reflex" ? "the reflex plane" : part.c_str(),
                  by.c_str());
  } else {
    std::snprintf(line, sizeof line,
                  "(%s, %s) is (%s) mm, |.| %.3f beyond %.3f by %.3f: move %s by (%s) mm in C's "
                  "x, y (x image right, y image down), towards the axis",
                  c.parameters[0].c_str(), c.parameters[1].c_str(), is.c_str(), c.value,
                  c.limit, excess, part.c_str(), by.c_str());
  }
  return line;
}

std::string RotationValleyNote(const ToleranceCheck& c) {
  if (!(std::abs(c.valley_correlation) > kRotationValleyCorrelation)) return "";
  char line[300];
  std::snprintf(line, sizeof line,
                "%s correlation %+.4f: in the camera-rotation valley; this value is not "
                "separable from the camera's rotation against the bodies (the principal point "
                "moves with it)",
                c.valley_pair.c_str(), c.valley_correlation);
  return line;
}

std::vector<ToleranceCheck> CheckTolerances(const RigParams& rig, const ToleranceSpec& spec) {
  const NamedCovariance cov(rig);
  std::vector<ToleranceCheck> checks;
  std::vector<std::pair<size_t, int>> held_profiles;  // (check, mirror): terms not in the covariance
  for (int m = 0; m < 2; ++m) {
    const auto& pose = m == 0 ? rig.mirror1_pose : rig.mirror2_pose;
    const BodyTolerance& tol = spec.mirror[m];
    // rx, ry, tx, ty, tz of that mirror's pose block.
    const RigParameter* p = BlockParameters(PoseBlock(m == 0 ? Mirror::kOne : Mirror::kTwo));
    const std::string body = GroupOf(p[kRx]);
    if (tol.decentre_mm >= 0) {
      checks.push_back(Magnitude2(cov, body + ".decentre", "mm", p[kTx].name, p[kTy].name,
                                  pose[kTx], pose[kTy], tol.decentre_mm));
    }
    if (tol.tilt_rad >= 0) {
      checks.push_back(Magnitude2(cov, body + ".tilt", "rad", p[kRx].name, p[kRy].name, pose[kRx],
                                  pose[kRy], tol.tilt_rad));
    }
    if (tol.axial_mm >= 0) {
      checks.push_back(Magnitude1(cov, body + ".axial", "mm", p[kTz].name, pose[kTz], tol.axial_mm));
    }
    if (tol.profile_pv_mm >= 0) {
      checks.push_back(ProfileCheck(cov, rig, m, tol.profile_pv_mm));
      if (rig.calibration && !checks.back().sigma) held_profiles.emplace_back(checks.size() - 1, m);
    }
  }
  // rx, ry, dz of the reflex disc.
  const RigParameter* reflex = BlockParameters(kReflexBlock);
  if (spec.reflex_tilt_rad >= 0) {
    checks.push_back(Magnitude2(cov, GroupOf(reflex[kReflexRx]) + std::string(".tilt"), "rad",
                                reflex[kReflexRx].name, reflex[kReflexRy].name, rig.reflex[kReflexRx], rig.reflex[kReflexRy],
                                spec.reflex_tilt_rad));
  }
  if (spec.reflex_dz_mm >= 0) {
    checks.push_back(Magnitude1(cov, reflex[kReflexDz].name, "mm", reflex[kReflexDz].name, rig.reflex[kReflexDz],
                                spec.reflex_dz_mm));
  }
  for (ToleranceCheck& c : CheckRigBody(rig, spec.rig_body, cov)) checks.push_back(std::move(c));
  for (size_t i = 0; i < checks.size(); ++i) {
    ToleranceCheck& c = checks[i];
    Decide(spec.confidence_sigmas, &c);
    for (const std::string& p : c.parameters) {
      // The principal point (cx, cy).
      for (const RigParameter& camera : RigParameterTable()) {
        if (camera.valley != RotationValley::kPrincipalPoint) continue;
        const double r = cov.Correlation(p, camera.name);
        if (std::abs(r) > std::abs(c.valley_correlation)) {
          c.valley_correlation = r;
          c.valley_pair = p + " ~ " + camera.name;
        }
      }
    }
  }
  // A held profile (its terms not refined): decided from what is known of it, not assumed.
  for (const auto& [i, m] : held_profiles) DecideHeldProfile(rig, m, spec.confidence_sigmas, &checks[i]);
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
      pose[kRx] += tilt.x();
      pose[kRy] += tilt.y();
      pose[kTx] += decentre.x();
      pose[kTy] += decentre.y();
      pose[kTz] += InRange(rng, limit(tol.axial_mm));
    }
    const Eigen::Vector2d reflex_tilt = InDisc(rng, limit(spec.reflex_tilt_rad));
    rig.reflex[kReflexRx] += reflex_tilt.x();
    rig.reflex[kReflexRy] += reflex_tilt.y();
    rig.reflex[kReflexDz] += InRange(rng, limit(spec.reflex_dz_mm));
    for (int m = 0; m < 2; ++m) {
      const double pv = spec.mirror[m].profile_pv_mm;
      if (!(pv > 0)) continue;
      ProfileShape& shape = m == 0 ? rig.profile1 : rig.profile2;
      auto& c = m == 0 ? rig.mirror1_profile : rig.mirror2_profile;
      if (!shape.present) shape = DefaultProfileShape(rig, m == 0 ? Mirror::kOne : Mirror::kTwo);
      const auto drawn = RandomProfile(shape, std::uniform_real_distribution<double>(0, pv)(rng), &rng);
      for (int k = 0; k < kProfileTerms; ++k) c[k] += drawn[k];
    }
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

std::array<double, kProfileTerms> RandomProfile(const ProfileShape& shape, double pv_mm,
                                                std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::array<double, kProfileTerms> c{};
  // Lower orders dominate a turned surface: P1 and P2 at full weight, P3, P4 and astigmatism
  // at half.
  const double weight[kProfileTerms] = {1, 1, 0.5, 0.5, 0.5, 0.5};
  for (int k = 0; k < kProfileTerms; ++k) c[k] = weight[k] * normal(*rng);
  ProfileShape smooth = shape;
  smooth.present = true;
  smooth.ripple_amplitude = 0;
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (int i = 0; i <= 60; ++i) {
    const double r = shape.r_min + (shape.r_max - shape.r_min) * i / 60;
    for (int deg = 0; deg < 360; deg += 6) {
      const double z = SagAt(c, smooth, r * std::cos(deg * M_PI / 180), r * std::sin(deg * M_PI / 180));
      lo = std::min(lo, z);
      hi = std::max(hi, z);
    }
  }
  const double scale = hi > lo ? pv_mm / (hi - lo) : 0;
  for (double& v : c) v *= scale;
  return c;
}

ProfileSensitivity SimulateProfileSensitivity(const RigParams& nominal, double pv_mm, int samples,
                                              unsigned seed) {
  ProfileSensitivity out;
  out.pv_mm = pv_mm;
  out.samples = samples;
  const RigModel nominal_model(nominal);
  const Triangulator triangulator(nominal_model);
  const std::vector<BandPoint> near = StereoBandPoints(nominal_model, 1000.0);
  const std::vector<BandPoint> far = StereoBandPoints(nominal_model, 2000.0);
  std::mt19937 rng(seed);
  std::vector<double> shifts[2], range_errors;
  for (int s = 0; s < samples; ++s) {
    RigParams rig = nominal;
    rig.kind = ModelKind::kNoncentral;
    for (int m = 0; m < 2; ++m) {
      ProfileShape& shape = m == 0 ? rig.profile1 : rig.profile2;
      auto& c = m == 0 ? rig.mirror1_profile : rig.mirror2_profile;
      if (!shape.present) shape = DefaultProfileShape(rig, m == 0 ? Mirror::kOne : Mirror::kTwo);
      const auto drawn = RandomProfile(shape, pv_mm, &rng);
      for (int k = 0; k < kProfileTerms; ++k) c[k] += drawn[k];
    }
    const RigModel machined(rig);
    for (size_t i = 0; i < near.size(); i += 3) {
      for (int m = 0; m < 2; ++m) {
        const auto px = machined.Project(near[i].point_in_cam, m == 0 ? Mirror::kOne : Mirror::kTwo);
        if (px) shifts[m].push_back((*px - near[i].pixel[m]).norm());
      }
    }
    for (size_t i = 0; i < far.size(); i += 3) {
      const auto p1 = machined.Project(far[i].point_in_cam, Mirror::kOne);
      const auto p2 = machined.Project(far[i].point_in_cam, Mirror::kTwo);
      if (!p1 || !p2) continue;
      const auto point = triangulator.Midpoint(*p1, *p2);
      if (!point) continue;
      const double range = far[i].point_in_cam.head<2>().norm();
      range_errors.push_back(std::abs(point->head<2>().norm() - range) / range);
    }
  }
  for (int m = 0; m < 2; ++m) out.p95_shift_px_1m[m] = Percentile(shifts[m], 0.95);
  out.p95_range_error_2m = Percentile(range_errors, 0.95);
  return out;
}

}  // namespace omni::design
