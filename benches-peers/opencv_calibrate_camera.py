#!/usr/bin/env python3
"""OpenCV peer of `lucent scan calibrate-camera`: findChessboardCorners (adaptive threshold,
normalised image) + cornerSubPix (23 × 23 window), or findCirclesGrid (default blob detector)
with --pattern circles / acircles, + calibrateCamera on the same photographs, beside lucent's
result on them; prints both and their differences, or JSON with --json.

usage: opencv_calibrate_camera.py IMAGE... --corners 11x8 --square 20 [--lucent BIN]
       [--pattern chessboard|circles|acircles]
       [--fix-k3] [--zero-tangent] [--rational] [--thin-prism] [--tilted] [--json]
Needs opencv-contrib-python-headless (or opencv-python) and numpy (PyPI).
"""
import argparse, json, os, subprocess, sys, time
import cv2
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('images', nargs='+')
    ap.add_argument('--corners', required=True)
    ap.add_argument('--square', type=float, required=True)
    ap.add_argument('--pattern', default='chessboard', choices=['chessboard', 'circles', 'acircles'])
    ap.add_argument('--lucent', default=os.environ.get('LUCENT', os.path.join(ROOT, 'target/release/lucent')))
    for f in ['fix-k3', 'zero-tangent', 'rational', 'thin-prism', 'tilted']:
        ap.add_argument('--' + f, action='store_true')
    ap.add_argument('--json', action='store_true')
    a = ap.parse_args()
    cols, rows = map(int, a.corners.split('x'))
    flags = (cv2.CALIB_FIX_K3 if a.fix_k3 else 0) | (cv2.CALIB_ZERO_TANGENT_DIST if a.zero_tangent else 0) \
        | (cv2.CALIB_RATIONAL_MODEL if a.rational else 0) | (cv2.CALIB_THIN_PRISM_MODEL if a.thin_prism else 0) \
        | (cv2.CALIB_TILTED_MODEL if a.tilted else 0)
    n_coef = 14 if a.tilted else 12 if a.thin_prism else 8 if a.rational else 5
    objp = np.zeros((cols * rows, 3), np.float32)
    objp[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * a.square
    if a.pattern == 'acircles':
        # OpenCV's calibration sample: ((2j + i mod 2) s, i s) for row i, disc j.
        objp[:, 0] = [(2 * j + i % 2) * a.square for i in range(rows) for j in range(cols)]
    t0 = time.perf_counter()
    pts, size = [], None
    for f in a.images:
        g = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
        size = g.shape[::-1]
        if a.pattern != 'chessboard':
            kind = cv2.CALIB_CB_ASYMMETRIC_GRID if a.pattern == 'acircles' else cv2.CALIB_CB_SYMMETRIC_GRID
            ok, c = cv2.findCirclesGrid(g, (cols, rows), flags=kind)
            if not ok:
                sys.exit(f'{f}: OpenCV finds no {cols}x{rows} {a.pattern} grid')
            pts.append(c.reshape(-1, 1, 2).astype(np.float32))
            continue
        ok, c = cv2.findChessboardCorners(g, (cols, rows), cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
        if not ok:
            sys.exit(f'{f}: OpenCV finds no {cols}x{rows} chessboard')
        c = cv2.cornerSubPix(g, c, (11, 11), (-1, -1), (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 1e-3))
        # OpenCV may start the lattice at either end; lucent's order starts at the corner nearest the
        # image's top-left. Reorder OpenCV's to the same convention before comparing corners.
        q = c.reshape(rows, cols, 2)
        if np.linalg.norm(q[-1, -1]) < np.linalg.norm(q[0, 0]):
            q = q[::-1, ::-1]
        pts.append(np.ascontiguousarray(q.reshape(-1, 1, 2)))
    rms, k, dist, _, _ = cv2.calibrateCamera([objp] * len(pts), pts, size, None, None, flags=flags,
                                             criteria=(cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 200, 1e-12))
    t_cv = time.perf_counter() - t0
    args = [a.lucent, 'scan', 'calibrate-camera', *a.images, '--corners', a.corners, '--square', str(a.square), '--json', '--pattern', a.pattern]
    args += [f'--{f}' for f in ['fix-k3', 'zero-tangent', 'rational', 'thin-prism', 'tilted'] if getattr(a, f.replace('-', '_'))]
    t0 = time.perf_counter()
    r = subprocess.run(args, capture_output=True, text=True)
    t_lu = time.perf_counter() - t0
    if r.returncode != 0:
        sys.exit(f'lucent failed: {r.stderr.strip()}')
    lu = json.loads(r.stdout)
    cv = {'fx': k[0, 0], 'fy': k[1, 1], 'cx': k[0, 2], 'cy': k[1, 2], 'dist': dist.ravel()[:n_coef].tolist(), 'rms_px': rms, 'seconds': t_cv}
    out = {'opencv': cv2.__version__, 'images': len(a.images), 'size': size, 'opencv_result': cv,
           'lucent_result': {key: lu[key] for key in ['fx', 'fy', 'cx', 'cy', 'dist', 'rms_px']} | {'seconds': t_lu}}
    if a.json:
        print(json.dumps(out, indent=1))
        return
    print(f"{len(a.images)} images {size[0]}x{size[1]}, {cols}x{rows} {a.pattern}; OpenCV {cv2.__version__}")
    for key in ['fx', 'fy', 'cx', 'cy', 'rms_px']:
        print(f"  {key:7} lucent {lu[key]:12.4f}   OpenCV {cv[key]:12.4f}   difference {lu[key] - cv[key]:+.4f}")
    print('  dist    lucent', ' '.join(f'{x:+.5f}' for x in lu['dist']))
    print('          OpenCV', ' '.join(f'{x:+.5f}' for x in cv['dist']))
    print(f"  seconds lucent {t_lu:.2f} (image reading and corner finding included), OpenCV {t_cv:.2f} (the same)")


if __name__ == '__main__':
    main()
