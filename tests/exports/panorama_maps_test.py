#!/usr/bin/env python3
"""The panorama maps export read with numpy alone (issue 20).

A smooth test image (sums of low-frequency sinusoids, 8-bit grey) is unwarped twice: by
`omnistereo panorama` (cv::remap, bilinear with OpenCV's 1/32 px fixed-point weights) and here by
a bilinear remap written in numpy from the exported maps. They must agree to 1.5 grey levels
(the fixed-point weights) wherever both are defined, which shows the maps are the panorama's own.
The row and column tables must be monotonic and span the rings' stereo band, the viewpoints lie on
the cylinder axis, and an unwritable path gives one line and no file.

usage: panorama_maps_test.py OMNISTEREO_EXE MODEL TMP_DIR
"""
import os
import struct
import subprocess
import sys
import zlib

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import omni_cli  # noqa: E402  (tests/omni_cli.py)

EXE, MODEL, TMP = sys.argv[1:4]
run = omni_cli.runner(EXE)


def write_png(path, grey):
    """8-bit grey PNG with zlib only."""
    h, w = grey.shape
    raw = b"".join(b"\0" + grey[r].tobytes() for r in range(h))
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def read_png(path):
    """8-bit grey or BGR/RGB PNG (no interlace) -> grey array, with zlib only."""
    with open(path, "rb") as f:
        data = f.read()
    pos, idat, w, h, ctype = 8, b"", 0, 0, 0
    while pos < len(data):
        n, tag = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if tag == b"IHDR":
            w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
            assert depth == 8, depth
        elif tag == b"IDAT":
            idat += body
        pos += 12 + n
    ch = {0: 1, 2: 3}[ctype]
    raw = zlib.decompress(idat)
    out = np.zeros((h, w * ch), np.uint8)
    stride, prev = w * ch, np.zeros(w * ch, np.int32)
    for r in range(h):
        kind = raw[r * (stride + 1)]
        line = np.frombuffer(raw, np.uint8, stride, r * (stride + 1) + 1).astype(np.int32)
        cur = np.zeros(stride, np.int32)
        for i in range(stride):
            a = cur[i - ch] if i >= ch else 0
            b, c = prev[i], prev[i - ch] if i >= ch else 0
            pred = {0: 0, 1: a, 2: b, 3: (a + b) // 2}.get(kind)
            if kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[i] = (line[i] + pred) & 0xff
        out[r], prev = cur, cur
    return out.reshape(h, w, ch)[..., 0]


def bilinear(image, mx, my):
    valid = (mx >= 0) & (my >= 0) & (mx <= image.shape[1] - 1) & (my <= image.shape[0] - 1)
    x0 = np.clip(np.floor(mx).astype(int), 0, image.shape[1] - 2)
    y0 = np.clip(np.floor(my).astype(int), 0, image.shape[0] - 2)
    fx, fy = mx - x0, my - y0
    im = image.astype(float)
    out = ((1 - fx) * (1 - fy) * im[y0, x0] + fx * (1 - fy) * im[y0, x0 + 1] +
           (1 - fx) * fy * im[y0 + 1, x0] + fx * fy * im[y0 + 1, x0 + 1])
    return out, valid


def main():
    os.makedirs(TMP, exist_ok=True)
    v, u = np.mgrid[0:960, 0:1280].astype(float)
    grey = 128 + 60 * np.sin(u / 37.0) * np.cos(v / 53.0) + 40 * np.sin((u + v) / 91.0)
    write_png(os.path.join(TMP, "image.png"), np.clip(np.rint(grey), 0, 255).astype(np.uint8))
    image = read_png(os.path.join(TMP, "image.png"))

    maps_path = os.path.join(TMP, "maps.npz")
    run("export", f"--model={MODEL}", "--format=panorama_maps", "--panorama_width=640",
        f"--out={maps_path}", "--allow_uncalibrated")
    run("panorama", f"--model={MODEL}", f"--image={TMP}/image.png", "--panorama_width=640",
        f"--out={TMP}/pano")
    maps = np.load(maps_path)
    for ring in (1, 2):
        mx, my = maps[f"ring{ring}_map_x"], maps[f"ring{ring}_map_y"]
        assert mx.dtype == np.float32 and mx.shape[1] == 640, (mx.dtype, mx.shape)
        mine, valid = bilinear(image, mx.astype(float), my.astype(float))
        theirs = read_png(os.path.join(TMP, "pano", f"panorama{ring}.png")).astype(float)
        assert theirs.shape == mx.shape, (theirs.shape, mx.shape)
        # Away from the ring's border (where cv::remap blends with its black border).
        inner = valid.copy()
        inner[1:-1, 1:-1] &= valid[:-2, 1:-1] & valid[2:, 1:-1] & valid[1:-1, :-2] & valid[1:-1, 2:]
        diff = np.abs(mine - theirs)[inner]
        print(f"ring {ring}: {inner.sum()} panorama pixels, |numpy - panorama| max {diff.max():.2f}, "
              f"mean {diff.mean():.3f} grey levels")
        assert inner.sum() > 0.8 * (mx >= 0).sum(), (inner.sum(), (mx >= 0).sum())
        assert diff.max() <= 1.5, diff.max()
    el, az = maps["elevation_rad"], maps["azimuth_rad"]
    assert el.shape == (maps["ring1_map_x"].shape[0],) and az.shape == (640,)
    assert np.all(np.diff(el) < 0), "elevation falls down the rows"
    assert np.all(np.diff(az) < 0), "azimuth falls along the columns (the paper's order)"
    f = maps["viewpoints_mm"]
    axis = maps["cam_from_cylinder"][:, 2]
    baseline = (f[0] - f[1]) / np.linalg.norm(f[0] - f[1])
    assert np.allclose(baseline, axis, atol=1e-12), (baseline, axis)
    # An unwritable path: one line naming it, no file.
    p = run("export", f"--model={MODEL}", "--format=panorama_maps",
            f"--out={TMP}/no/such/dir/maps.npz", "--allow_uncalibrated", expect=1)
    assert p.stderr.count("\n") == 1 and "no/such/dir" in p.stderr, p.stderr
    assert not os.path.exists(os.path.join(TMP, "no"))
    print("ok")


if __name__ == "__main__":
    main()
