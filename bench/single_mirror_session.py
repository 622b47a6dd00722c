#!/usr/bin/env python3
"""A single-mirror camera's photos as omnistereo sessions, for scoring our model on the SAME
corners as bench/central_baselines.cc (its corners file format) with a train / held-out split.

  bench/single_mirror_session.py --corners FILE --photos DIR --out DIR \
      --rim CX,CY,R_PX [--rim_diameter_mm D] [--lens telecentric|perspective] [--mirror ...]
      [--holdout 3,6,9] [--rows 6 --cols 8 --square_mm 42]

Writes in OUT (photos are referenced, never copied):
  start.yaml                  the start model: the mirror's rim (found in the photos, e.g. by
                              bench/eval_rim) with its assumed diameter, an aligned camera
  train/session.yaml, train/detections.yaml      the training photos (estimate: every group)
  heldout/session.yaml, heldout/detections.yaml  the held-out photos (estimate: [], the model
                              ../train/calibrated.yaml held: only the boards' poses solved)
Then:  omnistereo calibrate --session OUT/train/session.yaml --detections OUT/train/detections.yaml --out OUT/train/calibrated.yaml
       omnistereo calibrate --session OUT/heldout/session.yaml --detections OUT/heldout/detections.yaml --out OUT/heldout/scored.yaml
The start: a telecentric lens over a paraboloid (K = -1) whose rim lies in its focus's plane
(R = r_rim: the rim seen at 90 deg from the axis), magnification rim px / rim mm; a perspective
lens over a hyperboloid (K = -2) with the camera at its far focus and the rim at 90 deg. The
absolute size comes from --rim_diameter_mm (an assumption where the mirror was not measured).
"""
import argparse
import math
import os


def read_corners(path):
    photos, size = [], None
    for line in open(path):
        line = line.split('#', 1)[0].strip()
        if not line:
            continue
        f = line.split()
        if f[0] == 'image_size':
            size = (int(f[1]), int(f[2]))
        elif f[0] == 'photo':
            photos.append((f[1], []))
        else:
            photos[-1][1].append((int(f[0]), float(f[1]), float(f[2])))
    return size, photos


def start_model(args, size):
    cx, cy, r_px = (float(v) for v in args.rim.split(','))
    r_rim = args.rim_diameter_mm / 2
    lines = ['format: omnistereo-model/1', 'kind: ideal', 'rig: single', 'lens: ' + args.lens,
             'units: {length: mm, angle: rad}',
             'image: {width: %d, height: %d}' % size]
    if args.lens == 'telecentric':
        m = r_px / r_rim  # px per mm
        R, K, vertex_z = r_rim, -1.0, 2 * r_rim
        f = m
    else:
        # Hyperboloid K = -2 (e = sqrt 2), rim at 90 deg from the axis seen from the near focus:
        # rim height = near focus height; near focus R / (1 + e) above the vertex.
        e = math.sqrt(2.0)
        K = -2.0
        # Choose R so the rim (r_rim) lies in the near focus's plane: sag(r_rim) = R / (1 + e).
        # sag = r^2 / (R + sqrt(R^2 - (1 + K) r^2)); solve numerically.
        lo, hi = 1e-3, 100 * r_rim
        for _ in range(200):
            R = 0.5 * (lo + hi)
            sag = r_rim ** 2 / (R + math.sqrt(R * R - (1 + K) * r_rim ** 2))
            if sag > R / (1 + e):
                lo = R
            else:
                hi = R
        vertex_z = R / (e - 1)  # the camera at the far focus
        z_rim = vertex_z + R / (1 + e)
        f = r_px * z_rim / r_rim
    lines += ['camera:', '  fx: %.6f' % f, '  fy: %.6f' % f, '  cx: %.6f' % cx, '  cy: %.6f' % cy,
              '  skew: 0',
              '  distortion: {model: radtan, dist_k1: 0, dist_k2: 0, dist_p1: 0, dist_p2: 0, dist_k3: 0}',
              'design:', '  R: %.9g' % R, '  K: %.9g' % K, '  vertex_z: %.9g' % vertex_z,
              '  r_sys: %.9g' % r_rim, '  r_cam: %.9g' % (args.r_cam_fraction * r_rim),
              'mirror1:', '  cam_from_mirror: {rx: 0, ry: 0, tx: 0, ty: 0, tz: 0}']
    return '\n'.join(lines) + '\n'


def write_split(out, name, photos, args, size, estimate, model):
    d = os.path.join(out, name)
    os.makedirs(d, exist_ok=True)
    photo_dir = os.path.relpath(os.path.abspath(args.photos), d)
    images = ', '.join(os.path.join(photo_dir, p) for p, _ in photos)
    with open(os.path.join(d, 'session.yaml'), 'w') as s:
        s.write('format: omnistereo-session/1\nmodel: %s\nimages: [%s]\n' % (model, images))
        s.write('targets:\n  - {type: chessboard, rows: %d, cols: %d, square: %g}\n'
                % (args.rows, args.cols, args.square_mm))
        s.write('estimate: [%s]\n' % ', '.join(estimate))
        s.write('lips: false\n')
        for key, value in args.session_key or []:
            s.write('%s: %s\n' % (key, value))
    with open(os.path.join(d, 'detections.yaml'), 'w') as f:
        f.write('format: omnistereo-detections/1\nsession: session.yaml\nimages:\n')
        for p, corners in photos:
            f.write('  - file: %s\n    width: %d\n    height: %d\n    corners:\n'
                    % (os.path.join(photo_dir, p), size[0], size[1]))
            for cid, u, v in corners:
                f.write('      - [0, %d, 1, %.6f, %.6f]\n' % (cid, u, v))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--corners', required=True)
    ap.add_argument('--photos', required=True)
    ap.add_argument('--out', required=True)
    ap.add_argument('--rim', required=True, help='CX,CY,R_PX of the mirror rim in the photos')
    ap.add_argument('--rim_diameter_mm', type=float, default=60.0)
    ap.add_argument('--r_cam_fraction', type=float, default=0.15,
                    help="the centre the camera's own reflection hides, as a fraction of the rim")
    ap.add_argument('--lens', choices=['telecentric', 'perspective'], default='telecentric')
    ap.add_argument('--holdout', default='', help='1-based indices (default every third)')
    ap.add_argument('--rows', type=int, default=6)
    ap.add_argument('--cols', type=int, default=8)
    ap.add_argument('--square_mm', type=float, default=42.0)
    ap.add_argument('--estimate', default='camera,distortion,mirror1_shape,mirror1_pose')
    ap.add_argument('--session_key', nargs=2, action='append', metavar=('KEY', 'VALUE'),
                    help='an extra session key for the training session (repeatable)')
    args = ap.parse_args()
    size, photos = read_corners(args.corners)
    n = len(photos)
    held = ({int(i) for i in args.holdout.split(',')} if args.holdout
            else {i for i in range(1, n + 1) if i % 3 == 0})
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, 'start.yaml'), 'w') as f:
        f.write(start_model(args, size))
    train = [p for i, p in enumerate(photos, 1) if i not in held and p[1]]
    test = [p for i, p in enumerate(photos, 1) if i in held and p[1]]
    write_split(args.out, 'train', train, args, size, args.estimate.split(','), '../start.yaml')
    keys, args.session_key = args.session_key, None
    write_split(args.out, 'heldout', test, args, size, [], '../train/calibrated.yaml')
    print('train: %d photos, held out: %d photos' % (len(train), len(test)))


if __name__ == '__main__':
    main()
