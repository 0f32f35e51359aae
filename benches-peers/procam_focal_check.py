"""Is the projector-camera geometry of the procam captures pinned by the chessboard corners?

Usage: python3 benches-peers/procam_focal_check.py CORNERS.json [--square 75] [--corners 9x7]

CORNERS.json is what `procam_calibrate_opencv.py --json` writes (its `camera_corners`,
`projector_corners` and `stereo_fixed_intrinsics`). Needs numpy, scipy and opencv.

1. The camera is calibrated with OpenCV (`calibrateCamera`, principal point and distortion free)
   with its focal length held at 0.85-1.15 times 3440 px; the reprojection RMS is printed for
   each.
2. With the board poses of the free camera calibration, the projector (one focal length for both
   axes, principal point, two radial terms, pose) is fitted by Levenberg-Marquardt to the
   projector corners with its focal length held at 0.85-1.15 times the free value; the RMS, the
   projector centre in the camera frame and its distance to each board centre are printed. A
   geometry that the corners pin shows a clear minimum of the RMS at the free focal length.
"""
import argparse, json

import cv2
import numpy as np
from scipy.optimize import least_squares


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('corners_json')
    ap.add_argument('--square', type=float, default=75.0)
    ap.add_argument('--corners', default='9x7')
    a = ap.parse_args()
    d = json.load(open(a.corners_json))
    cols, rows = map(int, a.corners.split('x'))
    objp = np.zeros((cols * rows, 3))
    objp[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * a.square
    cam = [np.array(c, np.float32).reshape(-1, 1, 2) for c in d['camera_corners']]
    prj = [np.array(c, np.float64).reshape(-1, 2) for c in d['projector_corners']]
    objs = [objp.astype(np.float32)] * len(cam)
    rc, kc, dc, rvs, tvs = cv2.calibrateCamera(objs, cam, (1280, 1024), None, None)
    f_cam = kc[0, 0]
    print(f'camera, all free: f {f_cam:.0f} px, RMS {rc:.3f} px')
    for s in (0.85, 0.95, 1.05, 1.15):
        k = np.array([[f_cam * s, 0, kc[0, 2]], [0, f_cam * s, kc[1, 2]], [0, 0, 1]])
        r = cv2.calibrateCamera(objs, cam, (1280, 1024), k, None, flags=cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_FOCAL_LENGTH)[0]
        print(f'camera, f held at {s:.2f}x: RMS {r:.3f} px')
    boards = []
    for rv, tv in zip(rvs, tvs):
        R, _ = cv2.Rodrigues(rv)
        boards.append(objp @ R.T + np.ravel(tv))

    def residual(x, f):
        cx, cy, k1, k2 = x[:4]
        R, _ = cv2.Rodrigues(x[4:7])
        out = []
        for P, q in zip(boards, prj):
            X = P @ R.T + x[7:10]
            u, v = X[:, 0] / X[:, 2], X[:, 1] / X[:, 2]
            r2 = u * u + v * v
            rad = 1 + k1 * r2 + k2 * r2 * r2
            out += [f * u * rad + cx - q[:, 0], f * v * rad + cy - q[:, 1]]
        return np.concatenate(out)

    st = d['stereo_fixed_intrinsics']
    x0 = np.r_[d['projector']['cx'], d['projector']['cy'], 0, 0, cv2.Rodrigues(np.array(st['rotation']))[0].ravel(), st['translation']]
    f0 = 0.5 * (d['projector']['fx'] + d['projector']['fy'])
    for s in (0.85, 1.0, 1.15):
        r = least_squares(residual, x0, args=(f0 * s,), method='lm', max_nfev=20000)
        R, _ = cv2.Rodrigues(r.x[4:7])
        c = -R.T @ r.x[7:10]
        rms = np.sqrt(2 * np.mean(r.fun ** 2))
        dist = ' '.join(f'{np.linalg.norm(P.mean(0) - c):.0f}' for P in boards)
        print(f'projector, f held at {s:.2f}x ({f0 * s:.0f} px): RMS {rms:.3f} px, centre {np.round(c)}, distance to the boards {dist}')


if __name__ == '__main__':
    main()
