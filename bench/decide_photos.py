#!/usr/bin/env python3
"""Issue 49's acceptance of "the photos that would decide": the sigma `omnistereo tolerance`
predicts after its suggested photos, against the sigma reached when those photos are made and
added to the session and the rig is calibrated again (within 30%).

  bench/decide_photos.py BUILD_DIR [--scene demo_scene.yaml] [--truth big_rig_misaligned.yaml]
                         [--seed 21] [--images N] [--width 1280 --height 960] [--noise 0.05]
                         [--checks mirror2.spacing,reflex.dz,...] [--margins 1.6,1.0]
                         [--render RENDERED_DIR] [--out DIR]

Per session: the scene's photos through the truth, calibrated (profile: auto); for each check a
tolerance file whose limit lies `margin` sigma beyond the calibrated value (UNDECIDED at 2 sigma:
the prediction is asked for a sigma of margin / 2 times the present one); `tolerance` prints the
photos (board, range, height, azimuths) and the sigma they would reach; those photos are placed
as printed (the board's centre at the range, height and azimuth, facing the axis) and added to
the session's photos; the rig is calibrated again and `tolerance` run again with the same file.
Printed per check: sigma now (the table's and the predictor's), predicted, reached, their ratio.

Two ways of making the photos:
  fast (default): bench_calibrate's scene mode, exact corners of the truth plus Gaussian corner
     noise (--noise px), lips from the truth: the first-order prediction against a real solve
     with the same kind of data it assumes;
  --render DIR: DIR holds a session rendered by `omnistereo render` (through --truth at
     --width x --height, its images, truth.yaml and a calibrated.yaml from its detections:
     detections.yaml); the suggested photos are rendered through POV-Ray with the scene's camera
     effects (one board each), detected with a session of those boards only, their detections
     appended to DIR's (target indices after the session's), and the session calibrated again
     by `omnistereo calibrate`.
"""
import argparse
import math
import os
import re
import subprocess
import sys
import tempfile

import yaml

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Body-frame and reflex checks (design/rig_body.h), as tolerance_acceptance.py's, and the
# camera-frame axial positions: (part, key in the file, name in the output).
CHECKS = {
    "mirror2.decentre_to_mirror1": ("mirror2", "decentre_to_mirror1"),
    "mirror2.tilt_to_mirror1": ("mirror2", "tilt_to_mirror1"),
    "mirror2.spacing": ("mirror2", "spacing"),
    "camera.decentre_to_axis": ("camera", "decentre_to_axis"),
    "reflex.tilt": ("reflex", "tilt"),
    "reflex.dz": ("reflex", "dz"),
    "mirror1.axial": ("mirror1", "axial"),
    "mirror2.axial": ("mirror2", "axial"),
}
# mirror*.axial (camera frame) cannot share a file with the body-frame keys of the same part.
BODY_PARTS = {"mirror2": ("decentre_to_mirror1", "tilt_to_mirror1", "spacing"),
              "camera": ("decentre_to_axis",)}

LINE = re.compile(r"^\s+(\S+)\s+(-?[0-9.]+) (mm|deg)\s+(\S+)\s+(-?[0-9.]+)\s+(PASS|FAIL|UNDECIDED)")
PHOTOS = re.compile(r"^\s+(\S+): (\d+) photos?: (.*); sigma ([0-9.e+-]+) -> ([0-9.e+-]+) (mm|deg) "
                    r"\(([0-9.e+-]+) (?:mm|deg) decides\)")
GROUP = re.compile(r"a (\d+)x(\d+) (board|Kalibr AprilGrid \(spacing 0.3\)) of ([0-9.]+) mm (?:squares|tags) "
                   r"at ([0-9.]+) m, (\w+) in the band "
                   r"\(its centre (-?[0-9.]+) mm up the axis from the camera\), azimuths? (.*) deg")


def run(cmd, env=None, cwd=None):
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=cwd)
    if r.returncode != 0:
        sys.exit("failed: %s\n%s%s" % (" ".join(cmd), r.stdout[-3000:], r.stderr[-3000:]))
    return r.stdout


def tolerance(omni, model, config):
    """({check: (value, sigma, limit, verdict)} in mm / rad, {check: prediction}, stdout)."""
    out = run([omni, "tolerance", "--model=" + model, "--config=" + config])
    checks, photos = {}, {}
    for line in out.splitlines():
        m = LINE.match(line)
        if m:
            k = math.pi / 180 if m.group(3) == "deg" else 1.0
            sigma = None if m.group(4) == "-" else float(m.group(4)) * k
            checks[m.group(1)] = (float(m.group(2)) * k, sigma, float(m.group(5)) * k, m.group(6))
            continue
        m = PHOTOS.match(line)
        if m:
            k = math.pi / 180 if m.group(6) == "deg" else 1.0
            boards = []
            for part in [x for x in m.group(3).split("; ") if x]:  # "0 photos: ; ...": none helps
                g = GROUP.match(part)
                if not g:
                    sys.exit("cannot read the photos of: %s" % part)
                for item in g.group(8).split(", "):
                    deg, _, count = item.partition(" x")
                    for _ in range(int(count or 1)):
                        boards.append({"rows": int(g.group(1)), "cols": int(g.group(2)),
                                       "grid": g.group(3) != "board",
                                       "square": float(g.group(4)), "range": 1000 * float(g.group(5)),
                                       "height": float(g.group(7)), "azimuth_deg": float(deg)})
            assert len(boards) == int(m.group(2)), line
            photos[m.group(1)] = {"boards": boards, "now": float(m.group(4)) * k,
                                  "after": float(m.group(5)) * k, "needed": float(m.group(7)) * k}
    return checks, photos, out


def write_tolerances(path, limits):
    parts = {}
    for (part, key), v in limits.items():
        parts.setdefault(part, []).append("%s: %.9g" % (key, v))
    with open(path, "w") as f:
        f.write("format: omnistereo-tolerances/1\n")
        for part, items in parts.items():
            f.write("%s: {%s}\n" % (part, ", ".join(items)))
        f.write("confidence_sigmas: 2.0\nsimulate: {samples: 0}\n")


def rotation_vector(r):
    """The angle-axis vector of a 3x3 rotation (list of rows); not near 0 or pi here."""
    angle = math.acos(max(-1.0, min(1.0, (r[0][0] + r[1][1] + r[2][2] - 1) / 2)))
    axis = [r[2][1] - r[1][2], r[0][2] - r[2][0], r[1][0] - r[0][1]]
    n = math.sqrt(sum(a * a for a in axis))
    return [angle * a / n for a in axis]


def placement(board, target):
    """The board's centre at (range, azimuth, height) in C, facing the axis: its x along the
    tangent, y up the axis, z (its back) away from the rig; as design/decide_photos.cc's
    candidates and synthetic/scene.cc's random placements."""
    a = math.radians(board["azimuth_deg"])
    x = [-math.sin(a), math.cos(a), 0.0]
    y = [0.0, 0.0, 1.0]
    z = [math.cos(a), math.sin(a), 0.0]
    r = [[x[i], y[i], z[i]] for i in range(3)]
    centre = [board["range"] * math.cos(a), board["range"] * math.sin(a), board["height"]]
    if board.get("grid"):  # a tag grid's origin: its first tag's corner; n tags span (1.3 n - 0.3) T
        pattern = [(1.3 * board["cols"] - 0.3) / 2 * board["square"],
                   (1.3 * board["rows"] - 0.3) / 2 * board["square"], 0]
    else:
        pattern = [(board["cols"] - 1) / 2 * board["square"], (board["rows"] - 1) / 2 * board["square"], 0]
    t = [centre[i] - sum(r[i][j] * pattern[j] for j in range(3)) for i in range(3)]
    return {"target": target, "rotation": rotation_vector(r), "translation": t}


def board_targets(boards, first):
    """One target per distinct board, indexed from `first`; each board's target index."""
    kinds, index = [], []
    for b in boards:
        key = (b["rows"], b["cols"], b["square"], b.get("grid", False))
        if key not in kinds:
            kinds.append(key)
        index.append(first + kinds.index(key))
    # Tag grids' ids after the session's (which stay below 100 in sample_configs' scenes).
    targets, next_id = [], 100
    for r, c, s, grid in kinds:
        if grid:
            targets.append({"type": "kalibr_aprilgrid", "rows": r, "cols": c, "tag_size": s,
                            "spacing": 0.3, "first_id": next_id})
            next_id += r * c
        else:
            targets.append({"type": "chessboard", "rows": r, "cols": c, "square": s})
    return targets, index


def scene_text(header, targets, images):
    """A scene file: the base scene's header keys (image, render, camera_effects, room, ...),
    the targets and explicit images."""
    scene = {k: v for k, v in header.items() if k not in ("targets", "images", "random")}
    scene["targets"] = targets
    scene["images"] = images
    return "format: omnistereo-scene/1\n" + yaml.safe_dump(
        {k: v for k, v in scene.items() if k != "format"}, default_flow_style=None, sort_keys=False)


def truth_images(truth_path):
    """The rendered (or --no_render) session's placements as a scene's explicit images."""
    truth = yaml.safe_load(open(truth_path))
    images = []
    for im in truth["images"]:
        images.append({"name": os.path.splitext(im["file"])[0],
                       "placements": [{"target": p["target"], "rotation": p["rotation"],
                                       "translation": p["translation"]} for p in im["placements"]]})
    return truth["targets"], images


def fast_calibrate(bench, scene, truth, noise, model_out, log):
    env = dict(os.environ, OMNI_MODEL_OUT=model_out, OMNI_PROFILE="auto")
    open(log, "w").write(run([bench, scene, truth, str(noise)], env))


def limits_for(check, calibrated, margin):
    value, sigma = calibrated[check][0], calibrated[check][1]
    return {CHECKS[check]: value + margin * sigma}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--scene", default="demo_scene.yaml")
    ap.add_argument("--truth", default="big_rig_misaligned.yaml")
    ap.add_argument("--seed", default=None, help="the scene's random seed (default: the file's)")
    ap.add_argument("--images", type=int, default=None, help="the scene's random image count")
    ap.add_argument("--width", type=int, default=None)
    ap.add_argument("--height", type=int, default=None)
    ap.add_argument("--noise", type=float, default=0.05)
    ap.add_argument("--checks", default="mirror2.spacing,mirror2.tilt_to_mirror1,reflex.tilt,reflex.dz,"
                                        "camera.decentre_to_axis,mirror1.axial")
    ap.add_argument("--margins", default="1.6,1.0", help="limits at value + margin sigma")
    ap.add_argument("--render", default=None, help="a rendered, detected and calibrated session")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--max_photos", type=int, default=0,
                    help="per check, the first margin whose suggestion has at most this many photos "
                         "(renders are slow)")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    omni = os.path.join(args.build, "apps", "omnistereo")
    bench = os.path.join(args.build, "bench", "bench_calibrate")
    out = args.out or tempfile.mkdtemp(prefix="decide_photos_")
    os.makedirs(out, exist_ok=True)
    truth = os.path.join(SOURCE, "sample_configs", args.truth)
    text = open(os.path.join(SOURCE, "sample_configs", args.scene)).read()
    if args.seed:
        text = re.sub(r"^  seed: \d+", "  seed: %s" % args.seed, text, flags=re.M)
    if args.images:
        text = re.sub(r"^  images: \d+", "  images: %d" % args.images, text, flags=re.M)
    if args.width:
        text = re.sub(r"^image: \{width: \d+, height: \d+\}",
                      "image: {width: %d, height: %d}" % (args.width, args.height), text, flags=re.M)
    base_scene = os.path.join(out, "base_scene.yaml")
    open(base_scene, "w").write(text)
    header = yaml.safe_load(text)

    if args.render:
        base_dir = args.render
        base_model = os.path.join(base_dir, "calibrated.yaml")
    else:
        base_dir = os.path.join(out, "base")
        run([omni, "render", "--no_render", "--model=" + truth, "--scene=" + base_scene,
             "--out=" + base_dir])
        base_model = os.path.join(out, "base_calibrated.yaml")
        fast_calibrate(bench, base_scene, truth, args.noise, base_model, os.path.join(out, "base.txt"))
    targets, images = truth_images(os.path.join(base_dir, "truth.yaml"))

    checks = args.checks.split(",")
    rows = []
    done_checks = set()
    for check in checks:
        # One check per file: a part's camera-frame and body-frame keys cannot share one
        # (tolerance_file.h).
        probe = os.path.join(out, "probe_%s.yaml" % check.replace(".", "_"))
        write_tolerances(probe, {CHECKS[check]: 1e6})
        calibrated, _, _ = tolerance(omni, base_model, probe)
        if check not in calibrated or calibrated[check][1] is None:
            print("%s: no sigma in the calibrated model, skipped" % check)
            continue
        for margin in [float(m) for m in args.margins.split(",")]:
            if check in done_checks:
                break  # --max_photos: one prediction per check, the first margin few enough photos decide
            tag = "%s_m%g" % (check.replace(".", "_"), margin)
            config = os.path.join(out, tag + ".yaml")
            write_tolerances(config, limits_for(check, calibrated, margin))
            before, photos, text = tolerance(omni, base_model, config)
            open(os.path.join(out, tag + "_before.txt"), "w").write(text)
            if before[check][3] != "UNDECIDED" or check not in photos:
                print("%s margin %g: %s, no photos suggested" % (check, margin, before[check][3]))
                continue
            p = photos[check]
            if not p["boards"]:
                print("%s margin %g: no photo lowers the sigma" % (check, margin))
                continue
            if args.max_photos and len(p["boards"]) > args.max_photos:
                print("%s margin %g: %d photos suggested, more than --max_photos" % (check, margin, len(p["boards"])))
                continue
            new_targets, index = board_targets(p["boards"], len(targets))
            new_images = [{"name": "extra%02d" % (i + 1), "placements": [placement(b, index[i])]}
                          for i, b in enumerate(p["boards"])]
            model = os.path.join(out, tag + "_calibrated.yaml")
            if args.render:
                render_and_calibrate(omni, header, base_dir, targets, new_targets, new_images,
                                     truth, os.path.join(out, tag), model, args.jobs)
            else:
                scene = os.path.join(out, tag + "_scene.yaml")
                open(scene, "w").write(scene_text(header, targets + new_targets, images + new_images))
                fast_calibrate(bench, scene, truth, args.noise, model, os.path.join(out, tag + ".txt"))
            after, _, text = tolerance(omni, model, config)
            open(os.path.join(out, tag + "_after.txt"), "w").write(text)
            reached = after[check][1]
            ratio = reached / p["after"] if p["after"] > 0 else float("nan")
            rows.append((check, margin, before[check][1], p["now"], p["after"], reached, ratio,
                         len(p["boards"]), before[check][3], after[check][3]))
            if args.max_photos:
                done_checks.add(check)
            print("%-28s margin %.1f: sigma %.4g (predictor %.4g) -> predicted %.4g with %2d photos, "
                  "reached %.4g: ratio %.2f (%s -> %s)" % (check, margin, before[check][1], p["now"],
                                                          p["after"], len(p["boards"]), reached,
                                                          ratio, before[check][3], after[check][3]))
            sys.stdout.flush()
    if rows:
        ratios = [r[6] for r in rows]
        print("\n%d predictions: reached / predicted %.2f..%.2f, %d within 30%%" % (
            len(rows), min(ratios), max(ratios), sum(abs(r - 1) <= 0.3 for r in ratios)))


def render_and_calibrate(omni, header, base_dir, targets, new_targets, new_images, truth, work,
                         model_out, jobs):
    """Renders the new photos (their boards only), detects them, appends their detections to the
    base session's and calibrates the whole again."""
    os.makedirs(work, exist_ok=True)
    scene = os.path.join(work, "scene.yaml")
    # The new boards alone, indexed from 0 in their own session.
    first = len(targets)
    local = [{"name": im["name"], "placements": [dict(p, target=p["target"] - first)
                                                  for p in im["placements"]]} for im in new_images]
    open(scene, "w").write(scene_text(header, new_targets, local))
    render_dir = os.path.join(work, "render")
    run([omni, "render", "--model=" + truth, "--scene=" + scene, "--out=" + render_dir,
         "--jobs=%d" % jobs])
    # Detect from the base session's starting model (as the user's session would).
    base_session = yaml.safe_load(open(os.path.join(base_dir, "session.yaml")))
    session = yaml.safe_load(open(os.path.join(render_dir, "session.yaml")))
    session["model"] = os.path.join(os.path.abspath(base_dir), base_session["model"])
    open(os.path.join(render_dir, "session.yaml"), "w").write(yaml.safe_dump(session, sort_keys=False))
    detections = os.path.join(work, "detections.yaml")
    run([omni, "detect", "--session=" + os.path.join(render_dir, "session.yaml"), "--out=" + detections])
    # The whole session: the base images and targets, then the new ones.
    merged = yaml.safe_load(open(os.path.join(base_dir, "detections.yaml")))
    extra = yaml.safe_load(open(detections))
    for im in extra["images"]:
        im["file"] = os.path.join(os.path.abspath(render_dir), os.path.basename(im["file"]))
        # Rows [target, corner id, mirror, u, v]: the new boards' indices after the session's.
        im["corners"] = [[row[0] + first] + row[1:] for row in im.get("corners") or []]
    merged["images"] += extra["images"]
    whole = dict(base_session)
    whole["model"] = os.path.join(os.path.abspath(base_dir), base_session["model"])
    whole["images"] = [os.path.join(os.path.abspath(base_dir), f) for f in base_session["images"]] + \
        [im["file"] for im in extra["images"]]
    whole["targets"] = base_session["targets"] + new_targets
    session_path = os.path.join(work, "session.yaml")
    open(session_path, "w").write(yaml.safe_dump(whole, sort_keys=False))
    merged_path = os.path.join(work, "merged_detections.yaml")
    open(merged_path, "w").write(yaml.safe_dump(merged, sort_keys=False))
    run([omni, "calibrate", "--session=" + session_path, "--detections=" + merged_path,
         "--out=" + model_out])


if __name__ == "__main__":
    main()
