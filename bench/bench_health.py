#!/usr/bin/env python3
"""Timed, counted run of the in-field health check and the target-free refinement.

usage: /usr/bin/python3 bench/bench_health.py [--out DIR] [--trials N] [--jobs J]
       (from the repository, after the build: uses build/apps/omnistereo)

A calibrated model of the misaligned big rig (the demo's: `omnistereo demo`, run once into
DIR/demo) is the stored model. Natural photos (a textured room, no target; each photo its own
room: room.texture_seed; the realistic camera) are rendered of
  same     the rig unchanged since calibration,
  tilted   mirror 2 tilted by 0.2 deg about its x axis after calibration,
  shifted  mirror 2 decentred by 0.2 mm along y after calibration,
  plain    the unchanged rig in a textureless room,
N of each (plain: N / 4), and every photo is checked on its own (one trial = one photo):
verdict counts, the group named, seconds per check. Then `refine` from the first 5 tilted and
the first 5 shifted photos: the change it finds against the true change (in its sigmas), the
projection difference from the true rig at 1 m in mirror 1's body, and its wall time.
Issue 22's targets: OK >= 95% (same), DRIFTED with mirror 2 named >= 95% (tilted, shifted),
CANNOT TELL (plain); refine within 3 sigma and <= 0.15 px; check <= 2 s per image, refine
<= 30 s for 5 images.
"""
import argparse
import math
import os
import re
import subprocess
import sys
import time

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OM = os.path.join(ROOT, "build", "apps", "omnistereo")
TRUE_RIG = os.path.join(ROOT, "sample_configs", "big_rig_misaligned.yaml")


def run(args, check=True):
    p = subprocess.run([OM] + args, capture_output=True, text=True)
    if check and p.returncode not in (0, 3, 4):
        sys.exit(f"omnistereo {' '.join(args)} failed:\n{p.stderr}")
    return p


def moved_rig(path, key, amount):
    """The true rig with mirror2.cam_from_mirror[key] changed by amount (rad or mm)."""
    with open(TRUE_RIG) as f:
        model = yaml.safe_load(f)
    model["mirror2"]["cam_from_mirror"][key] += amount
    model.pop("derived", None)
    with open(path, "w") as f:
        yaml.safe_dump(model, f)
    return path


def scene(path, names, plain=False):
    room = "{enabled: true, texture: plain}" if plain else \
        "{enabled: true, half_size: 3000, floor: -1200, ceiling: 1800, texture_seed: 7}"
    with open(path, "w") as f:
        f.write("format: omnistereo-scene/1\nimage: {width: 1280, height: 960}\n"
                "render: {antialias: true}\ncamera_effects: realistic\n"
                f"room: {room}\nimages: [{', '.join('{name: %s}' % n for n in names)}]\n")
    return path


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="/tmp/bench_health")
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    stored = os.path.join(a.out, "demo", "calibrated.yaml")
    if not os.path.exists(stored):
        print("calibrating the stored model (omnistereo demo) ...", flush=True)
        run(["demo", "--out", os.path.join(a.out, "demo")])
    rigs = {"same": TRUE_RIG,
            "tilted": moved_rig(os.path.join(a.out, "tilted.yaml"), "rx", math.radians(0.2)),
            "shifted": moved_rig(os.path.join(a.out, "shifted.yaml"), "ty", 0.2)}
    names = [f"t{k:02d}" for k in range(1, a.trials + 1)]
    photos = {}
    for case, rig in list(rigs.items()) + [("plain", TRUE_RIG)]:
        folder = os.path.join(a.out, case)
        n = names if case != "plain" else names[:max(1, a.trials // 4)]
        if not all(os.path.exists(os.path.join(folder, x + ".jpg")) for x in n):
            print(f"rendering {len(n)} photos: {case} ...", flush=True)
            run(["render", "--model", rig, "--scene",
                 scene(os.path.join(a.out, case + "_scene.yaml"), n, case == "plain"),
                 "--out", folder, "--jobs", str(a.jobs)])
        photos[case] = [os.path.join(folder, x + ".jpg") for x in n]

    expected = {"same": "OK", "tilted": "DRIFTED", "shifted": "DRIFTED", "plain": "CANNOT TELL"}
    for case, files in photos.items():
        verdicts, named, seconds, matches = {}, {}, [], []
        for photo in files:
            t0 = time.perf_counter()
            out_yaml = os.path.join(a.out, "check.yaml")
            run(["check", "--model", stored, "--images", photo, "--out", out_yaml])
            seconds.append(time.perf_counter() - t0)
            with open(out_yaml) as f:
                r = yaml.safe_load(f)
            verdicts[r["verdict"]] = verdicts.get(r["verdict"], 0) + 1
            g = r["named_group"] or "-"
            if r["runner_up"]:
                g += "/" + r["runner_up"]
            named[g] = named.get(g, 0) + 1
            matches.append(r["matches"])
        good = verdicts.get(expected[case], 0)
        print(f"check {case:8s}: {good}/{len(files)} {expected[case]} ({verdicts}), named {named}, "
              f"matches {min(matches)}-{max(matches)}, {sum(seconds) / len(seconds):.2f} s per "
              f"photo (max {max(seconds):.2f})", flush=True)

    deg = math.pi / 180
    with open(stored) as f:
        stored_yaml = yaml.safe_load(f)
    for case, key, name, amount in (("tilted", "rx", "mirror2.rx", 0.2 * deg),
                                    ("shifted", "ty", "mirror2.ty", 0.2)):
        refined = os.path.join(a.out, f"refined_{case}.yaml")
        t0 = time.perf_counter()
        p = run(["refine", "--model", stored, "--images", ",".join(photos[case][:5]), "--out",
                 refined, "--truth_model", rigs[case]])
        seconds = time.perf_counter() - t0
        with open(refined) as f:
            r = yaml.safe_load(f)
        before = stored_yaml["mirror2"]["cam_from_mirror"][key]
        after = r["mirror2"]["cam_from_mirror"][key]
        names = r["calibration"]["parameters"]
        sigma = r["calibration"]["sigma"][names.index(name)] if name in names else float("nan")
        proj = re.search(r"projection vs the true rig.*", p.stdout)
        scale = 1 / deg if key.startswith("r") else 1.0
        print(f"refine {case}: {name} change {(after - before) * scale:+.4f} (true "
              f"{amount * scale:+.4f}, sigma {sigma * scale:.4f}: "
              f"{(after - before - amount) / sigma:+.2f} sigma); "
              f"{proj.group(0) if proj else '?'}; {seconds:.1f} s for 5 photos", flush=True)


if __name__ == "__main__":
    main()
