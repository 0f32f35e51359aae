#!/usr/bin/env python3
"""lucent's calibration-target finders against OpenCV's on a folder of photographs: for each image
whether each finds the target, whether their point orders agree (else which symmetry of the grid
maps one onto the other), how far apart the points are, and each finder's time; then one
calibration of each finder's points by cv2.calibrateCamera.

usage: opencv_target_sets.py DIR COLS ROWS [--pattern chessboard|circles|acircles] [--json OUT]
       DIR holds the photographs (*.png, *.jpg); COLS × ROWS is OpenCV's pattern size.
Needs numpy, opencv-contrib-python-headless and the lucent package (PyPI / this repository).
OpenCV's chessboard corners are refined by cornerSubPix with a (5, 5) window: an (11, 11) one
moves corners by pixels where squares are under about 20 px (docs/scanning.md).
"""
import argparse, glob, json, os, re, time
# numpy's OpenBLAS threads spin on the second core between calls and slow both finders: one.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import cv2
import numpy as np
import lucent


def natural(s):
    return [int(t) if t.isdigit() else t for t in re.split(r'(\d+)', s)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('dir')
    ap.add_argument('cols', type=int)
    ap.add_argument('rows', type=int)
    ap.add_argument('--pattern', default='chessboard', choices=['chessboard', 'circles', 'acircles'])
    ap.add_argument('--json')
    a = ap.parse_args()
    size = (a.cols, a.rows)
    files = sorted([f for f in glob.glob(os.path.join(a.dir, '*')) if f.lower().endswith(('.png', '.jpg', '.jpeg'))], key=natural)
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
    flag = {'circles': cv2.CALIB_CB_SYMMETRIC_GRID, 'acircles': cv2.CALIB_CB_ASYMMETRIC_GRID}.get(a.pattern)
    if a.pattern == 'acircles':
        obj = np.array([[(2 * j + i % 2), i, 0] for i in range(a.rows) for j in range(a.cols)], np.float32)
    else:
        obj = np.array([[j, i, 0] for i in range(a.rows) for j in range(a.cols)], np.float32)
    rows, pts_cv, pts_lu, shape = [], [], [], None
    for f in files:
        g = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
        shape = g.shape[::-1]
        t = time.perf_counter()
        if flag is None:
            ok_cv, c = cv2.findChessboardCorners(g, size)
            if ok_cv:
                c = cv2.cornerSubPix(g, c, (5, 5), (-1, -1), crit)
        else:
            ok_cv, c = cv2.findCirclesGrid(g, size, flags=flag)
        t_cv = time.perf_counter() - t
        t = time.perf_counter()
        ok_lu, l = lucent.find_chessboard_corners(g, size) if flag is None else lucent.find_circles_grid(g, size, flag)
        t_lu = time.perf_counter() - t
        row = {'image': os.path.basename(f), 'opencv': bool(ok_cv), 'lucent': bool(ok_lu), 'opencv_s': t_cv, 'lucent_s': t_lu}
        if ok_cv and ok_lu:
            A = c.reshape(a.rows, a.cols, 2).astype(float)
            B = np.asarray(l, float).reshape(a.rows, a.cols, 2)
            syms = {'same': B, 'turned 180°': B[::-1, ::-1], 'rows reversed': B[::-1, :], 'each row reversed': B[:, ::-1]}
            name = min(syms, key=lambda k: np.abs(syms[k] - A).max())
            d = np.hypot(*(syms[name] - A).reshape(-1, 2).T)
            row.update(order=name, rms_px=float(np.sqrt(np.mean(d * d))), max_px=float(d.max()))
            pts_cv.append(c.reshape(-1, 1, 2).astype(np.float32))
            pts_lu.append(syms[name].reshape(-1, 1, 2).astype(np.float32))
        rows.append(row)
        print(f"{row['image']:32s} opencv {int(ok_cv)} lucent {int(ok_lu)}  {t_cv * 1e3:7.1f} / {t_lu * 1e3:7.1f} ms"
              + (f"  order {row['order']}, rms {row['rms_px']:.3f} px, max {row['max_px']:.3f} px" if 'order' in row else ''))
    out = {'images': len(rows), 'opencv_found': sum(r['opencv'] for r in rows), 'lucent_found': sum(r['lucent'] for r in rows),
           'order_differs': [r['image'] for r in rows if r.get('order', 'same') != 'same'], 'rows': rows}
    if len(pts_cv) >= 3:
        for name, pts in (('opencv', pts_cv), ('lucent', pts_lu)):
            rms, k, dist, _, _ = cv2.calibrateCamera([obj] * len(pts), pts, shape, None, None)
            out[f'calibration_{name}_points'] = {'rms_px': rms, 'fx': k[0, 0], 'fy': k[1, 1], 'cx': k[0, 2], 'cy': k[1, 2], 'dist': dist.ravel().tolist()}
            print(f"calibrateCamera on {name}'s points: RMS {rms:.4f} px, fx {k[0, 0]:.2f}, fy {k[1, 1]:.2f}, cx {k[0, 2]:.2f}, cy {k[1, 2]:.2f}")
    print(f"found: OpenCV {out['opencv_found']} / lucent {out['lucent_found']} of {out['images']}; order differs in {len(out['order_differs'])}")
    t_cv, t_lu = (sum(r[k] for r in rows) / len(rows) for k in ('opencv_s', 'lucent_s'))
    out['mean_opencv_s'], out['mean_lucent_s'] = t_cv, t_lu
    print(f"mean time a view: OpenCV {t_cv * 1e3:.2f} ms, lucent {t_lu * 1e3:.2f} ms (lucent / OpenCV {t_lu / t_cv:.2f})")
    if a.json:
        with open(a.json, 'w') as fh:
            json.dump(out, fh, indent=1)


if __name__ == '__main__':
    main()
