#!/usr/bin/env python3
"""OpenCV peer of `lucent scan calibrate-stereo`: findChessboardCorners + cornerSubPix, or
findCirclesGrid, in both cameras' photographs, calibrateCamera per camera, then stereoCalibrate
with the intrinsics refined jointly (CALIB_USE_INTRINSIC_GUESS, as lucent's joint fit), beside
lucent's result on the same photographs; prints both, or JSON with --json.

usage: opencv_stereo_calibrate.py --left L1 L2 … --right R1 R2 … --corners 4x11 --square 1
       [--pattern chessboard|circles|acircles] [--lucent BIN] [--json]
Needs opencv-contrib-python-headless (or opencv-python) and numpy (PyPI).
"""
import argparse, json, os, subprocess, sys, time
import cv2
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def find(path, pattern, cols, rows):
    g = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    if g is None:
        sys.exit(f'{path}: cannot read')
    if pattern == 'chessboard':
        ok, c = cv2.findChessboardCorners(g, (cols, rows), cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
        if ok:
            c = cv2.cornerSubPix(g, c, (11, 11), (-1, -1), (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 1e-3))
            # lucent's order starts at the corner nearest the image's top-left.
            q = c.reshape(rows, cols, 2)
            if np.linalg.norm(q[-1, -1]) < np.linalg.norm(q[0, 0]):
                q = q[::-1, ::-1]
            c = q.reshape(-1, 1, 2)
    else:
        kind = cv2.CALIB_CB_ASYMMETRIC_GRID if pattern == 'acircles' else cv2.CALIB_CB_SYMMETRIC_GRID
        ok, c = cv2.findCirclesGrid(g, (cols, rows), flags=kind)
    if not ok:
        sys.exit(f'{path}: OpenCV finds no {cols}x{rows} {pattern}')
    return np.ascontiguousarray(np.asarray(c, np.float32).reshape(-1, 1, 2)), g.shape[::-1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--left', nargs='+', required=True)
    ap.add_argument('--right', nargs='+', required=True)
    ap.add_argument('--corners', required=True)
    ap.add_argument('--square', type=float, required=True)
    ap.add_argument('--pattern', default='chessboard', choices=['chessboard', 'circles', 'acircles'])
    ap.add_argument('--lucent', default=os.environ.get('LUCENT', os.path.join(ROOT, 'target/release/lucent')))
    ap.add_argument('--json', action='store_true')
    a = ap.parse_args()
    cols, rows = map(int, a.corners.split('x'))
    objp = np.zeros((cols * rows, 3), np.float32)
    if a.pattern == 'acircles':
        objp[:, :2] = [((2 * j + i % 2) * a.square, i * a.square) for i in range(rows) for j in range(cols)]
    else:
        objp[:, :2] = [(j * a.square, i * a.square) for i in range(rows) for j in range(cols)]
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 200, 1e-12)
    t0 = time.perf_counter()
    pl, pr, size_l, size_r = [], [], None, None
    for fl, fr in zip(a.left, a.right):
        c, size_l = find(fl, a.pattern, cols, rows)
        pl.append(c)
        c, size_r = find(fr, a.pattern, cols, rows)
        pr.append(c)
    obj = [objp] * len(pl)
    _, kl, dl, _, _ = cv2.calibrateCamera(obj, pl, size_l, None, None, criteria=crit)
    _, kr, dr, _, _ = cv2.calibrateCamera(obj, pr, size_r, None, None, criteria=crit)
    rms, kl, dl, kr, dr, r, t, _, _ = cv2.stereoCalibrate(obj, pl, pr, kl, dl, kr, dr, size_l, flags=cv2.CALIB_USE_INTRINSIC_GUESS, criteria=crit)
    t_cv = time.perf_counter() - t0
    args = [a.lucent, 'scan', 'calibrate-stereo', '--left', *a.left, '--right', *a.right, '--corners', a.corners,
            '--square', str(a.square), '--pattern', a.pattern, '--json']
    t0 = time.perf_counter()
    p = subprocess.run(args, capture_output=True, text=True)
    t_lu = time.perf_counter() - t0
    if p.returncode != 0:
        sys.exit(f'lucent failed: {p.stderr.strip()}')
    lu = json.loads(p.stdout)
    r_lu = np.array(lu['rotation'])
    angle = np.degrees(np.arccos(np.clip((np.trace(r_lu @ r.T) - 1) / 2, -1, 1)))
    dev = lambda k, d: {'fx': k[0, 0], 'fy': k[1, 1], 'cx': k[0, 2], 'cy': k[1, 2], 'dist': d.ravel()[:5].tolist()}
    out = {'opencv': cv2.__version__, 'pairs': len(pl),
           'opencv_result': {'left': dev(kl, dl), 'right': dev(kr, dr), 'translation': t.ravel().tolist(), 'rms_px': rms, 'seconds': t_cv},
           'lucent_result': {'left': {k: lu['camera'][k] for k in ['fx', 'fy', 'cx', 'cy']}, 'right': {k: lu['projector'][k] for k in ['fx', 'fy', 'cx', 'cy']},
                             'translation': lu['translation'], 'rms_px': lu['rms_px'], 'seconds': t_lu},
           'rotation_difference_deg': angle}
    if a.json:
        print(json.dumps(out, indent=1))
        return
    print(f"{len(pl)} pairs, {cols}x{rows} {a.pattern}; OpenCV {cv2.__version__} (calibrateCamera ×2, stereoCalibrate with CALIB_USE_INTRINSIC_GUESS)")
    for side, key in [('left', 'camera'), ('right', 'projector')]:
        for k in ['fx', 'fy', 'cx', 'cy']:
            o = out['opencv_result'][side][k]
            print(f"  {side:5} {k}  lucent {lu[key][k]:10.3f}   OpenCV {o:10.3f}   difference {lu[key][k] - o:+.3f}")
    tl, tc = np.array(lu['translation']), t.ravel()
    print(f"  T      lucent {np.array2string(tl, precision=4)}   OpenCV {np.array2string(tc, precision=4)}   |T| {np.linalg.norm(tl):.4f} / {np.linalg.norm(tc):.4f}")
    print(f"  R      the two rotations differ by {angle:.4f}°")
    print(f"  RMS    lucent {lu['rms_px']:.4f} px (both cameras)   OpenCV {rms:.4f} px")
    print(f"  seconds lucent {t_lu:.2f} (detection included), OpenCV {t_cv:.2f} (the same)")


if __name__ == '__main__':
    main()
