#!/usr/bin/env python3
"""Timed run of the Python module (target: 1e6 points projected in <= 0.5 s).

usage: PYTHONPATH=build/python /usr/bin/python3 bench/bench_python.py [MODEL]
Projects 1e6 points 0.3-8 m around the rig via each mirror, back-projects 1e6 pixels and
triangulates 1e5 pairs (midpoint, with covariance); best of 3 runs each, wall time.
"""
import sys
import time

import numpy as np

import omnistereo as om

model = om.Model(sys.argv[1] if len(sys.argv) > 1 else "sample_configs/big_rig_misaligned.yaml")
rng = np.random.default_rng(1)
n = 1_000_000
r = np.exp(rng.uniform(np.log(300), np.log(8000), n))
az = rng.uniform(0, 2 * np.pi, n)
points = np.stack([r * np.cos(az), r * np.sin(az), rng.uniform(-0.3, 0.3, n) * r], axis=1)
pixels = np.stack([rng.uniform(0, 1280, n), rng.uniform(0, 960, n)], axis=1)


def best(f, repeats=3):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return min(times), out


for mirror in (1, 2):
    t, px = best(lambda: model.project(points, mirror))
    print(f"project 1e6 points via mirror {mirror}: {t:.3f} s "
          f"({np.isfinite(px[:, 0]).sum()} valid)")
t, (mirror, _, _) = best(lambda: model.unproject(pixels))
print(f"unproject 1e6 pixels: {t:.3f} s ({(mirror != 0).sum()} rays)")
both_pts = points[:200_000]
p1, p2 = model.project(both_pts, 1), model.project(both_pts, 2)
ok = np.isfinite(p1[:, 0]) & np.isfinite(p2[:, 0])
p1, p2 = p1[ok][:100_000], p2[ok][:100_000]
t, _ = best(lambda: model.triangulate(p1, p2))
print(f"triangulate {len(p1)} pairs (midpoint, covariance): {t:.3f} s")
