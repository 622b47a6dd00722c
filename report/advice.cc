// The report's advice (report.h Advice): what the data says a user should change, each rule a
// measured gap, never a generic tip, so that a good session gets none.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <array>
#include <optional>

#include "model/model_compare.h"
#include "model/rig_frames.h"
#include "model/rig_model.h"
#include "report/report.h"

namespace omni::report {
namespace {

constexpr int kMinCornersPerRing = 100;   // fewer: the ring's parameters rest on little data
constexpr int kMinOutliersToName = 10;    // outliers of one target in one image worth a look
constexpr double kPrintErrorPx = 0.5;     // ... when their median residual is this large
constexpr int kFewPhotos = 20;            // fewer photos than this: say the guide asks 20-40
constexpr double kTargetRmsFactor = 2.0;  // a target's residual RMS over the median target's
constexpr int kAzimuthSectors = 6;        // 60 deg each
constexpr double kEmptyBandShare = 0.02;  // a third of the band with fewer corners is empty

const char* RingName(int mirror, bool single = false) {
  if (single) return "the ring (the mirror)";
  return mirror == 1 ? "the outer ring (mirror 1)" : "the inner ring (mirror 2)";
}

// The elevation (deg above C's xy plane, the axis up) of a pixel's ray towards the world.
std::optional<double> RayElevation(const RigModel& model, const Eigen::Vector2d& pixel) {
  const auto ray = model.Unproject(pixel);
  if (!ray) return std::nullopt;
  const Eigen::Vector3d& d = ray->ray.direction;
  return std::atan2(d.z(), d.head<2>().norm()) * 180 / M_PI;
}

void CoverageAdvice(const ReportInput& in, std::vector<std::string>* out) {
  const RigModel model(in.result->estimate.rig);
  const std::vector<BandPoint> band = StereoBandPoints(model, 1000);
  // A single-mirror rig has no inner ring to advise on, and its band is its one ring's view.
  const bool single = in.result->estimate.rig.Single();
  for (int m = 1; m <= in.result->estimate.rig.Paths(); ++m) {
    double lo = 1e9, hi = -1e9;
    for (const BandPoint& p : band) {
      if (const auto e = RayElevation(model, p.pixel[m - 1])) {
        lo = std::min(lo, *e);
        hi = std::max(hi, *e);
      }
    }
    std::vector<double> elevation, azimuth;
    for (const auto& r : in.result->residuals.corners) {
      if (r.mirror != m) continue;
      const auto ray = model.Unproject(r.pixel);
      if (!ray) continue;
      const Eigen::Vector3d& d = ray->ray.direction;
      elevation.push_back(std::atan2(d.z(), d.head<2>().norm()) * 180 / M_PI);
      azimuth.push_back(std::atan2(d.y(), d.x()) * 180 / M_PI);
    }
    const int n = static_cast<int>(elevation.size());
    char line[400];
    if (n < kMinCornersPerRing) {
      std::snprintf(line, sizeof(line),
                    "%s has only %d corners in the solve: add images with targets in it%s",
                    RingName(m, single), n,
                    single ? "" : " (near targets fill the inner ring; tags need 3 px per bit there)");
      out->push_back(line);
      if (n == 0) continue;
    }
    if (hi > lo) {
      const double third = (hi - lo) / 3;
      int upper = 0, lower = 0;
      for (double e : elevation) {
        upper += e > hi - third;
        lower += e < lo + third;
      }
      // A single mirror has no stereo band: its band is the ring's own view.
      const char* band_name = single ? "view" : "stereo band";
      if (upper < kEmptyBandShare * n) {
        std::snprintf(line, sizeof(line),
                      "%s has %d corners above %.0f deg elevation (the upper third of its %s, "
                      "up to %.0f deg): add targets higher",
                      RingName(m, single), upper, hi - third, band_name, hi);
        out->push_back(line);
      }
      if (lower < kEmptyBandShare * n) {
        std::snprintf(line, sizeof(line),
                      "%s has %d corners below %.0f deg elevation (the lower third of its %s, "
                      "down to %.0f deg): add targets lower",
                      RingName(m, single), lower, lo + third, band_name, lo);
        out->push_back(line);
      }
    }
    std::vector<int> sector(kAzimuthSectors, 0);
    for (double a : azimuth) {
      const int s = static_cast<int>(std::floor((a + 180) / (360.0 / kAzimuthSectors)));
      ++sector[std::clamp(s, 0, kAzimuthSectors - 1)];
    }
    for (int s = 0; s < kAzimuthSectors; ++s) {
      if (sector[s] > 0) continue;
      const double from = -180 + s * 360.0 / kAzimuthSectors;
      std::snprintf(line, sizeof(line),
                    "%s has no corners between %.0f and %.0f deg azimuth (about C's z axis from "
                    "its x axis): place targets there",
                    RingName(m, single), from, from + 360.0 / kAzimuthSectors);
      out->push_back(line);
    }
  }
}

// A target whose corners in one image are left out in numbers and far beyond the detector's
// noise: a print that is not flat or not the session's size, or a wrong id, puts corners tenths
// of a pixel to pixels off; a detector's less precise corners (outliers at a few of its sigmas,
// 0.1-0.4 px for plain tags in the inner ring) are not named here.
void OutlierAdvice(const ReportInput& in, std::vector<std::string>* out) {
  std::map<std::pair<int, int>, std::vector<double>> outliers;  // (image, target) -> px
  for (const auto& r : in.result->residuals.rejected) {
    if (r.reason == "outlier") outliers[{r.image, r.target}].push_back(r.residual_px);
  }
  for (auto& [key, residuals] : outliers) {
    if (static_cast<int>(residuals.size()) < kMinOutliersToName) continue;
    std::sort(residuals.begin(), residuals.end());
    const double median = residuals[residuals.size() / 2];
    if (median < kPrintErrorPx) continue;
    const auto& images = in.observations->images;
    const std::string file =
        key.first >= 0 && key.first < static_cast<int>(images.size()) ? images[key.first].file
                                                                      : "?";
    char line[400];
    std::snprintf(line, sizeof(line),
                  "image %s target %d (%s): %zu corners left out as outliers (median %.2f px "
                  "off); check the print (flat, the session's square or tag size) and the "
                  "detections overlay",
                  file.c_str(), key.second,
                  key.second >= 0 && key.second < static_cast<int>(in.targets.size())
                      ? TargetName(in.targets[key.second]).c_str()
                      : "?",
                  residuals.size(), median);
    out->push_back(line);
  }
}

}  // namespace

// A held profile whose corners show a radial pattern along the mirror's radius, or that the
// corners' radii could not support (calib ProfileDecision).
void ProfileAdvice(const calib::CalibrationResult& r, std::vector<std::string>* out) {
  constexpr double kPatternChi2 = 4.0;  // as calib/profiles.cc
  for (int m = 0; m < 2; ++m) {
    const calib::ProfileDecision& d = r.residuals.profile[m];
    if (d.pattern_before.empty()) continue;
    char buf[400];
    if (d.freed) {
      if (d.pattern_chi2_after > kPatternChi2) {
        std::snprintf(buf, sizeof(buf),
                      "mirror %d: with its profile refined the corners' residuals still form a "
                      "pattern along the mirror's radius (chi^2 per band %.1f, see Mirror "
                      "profiles): finer than the profile's terms (turning marks?); it bounds "
                      "what this model can reach",
                      m + 1, d.pattern_chi2_after);
        out->push_back(buf);
      }
      continue;
    }
    if (d.pattern_chi2_after > kPatternChi2) {
      std::snprintf(buf, sizeof(buf),
                    "mirror %d: the corners' residuals form a pattern along the mirror's radius "
                    "(chi^2 per band %.1f, see Mirror profiles): a machining error the model lacks; "
                    "calibrate with profile: free",
                    m + 1, d.pattern_chi2_after);
      out->push_back(buf);
    }
    if (d.bins_covered < d.bins - 1) {
      std::snprintf(buf, sizeof(buf),
                    "mirror %d: the corners fill %d of %d bands of the radii they reach on it, too few to refine "
                    "its profile (held at its tolerance, which widens the sigmas): add photos with "
                    "targets low and high in ring %d",
                    m + 1, d.bins_covered, d.bins, m + 1);
      out->push_back(buf);
    }
  }
}

// Everything else the page shows that a user would act on: the assembly tolerances' verdicts,
// a session with fewer photos than the guide asks, and a target whose residuals stand out.
void SessionAdvice(const ReportInput& in, std::vector<std::string>* out) {
  std::string failed, undecided;
  for (const design::ToleranceCheck& t : in.tolerances) {
    if (t.verdict == design::Verdict::kFail) failed += (failed.empty() ? "" : ", ") + t.name;
    if (t.verdict == design::Verdict::kUndecided) undecided += (undecided.empty() ? "" : ", ") + t.name;
  }
  if (!failed.empty()) {
    out->push_back("assembly: " + failed + " outside its tolerance (see Assembly tolerances): "
                   "adjust the rig there and calibrate again");
  }
  if (!undecided.empty()) {
    out->push_back("assembly: " + undecided + " undecided (its value, within its uncertainty, straddles the "
                   "limit): more photos, targets near and far in both rings, would decide");
  }
  const int photos = in.observations ? static_cast<int>(in.observations->images.size()) : 0;
  if (photos > 0 && photos < kFewPhotos) {
    out->push_back(std::to_string(photos) + " photos: 20-40 with 1-3 targets each, near and far, "
                   "high and low, determine the rig and its lens better (docs/guide.md, step 3)");
  }
  // Per target: the RMS of its residuals against the median target's.
  std::map<int, std::pair<double, int>> per_target;  // target -> (sum of squares, count)
  for (const calib::CornerResidual& r : in.result->residuals.corners) {
    auto& [ss, n] = per_target[r.target];
    ss += r.residual.squaredNorm();
    ++n;
  }
  if (per_target.size() < 2) return;
  std::vector<double> rms;
  for (const auto& [t, v] : per_target) rms.push_back(std::sqrt(v.first / v.second));
  std::vector<double> sorted = rms;
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted[(sorted.size() - 1) / 2];
  size_t k = 0;
  for (const auto& [t, v] : per_target) {
    const double r = rms[k++];
    if (median > 0 && r > kTargetRmsFactor * median) {
      char line[400];
      const std::string name = t < static_cast<int>(in.targets.size()) ? TargetName(in.targets[t]) : "?";
      std::snprintf(line, sizeof(line),
                    "target %d (%s): its corners' residuals are %.3f px rms, %.1f times the other "
                    "targets' median (%.3f px): a print that is not flat, or its detections "
                    "(see Residual RMS per target and the overlays)",
                    t, name.c_str(), r, r / median, median);
      out->push_back(line);
    }
  }
}

// Boards lost beside a post: a target found in one ring of a photo and lost (or mostly lost) in the
// other, whose azimuths in the ring that found it meet a post's sector (the model's mount, in its
// body's frame): the post hides that board's other view. Said per photo and target, with how far
// to turn the board away; at most kMaxPostLines lines.
constexpr int kMinBoardCorners = 6;       // the ring that found the board: at least this many
constexpr double kPostMarginDeg = 1.0;    // a post's sector widened by this on each side
constexpr int kMaxPostLines = 5;

void PostAdvice(const ReportInput& in, std::vector<std::string>* out) {
  const RigParams& rig = in.result->estimate.rig;
  if (!rig.mount.present || rig.Single() || !in.observations || !(rig.mount.radius > 0)) return;
  const RigModel model(rig);
  const auto& pose = rig.mount.body == Mirror::kOne ? rig.mirror1_pose : rig.mirror2_pose;
  const Eigen::Matrix3d body_from_cam = PoseFromBlock(pose.data()).rotation.transpose();
  std::vector<std::string> lines;
  for (size_t i = 0; i < in.observations->images.size(); ++i) {
    std::map<int, std::array<std::vector<double>, 2>> azimuths;  // target -> per ring (rad)
    for (const CornerObservation& c : in.observations->images[i].corners) {
      const auto ray = model.Unproject(c.pixel);
      if (!ray) continue;
      const Eigen::Vector3d d = body_from_cam * ray->ray.direction;
      azimuths[c.target][c.mirror == Mirror::kOne ? 0 : 1].push_back(std::atan2(d.y(), d.x()));
    }
    for (const auto& [target, rings] : azimuths) {
      for (int found = 0; found < 2; ++found) {
        const std::vector<double>& az = rings[found];
        const size_t other = rings[1 - found].size();
        if (static_cast<int>(az.size()) < kMinBoardCorners || 2 * other >= az.size()) continue;
        // The board's azimuth span about its circular mean.
        double sx = 0, sy = 0;
        for (double a : az) sx += std::cos(a), sy += std::sin(a);
        const double mean = std::atan2(sy, sx);
        double lo = 0, hi = 0;
        for (double a : az) {
          const double off = std::remainder(a - mean, 2 * M_PI);
          lo = std::min(lo, off), hi = std::max(hi, off);
        }
        for (size_t k = 0; k < rig.mount.azimuths.size(); ++k) {
          const double half = rig.mount.WidthOf(k) / (2 * rig.mount.radius) + kPostMarginDeg * M_PI / 180;
          const double at = std::remainder(rig.mount.azimuths[k] - mean, 2 * M_PI);
          if (at + half < lo || at - half > hi) continue;
          // Turned so that the whole board clears the post's sector on its nearer side.
          const double turn = std::min(at + half - lo, hi - (at - half)) * 180 / M_PI;
          const std::string photo = i < in.image_paths.size() && !in.image_paths[i].empty()
                                        ? in.image_paths[i] : "photo " + std::to_string(i + 1);
          const std::string name =
              target < static_cast<int>(in.targets.size()) ? TargetName(in.targets[target]) : "?";
          char line[480];
          std::snprintf(line, sizeof(line),
                        "%s: target %d (%s) is found in %s (%zu corners) but %s in %s: it lies "
                        "across post %zu (azimuth %.0f deg), which hides it there; reshoot it "
                        "turned %.0f deg or more away from the post",
                        photo.c_str(), target, name.c_str(), RingName(found + 1), az.size(),
                        other == 0 ? "lost" : "mostly lost", RingName(2 - found), k + 1,
                        rig.mount.azimuths[k] * 180 / M_PI, std::ceil(turn));
          lines.push_back(line);
          break;
        }
      }
    }
  }
  const size_t shown = std::min<size_t>(lines.size(), kMaxPostLines);
  out->insert(out->end(), lines.begin(), lines.begin() + static_cast<long>(shown));
  if (lines.size() > shown) {
    out->push_back("and " + std::to_string(lines.size() - shown) +
                   " more boards lost beside a post (the overlays show them)");
  }
}

std::vector<std::string> Advice(const ReportInput& in) {
  std::vector<std::string> out;
  if (!in.result->solve.converged) {
    out.push_back("the final stage did not converge: raise solver.max_iterations in the session "
                  "or start from a model nearer the rig");
  }
  CoverageAdvice(in, &out);
  OutlierAdvice(in, &out);
  for (const auto& u : in.result->uncertainty.unobservable) {
    out.push_back(u.name + " is not determined by this session: " + u.hint);
  }
  ProfileAdvice(*in.result, &out);
  SessionAdvice(in, &out);
  PostAdvice(in, &out);
  return out;
}

}  // namespace omni::report
