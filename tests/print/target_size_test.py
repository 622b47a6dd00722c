#!/usr/bin/env python3
"""`omnistereo target` files have the size that was asked (issue 23), read back from the files:
the PDF's page (pdfinfo) and its drawing rasterised by poppler (pdftoppm, 600 dpi); the SVG's
page and rectangles parsed as XML; the PNG's pixel size and pHYs dpi. The pattern (the target's
black cells) and the 100 mm scale bar must measure what they should to 0.1 mm. Bad input (a
target too big for the paper, an unknown type, a bad extension) gives one line and no file.

usage: target_size_test.py OMNISTEREO_EXE TMP_DIR
"""
import os
import re
import struct
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import omni_cli  # noqa: E402  (tests/omni_cli.py)

EXE, TMP = sys.argv[1:3]
run = omni_cli.runner(EXE)
PAPERS = {"A4": (210.0, 297.0), "A2": (420.0, 594.0), "letter": (215.9, 279.4)}
FOOTER_MM = 22.0

CASES = [  # flags, paper, expected pattern width x height (mm)
    (["--type=chessboard", "--rows=6", "--cols=8", "--size=20"], "A4", (9 * 20.0, 7 * 20.0)),
    (["--type=apriltag_grid", "--rows=4", "--cols=5", "--size=30", "--spacing=0.3",
      "--first_id=5"], "letter", (5 * 30 + 4 * 9.0, 4 * 30 + 3 * 9.0)),
    (["--type=kalibr_aprilgrid", "--rows=6", "--cols=6", "--size=40", "--spacing=0.3"], "A2",
     (6 * 40 + 7 * 12.0, 6 * 40 + 7 * 12.0)),
]


def extent(mask, mm_per_px):
    """Width and height (mm) of the True pixels' bounding box."""
    rows, cols = np.nonzero(mask)
    return ((cols.max() - cols.min() + 1) * mm_per_px, (rows.max() - rows.min() + 1) * mm_per_px)


def check(what, got, want, tol=0.1):
    print(f"{what}: {got:.3f} mm (asked {want:.3f})")
    assert abs(got - want) <= tol, f"{what}: {got} mm, expected {want} +- {tol}"


def page_of(paper, pattern, page_w):
    """The page as placed: landscape if the printed width is the paper's height."""
    w, h = PAPERS[paper]
    return (w, h) if abs(page_w - w) < 1 else (h, w)


def main():
    os.makedirs(TMP, exist_ok=True)
    for k, (flags, paper, (pw, ph)) in enumerate(CASES):
        base = os.path.join(TMP, f"t{k}")
        out = run("target", *flags, f"--paper={paper}", f"--out={base}.pdf").stdout
        entry = re.search(r"^  - (\{type: .*\})$", out, re.M)
        assert entry, out
        # PDF: page size, then the drawing rasterised at 600 dpi.
        info = run_tool("pdfinfo", f"{base}.pdf")
        m = re.search(r"Page size:\s+([\d.]+) x ([\d.]+) pts", info)
        page_w, page_h = float(m[1]) * 25.4 / 72, float(m[2]) * 25.4 / 72
        want_w, want_h = page_of(paper, (pw, ph), page_w)
        check(f"{flags[0]} PDF page width", page_w, want_w)
        check(f"{flags[0]} PDF page height", page_h, want_h)
        run_tool("pdftoppm", "-r", "600", "-gray", "-singlefile", f"{base}.pdf", base)
        grey = read_pgm(base + ".pgm")
        mm = 25.4 / 600
        footer_px = int(round((page_h - FOOTER_MM) / mm))
        black = grey < 128
        w, h = extent(black[:footer_px], mm)
        check(f"{flags[0]} PDF pattern width", w, pw)
        check(f"{flags[0]} PDF pattern height", h, ph)
        bar_rows = black[int(round((page_h - 6) / mm)) + 3, :]  # a row through the bar
        check(f"{flags[0]} PDF scale bar", (np.nonzero(bar_rows)[0].ptp() + 1) * mm, 100.0)
        assert entry[1] in info_text(f"{base}.pdf"), "the session entry is on the sheet"

        # SVG: the page and the rectangles of the path.
        run("target", *flags, f"--paper={paper}", f"--out={base}.svg")
        root = ET.parse(f"{base}.svg").getroot()
        check("SVG page width", float(root.get("width").rstrip("m")), want_w)
        check("SVG page height", float(root.get("height").rstrip("m")), want_h)
        path = root.find("{http://www.w3.org/2000/svg}path").get("d")
        rects = [tuple(map(float, r)) for r in
                 re.findall(r"M([-\d.e]+) ([-\d.e]+)h([-\d.e]+)v([-\d.e]+)h", path)]
        cells = [r for r in rects if r[1] < want_h - FOOTER_MM]
        x0 = min(r[0] for r in cells); x1 = max(r[0] + r[2] for r in cells)
        y0 = min(r[1] for r in cells); y1 = max(r[1] + r[3] for r in cells)
        check("SVG pattern width", x1 - x0, pw, 1e-6)
        check("SVG pattern height", y1 - y0, ph, 1e-6)
        texts = "".join(t.text for t in root.iter("{http://www.w3.org/2000/svg}text"))
        assert entry[1] in texts, texts

        # PNG: pixel size at the stated dpi, and its pHYs chunk.
        run("target", *flags, f"--paper={paper}", "--dpi=150", f"--out={base}.png")
        with open(f"{base}.png", "rb") as f:
            data = f.read()
        width, height = struct.unpack(">II", data[16:24])
        assert abs(width - want_w / 25.4 * 150) <= 1 and abs(height - want_h / 25.4 * 150) <= 1, \
            (width, height)
        i = data.index(b"pHYs")
        ppm_x, ppm_y, unit = struct.unpack(">IIB", data[i + 4:i + 13])
        assert unit == 1 and abs(ppm_x * 0.0254 - 150) < 0.02 and ppm_x == ppm_y, (ppm_x, unit)
        print(f"PNG {width} x {height} px at {ppm_x * 0.0254:.2f} dpi")

    # Bad input: one line each, nothing written.
    bad = os.path.join(TMP, "bad.pdf")
    for flags, needle in (
            (["--type=kalibr_aprilgrid", "--rows=6", "--cols=6", "--size=88", "--paper=A4"],
             "A4 (210 x 297 mm) holds at most"),
            # The message names the smallest paper that holds the pattern (issue 38).
            (["--type=kalibr_aprilgrid", "--rows=6", "--cols=6", "--size=88", "--paper=A4"],
             "--paper A0 holds it"),
            (["--type=checkerboard", "--rows=6", "--cols=8", "--size=20"], "--type: expected"),
            (["--type=chessboard", "--rows=6", "--cols=8", "--size=20", "--paper=B5"],
             "--paper: expected")):
        p = run("target", *flags, f"--out={bad}", expect=2)
        assert needle in p.stderr and p.stderr.count("\n") == 1, p.stderr
        assert not os.path.exists(bad)
    p = run("target", "--type=chessboard", "--rows=6", "--cols=8", "--size=20",
            f"--out={TMP}/bad.jpg", expect=2)
    assert "ending in .pdf, .svg or .png" in p.stderr, p.stderr
    print("ok")


def run_tool(*args):
    p = subprocess.run(args, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(args)}: exit {p.returncode}\n{p.stderr}")
    return p.stdout


def info_text(pdf):
    return subprocess.run(["pdftotext", pdf, "-"], capture_output=True, text=True).stdout


def read_pgm(path):
    with open(path, "rb") as f:
        data = f.read()
    parts = data.split(maxsplit=4)
    assert parts[0] == b"P5", parts[0]
    w, h, maxval = int(parts[1]), int(parts[2]), int(parts[3])
    return np.frombuffer(parts[4][:w * h], np.uint8).reshape(h, w)


if __name__ == "__main__":
    main()
