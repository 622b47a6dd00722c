#!/usr/bin/env python3
"""Triangulate two pixels with an exported ray table and numpy alone (no omnistereo library).

    omnistereo export --model calibrated.yaml --format rays --dtype float64 --out rays.npy
    python3 triangulate_with_rays.py rays.npy U1 V1 U2 V2

(U1, V1) is a pixel of the outer ring (mirror 1), (U2, V2) the same scene point in the inner ring
(mirror 2), both integers (the table holds the rays of pixel centres). Prints the point (mm, in
the table's frame) as the midpoint of the two rays' common perpendicular, and the rays' gap.
"""
import sys

import numpy as np

rays = np.load(sys.argv[1])            # (2, H, W, 6): [ring][v][u][ox, oy, oz, dx, dy, dz]
u1, v1, u2, v2 = (int(a) for a in sys.argv[2:6])
o1, d1 = rays[0, v1, u1, :3], rays[0, v1, u1, 3:]
o2, d2 = rays[1, v2, u2, :3], rays[1, v2, u2, 3:]
if np.isnan(o1[0]) or np.isnan(o2[0]):
    sys.exit("a pixel does not see its ring (NaN in the table)")
# Closest points o1 + s d1 and o2 + t d2: w + s d1 - t d2 is normal to both directions.
w = o1 - o2
a, b, c, d, e = d1 @ d1, d1 @ d2, d2 @ d2, d1 @ w, d2 @ w
s = (b * e - c * d) / (a * c - b * b)
t = (a * e - b * d) / (a * c - b * b)
p1, p2 = o1 + s * d1, o2 + t * d2
point = (p1 + p2) / 2
print(f"point {point[0]:.3f} {point[1]:.3f} {point[2]:.3f} mm, "
      f"rays {np.linalg.norm(p1 - p2):.3f} mm apart")
