#include "design/decide_photos.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <tuple>

#include <Eigen/Dense>

#include "model/model_compare.h"
#include "model/rig_model.h"
#include "model/rig_parameters.h"

namespace omni::design {
namespace {

constexpr const char* kHeightNames[3] = {"low", "middle", "high"};

// The finite-difference step of a parameter in its unit.
double Step(ParameterUnit unit) {
  switch (unit) {
    case ParameterUnit::kPixel: return 1e-3;
    case ParameterUnit::kMillimetre: return 1e-4;
    case ParameterUnit::kRadian: return 1e-6;
    case ParameterUnit::kNone: return 1e-6;
  }
  return 1e-6;
}

// The board's corners in C, its pose moved by the rotation vector w (about its centre) and t.
std::vector<Eigen::Vector3d> Corners(const CandidatePhoto& c, const Eigen::Vector3d& w,
                                     const Eigen::Vector3d& t) {
  const Eigen::Vector3d centre(c.range_mm * std::cos(c.azimuth_rad),
                               c.range_mm * std::sin(c.azimuth_rad), c.height_mm);
  const Eigen::Vector3d x(-std::sin(c.azimuth_rad), std::cos(c.azimuth_rad), 0);
  const Eigen::Vector3d y(0, 0, 1);
  const Eigen::Matrix3d r =
      w.norm() > 0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                   : Eigen::Matrix3d::Identity();
  std::vector<Eigen::Vector3d> corners;
  if (c.tag_grid) {  // each tag's 4 corners, tags 1.3 sides apart (Kalibr's spacing 0.3)
    const double pitch = 1.3 * c.square_mm;
    const double w = (c.cols * 1.3 - 0.3) * c.square_mm, h = (c.rows * 1.3 - 0.3) * c.square_mm;
    for (int j = 0; j < c.rows; ++j) {
      for (int i = 0; i < c.cols; ++i) {
        for (int k = 0; k < 4; ++k) {
          const double u = i * pitch + (k == 1 || k == 2 ? c.square_mm : 0) - w / 2;
          const double v = j * pitch + (k >= 2 ? c.square_mm : 0) - h / 2;
          corners.push_back(centre + r * (u * x + v * y) + t);
        }
      }
    }
    return corners;
  }
  for (int j = 0; j < c.rows; ++j) {
    for (int i = 0; i < c.cols; ++i) {
      const Eigen::Vector3d local =
          ((i - (c.cols - 1) / 2.0) * x + (j - (c.rows - 1) / 2.0) * y) * c.square_mm;
      corners.push_back(centre + r * local + t);
    }
  }
  return corners;
}

// Each corner's pixel in each ring (nullopt where the ring does not see it).
using Pixels = std::vector<std::optional<Eigen::Vector2d>>;
Pixels Project(const RigModel& model, const std::vector<Eigen::Vector3d>& corners) {
  Pixels out;
  for (Mirror m : {Mirror::kOne, Mirror::kTwo}) {
    for (const Eigen::Vector3d& p : corners) out.push_back(model.Project(p, m));
  }
  return out;
}

struct Simulated {
  CandidatePhoto photo;
  Eigen::MatrixXd information;  // over the covariance's parameters, the board's pose eliminated
};

// The candidates' information: d pixels / d parameters by central differences (the model rebuilt
// per perturbed parameter), weighted by each ring's sigma, the pose eliminated.
std::vector<Simulated> Simulate(const RigParams& rig, const std::vector<std::string>& names,
                                std::vector<CandidatePhoto> photos, const double sigma_px[2]) {
  const RigModel base(rig);
  std::vector<std::vector<Eigen::Vector3d>> corners;
  std::vector<Pixels> at_base;
  for (const CandidatePhoto& c : photos) {
    corners.push_back(Corners(c, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()));
    at_base.push_back(Project(base, corners.back()));
  }
  const size_t n = names.size();
  // d pixel / d parameter per candidate: rows 2 per (ring, corner), NaN where not seen.
  std::vector<Eigen::MatrixXd> jr(photos.size()), jp(photos.size());
  for (size_t k = 0; k < photos.size(); ++k) {
    jr[k] = Eigen::MatrixXd::Zero(2 * at_base[k].size(), n);
    jp[k] = Eigen::MatrixXd::Zero(2 * at_base[k].size(), 6);
  }
  auto difference = [](const Pixels& plus, const Pixels& minus, double h, Eigen::MatrixXd* j,
                       int col) {
    for (size_t i = 0; i < plus.size(); ++i) {
      if (plus[i] && minus[i]) {
        j->block<2, 1>(2 * i, col) = (*plus[i] - *minus[i]) / (2 * h);
      } else {
        j->block<2, 1>(2 * i, col).setConstant(NAN);
      }
    }
  };
  for (size_t p = 0; p < n; ++p) {
    const RigParameter* param = FindRigParameter(names[p]);
    if (!param) continue;  // not a rig parameter: no column
    const double h = Step(param->unit);
    RigParams plus = rig, minus = rig;
    *ParameterOf(&plus, names[p]) += h;
    *ParameterOf(&minus, names[p]) -= h;
    const RigModel model_plus(plus), model_minus(minus);
    for (size_t k = 0; k < photos.size(); ++k) {
      difference(Project(model_plus, corners[k]), Project(model_minus, corners[k]), h, &jr[k], p);
    }
  }
  for (size_t k = 0; k < photos.size(); ++k) {
    for (int q = 0; q < 6; ++q) {
      const double h = q < 3 ? 1e-6 : 1e-4;
      Eigen::Vector3d w = Eigen::Vector3d::Zero(), t = Eigen::Vector3d::Zero();
      (q < 3 ? w : t)(q % 3) = h;
      difference(Project(base, Corners(photos[k], w, t)), Project(base, Corners(photos[k], -w, -t)),
                 h, &jp[k], q);
    }
  }
  std::vector<Simulated> out;
  for (size_t k = 0; k < photos.size(); ++k) {
    // The rows every perturbation kept, weighted by their ring's sigma.
    std::vector<int> rows;
    const size_t per_ring = corners[k].size();
    for (size_t i = 0; i < at_base[k].size(); ++i) {
      if (!at_base[k][i]) continue;
      if (!jr[k].middleRows(2 * i, 2).allFinite() || !jp[k].middleRows(2 * i, 2).allFinite()) continue;
      ++photos[k].corners[i < per_ring ? 0 : 1];
      rows.push_back(static_cast<int>(i));
    }
    if (rows.size() < 6) continue;  // too few corners to pose the board
    Eigen::MatrixXd a(2 * rows.size(), n), b(2 * rows.size(), 6);
    for (size_t r = 0; r < rows.size(); ++r) {
      const double w = 1 / sigma_px[static_cast<size_t>(rows[r]) < per_ring ? 0 : 1];
      a.middleRows(2 * r, 2) = w * jr[k].middleRows(2 * rows[r], 2);
      b.middleRows(2 * r, 2) = w * jp[k].middleRows(2 * rows[r], 2);
    }
    const Eigen::MatrixXd hpp = b.transpose() * b;
    const Eigen::MatrixXd hpr = b.transpose() * a;
    Simulated s;
    s.photo = photos[k];
    s.information = a.transpose() * a - hpr.transpose() * hpp.ldlt().solve(hpr);
    out.push_back(std::move(s));
  }
  return out;
}

// The candidate photos: each board at each range it is made for, three heights in the band both
// rings see there, azimuths.
std::vector<CandidatePhoto> Candidates(const RigParams& rig, const DecidingPhotosOptions& o) {
  const RigModel model(rig);
  std::vector<CandidatePhoto> out;
  for (double range : o.ranges_mm) {
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (const BandPoint& p : StereoBandPoints(model, range)) {
      lo = std::min(lo, p.point_in_cam.z());
      hi = std::max(hi, p.point_in_cam.z());
    }
    if (!(hi > lo)) continue;
    for (const CandidateBoard& board : o.boards) {
      if (range > board.max_range_mm) continue;
      for (int h = 0; h < 3; ++h) {
        for (int a = 0; a < o.azimuths; ++a) {
          CandidatePhoto c;
          c.range_mm = range;
          c.height_mm = lo + (hi - lo) * (0.2 + 0.3 * h);
          c.height_name = kHeightNames[h];
          c.azimuth_rad = 2 * M_PI * a / o.azimuths;
          c.rows = board.rows;
          c.cols = board.cols;
          c.tag_grid = board.tag_grid;
          c.square_mm = board.square_mm_per_m * range / 1000;
          out.push_back(c);
        }
      }
    }
  }
  return out;
}

// What the calibration knows, split as more photos change it: the pixel noise's information S
// (the inverse of the noise-alone covariance N), which the photos add to, and the considered
// parameters' share C = T - N of the covariance T, a held coordinate's (or a detector bias's)
// move passed on through S^-1 S_xc: C = S^-1 B S^-1 with B = S C S fixed by the data that hold
// the considered columns (the lips, the held profile). With photos adding A the covariance is
// (S + A)^-1 + (S + A)^-1 B (S + A)^-1: the share shrinks where the photos pin what the
// considered columns moved. Without a noise covariance (older files) T^-1 stands for S, B = 0.
struct Knowledge {
  Eigen::MatrixXd information, considered;  // S, B
};

Knowledge KnowledgeOf(const CalibrationInfo& info, size_t n) {
  const Eigen::MatrixXd total = Eigen::Map<const Eigen::MatrixXd>(info.covariance.data(), n, n);
  const bool split = info.noise_covariance.size() == n * n;
  const Eigen::MatrixXd noise =
      split ? Eigen::Map<const Eigen::MatrixXd>(info.noise_covariance.data(), n, n) : total;
  Knowledge k;
  k.information = noise.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
  k.information = 0.5 * (k.information + k.information.transpose());
  k.considered = k.information * (total - noise) * k.information;
  k.considered = 0.5 * (k.considered + k.considered.transpose());
  return k;
}

double Variance(const Eigen::MatrixXd& information, const Eigen::MatrixXd& considered,
                const Eigen::VectorXd& g) {
  const Eigen::VectorXd x = information.ldlt().solve(g);
  return g.dot(x) + x.dot(considered * x);
}

// Of which the considered share: x' B x.
double ConsideredVariance(const Eigen::MatrixXd& information, const Eigen::MatrixXd& considered,
                          const Eigen::VectorXd& g) {
  const Eigen::VectorXd x = information.ldlt().solve(g);
  return x.dot(considered * x);
}

}  // namespace

std::string DecidingPhotos::Describe(const std::string& unit, double scale) const {
  if (in_valley) {
    return "in the camera-rotation valley: photos do not decide it (the data cannot tell it from "
           "the camera's turn against the bodies); measure it mechanically";
  }
  // Grouped by range and height, in the order first chosen.
  // range, height, the board's rows, cols, kind
  using Key = std::tuple<double, std::string, int, int, bool>;
  std::vector<std::pair<Key, std::vector<double>>> groups;
  std::vector<const CandidatePhoto*> firsts;  // per group: its first photo (height, square)
  for (const CandidatePhoto& p : photos) {
    const Key key{p.range_mm, std::string(p.height_name), p.rows, p.cols, p.tag_grid};
    auto it = std::find_if(groups.begin(), groups.end(), [&](const auto& g) { return g.first == key; });
    if (it == groups.end()) {
      groups.push_back({key, {}});
      firsts.push_back(&p);
      it = groups.end() - 1;
    }
    it->second.push_back(p.azimuth_rad * 180 / M_PI);
  }
  std::string text = std::to_string(photos.size()) + (photos.size() == 1 ? " photo: " : " photos: ");
  for (size_t g = 0; g < groups.size(); ++g) {
    const CandidatePhoto& board = *firsts[g];
    char part[280];
    std::snprintf(part, sizeof part, "%sa %dx%d %s of %.0f mm %s at %.1f m, %s in the "
                  "band (its centre %.0f mm up the axis from the camera), azimuth%s",
                  g ? "; " : "", board.rows, board.cols,
                  board.tag_grid ? "Kalibr AprilGrid (spacing 0.3)" : "board", board.square_mm,
                  board.tag_grid ? "tags" : "squares", board.range_mm / 1000, board.height_name,
                  board.height_mm, groups[g].second.size() > 1 ? "s" : "");
    text += part;
    // Each azimuth once, with how many photos there ("315 x5").
    std::map<long, int> az;
    for (double a : groups[g].second) ++az[std::lround(a)];
    bool first = true;
    for (const auto& [deg, count] : az) {
      text += (first ? " " : ", ") + std::to_string(deg) +
              (count > 1 ? " x" + std::to_string(count) : std::string());
      first = false;
    }
    text += " deg";
  }
  char tail[160];
  std::snprintf(tail, sizeof tail, "; sigma %.3g -> %.3g %s (%.3g %s decides)%s",
                sigma_now * scale, sigma_after * scale, unit.c_str(), sigma_needed * scale,
                unit.c_str(), decides ? "" : ": not enough, the check needs other data");
  text += tail;
  // What photos leave: the detectors' biases and held coordinates carried into the sigma.
  if (!decides && considered_after > 0) {
    char floor[240];
    std::snprintf(floor, sizeof floor, " (of it %.3g %s in quadrature: the detectors' biases and "
                  "held coordinates carried in, e.g. the lips' bias across the edge, which photos "
                  "do not average)", considered_after * scale, unit.c_str());
    text += floor;
  }
  return text;
}

namespace {

// The photos' information on the calibration's parameters (rig.calibration: parameters, each
// ring's residual RMS as its corners' sigma), each board's pose and the held profiles' terms
// eliminated.
std::vector<Simulated> SimulateOnRig(const RigParams& rig, std::vector<CandidatePhoto> photos) {
  const CalibrationInfo& info = *rig.calibration;
  const size_t n = info.parameters.size();
  // Each ring's corner sigma per image axis: its residuals' RMS is over the 2D residual (both
  // axes, calib/observation_set.cc CornerRms), sqrt(2) times the per-axis sigma (taken as the
  // sigma, it halved the photos' information: predicted / reached 0.67-0.70 on the axial positions).
  double sigma_px[2] = {0.1, 0.1};
  for (int m = 0; m < 2 && m < static_cast<int>(info.per_mirror_rms_px.size()); ++m) {
    if (info.per_mirror_rms_px[m] > 0) sigma_px[m] = info.per_mirror_rms_px[m] / std::sqrt(2.0);
  }
  // The held profiles (calibration.held_profiles): their terms move the new photos' corners too,
  // so each photo's information on the rig is taken with them free under what is known of them
  // (their prior, narrowed by the data), not as if they were exact: a photo adds nothing along a
  // held power term's trade with the axial positions.
  RigParams simulated_rig = rig;
  std::vector<std::string> names = info.parameters;
  std::vector<Eigen::MatrixXd> held_information;  // per held profile: Sigma_post^-1
  for (const HeldProfileInfo& h : info.held_profiles) {
    const Mirror mirror = h.mirror == 1 ? Mirror::kOne : Mirror::kTwo;
    ProfileShape& shape = h.mirror == 1 ? simulated_rig.profile1 : simulated_rig.profile2;
    if (!shape.present) {
      shape = ProfileShape{};
      shape.present = true;
      shape.r_min = h.r_min;
      shape.r_max = h.r_max;
    }
    const RigParameter* terms = BlockParameters(ProfileBlock(mirror));
    for (int k = 0; k < kProfileTerms; ++k) names.push_back(terms[k].name);
    const Eigen::MatrixXd prior =
        Eigen::Map<const Eigen::MatrixXd>(h.prior_covariance.data(), kProfileTerms, kProfileTerms);
    Eigen::MatrixXd held = prior.ldlt().solve(Eigen::MatrixXd::Identity(kProfileTerms, kProfileTerms));
    if (!h.data_information.empty()) {
      held += Eigen::Map<const Eigen::MatrixXd>(h.data_information.data(), kProfileTerms, kProfileTerms);
    }
    held_information.push_back(0.5 * (held + held.transpose()));
  }
  std::vector<Simulated> simulated = Simulate(simulated_rig, names, std::move(photos), sigma_px);
  if (!held_information.empty()) {
    const int h = static_cast<int>(names.size() - n);
    Eigen::MatrixXd prior = Eigen::MatrixXd::Zero(h, h);
    for (size_t b = 0; b < held_information.size(); ++b) {
      prior.block(b * kProfileTerms, b * kProfileTerms, kProfileTerms, kProfileTerms) = held_information[b];
    }
    for (Simulated& s : simulated) {
      const Eigen::MatrixXd a = s.information;
      const Eigen::MatrixXd a_xc = a.topRightCorner(n, h);
      const Eigen::MatrixXd a_cc = a.bottomRightCorner(h, h) + prior;
      s.information = a.topLeftCorner(n, n) - a_xc * a_cc.ldlt().solve(a_xc.transpose());
    }
  }
  return simulated;
}

// The check's gradient over the calibration's parameters.
Eigen::VectorXd GradientOf(const CalibrationInfo& info, const ToleranceCheck& c) {
  Eigen::VectorXd g = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(info.parameters.size()));
  for (size_t i = 0; i < c.gradient_names.size(); ++i) {
    const auto it = std::find(info.parameters.begin(), info.parameters.end(), c.gradient_names[i]);
    if (it != info.parameters.end()) g(it - info.parameters.begin()) = c.gradient[i];
  }
  return g;
}

}  // namespace

std::optional<double> SigmaAfterPhotos(const RigParams& rig, const ToleranceCheck& check,
                                       const std::vector<CandidatePhoto>& photos) {
  if (!rig.calibration || !check.sigma || check.gradient_names.empty()) return std::nullopt;
  const CalibrationInfo& info = *rig.calibration;
  const size_t n = info.parameters.size();
  if (n == 0 || info.covariance.size() != n * n) return std::nullopt;
  const Knowledge known = KnowledgeOf(info, n);
  Eigen::MatrixXd information = known.information;
  for (const Simulated& s : SimulateOnRig(rig, photos)) information += s.information;
  return std::sqrt(std::max(0.0, Variance(information, known.considered, GradientOf(info, check))));
}

std::vector<DecidingPhotos> PhotosThatDecide(const RigParams& rig,
                                             const std::vector<ToleranceCheck>& checks,
                                             double confidence_sigmas,
                                             const DecidingPhotosOptions& options) {
  std::vector<DecidingPhotos> out;
  if (!rig.calibration) return out;
  const CalibrationInfo& info = *rig.calibration;
  const size_t n = info.parameters.size();
  if (n == 0 || info.covariance.size() != n * n) return out;
  std::vector<const ToleranceCheck*> undecided;
  for (const ToleranceCheck& c : checks) {
    if (c.verdict == Verdict::kUndecided && c.sigma && !c.gradient_names.empty() &&
        std::abs(c.value - c.limit) > 0) {
      undecided.push_back(&c);
    }
  }
  if (undecided.empty()) return out;
  const Knowledge known = KnowledgeOf(info, n);
  std::vector<Simulated> simulated = SimulateOnRig(rig, Candidates(rig, options));
  if (simulated.empty()) return out;
  for (const ToleranceCheck* c : undecided) {
    const Eigen::VectorXd g = GradientOf(info, *c);
    DecidingPhotos d;
    d.check = c->name;
    if (std::abs(c->valley_correlation) > kRotationValleyCorrelation) {
      d.in_valley = true;
      d.sigma_now = d.sigma_after = *c->sigma;
      d.sigma_needed = std::abs(c->value - c->limit) / confidence_sigmas;
      out.push_back(std::move(d));
      continue;
    }
    d.sigma_now = std::sqrt(std::max(0.0, Variance(known.information, known.considered, g)));
    d.sigma_needed = std::abs(c->value - c->limit) / confidence_sigmas;
    d.sigma_after = d.sigma_now;
    Eigen::MatrixXd current = known.information;
    while (d.sigma_after > d.sigma_needed && static_cast<int>(d.photos.size()) < options.max_photos) {
      double best = HUGE_VAL;
      const Simulated* chosen = nullptr;
      for (const Simulated& s : simulated) {
        const double v = Variance(current + s.information, known.considered, g);
        if (v < best) best = v, chosen = &s;
      }
      if (!chosen || !(std::sqrt(best) < 0.999 * d.sigma_after)) break;  // nothing helps
      current += chosen->information;
      d.photos.push_back(chosen->photo);
      d.sigma_after = std::sqrt(std::max(0.0, best));
    }
    d.decides = d.sigma_after <= d.sigma_needed;
    d.considered_after = std::sqrt(std::max(0.0, ConsideredVariance(current, known.considered, g)));
    out.push_back(std::move(d));
  }
  return out;
}

}  // namespace omni::design
