#!/usr/bin/env python3
"""The central approximations read back as Kalibr and basalt would read them (issue 20).

`omnistereo export --format kalibr|basalt` fits, per ring, a central camera (unified model with
radtan for Kalibr, double sphere for basalt) to the non-central model. Here the written files are
read with plain parsers (PyYAML, json) and every grid pixel of each ring (u, v multiples of 4, its
ray from the exported float64 ray table) is re-projected with the central models written below
from their published formulas (Mei & Rives 2007 with Kalibr's radtan; Usenko et al. 2018), at
0.25, 1 and 8 m along the ray. The RMS and max per ring must equal what the export reported
(basalt's file carries them at full precision, the printed table at 4 decimals).
On the ideal rig (single viewpoint, no lens distortion) the unified model is exact: its residual
must vanish; on the misaligned rig it must be small but not zero.

usage: central_test.py OMNISTEREO_EXE IDEAL_MODEL MISALIGNED_MODEL TMP_DIR
"""
import json
import os
import re
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import omni_cli  # noqa: E402  (tests/omni_cli.py)
import yaml

EXE, IDEAL, MISALIGNED, TMP = sys.argv[1:5]
run = omni_cli.runner(EXE)
DISTANCES_MM = [250.0, 1000.0, 8000.0]
STEP = 4


def project_omni_radtan(q, dist, p):
    """Kalibr omni (xi, fu, fv, pu, pv) + radtan (k1, k2, r1, r2); p (N, 3) in the camera."""
    xi, fu, fv, pu, pv = q
    k1, k2, r1, r2 = dist
    d = np.linalg.norm(p, axis=1)
    den = p[:, 2] + xi * d
    ok = den > 1e-9 * d
    mx, my = p[:, 0] / den, p[:, 1] / den
    rho2 = mx * mx + my * my
    rad = k1 * rho2 + k2 * rho2 * rho2
    dx = mx * rad + 2 * r1 * mx * my + r2 * (rho2 + 2 * mx * mx)
    dy = my * rad + 2 * r2 * mx * my + r1 * (rho2 + 2 * my * my)
    return np.stack([fu * (mx + dx) + pu, fv * (my + dy) + pv], axis=1), ok


def project_ds(q, p):
    """Double sphere (fx, fy, cx, cy, xi, alpha); p (N, 3) in the camera."""
    fx, fy, cx, cy, xi, alpha = q
    d1 = np.linalg.norm(p, axis=1)
    k = xi * d1 + p[:, 2]
    d2 = np.sqrt(p[:, 0] ** 2 + p[:, 1] ** 2 + k * k)
    den = alpha * d2 + (1 - alpha) * k
    ok = den > 1e-9 * d1
    return np.stack([fx * p[:, 0] / den + cx, fy * p[:, 1] / den + cy], axis=1), ok


def residuals(rays, ring, project, cam_from_rig):
    """RMS and max pixel distance per distance over the ring's grid pixels."""
    r = rays[ring, ::STEP, ::STEP]
    vs, us = np.nonzero(np.isfinite(r[..., 0]))
    pix = np.stack([us * STEP, vs * STEP], axis=1).astype(float)
    o, d = r[vs, us, :3], r[vs, us, 3:]
    out = []
    for dist in DISTANCES_MM:
        x_m = (o + dist * d) / 1000.0
        p = x_m @ cam_from_rig[:3, :3].T + cam_from_rig[:3, 3]
        px, ok = project(p)
        e = np.linalg.norm(px[ok] - pix[ok], axis=1)
        out.append((np.sqrt(np.mean(e * e)), e.max(), len(pix)))
    return out


def printed(stdout):
    """{(ring, distance_m): (rms, max)} from the export's table."""
    table = {}
    for m in re.finditer(r"ring (\d) at ([\d.]+) m: RMS ([\d.]+) px, max ([\d.]+) px", stdout):
        table[(int(m[1]), float(m[2]))] = (float(m[3]), float(m[4]))
    return table


def check_model(model, tag):
    rays_path = os.path.join(TMP, f"{tag}_rays.npy")
    run("export", f"--model={model}", "--format=rays", "--dtype=float64", f"--out={rays_path}",
        "--allow_uncalibrated")
    rays = np.load(rays_path)
    found = {}

    kalibr = os.path.join(TMP, f"{tag}_camchain.yaml")
    out = run("export", f"--model={model}", "--format=kalibr", f"--out={kalibr}",
              "--allow_uncalibrated").stdout
    table = printed(out)
    with open(kalibr) as f:
        chain = yaml.safe_load(f)
    assert set(chain) == {"cam0", "cam1"}, chain.keys()
    for ring in range(2):
        cam = chain[f"cam{ring}"]
        assert cam["camera_model"] == "omni" and cam["distortion_model"] == "radtan"
        assert cam["resolution"] == [rays.shape[2], rays.shape[1]]
        t = np.array(cam["T_cam_imu"])
        if ring == 1:  # cam1 from cam0 agrees with the two poses
            t01 = np.array(cam["T_cn_cnm1"])
            t0 = np.array(chain["cam0"]["T_cam_imu"])
            assert np.allclose(t01 @ t0, t, atol=1e-12), (t01 @ t0, t)
        res = residuals(rays, ring,
                        lambda p: project_omni_radtan(cam["intrinsics"], cam["distortion_coeffs"], p), t)
        for dist, (rms, mx, n) in zip(DISTANCES_MM, res):
            want = table[(ring + 1, dist / 1000)]
            print(f"{tag} kalibr ring {ring + 1} at {dist / 1000:.2f} m: rms {rms:.6f} max {mx:.6f} "
                  f"px ({n} pixels); reported {want}")
            assert abs(rms - want[0]) <= 6e-5 and abs(mx - want[1]) <= 6e-5, (rms, mx, want)
            found[("unified", ring, dist)] = rms

    basalt = os.path.join(TMP, f"{tag}_calib.json")
    out = run("export", f"--model={model}", "--format=basalt", f"--out={basalt}",
              "--allow_uncalibrated").stdout
    with open(basalt) as f:
        calib = json.load(f)
    # Whole or nothing (issue 38): --out naming a folder fails and leaves no residual map.
    folder = os.path.join(TMP, f"{tag}_taken.json")
    os.makedirs(folder, exist_ok=True)
    bad = subprocess.run([EXE, "export", f"--model={model}", "--format=basalt", f"--out={folder}",
                          "--allow_uncalibrated"], capture_output=True, text=True)
    assert bad.returncode != 0, bad.stdout
    assert not os.path.exists(os.path.join(TMP, f"{tag}_taken_residual.png")), "a map was left"
    assert "taken.json" in bad.stderr, bad.stderr
    v = calib["value0"]
    assert len(v["T_imu_cam"]) == 2 and len(v["intrinsics"]) == 2
    # basalt's Calibration reads the IMU noise as 3-vectors (Vec3), positive (issue 38).
    for key in ("accel_noise_std", "gyro_noise_std", "accel_bias_std", "gyro_bias_std"):
        assert isinstance(v[key], list) and len(v[key]) == 3 and all(x > 0 for x in v[key]), key
    for ring in range(2):
        q = v["intrinsics"][ring]
        assert q["camera_type"] == "ds"
        q = q["intrinsics"]
        pose = v["T_imu_cam"][ring]
        x, y, z, w = pose["qx"], pose["qy"], pose["qz"], pose["qw"]
        r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        imu_from_cam = np.eye(4)
        imu_from_cam[:3, :3] = r
        imu_from_cam[:3, 3] = [pose["px"], pose["py"], pose["pz"]]
        params = [q["fx"], q["fy"], q["cx"], q["cy"], q["xi"], q["alpha"]]
        res = residuals(rays, ring, lambda p: project_ds(params, p), np.linalg.inv(imu_from_cam))
        reported = calib["omnistereo"]["residuals"][ring]
        for (rms, mx, n), want in zip(res, reported):
            print(f"{tag} basalt ring {ring + 1} at {want['distance_m']:.2f} m: rms {rms:.6f} "
                  f"max {mx:.6f} px; reported {want['rms_px']:.6f} {want['max_px']:.6f}")
            assert want["pixels"] == n, (want, n)
            assert abs(rms - want["rms_px"]) <= 1e-9 * max(1, rms), (rms, want)
            assert abs(mx - want["max_px"]) <= 1e-9 * max(1, mx), (mx, want)
            found[("ds", ring, want["distance_m"] * 1000)] = rms
    return found


def main():
    os.makedirs(TMP, exist_ok=True)
    ideal = check_model(IDEAL, "ideal")
    for ring in range(2):
        for dist in DISTANCES_MM:
            assert ideal[("unified", ring, dist)] < 0.01, ("unified exact on the ideal rig", ring,
                                                           dist, ideal[("unified", ring, dist)])
    real = check_model(MISALIGNED, "misaligned")
    assert max(real.values()) > 0.01, "a non-central ring fitted exactly?"
    # Bad input: unknown format, wrong suffix; nothing written.
    out = os.path.join(TMP, "x.yaml")
    p = run("export", f"--model={MISALIGNED}", "--format=opencv", f"--out={out}",
            "--allow_uncalibrated", expect=2)
    assert "--format: expected" in p.stderr and not os.path.exists(out), p.stderr
    p = run("export", f"--model={MISALIGNED}", "--format=basalt", f"--out={out}",
            "--allow_uncalibrated", expect=2)
    assert "ending in .json" in p.stderr and not os.path.exists(out), p.stderr
    print("ok")


if __name__ == "__main__":
    main()
