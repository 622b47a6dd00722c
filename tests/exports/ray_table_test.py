#!/usr/bin/env python3
"""The ray table export read with numpy alone (issue 20).

The paper's range experiment (tab:rmse_triangulation_experiment: points at horizontal ranges
0.25, 0.5, 1, 2, 4 and 8 m, all around the rig, in the stereo band): each point is projected into
both rings by `omnistereo project`, its pixels rounded to pixel centres (the table holds the rays
of pixel centres), and the pairs are triangulated twice:
  - by `omnistereo triangulate --method midpoint` from a detections file of those pixels;
  - here, from the exported float64 ray table, by the midpoint of the common perpendicular of the
    two rays [midpoint_on_common_perpendicular], written below from the formula.
They must agree to 1e-6 mm, in C and in mirror 1's body (--frame mirror1). Also: the table's
shape and dtype, unit directions, NaN outside the rings, and an uncalibrated model refused.

usage: ray_table_test.py OMNISTEREO_EXE MODEL TMP_DIR
"""
import csv
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import omni_cli  # noqa: E402  (tests/omni_cli.py)

EXE, MODEL, TMP = sys.argv[1], sys.argv[2], sys.argv[3]
run = omni_cli.runner(EXE)
RANGES_MM = [250, 500, 1000, 2000, 4000, 8000]


def midpoint(o1, d1, o2, d2):
    """Midpoint of the common perpendicular of the rays o1 + s d1, o2 + t d2 (rows)."""
    w = o1 - o2
    a = np.sum(d1 * d1, axis=1)
    b = np.sum(d1 * d2, axis=1)
    c = np.sum(d2 * d2, axis=1)
    d = np.sum(d1 * w, axis=1)
    e = np.sum(d2 * w, axis=1)
    den = a * c - b * b
    s = (b * e - c * d) / den
    t = (a * e - b * d) / den
    return 0.5 * ((o1 + s[:, None] * d1) + (o2 + t[:, None] * d2))


def main():
    os.makedirs(TMP, exist_ok=True)
    # Points: 12 azimuths x 41 heights per range; those both rings see are kept.
    pts = []
    for r in RANGES_MM:
        for az in np.radians(np.arange(0, 360, 30) + 7.0):
            for z in np.linspace(-0.6 * r, 0.6 * r, 41):
                pts.append((r * np.cos(az), r * np.sin(az), z, r))
    pts = np.array(pts)
    points_csv = os.path.join(TMP, "points.csv")
    np.savetxt(points_csv, pts[:, :3], delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    pixels_csv = os.path.join(TMP, "pixels.csv")
    run("project", f"--model={MODEL}", f"--points={points_csv}", f"--out={pixels_csv}")
    with open(pixels_csv) as f:
        rows = list(csv.DictReader(f))
    both = [i for i, row in enumerate(rows) if row["valid1"] == "1" and row["valid2"] == "1"]
    pix = np.array([[float(rows[i][k]) for k in ("u1", "v1", "u2", "v2")] for i in both])
    pix = np.rint(pix)
    ranges = pts[both, 3]
    for r in RANGES_MM:
        n = int(np.sum(ranges == r))
        if n < 10:
            sys.exit(f"only {n} points at {r} mm are seen by both rings")

    # Refused without a calibration (MODEL is a synthetic rig), then exported anyway.
    out = os.path.join(TMP, "rays_c.npy")
    p = run("export", f"--model={MODEL}", "--format=rays", f"--out={out}", expect=2)
    assert "calibration: missing" in p.stderr, p.stderr
    assert not os.path.exists(out)

    for frame in ("cam", "mirror1"):
        run("export", f"--model={MODEL}", "--format=rays", "--dtype=float64", f"--frame={frame}",
            f"--out={os.path.join(TMP, f'rays_{frame}.npy')}", "--allow_uncalibrated")
    # A pixel rounded to its centre may fall off the ring's edge: such pairs are dropped.
    rays = np.load(os.path.join(TMP, "rays_cam.npy"))
    u1, v1, u2, v2 = (pix[:, k].astype(int) for k in range(4))
    keep = np.isfinite(rays[0, v1, u1, 0]) & np.isfinite(rays[1, v2, u2, 0])
    pix, ranges = pix[keep], ranges[keep]
    print(f"{int(np.sum(~keep))} of {len(keep)} pairs dropped: a rounded pixel off its ring")

    # The pairs as one image's corners (target 0, id = index) for `triangulate`.
    det = os.path.join(TMP, "detections.yaml")
    with open(det, "w") as f:
        f.write("format: omnistereo-detections/1\nimages:\n  - file: none.png\n"
                "    width: 1280\n    height: 960\n    corners:\n")
        for k, (u1, v1, u2, v2) in enumerate(pix):
            f.write(f"      - [0, {k}, 1, {u1:.1f}, {v1:.1f}]\n")
            f.write(f"      - [0, {k}, 2, {u2:.1f}, {v2:.1f}]\n")

    worst = 0.0
    for frame in ("cam", "mirror1"):
        rays = np.load(os.path.join(TMP, f"rays_{frame}.npy"))
        assert rays.shape == (2, 960, 1280, 6) and rays.dtype == np.float64, (rays.shape, rays.dtype)
        seen = np.isfinite(rays[..., 0])
        assert not np.any(seen[0] & seen[1]), "a pixel in both rings"
        assert np.all(np.isnan(rays[:, 480, 640])), "the image centre sees a ring"
        norms = np.linalg.norm(rays[..., 3:][seen], axis=1)
        assert np.max(np.abs(norms - 1)) < 1e-12, np.max(np.abs(norms - 1))

        u1, v1, u2, v2 = (pix[:, k].astype(int) for k in range(4))
        r1, r2 = rays[0, v1, u1], rays[1, v2, u2]
        assert np.all(np.isfinite(r1)) and np.all(np.isfinite(r2)), "a pair's pixel has no ray"
        mine = midpoint(r1[:, :3], r1[:, 3:], r2[:, :3], r2[:, 3:])

        out_csv = os.path.join(TMP, f"tri_{frame}.csv")
        run("triangulate", f"--model={MODEL}", f"--detections={det}", f"--out={out_csv}",
            "--method=midpoint", f"--frame={frame}")
        with open(out_csv) as f:
            tri = {int(row["id"]): row for row in csv.DictReader(f)}
        assert len(tri) == len(pix), (len(tri), len(pix))
        cli = np.array([[float(tri[k][c]) for c in ("x_mm", "y_mm", "z_mm")]
                        for k in range(len(pix))])
        diff = np.linalg.norm(mine - cli, axis=1)
        for r in RANGES_MM:
            sel = ranges == r
            print(f"frame {frame}: {r / 1000:.2f} m, {int(np.sum(sel))} points, "
                  f"max |numpy - triangulate| {diff[sel].max():.2e} mm")
        worst = max(worst, diff.max())
    if not worst <= 1e-6:
        sys.exit(f"numpy and triangulate differ by up to {worst:.3e} mm (limit 1e-6 mm)")
    print(f"ok: {len(pix)} pairs, numpy midpoint equals triangulate to {worst:.1e} mm")


if __name__ == "__main__":
    main()
