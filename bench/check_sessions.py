#!/usr/bin/env python3
"""`check` on the photos a rig was calibrated on, and on a knocked copy of its model (issue 48).

usage: /usr/bin/python3 bench/check_sessions.py SESSION.yaml DETECTIONS.yaml TRUTH.yaml 'PHOTOS_GLOB'
           [--out DIR] [--name NAME] [--each N]
       (from the repository, after the build: uses build/apps/omnistereo)

Calibrates the session from its detections (its `calibration:` then carries the lip bins of its
photos: health/lip_reference.h), then checks
  own      the calibrated model on its own photos, all together and each alone (the first N),
  knocked  the same model with mirror 2 moved by +0.2 mm along x (mirror2.cam_from_mirror.tx) on
           the same photos, all together and each alone (the first 2),
  truth    the true model (no calibration section: no lip reference) on all photos.
Prints per check: verdict, the group named (/runner-up), chi^2, bins, p-value, matches, ray gap
and lip rms. Issue 48's targets: own OK (all and each, where the photo has texture enough:
CANNOT TELL under 150 matches), knocked DRIFTED naming mirror2.
"""
import argparse
import glob
import os
import subprocess
import sys
import time

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OM = os.path.join(ROOT, "build", "apps", "omnistereo")


def check(model, images, out):
    p = subprocess.run([OM, "check", "--model", model, "--images", images, "--out", out],
                       capture_output=True, text=True)
    if p.returncode not in (0, 3, 4):
        return "FAILED: " + p.stderr.strip()[-300:]
    with open(out) as f:
        r = yaml.safe_load(f)
    group = (r["named_group"] or "") + ("/" + r["runner_up"] if r["runner_up"] else "")
    return (f"{r['verdict']:11s} {group:16s} chi2 {r['chi2']:8.1f} for {r['dof']:3d} "
            f"(p {r['p_value']:7.2g})  matches {r['matches']:5d}  gap {r['gap_rms_px']:.3f} px  "
            f"lip {r['lip_rms_px']:.3f} px")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("session")
    ap.add_argument("detections")
    ap.add_argument("truth")
    ap.add_argument("photos")
    ap.add_argument("--out", default="/tmp/check_sessions")
    ap.add_argument("--name", default="session")
    ap.add_argument("--each", type=int, default=100)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    calibrated = os.path.join(a.out, a.name + ".calibrated.yaml")
    t0 = time.time()
    p = subprocess.run([OM, "calibrate", "--session", a.session, "--detections", a.detections,
                        "--out", calibrated, "--truth_model", a.truth], capture_output=True, text=True)
    with open(os.path.join(a.out, a.name + ".calibrate.log"), "w") as f:
        f.write(p.stdout + p.stderr)
    if p.returncode:
        sys.exit(f"calibrate failed:\n{p.stderr}")
    reference = [l for l in p.stdout.splitlines() if l.startswith("lip reference")]
    print(f"{a.name}: calibrated in {time.time() - t0:.0f} s; {reference[0] if reference else ''}")
    with open(calibrated) as f:
        model = yaml.safe_load(f)
    model["mirror2"]["cam_from_mirror"]["tx"] += 0.2
    model.pop("derived", None)
    knocked = os.path.join(a.out, a.name + ".knocked.yaml")
    with open(knocked, "w") as f:
        yaml.safe_dump(model, f, sort_keys=False)
    photos = sorted(glob.glob(a.photos))
    rows = [("own all", calibrated, a.photos), ("knocked all", knocked, a.photos),
            ("truth all", a.truth, a.photos)]
    rows += [("own " + os.path.basename(x), calibrated, x) for x in photos[:a.each]]
    rows += [("knocked " + os.path.basename(x), knocked, x) for x in photos[:min(2, a.each)]]
    for k, (label, m, images) in enumerate(rows):
        print(f"  {label:22s} " + check(m, images, os.path.join(a.out, f"{a.name}.check{k}.yaml")),
              flush=True)


if __name__ == "__main__":
    main()
