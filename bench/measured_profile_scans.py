#!/usr/bin/env python3
"""Profilometer scans of a model's mirror profiles and a starting model that names them.

  measured_profile_scans.py TRUTH.yaml OUT_DIR [accuracy_mm=0.001] [seed=1] [step_mm=0.25]

Writes OUT_DIR/scans/mirror1.csv and mirror2.csv: each mirror's profile of TRUTH.yaml (its
`profile:` map: the Legendre terms and astigmatism of docs/formats/model.md, evaluated here
independently of the C++ code) along three scan lines at 0, 60 and 120 deg, every step_mm from
1 mm inside the profile's r_min (mirror 2: from its hole) to r_sys, with a 3 um piston (the
instrument's zero) and N(0, accuracy^2) noise; and OUT_DIR/start.yaml, the design
(sample_configs/big_rig_ideal.yaml as kind noncentral) whose mirrors name those scans with that
accuracy (`profile_from:`). For bench_calibrate's scene mode (OMNI_START_MODEL=OUT_DIR/start.yaml).
"""
import math
import os
import random
import sys

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))


def legendre(w):
    return [w, 1.5 * w * w - 0.5, (2.5 * w * w - 1.5) * w, (4.375 * w * w - 3.75) * w * w + 0.375]


def sag(profile, r, theta):
    r_min, r_max = profile["r_min"], profile["r_max"]
    w = 2 * (r * r - r_min * r_min) / (r_max * r_max - r_min * r_min) - 1
    p = legendre(w)
    value = sum(profile.get("sag_p%d" % (n + 1), 0.0) * p[n] for n in range(4))
    x, y = r * math.cos(theta), r * math.sin(theta)
    value += (profile.get("sag_cos2", 0.0) * (x * x - y * y) +
              profile.get("sag_sin2", 0.0) * 2 * x * y) / (r_max * r_max)
    return value


def main():
    truth_path, out = sys.argv[1], sys.argv[2]
    accuracy = float(sys.argv[3]) if len(sys.argv) > 3 else 0.001
    rng = random.Random(int(sys.argv[4]) if len(sys.argv) > 4 else 1)
    step = float(sys.argv[5]) if len(sys.argv) > 5 else 0.25
    truth = yaml.safe_load(open(truth_path))
    design = truth["design"]
    os.makedirs(os.path.join(out, "scans"), exist_ok=True)
    for name, r_low in (("mirror1", None), ("mirror2", design["r_cam"])):
        profile = truth[name]["profile"]
        first = max(profile["r_min"] - 1, r_low or 0)
        with open(os.path.join(out, "scans", name + ".csv"), "w") as f:
            f.write("theta_deg,r_mm,sag_mm\n")
            for deg in (0, 60, 120):
                k = 0
                while first + step * k <= design["r_sys"] + 1e-9:
                    r = first + step * k
                    s = sag(profile, r, math.radians(deg)) + 0.003 + rng.gauss(0, accuracy)
                    f.write("%d,%.9f,%.12g\n" % (deg, r, s))
                    k += 1
    text = open(os.path.join(HERE, "..", "sample_configs", "big_rig_ideal.yaml")).read()
    text = text.replace("kind: ideal ", "kind: noncentral ", 1)
    lines = []
    for line in text.splitlines(keepends=True):
        lines.append(line)
        for lip, name in (("  lip: {color: blue", "mirror1"), ("  lip: {color: red", "mirror2")):
            if line.startswith(lip):
                lines.append("  profile_from: scans/%s.csv\n  profile_accuracy_mm: %.9g\n" %
                             (name, accuracy))
    with open(os.path.join(out, "start.yaml"), "w") as f:
        f.write("".join(lines))


if __name__ == "__main__":
    main()
