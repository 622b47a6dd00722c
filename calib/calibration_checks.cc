#include "calib/calibration_checks.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>

#include "calib/projection_uncertainty.h"
#include "io/text_append.h"
#include "model/model_compare.h"
#include "model/rig_parameters.h"

namespace omni::calib {

CornerNoise CornerNoiseAgainstTruth(const CalibrationResult& result,
                                    const Observations& detections, const Truth& truth) {
  std::set<std::tuple<int, int, int, int>> rejected;
  for (const auto& r : result.residuals.rejected) rejected.emplace(r.image, r.target, r.id, r.mirror);
  const auto base = [](const std::string& f) { return f.substr(f.find_last_of('/') + 1); };
  double squared[2] = {0, 0};
  CornerNoise out;
  for (size_t i = 0; i < detections.images.size(); ++i) {
    const TruthImage* image = nullptr;
    for (const auto& t : truth.images) {
      if (base(t.file) == base(detections.images[i].file)) image = &t;
    }
    for (const auto& c : detections.images[i].corners) {
      if (rejected.count({static_cast<int>(i), c.target, c.id, MirrorIndex(c.mirror)})) continue;
      const TrueCornerMatch match = NearestTrueCorner(
          image ? image->corners : std::vector<TruthCorner>{}, c.mirror, c.pixel, HUGE_VAL,
          [&](const TruthCorner& t) { return t.target == c.target && t.id == c.id; });
      if (!match.corner) {
        ++out.unmatched;
        continue;
      }
      squared[MirrorIndex(c.mirror) - 1] += match.distance_px * match.distance_px;
      ++out.count[MirrorIndex(c.mirror) - 1];
    }
  }
  for (int m = 0; m < 2; ++m) {
    if (out.count[m] > 0) out.true_rms_px[m] = std::sqrt(squared[m] / out.count[m]);
  }
  return out;
}

std::string CornerNoiseText(const CalibrationResult& result, const CornerNoise& noise,
                            const std::string& truth_path) {
  std::string out;
  io::AppendFormat(&out, "corner noise (--truth %s): reprojection RMS against the detector's true "
                   "error over the same corners (2-D RMS)\n", truth_path.c_str());
  for (int m = 0; m < 2; ++m) {
    if (noise.count[m] == 0) continue;
    io::AppendFormat(&out, "  ring %d: %.4f px vs %.4f px over %d corners: ratio %.2f\n", m + 1,
                     result.residuals.per_mirror_rms_px[m], noise.true_rms_px[m], noise.count[m],
                     result.residuals.per_mirror_rms_px[m] / noise.true_rms_px[m]);
  }
  if (noise.unmatched > 0) {
    io::AppendFormat(&out, "  (%d detected corners have no true counterpart)\n", noise.unmatched);
  }
  return out;
}

std::string TruthShareText(const CalibrationResult& result, const RigParams& truth) {
  const RigModel true_model(truth), calibrated(result.estimate.rig);
  const ProjectionDifference in_m1 = CompareProjectionsInMirror1(true_model, calibrated, 1000);
  const ProjectionDifference in_cam = CompareProjections(true_model, calibrated, 1000);
  std::string out =
      "against the true model: projection difference at 1 m over the stereo band, RMS (max) per "
      "ring\n";
  io::AppendFormat(&out, "  points in mirror 1's body: ring 1 %.3f (%.3f) px, ring 2 %.3f (%.3f) "
                   "px\n", in_m1.rms_px[0], in_m1.max_px[0], in_m1.rms_px[1], in_m1.max_px[1]);
  io::AppendFormat(&out, "  points in the camera frame: ring 1 %.3f (%.3f) px, ring 2 %.3f (%.3f) "
                   "px\n", in_cam.rms_px[0], in_cam.max_px[0], in_cam.rms_px[1], in_cam.max_px[1]);
  const ProjectionErrorShare share = ShareOfProjectionError(result, truth, 1000);
  io::AppendFormat(&out, "  linearised, points in mirror 1's body: ring 1 %.3f px, ring 2 %.3f px; "
                   "with one group's error alone:", share.total_px[0], share.total_px[1]);
  for (size_t g = 0; g < share.groups.size(); ++g) {
    io::AppendFormat(&out, " %s %.3f / %.3f", share.groups[g].c_str(), share.group_px[g][0],
                     share.group_px[g][1]);
  }
  io::AppendFormat(&out, "\n  parameter error against the covariance: chi^2 %.1f for %d "
                   "parameters\n", share.chi2, share.dof);
  return out;
}

std::string TruthLine(const CalibrationResult& result, const RigParams& truth) {
  double worst = 0;
  std::string worst_name;
  for (size_t i = 0; i < result.estimate.names.size(); ++i) {
    const std::string& name = result.estimate.names[i];
    const RigParameter* p = FindRigParameter(name);
    const bool misalignment = p && (std::string(p->block) == "mirror1_pose" ||
                                    std::string(p->block) == "mirror2_pose" ||
                                    std::string(p->block) == "reflex");
    if (!misalignment || !(result.uncertainty.sigma(i) > 0)) continue;
    const double* true_value = ParameterOf(truth, name);
    const double z = std::abs(result.estimate.values(i) - (true_value ? *true_value : NAN)) /
                     result.uncertainty.sigma(i);
    if (z > worst) worst = z, worst_name = name;
  }
  const RigModel true_model(truth), calibrated(result.estimate.rig);
  const ProjectionDifference m1 = CompareProjectionsInMirror1(true_model, calibrated, 1000);
  const ProjectionDifference cam = CompareProjections(true_model, calibrated, 1000);
  std::string out;
  io::AppendFormat(&out, "worst misalignment |value-truth|/sigma %.2f (%s); projection at 1 m "
                   "RMS: mirror 1's body %.3f / %.3f px, C %.3f / %.3f px (ring 1 / ring 2)\n",
                   worst, worst_name.c_str(), m1.rms_px[0], m1.rms_px[1], cam.rms_px[0],
                   cam.rms_px[1]);
  return out;
}

std::string ValuesText(const CalibrationResult& result) {
  std::ostringstream out;
  out.precision(17);
  for (size_t i = 0; i < result.estimate.names.size(); ++i) {
    out << result.estimate.names[i] << " " << result.estimate.values(i) << " "
        << result.uncertainty.sigma(i) << "\n";
  }
  return out.str();
}

std::string LeftOutText(const CalibrationResult& result, const Observations& detections,
                        const std::vector<TargetSpec>& targets) {
  std::string out;
  char buf[512];
  std::map<int, std::pair<int, std::set<int>>> per_target;  // target -> (count, images)
  for (const auto& r : result.residuals.rejected) {
    std::snprintf(buf, sizeof buf, "left out: image %d (%s) target %d corner %d ring %d at (%.2f, %.2f): %s",
                  r.image, detections.images[r.image].file.c_str(), r.target, r.id, r.mirror,
                  r.pixel.x(), r.pixel.y(), r.reason.c_str());
    out += buf;
    if (r.residual_px > 0) {
      std::snprintf(buf, sizeof buf, " (%.2f px)", r.residual_px);
      out += buf;
    }
    out += "\n";
    auto& [count, images] = per_target[r.target];
    ++count;
    images.insert(r.image);
  }
  if (per_target.empty()) return out;
  std::snprintf(buf, sizeof buf, "left out %zu corner observation(s):", result.residuals.rejected.size());
  out += buf;
  const char* separator = " ";
  for (const auto& [t, entry] : per_target) {
    const std::string name = t >= 0 && t < static_cast<int>(targets.size())
                                 ? TargetName(targets[t])
                                 : std::string("?");
    std::snprintf(buf, sizeof buf, "%starget %d (%s) %d in %zu photo(s)", separator, t,
                  name.c_str(), entry.first, entry.second.size());
    out += buf;
    separator = ", ";
  }
  return out + "\n";
}

std::string DatasetMismatch(const CalibrationInfo& info, const Observations& detections,
                            const std::vector<TargetSpec>& targets) {
  const std::string described = TargetsDescription(targets);
  const int images = static_cast<int>(detections.images.size());
  if ((info.images > 0 && info.images != images) ||
      (!info.targets.empty() && info.targets != described)) {
    return "its calibration: dataset: has " + std::to_string(info.images) + " images of " +
           info.targets + "; these have " + std::to_string(images) + " images of " + described;
  }
  return "";
}

std::string MovedWhenSolvedAgain(const CalibrationInfo& info, const CalibrationResult& result) {
  for (size_t i = 0; i < info.parameters.size() && i < info.sigma.size(); ++i) {
    for (size_t j = 0; j < result.estimate.names.size(); ++j) {
      if (result.estimate.names[j] != info.parameters[i] || !(info.sigma[i] > 0)) continue;
      const double moved = std::abs(result.estimate.values(j) - info.values[i]) / info.sigma[i];
      if (moved > 1.0) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "%s moved %.1f sigma when solved again",
                      info.parameters[i].c_str(), moved);
        return buf;
      }
    }
  }
  return "";
}

}  // namespace omni::calib
