#include "design/held_profile.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <Eigen/Dense>

namespace omni::design {
namespace {

ProfileMatrix FromRowMajor(const std::vector<double>& v) {
  ProfileMatrix m = ProfileMatrix::Zero();
  if (v.size() != static_cast<size_t>(kProfileTerms * kProfileTerms)) return m;
  for (int a = 0; a < kProfileTerms; ++a) {
    for (int b = 0; b < kProfileTerms; ++b) m(a, b) = v[a * kProfileTerms + b];
  }
  return 0.5 * (m + m.transpose());
}

// The information of a covariance over the terms it has a variance for (the others get none).
ProfileMatrix InformationOf(const ProfileMatrix& covariance) {
  std::vector<int> terms;
  for (int k = 0; k < kProfileTerms; ++k) {
    if (covariance(k, k) > 0) terms.push_back(k);
  }
  ProfileMatrix out = ProfileMatrix::Zero();
  if (terms.empty()) return out;
  const Eigen::MatrixXd sub = covariance(terms, terms);
  const Eigen::MatrixXd inv = sub.ldlt().solve(Eigen::MatrixXd::Identity(sub.rows(), sub.cols()));
  out(terms, terms) = 0.5 * (inv + inv.transpose());
  return out;
}

// The standard normal's cumulative distribution.
double Phi(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

// erf^-1 by Newton on erf (from a start within 0.2 of it; |x| < 1).
double ErfInverse(double x) {
  double y = x / (1 - x * x + 1e-300) * 0.9;
  y = std::clamp(y, -5.0, 5.0);
  for (int i = 0; i < 60; ++i) {
    const double step = (std::erf(y) - x) / (2 / std::sqrt(M_PI) * std::exp(-y * y));
    y -= std::clamp(step, -0.5, 0.5);
    if (std::abs(step) < 1e-15) break;
  }
  return y;
}

const char* Um(double mm, char* buf, size_t size) {
  std::snprintf(buf, size, "%.2f", 1000 * mm);
  return buf;
}

}  // namespace

PvInterval PeakToValleyInterval(const ProfileShape& shape,
                                const std::array<double, kProfileTerms>& coeffs,
                                const ProfileMatrix& information, double p, int draws,
                                unsigned seed) {
  PvInterval out;
  const Eigen::SelfAdjointEigenSolver<ProfileMatrix> eig(0.5 * (information + information.transpose()));
  const double min_eigenvalue = 1.0 / (kUnboundedSigmaMm * kUnboundedSigmaMm);
  if (!(eig.eigenvalues().minCoeff() > min_eigenvalue)) return out;
  out.bounded = true;
  // dc = U Lambda^-1/2 z: the draws' covariance is information^-1.
  const ProfileMatrix root =
      eig.eigenvectors() * eig.eigenvalues().cwiseInverse().cwiseSqrt().asDiagonal();
  // The sag over the radii and azimuths: the held profile's (with its ripple, fixed data) plus
  // the terms' linear part of dc.
  constexpr int kRadii = 41, kAzimuths = 36;
  Eigen::MatrixXd basis(kRadii * kAzimuths, kProfileTerms);
  Eigen::VectorXd held(kRadii * kAzimuths);
  for (int i = 0; i < kRadii; ++i) {
    const double r = shape.r_min + (shape.r_max - shape.r_min) * i / (kRadii - 1);
    for (int a = 0; a < kAzimuths; ++a) {
      const double x = r * std::cos(2 * M_PI * a / kAzimuths), y = r * std::sin(2 * M_PI * a / kAzimuths);
      const auto g = ProfileTermGradient(shape, x, y);
      for (int k = 0; k < kProfileTerms; ++k) basis(i * kAzimuths + a, k) = g[k];
      held(i * kAzimuths + a) = ProfileSag(coeffs.data(), shape, x, y, false).z;
    }
  }
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> pv(draws);
  Eigen::Matrix<double, kProfileTerms, 1> z;
  for (int d = 0; d < draws; ++d) {
    for (int k = 0; k < kProfileTerms; ++k) z(k) = normal(rng);
    const Eigen::VectorXd sag = held + basis * (root * z);
    pv[d] = sag.maxCoeff() - sag.minCoeff();
  }
  std::sort(pv.begin(), pv.end());
  out.upper = pv[std::clamp(static_cast<int>(std::lround(p * (draws - 1))), 0, draws - 1)];
  // Below, the held profile's own extremes: the peak-to-valley is at least the sag difference
  // between them, linear in dc, so held PV - z_p sigma of that difference is a bound that holds
  // whatever the held profile (the draws' lower quantile is not: near the exact conic every
  // draw has some peak-to-valley, and an exact mirror would be called beyond a small limit).
  Eigen::Index hi = 0, lo = 0;
  held.maxCoeff(&hi);
  held.minCoeff(&lo);
  const Eigen::Matrix<double, kProfileTerms, 1> g = (basis.row(hi) - basis.row(lo)).transpose();
  const double z_p = std::sqrt(2.0) * ErfInverse(2 * p - 1);
  out.lower = (held(hi) - held(lo)) - z_p * std::sqrt(std::max(0.0, g.dot((root * root.transpose()) * g)));
  return out;
}

HeldProfileKnowledge KnowledgeOfHeldProfile(const RigParams& rig, int m) {
  HeldProfileKnowledge out;
  const HeldProfileInfo* held = nullptr;
  if (rig.calibration) {
    for (const HeldProfileInfo& h : rig.calibration->held_profiles) {
      if (h.mirror == m + 1) held = &h;
    }
  }
  const std::optional<MeasuredProfile>& scan = rig.measured_profile[m];
  out.recorded = held || scan;
  if (!out.recorded) return out;
  const bool data = held && !held->data_information.empty();
  const ProfileMatrix data_information = data ? FromRowMajor(held->data_information) : ProfileMatrix::Zero();
  // The scan's fit over the terms it measured (its unmeasured astigmatism is assumed, below).
  ProfileMatrix scan_information = ProfileMatrix::Zero();
  if (scan) {
    ProfileMatrix fit = scan->fit.covariance;
    for (int k = 0; k < kProfileTerms; ++k) {
      if (!scan->fit.measured[k]) fit.row(k).setZero(), fit.col(k).setZero();
    }
    scan_information = InformationOf(fit);
  }
  out.measured = scan_information + data_information;
  out.measured_from = scan && data ? "the scan and the data" : scan ? "the scan" : data ? "the data" : "";
  // The calibration's prior: the machining tolerance, or a scan's fit with the tolerance on its
  // unmeasured terms; without a record (profile: off with a scan) the scan alone.
  out.assumed = held ? ProfileMatrix(InformationOf(FromRowMajor(held->prior_covariance)) + data_information)
                     : out.measured;
  if (held) {
    const ProfileMatrix prior = FromRowMajor(held->prior_covariance);
    for (int k = 0; k < kProfileTerms; ++k) {
      if (!(scan && scan->fit.measured[k])) out.tolerance_mm = std::max(out.tolerance_mm, std::sqrt(prior(k, k)));
    }
  }
  return out;
}

void DecideHeldProfile(const RigParams& rig, int m, double k, ToleranceCheck* check) {
  // A held zero profile is not in the model (an exact quadric): the record keeps its radii.
  ProfileShape shape = m == 0 ? rig.profile1 : rig.profile2;
  if (!shape.present) {
    for (const HeldProfileInfo& h : rig.calibration->held_profiles) {
      if (h.mirror != m + 1) continue;
      shape = ProfileShape{};
      shape.present = true;
      shape.r_min = h.r_min;
      shape.r_max = h.r_max;
    }
  }
  const auto& coeffs = m == 0 ? rig.mirror1_profile : rig.mirror2_profile;
  check->sigma.reset();
  check->verdict = Verdict::kUndecided;
  const HeldProfileKnowledge known = KnowledgeOfHeldProfile(rig, m);
  if (!shape.present || !known.recorded) {
    check->note =
        "held as given and not considered (profile: off, or a model written before held profiles "
        "were recorded): nothing bounds it; a scan (profile_from: in the starting model) or "
        "profile: auto would";
    return;
  }
  const double p = Phi(k);
  char a[32], b[32], c[32], line[700];
  const PvInterval measured = PeakToValleyInterval(shape, coeffs, known.measured, p);
  if (measured.bounded) {
    check->sigma = std::max(0.0, measured.upper - check->value) / k;
    if (measured.upper <= check->limit) check->verdict = Verdict::kPass;
    if (measured.lower > check->limit) check->verdict = Verdict::kFail;
    std::snprintf(line, sizeof line,
                  "held (not refined): its peak-to-valley lies in %s..%s um at %.1f sigma by what "
                  "%s tell%s of it%s",
                  Um(std::max(0.0, measured.lower), a, sizeof a), Um(measured.upper, b, sizeof b), k,
                  known.measured_from.c_str(), known.measured_from == "the scan" ? "s" : "",
                  check->verdict == Verdict::kUndecided
                      ? ": the limit lies inside; a finer scan or photos that free the profile "
                        "would decide"
                      : "");
    check->note = line;
    return;
  }
  // Nothing measured bounds it: what the assumed tolerance alone would say, said, not decided.
  const PvInterval assumed = PeakToValleyInterval(shape, coeffs, known.assumed, p);
  const char* would = !assumed.bounded                ? nullptr
                      : assumed.upper <= check->limit ? "PASS"
                      : assumed.lower > check->limit  ? "FAIL"
                                                      : nullptr;
  std::snprintf(line, sizeof line,
                "held (not refined): %s%s; with the assumed machining tolerance (%s um per term) it "
                "lies in %s..%s um at %.1f sigma%s; a scan (profile_from: in the starting model) "
                "would decide",
                known.measured_from.empty()
                    ? "nothing measured bounds it"
                    : (known.measured_from +
                       (known.measured_from == "the scan" ? " does" : " do") + " not bound it")
                          .c_str(),
                known.measured_from.find("data") != std::string::npos
                    ? " (its power term bends the rays as an axial shift or a focal length does)"
                    : "",
                Um(known.tolerance_mm, c, sizeof c), Um(std::max(0.0, assumed.lower), a, sizeof a),
                Um(assumed.upper, b, sizeof b), k,
                would ? (std::string(", which alone would ") + would +
                         " it: an assumption, not a measurement")
                            .c_str()
                      : "");
  check->note = line;
}

}  // namespace omni::design
