#!/usr/bin/env python3
"""The Python module against the command line (issue 20): the same model, the same numbers.

`omnistereo` (the module, from the build's python/ folder) and `omnistereo` (the executable) on
the misaligned rig: projection of points 0.3-8 m around the rig in both rings, back-projection of
a pixel grid, triangulation of pixel pairs (midpoint and reprojection-refined, in C and in mirror
1's body, with covariance) must agree to 1e-9 px / mm; read_detections returns what the file
says; Detector.detect on a POV-Ray render equals `omnistereo detect` on it; bad input raises
ValueError naming the file or argument.

usage: module_test.py OMNISTEREO_EXE MODEL FORMATS_DIR SCENE TMP_DIR   (PYTHONPATH: build/python)
"""
import csv
import os
import subprocess
import sys

import numpy as np

import omnistereo as om

EXE, MODEL, FORMATS, SCENE, TMP = sys.argv[1:6]


def run(*args):
    p = subprocess.run([EXE, *args], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"omnistereo {' '.join(args)}: exit {p.returncode}\n{p.stdout}{p.stderr}")
    return p


def read_csv(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    numeric = [k for k in rows[0] if k not in ("image", "file")]
    return {k: np.array([float(r[k]) for r in rows]) for k in numeric}


def same(a, b, tol, what):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, (what, a.shape, b.shape)
    assert np.array_equal(np.isnan(a), np.isnan(b)), f"{what}: NaN in different places"
    d = np.nanmax(np.abs(a - b)) if np.any(~np.isnan(a)) else 0.0
    assert d <= tol, f"{what}: differ by {d:.3e} (limit {tol})"
    print(f"{what}: max difference {d:.1e}")


def main():
    os.makedirs(TMP, exist_ok=True)
    model = om.Model(MODEL)
    assert (model.width, model.height, model.kind) == (1280, 960, "noncentral")
    assert model.calibration is None

    # Projection: points at 0.3-8 m, all azimuths, heights around the stereo band.
    rng = np.random.default_rng(3)
    n = 3000
    r = np.exp(rng.uniform(np.log(300), np.log(8000), n))
    az = rng.uniform(0, 2 * np.pi, n)
    pts = np.stack([r * np.cos(az), r * np.sin(az), rng.uniform(-0.4, 0.6, n) * r], axis=1)
    np.savetxt(os.path.join(TMP, "points.csv"), pts, delimiter=",", header="x_mm,y_mm,z_mm",
               comments="", fmt="%.17g")
    run("project", f"--model={MODEL}", f"--points={TMP}/points.csv", f"--out={TMP}/pixels.csv")
    cli = read_csv(os.path.join(TMP, "pixels.csv"))
    px1, px2 = model.project(pts, 1), model.project(pts, 2)
    same(px1, np.stack([cli["u1"], cli["v1"]], axis=1), 1e-9, "project via mirror 1 (px)")
    same(px2, np.stack([cli["u2"], cli["v2"]], axis=1), 1e-9, "project via mirror 2 (px)")
    both = np.isfinite(px1[:, 0]) & np.isfinite(px2[:, 0])
    assert both.sum() > 500, both.sum()

    # Back-projection of a pixel grid.
    uu, vv = np.meshgrid(np.arange(0, 1280, 7.5), np.arange(0, 960, 7.5))
    pix = np.stack([uu.ravel(), vv.ravel()], axis=1)
    np.savetxt(os.path.join(TMP, "grid.csv"), pix, delimiter=",", header="u,v", comments="",
               fmt="%.17g")
    run("unproject", f"--model={MODEL}", f"--pixels={TMP}/grid.csv", f"--out={TMP}/rays.csv")
    cli = read_csv(os.path.join(TMP, "rays.csv"))
    mirror, origin, direction = model.unproject(pix)
    valid = cli["valid"] == 1
    assert np.array_equal(mirror != 0, valid)
    assert np.array_equal(mirror[valid], cli["mirror"][valid].astype(int))
    same(origin[valid], np.stack([cli[k] for k in ("ox", "oy", "oz")], 1)[valid], 1e-9,
         "unproject origin (mm)")
    same(direction[valid], np.stack([cli[k] for k in ("dx", "dy", "dz")], 1)[valid], 1e-9,
         "unproject direction")

    # Triangulation of the pairs of points both rings see.
    p1, p2 = px1[both], px2[both]
    det = os.path.join(TMP, "pairs.yaml")
    with open(det, "w") as f:
        f.write("format: omnistereo-detections/1\nimages:\n  - file: none.png\n"
                "    width: 1280\n    height: 960\n    corners:\n")
        for k in range(len(p1)):
            f.write(f"      - [0, {k}, 1, {p1[k, 0]!r}, {p1[k, 1]!r}]\n")
            f.write(f"      - [0, {k}, 2, {p2[k, 0]!r}, {p2[k, 1]!r}]\n")
    for method in ("midpoint", "reprojection"):
        for frame in ("cam", "mirror1"):
            out = os.path.join(TMP, f"tri_{method}_{frame}.csv")
            run("triangulate", f"--model={MODEL}", f"--detections={det}", f"--out={out}",
                f"--method={method}", f"--frame={frame}", "--sigma_px=0.5",
                "--sigma_px_ring2=0.8")
            cli = read_csv(out)
            order = np.argsort(cli["id"])
            mine = model.triangulate(p1, p2, method=method, frame=frame, sigma_px=0.5,
                                     sigma_px_ring2=0.8)
            ok = np.isfinite(mine["points"][:, 0])
            assert ok.sum() == len(order), (ok.sum(), len(order))
            ids = cli["id"][order].astype(int)
            assert np.array_equal(np.nonzero(ok)[0], ids)
            same(mine["points"][ok], np.stack([cli[k][order] for k in ("x_mm", "y_mm", "z_mm")], 1),
                 1e-9, f"triangulate {method} in {frame} (mm)")
            cov = mine["covariance"][ok]
            for key, (i, j) in {"cov_xx": (0, 0), "cov_xy": (0, 1), "cov_xz": (0, 2),
                                "cov_yy": (1, 1), "cov_yz": (1, 2), "cov_zz": (2, 2)}.items():
                ref = cli[key][order]
                same(cov[:, i, j] / np.abs(ref).max(), ref / np.abs(ref).max(), 1e-9,
                     f"  {key} (relative)")

    # Files: a calibrated model's calibration, a detections file.
    cal = om.Model(os.path.join(FORMATS, "calibrated_big_rig.yaml")).calibration
    assert cal is not None and len(cal["parameters"]) == len(cal["values"]) == len(cal["sigma"])
    assert cal["covariance"].shape == (len(cal["parameters"]),) * 2
    assert np.allclose(np.sqrt(np.diag(cal["covariance"])), cal["sigma"], rtol=1e-6)
    assert cal["images"] == 24 and cal["n_observations"] > 2000, cal
    dets = om.read_detections(os.path.join(FORMATS, "detections_example.yaml"))
    first = dets["images"][0]
    assert first["file"] == "images/0001.png" and (first["width"], first["height"]) == (1280, 960)
    assert np.allclose(first["corners"][0], [0, 12, 1, 523.112, 301.887])
    assert first["lips"][0]["mirror"] == 1 and first["lips"][0]["points"].shape[1] == 2

    # Detection on a render equals the command's.
    run("render", f"--model={MODEL}", f"--scene={SCENE}", f"--out={TMP}/render")
    session = os.path.join(TMP, "render", "session.yaml")
    run("detect", f"--session={session}", f"--out={TMP}/det.yaml")
    cli = om.read_detections(os.path.join(TMP, "det.yaml"))
    detector = om.Detector(session)
    assert detector.guide == ""
    mine = detector.detect()  # guided by the lips first, as the command is
    assert detector.guide.startswith("detection guided by"), detector.guide
    assert len(mine["images"]) == len(cli["images"]) == 1
    a, b = mine["images"][0]["corners"], cli["images"][0]["corners"]
    assert len(a) > 50, len(a)
    same(a, b, 1e-9, f"detect: {len(a)} corners")
    assert len(mine["images"][0]["lips"]) == len(cli["images"][0]["lips"])

    # Bad input.
    for call, needle in ((lambda: om.Model(os.path.join(TMP, "missing.yaml")), "missing.yaml"),
                         (lambda: model.project(np.zeros((4, 2)), 1), "points"),
                         (lambda: model.project(np.zeros((4, 3)), 3), "mirror"),
                         (lambda: model.triangulate(p1, p2[:-1]), "same number of rows"),
                         (lambda: model.unproject(pix, frame="world"), "frame")):
        try:
            call()
        except ValueError as e:
            assert needle in str(e), (needle, str(e))
        else:
            sys.exit(f"no ValueError for {needle}")
    print("ok")


if __name__ == "__main__":
    main()
