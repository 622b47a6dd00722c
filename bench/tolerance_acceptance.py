#!/usr/bin/env python3
"""Issue 49's acceptance of `omnistereo tolerance`: verdicts on sessions not tuned on.

For each session (a scene file with a fresh random seed, a truth model, a corner noise) the fast
path calibrates (bench_calibrate's scene mode: exact corners of the truth plus Gaussian noise,
lips from the truth; no renders), then `omnistereo tolerance` judges the calibrated model
against tolerance files made from the truth: for every check, one limit the truth passes
(truth + k sigma) and one it fails (truth - k sigma, where that is >= 0), sigma the calibrated
model's own for that check. Body-frame keys (design/rig_body.h: the parts against mirror 1's
axis), the reflex in mirror 1's body, and the profiles' peak-to-valley where the truth has one.
A verdict is right (PASS on the pass file, FAIL on the fail file), wrong (the other), or
UNDECIDED; the verdicts are at the tolerance file's confidence_sigmas (2).

  bench/tolerance_acceptance.py BUILD_DIR [--k 2,3,4] [--profile auto] [--seeds 101,202]
                                [--sessions all|small] [--out DIR]

BUILD_DIR holds apps/omnistereo and bench/bench_calibrate. Prints one line per check and session and
the totals per k (right / wrong / undecided, decided %), with the checks whose model carries no
sigma (a profile held as the conic) counted apart.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# (name, scene file, truth model, corner noise px): 1.2 and 5 MP shapes, with and without the
# prototype's posts and the machined profiles.
SESSIONS = [
    ("1.2MP", "realistic_scene.yaml", "big_rig_misaligned.yaml", 0.05),
    ("1.2MP machined", "realistic_scene.yaml", "big_rig_machined.yaml", 0.05),
    ("1.2MP posts", "realistic_scene.yaml", "big_rig_prototype.yaml", 0.05),
    ("1.2MP posts machined", "realistic_scene.yaml", "PROTOTYPE_MACHINED", 0.05),
    ("5MP posts", "prototype_scene.yaml", "big_rig_prototype.yaml", 0.1),
    ("5MP posts machined", "prototype_scene.yaml", "PROTOTYPE_MACHINED", 0.1),
    ("5MP", "prototype_scene.yaml", "big_rig_misaligned.yaml", 0.1),
]

# The checks: key in the tolerance file (part, key), the check's name in tolerance's output.
CHECKS = [
    ("mirror2", "decentre_to_mirror1", "mirror2.decentre_to_mirror1"),
    ("mirror2", "tilt_to_mirror1", "mirror2.tilt_to_mirror1"),
    ("mirror2", "spacing", "mirror2.spacing"),
    ("camera", "decentre_to_axis", "camera.decentre_to_axis"),
    ("camera", "tilt_to_axis", "camera.tilt_to_axis"),
    ("reflex", "tilt", "reflex.tilt"),
    ("reflex", "dz", "reflex.dz"),
    ("mirror1", "profile_pv", "mirror1.profile"),
    ("mirror2", "profile_pv", "mirror2.profile"),
]

LINE = re.compile(r"^\s+(\S+)\s+(-?[0-9.]+) (mm|deg)\s+(\S+)\s+(-?[0-9.]+)\s+(PASS|FAIL|UNDECIDED)")


def run(cmd, env=None):
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        sys.exit("failed: %s\n%s%s" % (" ".join(cmd), r.stdout[-2000:], r.stderr[-2000:]))
    return r.stdout


def write_tolerances(path, limits):
    """limits: {(part, key): value in mm or rad}."""
    parts = {}
    for (part, key), v in limits.items():
        parts.setdefault(part, []).append("%s: %.9g" % (key, v))
    with open(path, "w") as f:
        f.write("format: omnistereo-tolerances/1\n")
        for part, items in parts.items():
            f.write("%s: {%s}\n" % (part, ", ".join(items)))
        f.write("confidence_sigmas: 2.0\nsimulate: {samples: 0}\n")


def tolerance(omni, model, config):
    """{check name: (value, sigma or None, limit, verdict)} in mm / rad."""
    out = {}
    for line in run([omni, "tolerance", "--model=" + model, "--config=" + config]).splitlines():
        m = LINE.match(line)
        if not m:
            continue
        k = 3.141592653589793 / 180 if m.group(3) == "deg" else 1.0
        sigma = None if m.group(4) == "-" else float(m.group(4)) * k
        out[m.group(1)] = (float(m.group(2)) * k, sigma, float(m.group(5)) * k, m.group(6))
    return out


def prototype_machined(tmp):
    """The prototype (posts) with big_rig_machined.yaml's profiles on both mirrors."""
    proto = open(os.path.join(SOURCE, "sample_configs", "big_rig_prototype.yaml")).read()
    machined = open(os.path.join(SOURCE, "sample_configs", "big_rig_machined.yaml")).read()
    profiles = re.findall(r"^  profile: \{.*$", machined, re.M)
    assert len(profiles) == 2
    lines = proto.splitlines()
    out, seen = [], 0
    for i, line in enumerate(lines):
        out.append(line)
        if line.startswith("mirror1:") or line.startswith("mirror2:"):
            out.append(profiles[seen])
            seen += 1
    path = os.path.join(tmp, "big_rig_prototype_machined.yaml")
    open(path, "w").write("\n".join(out) + "\n")
    return path


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--k", default="2,3,4", help="limits at truth +- k sigma")
    ap.add_argument("--profile", default="auto")
    ap.add_argument("--seeds", default="101,202")
    ap.add_argument("--sessions", default="all")
    ap.add_argument("--out", default=None, help="keep the models and files here")
    args = ap.parse_args()
    omni = os.path.join(args.build, "apps", "omnistereo")
    bench = os.path.join(args.build, "bench", "bench_calibrate")
    ks = [float(k) for k in args.k.split(",")]
    tmp = args.out or tempfile.mkdtemp(prefix="tolerance_acceptance_")
    os.makedirs(tmp, exist_ok=True)
    sessions = SESSIONS if args.sessions == "all" else SESSIONS[:2]
    totals = {k: [0, 0, 0, 0] for k in ks}  # right, wrong, undecided, no sigma
    per_check = {}
    for name, scene, truth, noise in sessions:
        truth_path = prototype_machined(tmp) if truth == "PROTOTYPE_MACHINED" else \
            os.path.join(SOURCE, "sample_configs", truth)
        for seed in args.seeds.split(","):
            tag = re.sub(r"\W+", "_", "%s_%s" % (name, seed))
            text = open(os.path.join(SOURCE, "sample_configs", scene)).read()
            text = re.sub(r"^  seed: \d+", "  seed: %s" % seed, text, flags=re.M)
            scene_path = os.path.join(tmp, tag + "_scene.yaml")
            open(scene_path, "w").write(text)
            model = os.path.join(tmp, tag + "_calibrated.yaml")
            env = dict(os.environ, OMNI_MODEL_OUT=model, OMNI_PROFILE=args.profile)
            log = run([bench, scene_path, truth_path, str(noise)], env)
            open(os.path.join(tmp, tag + "_calibrate.txt"), "w").write(log)
            # The values: the truth's (no covariance) and the model's sigmas, every check probed.
            probe = os.path.join(tmp, "probe.yaml")
            write_tolerances(probe, {(p, k): 1e6 for p, k, _ in CHECKS})
            true = tolerance(omni, truth_path, probe)
            calibrated = tolerance(omni, model, probe)
            for k in ks:
                passing, failing = {}, {}
                for part, key, check in CHECKS:
                    t, s = true[check][0], calibrated[check][1]
                    if s is None or t <= 0:
                        continue
                    passing[(part, key)] = t + k * s
                    if t - k * s >= 0:
                        failing[(part, key)] = t - k * s
                for limits, want in ((passing, "PASS"), (failing, "FAIL")):
                    path = os.path.join(tmp, "%s_k%g_%s.yaml" % (tag, k, want.lower()))
                    write_tolerances(path, limits)
                    got = tolerance(omni, model, path)
                    for part, key, check in CHECKS:
                        if (part, key) not in limits:
                            continue
                        verdict = got[check][3]
                        i = 0 if verdict == want else 2 if verdict == "UNDECIDED" else 1
                        totals[k][i] += 1
                        per_check.setdefault((k, check), [0, 0, 0])[i] += 1
                        print("k %g %-22s %-28s want %-4s got %-9s value %.5g sigma %.3g truth "
                              "%.5g limit %.5g" % (k, tag, check, want, verdict, got[check][0],
                                                   got[check][1] or 0, true[check][0],
                                                   limits[(part, key)]))
                # Checks no limit could be set for: the model carries no sigma (a held profile).
                for part, key, check in CHECKS:
                    if calibrated[check][1] is None and true[check][0] > 0:
                        totals[k][3] += 1
            sys.stdout.flush()
    print("\nper check (right / wrong / undecided):")
    for (k, check), (r, w, u) in sorted(per_check.items()):
        print("  k %g %-28s %d / %d / %d" % (k, check, r, w, u))
    print("\ntotals (limits at truth +- k sigma; verdicts at 2 sigma):")
    for k in ks:
        r, w, u, n = totals[k]
        print("  k %g: %d right, %d wrong, %d undecided of %d: %.0f%% decided; %d checks without "
              "a sigma (a held profile) not counted" % (k, r, w, u, r + w + u,
                                                          100.0 * (r + w) / max(1, r + w + u), n))


if __name__ == "__main__":
    main()
