#!/usr/bin/env python3
"""The omnistereo Python module in a few lines (build: PYTHONPATH=build/python; installed:
`cmake --install build` puts it where Debian's python3 finds it).

    python3 python_module.py calibrated.yaml

Projects a ring of points 2 m away into both rings, back-projects the pixels, triangulates the
pairs with their covariance, and prints what the calibration says of itself.
"""
import sys

import numpy as np

import omnistereo

model = omnistereo.Model(sys.argv[1])
print(f"{model.path}: {model.kind} model, {model.width}x{model.height}")

# Points at 2 m all around the rig, 0.2 m above the camera (mm, camera frame C).
azimuth = np.radians(np.arange(0, 360, 10))
points = np.stack([2000 * np.cos(azimuth), 2000 * np.sin(azimuth), np.full_like(azimuth, 200)], 1)
outer = model.project(points, 1)  # (N, 2) pixels via mirror 1; NaN where not seen
inner = model.project(points, 2)
seen = ~np.isnan(outer[:, 0]) & ~np.isnan(inner[:, 0])
print(f"{seen.sum()} of {len(points)} points are seen in both rings")

mirror, origin, direction = model.unproject(outer[seen])
print(f"their outer-ring pixels back-project via mirror {set(mirror.tolist())}")

result = model.triangulate(outer[seen], inner[seen], sigma_px=0.1, frame="cam")
error = np.linalg.norm(result["points"] - points[seen], axis=1)
sigma = np.sqrt(np.trace(result["covariance"], axis1=1, axis2=2))
print(f"triangulated back to within {error.max():.2e} mm; at 0.1 px noise each point's "
      f"sigma would be {np.median(sigma):.1f} mm")

calibration = model.calibration
if calibration is None:
    print("no calibration: section (an uncalibrated model)")
else:
    for name, value, sigma in list(zip(calibration["parameters"], calibration["values"],
                                       calibration["sigma"]))[:6]:
        print(f"  {name:12s} {value:12.6f} +- {sigma:.6f}")
    print(f"  RMS {calibration['rms_px']:.3f} px over {calibration['n_observations']} corners")
