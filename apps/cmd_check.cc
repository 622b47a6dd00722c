// `omnistereo check --model M --images I[,I...] [--out check.yaml]`: does the stored calibration
// still describe the rig? (health/check.h). Prints the evidence, the statistic with
// its expected distribution, and the verdict; exit code 0 OK, 3 DRIFTED, 4 CANNOT TELL (2: bad
// input). --out writes the same as YAML (omnistereo-check/1).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/health_cli.h"
#include "health/check.h"
#include "health/check_file.h"
#include "health/drift.h"
#include "io/file_util.h"
#include "model/rig_parameters.h"

namespace omni::apps {
namespace {

// A drift coordinate's amount in assembly units: (value, unit).
std::pair<double, const char*> Display(const std::string& name, double value) {
  if (const RigParameter* p = FindRigParameter(name)) {
    return {DisplayValue(*p, value), DisplayUnit(*p)};
  }
  // camera.rx / ry / rz (rad) and camera.tx / ty / tz (mm): the camera's move in its mount.
  const int index = health::DriftCoordinateIndex(name);
  if (index >= 0 && health::DriftCoordinates()[index].mount_rotation) {
    return {value * 180 / M_PI, "deg"};
  }
  return {value, "mm"};
}

std::string GroupLine(const health::GroupFit& fit) {
  std::ostringstream s;
  char head[160];
  std::snprintf(head, sizeof(head), "  %-8s chi^2 %.1f for %d (p %.2g):", fit.group.c_str(),
                fit.chi2, fit.dof, fit.p_value);
  s << head;
  for (size_t k = 0; k < fit.names.size(); ++k) {
    const auto [v, unit] = Display(fit.names[k], fit.amounts[static_cast<int>(k)]);
    const auto [sd, unit2] = Display(fit.names[k], fit.sigma[static_cast<int>(k)]);
    (void)unit2;
    char item[128];
    std::snprintf(item, sizeof(item), " %s %+.3g +- %.2g %s", fit.names[k].c_str(), v, sd, unit);
    s << (k ? "," : "") << item;
  }
  return s.str();
}

}  // namespace

int RunCheck() {
  const RigParams stored = ReadStoredModel("check");
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<health::ImageEvidence> evidence = CollectEvidenceFromFlags(stored, "check");
  const health::CheckResult r = health::CheckRig(stored, evidence);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const bool one_ring = stored.Paths() < 2;
  if (one_ring) {
    // A single mirror: the rim's edge against the calibration photos' (health/check.h).
    std::printf("check: %d image%s, %d points of the mirror's rim (rms %.3f px from the calibration "
                "photos'), %.1f s\n",
                r.n_images, r.n_images == 1 ? "" : "s", r.n_lip_points, r.lip_rms_px, seconds);
    std::printf("  bins: %d of the rim's edge (%d deg of azimuth each) measured from the "
                "calibration photos'",
                r.lip_bins, 360 / health::CheckOptions{}.azimuth_bins);
  } else {
    std::printf("check: %d image%s, %d ring-to-ring matches (ray gap rms %.3f px), %d lip points "
                "(rms %.3f px), %.1f s\n",
                r.n_images, r.n_images == 1 ? "" : "s", r.n_matches, r.gap_rms_px, r.n_lip_points,
                r.lip_rms_px, seconds);
    std::printf("  bins: %d of matches over %d of 24 azimuth sectors, %d of lip edges",
                r.match_bins, r.covered_azimuth_bins, r.lip_bins);
    if (r.referenced_lip_bins > 0) {
      std::printf(" (%d measured from the calibration photos' lips)", r.referenced_lip_bins);
    }
  }
  std::printf("\n");
  if (one_ring && r.rim_scatter_factor > 0) {
    std::printf("  the rim's shift, scale and tilt: chi^2 %.1f for %d (expected %d +- %.0f if the rig "
                "has not moved; its sectors scatter %.2f times as their calibration photos "
                "did%s); p-value %.3g\n",
                r.chi2, r.dof, r.dof, std::sqrt(2.0 * r.dof), std::sqrt(r.rim_scatter_factor),
                r.rim_scatter_factor > 1 ? ", allowed for" : "", r.p_value);
  } else if (r.dof > 0) {
    std::printf("  chi^2 %.1f for %d bins (expected %d +- %.0f if the model still holds%s); "
                "p-value %.3g\n",
                r.chi2, r.dof, r.dof, std::sqrt(2.0 * r.dof),
                r.model_covariance ? ", its covariance allowed for" : "", r.p_value);
  }
  std::printf("verdict: %s: %s\n", health::VerdictName(r.verdict), r.reason.c_str());
  if (r.verdict == health::Verdict::kDrifted) {
    std::printf("groups fitted to the residuals, best first (internal coordinates: drift.h):\n");
    for (const health::GroupFit& g : r.groups) {
      // A single mirror's rim shows five numbers; a group's ten coordinates fitted to them are
      // a degenerate mix (a shift read as a tilt), so only how well each group fits is shown.
      if (one_ring) {
        std::printf("  %-8s chi^2 %.1f for %d (p %.2g)\n", g.group.c_str(), g.chi2, g.dof,
                    g.p_value);
      } else {
        std::printf("%s\n", GroupLine(g).c_str());
      }
    }
    if (!r.runner_up.empty()) {
      std::printf("  %s explains it nearly as well: the photos cannot tell the two apart\n",
                  r.runner_up.c_str());
    }
    if (one_ring) {
      std::printf("next: re-estimate the move from the rim with `omnistereo refine --model %s "
                  "--images ...` (it takes the move up with the group named; to know whether the "
                  "camera or the mirror moved, calibrate again from photos of the target)\n",
                  FLAGS_model.c_str());
    } else {
      std::printf("next: re-estimate what moved from these photos with `omnistereo refine --model "
                  "%s --images ...`, or recalibrate with targets\n",
                  FLAGS_model.c_str());
    }
  } else if (r.verdict == health::Verdict::kCannotTell && r.model_misfit) {
    std::printf("next: check that --model is this rig's calibrated model; if it is, the rig moved "
                "too far for `refine`: calibrate again with targets\n");
  } else if (r.verdict == health::Verdict::kCannotTell && one_ring) {
    const bool has_reference = stored.calibration && !stored.calibration->lip_reference.empty();
    std::printf("next: %s\n",
                has_reference
                    ? "photograph with the mirror's rim in view, nothing held across it"
                    : "calibrate with this version, which records the rim (or score new photos "
                      "of the target: a session of them with `estimate: []` through `calibrate`, "
                      "RMS per photo)");
  } else if (r.verdict == health::Verdict::kCannotTell) {
    std::printf("next: photograph a textured scene (shelves, posters, a patterned floor) that "
                "fills most of the view around the rig\n");
  }
  if (!FLAGS_out.empty()) {
    io::WriteFileAtomically(FLAGS_out, health::CheckResultYaml(r, FLAGS_model));
    std::printf("wrote %s\n", FLAGS_out.c_str());
  }
  switch (r.verdict) {
    case health::Verdict::kOk: return 0;
    case health::Verdict::kDrifted: return 3;
    case health::Verdict::kCannotTell: return 4;
  }
  return 0;
}

}  // namespace omni::apps
