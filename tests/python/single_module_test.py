#!/usr/bin/env python3
"""The Python module on single-mirror cameras (rig: single): the same numbers as the command line.

For each sample single-mirror model (a hyperboloid behind a perspective lens, a paraboloid behind
a telecentric lens, a sphere): projection of points 0.3-5 m around the camera via the mirror equals
`omnistereo project` to 1e-9 px, and via mirror 2 is NaN everywhere (there is none);
back-projection of a pixel grid equals `omnistereo unproject`, and every ray it gives passes
through the point it came from (projected, then back-projected: within 1e-6 mm at 1 m);
`rig` and `lens` say what the file says; triangulate raises ValueError (one view per photo).

usage: single_module_test.py OMNISTEREO_EXE SAMPLE_CONFIGS_DIR TMP_DIR   (PYTHONPATH: build/python)
"""
import csv
import os
import subprocess
import sys

import numpy as np

import omnistereo as om

EXE, CONFIGS, TMP = sys.argv[1:4]


def run(*args):
    p = subprocess.run([EXE, *args], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"omnistereo {' '.join(args)}: exit {p.returncode}\n{p.stdout}{p.stderr}")


def read_csv(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def same(a, b, tol, what):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, (what, a.shape, b.shape)
    assert np.array_equal(np.isnan(a), np.isnan(b)), f"{what}: NaN in different places"
    d = np.nanmax(np.abs(a - b)) if np.any(~np.isnan(a)) else 0.0
    assert d <= tol, f"{what}: differ by {d:.3e} (limit {tol})"
    print(f"{what}: max difference {d:.1e}")


def check(name, lens):
    path = os.path.join(CONFIGS, name)
    out = os.path.join(TMP, name.replace(".yaml", ""))
    os.makedirs(out, exist_ok=True)
    model = om.Model(path)
    assert (model.rig, model.lens) == ("single", lens), (model.rig, model.lens)

    rng = np.random.default_rng(5)
    n = 2000
    r = np.exp(rng.uniform(np.log(300), np.log(5000), n))
    az = rng.uniform(0, 2 * np.pi, n)
    # Heights from well below to a little above the mirror's horizon (C's +z looks up at it).
    pts = np.stack([r * np.cos(az), r * np.sin(az), rng.uniform(-1.2, 0.3, n) * r], axis=1)
    np.savetxt(os.path.join(out, "points.csv"), pts, delimiter=",", header="x_mm,y_mm,z_mm",
               comments="", fmt="%.17g")
    run("project", f"--model={path}", f"--points={out}/points.csv", f"--out={out}/pixels.csv")
    cli = read_csv(os.path.join(out, "pixels.csv"))
    px1 = model.project(pts, 1)
    same(px1, np.stack([cli["u1"], cli["v1"]], axis=1), 1e-9, f"{name}: project (px)")
    seen = np.isfinite(px1[:, 0])
    assert seen.sum() > n // 4, seen.sum()
    assert np.all(np.isnan(model.project(pts, 2))), "mirror 2 of a single rig projects"

    # Each seen point back-projected: its ray passes through it.
    mirror, origin, direction = model.unproject(px1[seen])
    assert np.all(mirror == 1), np.unique(mirror)
    to_point = pts[seen] - origin
    along = np.sum(to_point * direction, axis=1)
    miss = np.linalg.norm(to_point - along[:, None] * direction, axis=1)
    assert np.all(along > 0), "a ray points away from its point"
    worst = np.max(miss / np.linalg.norm(pts[seen], axis=1)) * 1000
    assert worst < 1e-6, f"{name}: a ray misses its point by {worst:.2e} mm at 1 m"
    print(f"{name}: {seen.sum()} rays through their points, worst {worst:.1e} mm at 1 m")

    # A pixel grid against the command line.
    uu, vv = np.meshgrid(np.arange(0, model.width, 9.5), np.arange(0, model.height, 9.5))
    pix = np.stack([uu.ravel(), vv.ravel()], axis=1)
    np.savetxt(os.path.join(out, "grid.csv"), pix, delimiter=",", header="u,v", comments="",
               fmt="%.17g")
    run("unproject", f"--model={path}", f"--pixels={out}/grid.csv", f"--out={out}/rays.csv")
    cli = read_csv(os.path.join(out, "rays.csv"))
    mirror, origin, direction = model.unproject(pix)
    valid = cli["valid"] == 1
    assert np.array_equal(mirror != 0, valid) and np.all(mirror[valid] == 1)
    same(origin[valid], np.stack([cli[k] for k in ("ox", "oy", "oz")], 1)[valid], 1e-9,
         f"{name}: unproject origin (mm)")
    same(direction[valid], np.stack([cli[k] for k in ("dx", "dy", "dz")], 1)[valid], 1e-9,
         f"{name}: unproject direction")

    try:
        model.triangulate(px1[seen][:3], px1[seen][:3])
    except ValueError as e:
        assert "single-mirror" in str(e) and name in str(e), str(e)
    else:
        sys.exit(f"{name}: triangulate did not refuse a single-mirror rig")


def main():
    check("single_hyperbolic.yaml", "perspective")
    check("single_parabolic_telecentric.yaml", "telecentric")
    check("single_spherical.yaml", "perspective")
    assert om.Model(os.path.join(CONFIGS, "big_rig_misaligned.yaml")).rig == "folded"
    print("ok")


if __name__ == "__main__":
    main()
