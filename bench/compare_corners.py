#!/usr/bin/env python3
"""Our detections of one chessboard against reference corners (e.g. OpenCV's
findChessboardCornersSB, written by bench/central_baselines.sh --write_corners), photo by photo:
corners found, the distance of each to the nearest reference corner (mean, max), and wrong ids:
corners whose id disagrees with the one relabelling of the reference grid (180-degree turns,
for a square board also 90) that most of the photo's corners agree with. Reads no pixels.
  bench/compare_corners.py DETECTIONS.yaml REFERENCE.txt [--target T]
REFERENCE: '# ... R x C inner-corner ...' header line, 'photo NAME', then 'ID U V' lines."""
import math
import re
import sys


def read_reference(path):
    photos, rows, cols, current = {}, None, None, None
    for line in open(path):
        m = re.search(r'(\d+) x (\d+) inner-corner', line)
        if m:
            rows, cols = int(m.group(1)), int(m.group(2))
        if line.startswith('photo '):
            current = line.split()[1]
            photos[current] = {}
        elif current and re.match(r'^\d+ ', line):
            i, u, v = line.split()
            photos[current][int(i)] = (float(u), float(v))
    return photos, rows, cols


def read_detections(path, target):
    photos, current = {}, None
    for line in open(path):
        m = re.match(r'\s*- file: "(.*)"', line)
        if m:
            current = m.group(1).split('/')[-1]
            photos[current] = {}
        m = re.match(r'\s*- \[(\d+), (\d+), (\d+), ([-\d.e]+), ([-\d.e]+)\]', line)
        if m and current and int(m.group(1)) == target:
            photos[current][int(m.group(2))] = (float(m.group(4)), float(m.group(5)))
    return photos


def relabellings(rows, cols):
    out = []
    for fr in (0, 1):
        for fc in (0, 1):
            out.append(lambda i, fr=fr, fc=fc: ((rows - 1 - i // cols) if fr else i // cols) * cols +
                       ((cols - 1 - i % cols) if fc else i % cols))
    return out


def main():
    args = sys.argv[1:]
    target = 0
    if '--target' in args:
        k = args.index('--target')
        target = int(args[k + 1])
        del args[k:k + 2]
    ours = read_detections(args[0], target)
    ref, rows, cols = read_reference(args[1])
    total = wrong_total = 0
    all_d = []
    print('photo                 found  mean_px  max_px  wrong_ids')
    for name in sorted(set(ours) | set(ref)):
        mine, theirs = ours.get(name, {}), ref.get(name, {})
        d, near = [], {}
        for i, p in mine.items():
            best = min(theirs.items(), key=lambda kv: math.dist(kv[1], p), default=None)
            if best:
                d.append(math.dist(best[1], p))
                near[i] = best[0]
        wrong = 0
        if near:
            agree = max(sum(f(i) == j for i, j in near.items()) for f in relabellings(rows, cols))
            wrong = len(near) - agree
        total += len(mine)
        wrong_total += wrong
        all_d += d
        print('%-20s %4d/%-3d %7.3f %7.3f %6d' % (name, len(mine), len(theirs),
                                                  sum(d) / len(d) if d else float('nan'),
                                                  max(d) if d else float('nan'), wrong))
    print('all: %d corners, mean %.3f px, max %.3f px, %d wrong ids' %
          (total, sum(all_d) / len(all_d) if all_d else float('nan'), max(all_d, default=float('nan')),
           wrong_total))


if __name__ == '__main__':
    main()
