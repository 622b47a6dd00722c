#include "design/optimizer.h"

#include <array>
#include <cmath>
#include <limits>
#include <sstream>

#include <nlopt.hpp>

#include "model/hyperboloid.h"

namespace omni::design {
namespace {

constexpr int kNumVars = 6;
constexpr int kNumIneq = 9;  // g1..g9
constexpr double kDeg = 180.0 / M_PI;

std::array<double, kNumVars> ToArray(const DesignParams& t) {
  return {t.c1, t.c2, t.k1, t.k2, t.d, t.r_sys};
}
DesignParams FromArray(const double* x) { return DesignParams{x[0], x[1], x[2], x[3], x[4], x[5]}; }

// f_r1(d/2) = b1 sqrt(u^2 - 1), u = (d/2 - z0_1) / a1, continued below mirror 1's vertex (u < 1)
// as -b1 sqrt(2 (1 - u)) (the mirror image of its behaviour near the vertex), so that h1 and
// theta_1,min stay continuous and monotone in d and point the solver back where the reflex plane
// misses mirror 1.
double SignedReflexRadius(const DesignParams& t) {
  const auto m1 = HyperboloidSheet<double>::Mirror1(t.c1, t.k1);
  const double u = (t.d / 2 - m1.z0) / m1.a;
  return u >= 1 ? m1.b * std::sqrt(u * u - 1) : -m1.b * std::sqrt(2 * (1 - u));
}

double Mass(const DesignParams& t, const OptimizerOptions& o) {
  const double r_ref = std::max(0.0, SignedReflexRadius(t));
  const SizeAndMass s = ComputeSizeAndMass(t, r_ref, o.r_cam, o.mass_inputs);
  return o.mass_model == MassModel::kAuthors ? s.m_authors_g : s.m_sys_g;
}

// g1..g9 and h1 in their natural units (mm, unitless, g, mm, mm, deg, deg, deg; h1 in mm).
struct RawConstraints {
  std::array<double, kNumIneq> g;
  double h1;
};

RawConstraints Constraints(const DesignParams& t, const OptimizerOptions& o) {
  const auto m1 = HyperboloidSheet<double>::Mirror1(t.c1, t.k1);
  const auto m2 = HyperboloidSheet<double>::Mirror2(t.c2, t.k2, t.d);
  const double r_ref = SignedReflexRadius(t);
  const double z1_rim = m1.Z(t.r_sys), z2_rim = m2.Z(t.r_sys);
  const double theta1_max = std::atan2(z1_rim - t.c1, t.r_sys);
  const double theta1_min = std::atan2(t.d / 2 - t.c1, r_ref);
  const double theta2_min = std::atan2(z2_rim - (t.d - t.c2), t.r_sys);
  RawConstraints c;
  c.g[0] = t.d - t.c2;
  c.g[1] = t.d / 2 - t.c1;
  c.g[2] = o.k_ratio_min - t.k2 / t.k1;
  c.g[3] = Mass(t, o) - o.mass_max_g;
  c.g[4] = (z1_rim - z2_rim) - o.h_sys_max;
  c.g[5] = o.vertex_offset_min - m2.VertexZ();
  c.g[6] = (o.theta1_max_sense == Theta1MaxSense::kAtMost ? 1.0 : -1.0) *
           (theta1_max - o.theta1_max_limit) * kDeg;
  c.g[7] = (o.theta1_min_limit - theta1_min) * kDeg;
  c.g[8] = (o.theta2_min_limit - theta2_min) * kDeg;
  c.h1 = r_ref - ReflexRadiusNeededByMirror2(t);
  return c;
}

// Divisors that bring each constraint to O(1) for the solver: 10 mm, 1 (ratio), 100 g, 1 deg.
constexpr std::array<double, kNumIneq> kIneqScale = {100.0, 100.0, 1.0, 100.0, 10.0,
                                                     10.0,  1.0,   1.0, 1.0};
constexpr double kEqScale = 10.0;
constexpr double kObjectiveScale = 100.0;
constexpr double kFdStep = 1e-6;  // in box-normalised coordinates

// The solver works in x in [0,1]^6, theta = lower + x (upper - lower), so that lengths of hundreds
// of mm and k of a few units weigh alike in SLSQP's quasi-Newton matrix.
struct Problem {
  const OptimizerOptions* options;
  std::array<double, kNumVars> lo, span;
  int evaluations = 0;

  DesignParams Theta(const double* x) const {
    double t[kNumVars];
    for (int i = 0; i < kNumVars; ++i) t[i] = lo[i] + x[i] * span[i];
    return FromArray(t);
  }
  // Scaled constraint vector: g1..g9 then h1.
  std::array<double, kNumIneq + 1> Scaled(const double* x) const {
    const RawConstraints c = Constraints(Theta(x), *options);
    std::array<double, kNumIneq + 1> s;
    for (int i = 0; i < kNumIneq; ++i) s[i] = c.g[i] / kIneqScale[i];
    s[kNumIneq] = c.h1 / kEqScale;
    return s;
  }
  // Values and central-difference Jacobian (rows: constraints, cols: x) of all constraints.
  void Jacobian(const double* x, std::array<double, kNumIneq + 1>* value,
                double (*jac)[kNumVars]) const {
    *value = Scaled(x);
    if (!jac) return;
    double xp[kNumVars];
    for (int j = 0; j < kNumVars; ++j) {
      std::copy(x, x + kNumVars, xp);
      xp[j] = x[j] + kFdStep;
      const auto plus = Scaled(xp);
      xp[j] = x[j] - kFdStep;
      const auto minus = Scaled(xp);
      for (int i = 0; i <= kNumIneq; ++i) jac[i][j] = (plus[i] - minus[i]) / (2 * kFdStep);
    }
  }
};

double Objective(unsigned n, const double* x, double* grad, void* data) {
  auto* p = static_cast<Problem*>(data);
  ++p->evaluations;
  const DesignParams t = p->Theta(x);
  if (grad) {
    const double d_b_d_theta[kNumVars] = {1, 1, 0, 0, -1, 0};
    for (int j = 0; j < kNumVars; ++j) grad[j] = d_b_d_theta[j] * p->span[j] / kObjectiveScale;
  }
  return (t.c1 + t.c2 - t.d) / kObjectiveScale;
}

void Inequalities(unsigned m, double* result, unsigned n, const double* x, double* grad,
                  void* data) {
  const auto* p = static_cast<const Problem*>(data);
  std::array<double, kNumIneq + 1> value;
  double jac[kNumIneq + 1][kNumVars];
  p->Jacobian(x, &value, grad ? jac : nullptr);
  for (int i = 0; i < kNumIneq; ++i) {
    result[i] = value[i];
    if (grad) std::copy(jac[i], jac[i] + kNumVars, grad + i * kNumVars);
  }
}

double Equality(unsigned n, const double* x, double* grad, void* data) {
  const auto* p = static_cast<const Problem*>(data);
  std::array<double, kNumIneq + 1> value;
  double jac[kNumIneq + 1][kNumVars];
  p->Jacobian(x, &value, grad ? jac : nullptr);
  if (grad) std::copy(jac[kNumIneq], jac[kNumIneq] + kNumVars, grad);
  return value[kNumIneq];
}

// Phase 1 objective: the squared scaled violations, sum max(0, g_i)^2 + h1^2.
double Violation(unsigned n, const double* x, double* grad, void* data) {
  const auto* p = static_cast<const Problem*>(data);
  const auto s = p->Scaled(x);
  double sum = s[kNumIneq] * s[kNumIneq];
  for (int i = 0; i < kNumIneq; ++i) sum += s[i] > 0 ? s[i] * s[i] : 0.0;
  return sum;
}

const char* NloptResultName(nlopt::result r) {
  switch (r) {
    case nlopt::SUCCESS: return "success";
    case nlopt::STOPVAL_REACHED: return "stopval_reached";
    case nlopt::FTOL_REACHED: return "ftol_reached";
    case nlopt::XTOL_REACHED: return "xtol_reached";
    case nlopt::MAXEVAL_REACHED: return "maxeval_reached";
    case nlopt::MAXTIME_REACHED: return "maxtime_reached";
    case nlopt::ROUNDOFF_LIMITED: return "roundoff_limited";
    case nlopt::FORCED_STOP: return "forced_stop";
    case nlopt::INVALID_ARGS: return "invalid_args";
    case nlopt::OUT_OF_MEMORY: return "out_of_memory";
    default: return "failure";
  }
}

double Halton(int index, int base) {
  double f = 1, r = 0;
  for (int i = index; i > 0; i /= base) {
    f /= base;
    r += f * (i % base);
  }
  return r;
}

bool Finite(const DesignParams& t) {
  for (double v : ToArray(t)) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

}  // namespace

std::string OptimizerOptions::Check() const {
  auto fail = [](const std::string& message) { return message; };
  if (!Finite(lower) || !Finite(upper)) return fail("search box has a non-finite bound");
  const char* names[kNumVars] = {"c1", "c2", "k1", "k2", "d", "r_sys"};
  const auto lo = ToArray(lower), hi = ToArray(upper);
  for (int i = 0; i < kNumVars; ++i) {
    if (lo[i] > hi[i]) {
      std::ostringstream s;
      s << "search box: lower " << names[i] << " = " << lo[i] << " exceeds upper " << hi[i];
      return fail(s.str());
    }
  }
  if (!(lower.k1 > 2) || !(lower.k2 > 2)) return fail("search box: k1 and k2 must exceed 2");
  if (!(lower.c1 > 0) || !(lower.c2 > 0) || !(lower.d > 0) || !(lower.r_sys > 0)) {
    return fail("search box: c1, c2, d and r_sys must be positive");
  }
  for (double v : {k_ratio_min, mass_max_g, h_sys_max, vertex_offset_min, theta1_max_limit,
                   theta1_min_limit, theta2_min_limit, r_cam, feasibility_tol, active_tol}) {
    if (!std::isfinite(v)) return fail("a constraint limit is not finite");
  }
  if (!(mass_max_g > 0) || !(h_sys_max > 0)) return fail("mass and height limits must be positive");
  if (!(r_cam > 0)) return fail("r_cam must be positive");
  for (const auto& s : starts) {
    if (!Finite(s)) return fail("a starting point is not finite");
  }
  if (starts.empty() && num_default_starts < 1) return fail("need at least one starting point");
  if (max_evaluations_per_start < 1) return fail("max_evaluations_per_start must be >= 1");
  return "";
}

const char* ToString(OptimizerStatus status) {
  switch (status) {
    case OptimizerStatus::kConverged: return "converged";
    case OptimizerStatus::kMaxEvaluations: return "max_evaluations";
    case OptimizerStatus::kInfeasible: return "infeasible";
    case OptimizerStatus::kInvalidOptions: return "invalid_options";
  }
  return "unknown";
}

DesignEvaluation EvaluateDesign(const DesignParams& theta, const OptimizerOptions& o) {
  DesignEvaluation e;
  e.theta = theta;
  e.baseline = theta.c1 + theta.c2 - theta.d;
  e.r_ref = ReflexRadius(theta);
  e.r_ref_needed = ReflexRadiusNeededByMirror2(theta);
  e.r_cam = o.r_cam;
  e.vertex_offset2 = HyperboloidSheet<double>::Mirror2(theta.c2, theta.k2, theta.d).VertexZ();
  e.size = ComputeSizeAndMass(theta, e.r_ref, o.r_cam, o.mass_inputs);
  e.fov = ComputeFieldOfView(theta, e.r_ref, o.r_cam);
  e.sroi = ComputeStereoRoiVertices(theta, e.fov);
  e.camera_fov = ComputeCameraFovBounds(theta, o.r_cam);
  e.chi = ImagingRatio(theta, e.fov);

  const RawConstraints c = Constraints(theta, o);
  const char* at_most = o.theta1_max_sense == Theta1MaxSense::kAtMost
                            ? "theta_1,max <= Lambda_1,max"
                            : "theta_1,max >= Lambda_1,max";
  const struct {
    const char* name;
    const char* label;
    const char* unit;
  } info[kNumIneq] = {
      {"g1", "d <= c2", "mm"},
      {"g2", "d/2 <= c1", "mm"},
      {"g3", "k2/k1 >= k_ratio_min", ""},
      {"g4", o.mass_model == MassModel::kAuthors ? "mass (authors' W) <= m_max" : "m_sys <= m_max",
       "g"},
      {"g5", "h_sys <= h_max", "mm"},
      {"g6", "z0_2 - a2 >= vertex_offset_min", "mm"},
      {"g7", at_most, "deg"},
      {"g8", "theta_1,min >= Lambda_1,min", "deg"},
      {"g9", "theta_2,min >= Lambda_2,min", "deg"},
  };
  e.feasible = true;
  for (int i = 0; i < kNumIneq; ++i) {
    ConstraintValue v{info[i].name, info[i].label, info[i].unit, c.g[i], false};
    v.active = std::abs(v.value) <= o.active_tol;
    v.satisfied = v.value <= o.feasibility_tol;
    e.feasible = e.feasible && v.satisfied;
    e.constraints.push_back(v);
  }
  ConstraintValue h{"h1", "f_r1(d/2) == r_ref needed by mirror 2", "mm", c.h1, true};
  h.active = true;
  h.satisfied = std::abs(c.h1) <= o.feasibility_tol;
  e.feasible = e.feasible && h.satisfied && e.r_ref > 0;
  e.constraints.push_back(h);
  return e;
}

std::vector<DesignParams> DefaultStarts(const OptimizerOptions& o) {
  // Uniform points of the box mostly put the reflex plane z = d/2 outside mirror 1 (d/2 below its
  // vertex or above F1), where the violation has local minima that trap the feasibility phase.
  // So c1, k1, k2, r_sys come from a Halton sequence over the box (the first start: its centre),
  // and d, c2 are placed relative to them: d/2 between mirror 1's vertex and F1 (g2, r_ref > 0),
  // c2 a little above d (g1), k2 at least k_ratio_min k1 when the box allows (g3).
  const auto lo = ToArray(o.lower), hi = ToArray(o.upper);
  auto clamp = [&](double v, int i) { return std::min(std::max(v, lo[i]), hi[i]); };
  const int bases[kNumVars] = {2, 3, 5, 7, 11, 13};
  std::vector<DesignParams> starts;
  for (int s = 0; s < o.num_default_starts; ++s) {
    double u[kNumVars];
    for (int i = 0; i < kNumVars; ++i) u[i] = s == 0 ? 0.5 : 0.1 + 0.8 * Halton(s, bases[i]);
    DesignParams t;
    t.c1 = lo[0] + u[0] * (hi[0] - lo[0]);
    t.k1 = lo[2] + u[2] * (hi[2] - lo[2]);
    t.k2 = clamp(std::max(lo[3] + u[3] * (hi[3] - lo[3]), o.k_ratio_min * t.k1), 3);
    t.r_sys = lo[5] + u[5] * (hi[5] - lo[5]);
    const double vertex1 = HyperboloidSheet<double>::Mirror1(t.c1, t.k1).VertexZ();
    t.d = clamp(2 * (vertex1 + u[4] * (t.c1 - vertex1)), 4);
    t.c2 = clamp(t.d * (1.0 + 0.1 * u[1]), 1);
    starts.push_back(t);
  }
  return starts;
}

// Method: NLopt's LD_SLSQP (sequential least-squares quadratic programming, Kraft 1988). It is the
// same family as the authors' fmincon SQP, handles the equality h1 and the nine inequalities
// directly (COBYLA has no true equality constraints and AUGLAG needs an inner solver and many more
// evaluations), and converges to the tight tolerances a reproduction needs (1e-10 on theta) in a
// few dozen iterations. Gradients: the objective's is exact; the constraints' are central
// differences, which are accurate to ~1e-10 here because every constraint is a smooth closed form
// (with the authors' mass model; the full model's Simpson integral is smooth in theta as well).
OptimizerResult OptimizeBaseline(const OptimizerOptions& options) {
  OptimizerResult result;
  if (std::string why = options.Check(); !why.empty()) {
    result.status = OptimizerStatus::kInvalidOptions;
    result.message = why;
    return result;
  }
  Problem problem{&options, {}, {}};
  const auto lo = ToArray(options.lower), hi = ToArray(options.upper);
  for (int i = 0; i < kNumVars; ++i) {
    problem.lo[i] = lo[i];
    problem.span[i] = hi[i] > lo[i] ? hi[i] - lo[i] : 1.0;
  }
  const std::vector<DesignParams> starts =
      options.starts.empty() ? DefaultStarts(options) : options.starts;

  bool any_feasible = false, best_hit_budget = false;
  double best_baseline = -std::numeric_limits<double>::infinity();
  for (size_t s = 0; s < starts.size(); ++s) {
    problem.evaluations = 0;
    std::vector<double> x_lo(kNumVars), x_hi(kNumVars), x(kNumVars);
    const auto st = ToArray(starts[s]);
    for (int i = 0; i < kNumVars; ++i) {
      x_lo[i] = 0.0;
      x_hi[i] = hi[i] > lo[i] ? 1.0 : 0.0;  // a degenerate side pins the variable
      x[i] = std::min(std::max((st[i] - lo[i]) / problem.span[i], x_lo[i]), x_hi[i]);
    }
    // Phase 1: most of the box is far from feasible (the reflex plane may even miss mirror 1), and
    // SLSQP started there stalls on its linearised constraints. A derivative-free descent on the
    // squared violations (BOBYQA) first brings the start close to the feasible set.
    if (Violation(kNumVars, x.data(), nullptr, &problem) > 1e-12) {
      nlopt::opt restore(nlopt::LN_BOBYQA, kNumVars);
      restore.set_lower_bounds(x_lo);
      restore.set_upper_bounds(x_hi);
      restore.set_min_objective(Violation, &problem);
      restore.set_stopval(1e-14);
      restore.set_xtol_rel(1e-10);
      restore.set_maxeval(options.max_evaluations_per_start);
      double v = 0;
      try {
        restore.optimize(x, v);
      } catch (const std::exception&) {
        // Keep the last iterate; phase 2 decides.
      }
      problem.evaluations += restore.get_numevals();
    }
    nlopt::opt opt(nlopt::LD_SLSQP, kNumVars);
    opt.set_lower_bounds(x_lo);
    opt.set_upper_bounds(x_hi);
    opt.set_max_objective(Objective, &problem);
    opt.add_inequality_mconstraint(Inequalities, &problem,
                                   std::vector<double>(kNumIneq, 1e-10));
    opt.add_equality_constraint(Equality, &problem, 1e-10);
    opt.set_xtol_rel(options.xtol_rel);
    if (options.ftol_rel > 0) opt.set_ftol_rel(options.ftol_rel);
    opt.set_maxeval(options.max_evaluations_per_start);

    nlopt::result code = nlopt::FAILURE;
    double f = 0;
    try {
      code = opt.optimize(x, f);
    } catch (const nlopt::roundoff_limited&) {
      code = nlopt::ROUNDOFF_LIMITED;  // x holds the last iterate
    } catch (const std::exception&) {
      code = nlopt::FAILURE;
    }
    StartOutcome outcome;
    outcome.start = starts[s];
    outcome.theta = problem.Theta(x.data());
    outcome.evaluations = problem.evaluations;
    outcome.nlopt_result = NloptResultName(code);
    const DesignEvaluation eval = EvaluateDesign(outcome.theta, options);
    outcome.feasible = eval.feasible && std::isfinite(eval.baseline);
    outcome.baseline = eval.baseline;
    result.evaluations += problem.evaluations;
    result.starts.push_back(outcome);
    // Ties (several starts reaching the same optimum) keep the earliest start.
    if (outcome.feasible && eval.baseline > best_baseline + 1e-9) {
      best_baseline = eval.baseline;
      result.best = eval;
      result.best_start = static_cast<int>(s);
      best_hit_budget = code == nlopt::MAXEVAL_REACHED;
      any_feasible = true;
    }
  }
  if (!any_feasible) {
    result.status = OptimizerStatus::kInfeasible;
    result.message = "no starting point converged to a design that satisfies every constraint";
    if (!starts.empty()) result.best = EvaluateDesign(result.starts.front().theta, options);
    return result;
  }
  result.status = best_hit_budget ? OptimizerStatus::kMaxEvaluations : OptimizerStatus::kConverged;
  std::ostringstream msg;
  int agree = 0;
  for (const auto& o : result.starts) {
    if (o.feasible && std::abs(o.baseline - best_baseline) < 1e-3) ++agree;
  }
  msg << agree << " of " << result.starts.size() << " starts reached the best baseline";
  result.message = msg.str();
  return result;
}

}  // namespace omni::design
