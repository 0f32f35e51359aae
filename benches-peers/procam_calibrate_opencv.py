#!/usr/bin/env python3
"""OpenCV peer of `lucent scan calibrate`: the approach of kamino410/procam-calibration's
calibrate.py (findChessboardCorners + cornerSubPix on the white frame, Gray-code decoding with
structured_light.GrayCodePattern.getProjPixel, a local homography per corner fitted by
cv2.findHomography to the decoded pixels in a window, then calibrateCamera for each device and
stereoCalibrate with the intrinsics fixed, OpenCV's default). Also runs stereoCalibrate with all
parameters free (CALIB_USE_INTRINSIC_GUESS), which is what `lucent scan calibrate` minimises.

usage: procam_calibrate_opencv.py CAPTURE_DIR... [--projector 1024x768] [--corners 9x7]
       [--square 75] [--half-window 23] [--black-threshold 40] [--white-threshold 5] [--json OUT]
       [--fix-k3] [--zero-tangent] [--rational] [--thin-prism] [--tilted]   (OpenCV's CALIB_FIX_K3,
       CALIB_ZERO_TANGENT_DIST, CALIB_RATIONAL_MODEL, CALIB_THIN_PRISM_MODEL, CALIB_TILTED_MODEL in
       every fit, as `lucent scan calibrate --fix-k3 --zero-tangent --rational --thin-prism --tilted`)
Needs opencv-contrib-python-headless and numpy (PyPI).
"""
import argparse, glob, json, os, sys, time
import cv2
import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('captures', nargs='+')
    ap.add_argument('--projector', default='1024x768')
    ap.add_argument('--corners', default='9x7')
    ap.add_argument('--square', type=float, default=75.0)
    ap.add_argument('--half-window', type=int, default=23)
    ap.add_argument('--black-threshold', type=int, default=40)
    ap.add_argument('--white-threshold', type=int, default=5)
    ap.add_argument('--json')
    ap.add_argument('--fix-k3', action='store_true')
    ap.add_argument('--zero-tangent', action='store_true')
    ap.add_argument('--rational', action='store_true')
    ap.add_argument('--thin-prism', action='store_true')
    ap.add_argument('--tilted', action='store_true')
    a = ap.parse_args()
    extra = (cv2.CALIB_FIX_K3 if a.fix_k3 else 0) | (cv2.CALIB_ZERO_TANGENT_DIST if a.zero_tangent else 0) | (cv2.CALIB_RATIONAL_MODEL if a.rational else 0) \
        | (cv2.CALIB_THIN_PRISM_MODEL if a.thin_prism else 0) | (cv2.CALIB_TILTED_MODEL if a.tilted else 0)
    pw, ph = map(int, a.projector.split('x'))
    cols, rows = map(int, a.corners.split('x'))
    objp = np.zeros((cols * rows, 3), np.float32)
    objp[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * a.square
    gc = cv2.structured_light.GrayCodePattern.create(pw, ph)
    gc.setWhiteThreshold(a.white_threshold)
    gc.setBlackThreshold(a.black_threshold)
    t0 = time.perf_counter()
    t_detect = t_local = 0.0
    objps, cam_pts, proj_pts = [], [], []
    cam_shape = None
    for d in a.captures:
        files = sorted(glob.glob(os.path.join(d, 'graycode_*.png')))
        imgs = [cv2.imread(f, cv2.IMREAD_GRAYSCALE) for f in files]
        white, black = imgs[-2], imgs[-1]
        cam_shape = white.shape[::-1]
        t = time.perf_counter()
        ok, corners = cv2.findChessboardCorners(white, (cols, rows))
        if not ok:
            sys.exit(f'board not found (capture {d})')
        corners = cv2.cornerSubPix(white, corners, (11, 11), (-1, -1),
                                   (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001))
        t_detect += time.perf_counter() - t
        t = time.perf_counter()
        pattern = imgs[:-2]
        lit = (white.astype(int) - black.astype(int)) > a.black_threshold
        hw = a.half_window
        pc = []
        for c in corners.reshape(-1, 2):
            cx, cy = int(round(c[0])), int(round(c[1]))
            src, dst = [], []
            for y in range(max(0, cy - hw), min(white.shape[0], cy + hw + 1)):
                for x in range(max(0, cx - hw), min(white.shape[1], cx + hw + 1)):
                    if not lit[y, x]:
                        continue
                    err, p = gc.getProjPixel(pattern, x, y)
                    if err:
                        continue
                    src.append((x, y))
                    dst.append(p)
            if len(src) < 25:
                sys.exit(f'too few valid pixels around a corner (capture {d})')
            h, _ = cv2.findHomography(np.array(src, np.float32), np.array(dst, np.float32))
            q = h @ np.array([c[0], c[1], 1.0])
            pc.append(q[:2] / q[2])
        t_local += time.perf_counter() - t
        objps.append(objp)
        cam_pts.append(corners.astype(np.float32))
        proj_pts.append(np.array(pc, np.float32).reshape(-1, 1, 2))
    t = time.perf_counter()
    rc, kc, dc, _, _ = cv2.calibrateCamera(objps, cam_pts, cam_shape, None, None, flags=extra)
    rp, kp, dp, _, _ = cv2.calibrateCamera(objps, proj_pts, (pw, ph), None, None, flags=extra)
    rs, kc2, dc2, kp2, dp2, R, T, _, _ = cv2.stereoCalibrate(objps, cam_pts, proj_pts, kc, dc, kp, dp, None, flags=cv2.CALIB_FIX_INTRINSIC | extra)
    t_calib = time.perf_counter() - t
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 200, 1e-12)
    rj, kcj, dcj, kpj, dpj, Rj, Tj, _, _ = cv2.stereoCalibrate(objps, cam_pts, proj_pts, kc.copy(), dc.copy(), kp.copy(), dp.copy(), None,
                                                               flags=cv2.CALIB_USE_INTRINSIC_GUESS | extra, criteria=crit)
    total = time.perf_counter() - t0

    def dev(k, dist, rms):
        return {'fx': k[0, 0], 'fy': k[1, 1], 'cx': k[0, 2], 'cy': k[1, 2], 'distortion': dist.ravel()[:14 if a.tilted else 12 if a.thin_prism else 8 if a.rational else 5].tolist(), 'rms_px': rms}
    out = {
        'opencv': cv2.__version__,
        'camera': dev(kc, dc, rc), 'projector': dev(kp, dp, rp),
        'stereo_fixed_intrinsics': {'rms_px': rs, 'rotation': R.tolist(), 'translation': T.ravel().tolist()},
        'stereo_all_free': {'rms_px': rj, 'camera': dev(kcj, dcj, float('nan')), 'projector': dev(kpj, dpj, float('nan')),
                            'rotation': Rj.tolist(), 'translation': Tj.ravel().tolist()},
        'seconds': {'total_with_image_reading': total, 'corner_detection': t_detect, 'local_homographies_with_decoding': t_local,
                    'calibrate_and_stereo': t_calib},
        'camera_corners': [p.reshape(-1, 2).tolist() for p in cam_pts],
        'projector_corners': [p.reshape(-1, 2).tolist() for p in proj_pts],
    }
    s = json.dumps(out, indent=1)
    if a.json:
        open(a.json, 'w').write(s)
    else:
        print(s)


if __name__ == '__main__':
    main()
