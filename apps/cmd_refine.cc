// `omnistereo refine --model M --images I[,I...] --out refined.yaml [--estimate groups]
// [--truth_model T]`: target-free refinement of what moved since the calibration, from photos of
// any textured scene (health/refine.h). Prints the check before, the parameters
// refined (before, after, change, sigma) and those the photos cannot determine (held, with what
// would determine them), and the check after; writes the refined model (atomically). With
// --truth_model (synthetic photos) also the truth column and the projection difference from the
// true rig at 1 m in mirror 1's body, before and after.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/health_cli.h"
#include "apps/progress.h"
#include "health/drift.h"
#include "health/refine.h"
#include "io/model_file.h"
#include "model/model_compare.h"
#include "model/rig_parameters.h"

DECLARE_string(truth_model);
DEFINE_string(estimate, "auto",
              "refine: the groups whose parameters may be refined, comma separated (camera: fx, "
              "fy, cx, cy; mirror1, mirror2: their poses; reflex: the disc's tilt and offset), or "
              "auto: the group the check names as moved (a single mirror: camera or mirror1, "
              "from its rim)");

namespace omni::apps {
namespace {

std::vector<std::string> GroupsFromFlag() {
  std::vector<std::string> groups;
  if (FLAGS_estimate == "auto") return groups;
  std::stringstream list(FLAGS_estimate);
  std::string g;
  while (std::getline(list, g, ',')) {
    if (g.empty()) continue;
    const std::vector<std::string>& known = health::DriftGroups();
    if (std::find(known.begin(), known.end(), g) == known.end()) {
      std::string among;
      for (const std::string& k : known) among += (among.empty() ? "" : ", ") + k;
      throw io::InputError("--estimate: expected groups among " + among + ", got '" + g + "'");
    }
    groups.push_back(g);
  }
  if (groups.empty()) throw io::InputError("--estimate: expected at least one group");
  return groups;
}

void PrintCheck(const char* when, const health::CheckResult& r) {
  std::printf("check %s: %s, ray gap rms %.3f px, lip rms %.3f px, chi^2 %.1f for %d bins "
              "(p %.3g)\n",
              when, health::VerdictName(r.verdict), r.gap_rms_px, r.lip_rms_px, r.chi2, r.dof,
              r.p_value);
}

}  // namespace

int RunRefine() {
  const RigParams stored = ReadStoredModel("refine");
  if (FLAGS_out.empty()) throw io::InputError("--out: expected the refined model file to write");
  health::RefineOptions options;
  options.groups = GroupsFromFlag();
  std::optional<RigParams> truth;
  if (!FLAGS_truth_model.empty()) truth = io::ReadModelFile(FLAGS_truth_model);
  const std::vector<health::ImageEvidence> evidence = CollectEvidenceFromFlags(stored, "refine");
  ProgressLine progress("refine", 0);
  options.status = [&](const std::string& now) { progress.Status(now); };
  const health::RefineResult r = health::RefineRig(stored, evidence, options);
  progress.Finish();

  PrintCheck("before", r.before);
  if (r.groups.empty()) {
    std::printf("nothing to refine: the stored model still holds (name groups with --estimate to "
                "refine them anyway)\n");
    io::WriteModelFile(FLAGS_out, r.rig);
    std::printf("wrote %s (unchanged)\n", FLAGS_out.c_str());
    return 0;
  }
  std::string groups;
  for (const std::string& g : r.groups) groups += (groups.empty() ? "" : ", ") + g;
  std::printf("refining %s%s\n", groups.c_str(),
              FLAGS_estimate == "auto" ? " (named by the check)" : "");
  if (stored.Paths() < 2) {
    std::printf("  from the mirror's rim alone, which cannot tell a move of the camera from one of "
                "the mirror: either group takes up the rim's move (--estimate camera or mirror1); "
                "recalibrate from photos of the target to tell them apart\n");
  }
  std::printf("refined %zu parameters from %zu image(s) in %.1f s (%d iterations):\n",
              r.refined.size(), evidence.size(), r.seconds, r.iterations);
  std::printf("  %-12s %12s %12s %10s %9s%s\n", "parameter", "stored", "refined", "change",
              "sigma", truth ? "   truth (refined-truth)/sigma" : "");
  for (const health::RefinedParameter& p : r.refined) {
    const RigParameter* rp = FindRigParameter(p.name);
    const double before = DisplayValue(*rp, p.before), after = DisplayValue(*rp, p.after);
    const double sigma = DisplayValue(*rp, p.sigma);
    std::printf("  %-12s %12.5g %12.5g %+10.4g %9.2g %s", p.name.c_str(), before, after,
                after - before, sigma, DisplayUnit(*rp));
    if (truth) {
      const double t = DisplayValue(*rp, *ParameterOf(*truth, p.name));
      std::printf("  %10.5g  %+.2f", t, sigma > 0 ? (after - t) / sigma : 0.0);
    }
    std::printf("\n");
  }
  for (const health::HeldParameter& h : r.held) {
    std::printf("  held (the photos cannot determine it): %s: %s\n", h.name.c_str(),
                h.hint.c_str());
  }
  if (r.variance_factor > 1) {
    std::printf("  sigmas scaled by sqrt(%.2f): the bins scatter more than their errors say\n",
                r.variance_factor);
  }
  PrintCheck("after", r.after);
  if (truth) {
    const RigModel true_model(*truth);
    const ProjectionDifference before =
        CompareProjectionsInMirror1(true_model, RigModel(stored), 1000);
    const ProjectionDifference after =
        CompareProjectionsInMirror1(true_model, RigModel(r.rig), 1000);
    if (stored.Paths() < 2) {
      std::printf("projection vs the true rig at 1 m in the mirror's body: %.3f -> %.3f px RMS\n",
                  before.rms_px[0], after.rms_px[0]);
    } else {
      std::printf("projection vs the true rig at 1 m in mirror 1's body: ring 1 %.3f -> %.3f px, "
                  "ring 2 %.3f -> %.3f px RMS\n",
                  before.rms_px[0], after.rms_px[0], before.rms_px[1], after.rms_px[1]);
    }
  }
  io::WriteModelFile(FLAGS_out, r.rig);
  std::printf("wrote %s\n", FLAGS_out.c_str());
  return 0;
}

}  // namespace omni::apps
