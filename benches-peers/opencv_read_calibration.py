"""OpenCV reads the FileStorage copy that `lucent scan calibrate --opencv-out` writes.

Usage: python3 benches-peers/opencv_read_calibration.py CALIB.json CALIB.xml
       (needs numpy and opencv-python; the two files from one `lucent scan calibrate` run)

cv::FileStorage opens CALIB.xml (or .yml); its matrices under procam-calibration's node names
(cam_int, cam_dist, proj_int, proj_dist, roration, translation, img_shape) and proj_shape must
equal the JSON's values. Then cv2.projectPoints, with the projector's intrinsics and the
camera → projector pose read by OpenCV, maps three camera-frame points to the same projector
pixels as the JSON's parameters in numpy's own OpenCV-model projection. Prints the largest
differences.
"""
import json
import sys

import cv2
import numpy as np


def project(K, d, X):
    """OpenCV's model written out: k1, k2, p1, p2, k3, the rational k4…k6, the thin prism s1…s4
    and the sensor tilt τx, τy (computeTiltProjectionMatrix), as many as `d` gives."""
    x, y = X[:, 0] / X[:, 2], X[:, 1] / X[:, 2]
    k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4, tx, ty = (list(d) + [0.0] * 14)[:14]
    r2 = x * x + y * y
    f = (1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3) / (1 + k4 * r2 + k5 * r2 ** 2 + k6 * r2 ** 3)
    xd = x * f + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) + s1 * r2 + s2 * r2 ** 2
    yd = y * f + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y + s3 * r2 + s4 * r2 ** 2
    rx = np.array([[1, 0, 0], [0, np.cos(tx), np.sin(tx)], [0, -np.sin(tx), np.cos(tx)]])
    ry = np.array([[np.cos(ty), 0, -np.sin(ty)], [0, 1, 0], [np.sin(ty), 0, np.cos(ty)]])
    rxy = ry @ rx
    tilt = np.array([[rxy[2, 2], 0, -rxy[0, 2]], [0, rxy[2, 2], -rxy[1, 2]], [0, 0, 1]]) @ rxy
    v = tilt @ np.stack([xd, yd, np.ones_like(xd)])
    xd, yd = v[0] / v[2], v[1] / v[2]
    return np.stack([K[0, 0] * xd + K[0, 2], K[1, 1] * yd + K[1, 2]], 1)


def main(argv):
    if len(argv) != 2:
        sys.exit(__doc__.strip().splitlines()[2])
    with open(argv[0]) as f:
        c = json.load(f)
    fs = cv2.FileStorage(argv[1], cv2.FILE_STORAGE_READ)
    if not fs.isOpened():
        sys.exit(f'{argv[1]}: OpenCV cannot open it')
    m = {n: fs.getNode(n).mat() for n in ('cam_int', 'cam_dist', 'proj_int', 'proj_dist', 'roration', 'translation', 'img_shape', 'proj_shape')}
    rms = fs.getNode('rms').real()
    K = lambda d: np.array([[d['fx'], 0, d['cx']], [0, d['fy'], d['cy']], [0, 0, 1.0]])
    want = {
        'cam_int': K(c['camera']), 'cam_dist': np.array([c['camera']['distortion']]),
        'proj_int': K(c['projector']), 'proj_dist': np.array([c['projector']['distortion']]),
        'roration': np.array(c['rotation']), 'translation': np.array(c['translation']).reshape(3, 1),
        'img_shape': np.array([[c['camera']['height']], [c['camera']['width']]], float),
        'proj_shape': np.array([[c['projector']['height']], [c['projector']['width']]], float),
    }
    worst = max(np.abs(m[n] - want[n]).max() / max(1.0, np.abs(want[n]).max()) for n in want)
    print(f'OpenCV {cv2.__version__} read {argv[1]}: largest relative difference from the JSON {worst:.1e}; rms {rms} (JSON {c["rms_px"]})')
    X = np.array([[100.0, -50.0, 3000.0], [-400.0, 300.0, 3500.0], [250.0, 420.0, 2800.0]])
    rvec, _ = cv2.Rodrigues(m['roration'])
    px_cv, _ = cv2.projectPoints(X, rvec, m['translation'], m['proj_int'], m['proj_dist'])
    Xp = X @ np.array(c['rotation']).T + np.array(c['translation'])
    px_np = project(want['proj_int'], c['projector']['distortion'], Xp)
    print(f'projector pixels of three points, cv2.projectPoints on the file vs the JSON: largest difference {np.abs(px_cv.reshape(-1, 2) - px_np).max():.1e} px')


if __name__ == '__main__':
    main(sys.argv[1:])
