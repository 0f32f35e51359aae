#!/usr/bin/env python3
"""lucent's ChArUco detector against OpenCV's CharucoDetector on the same photographs: markers
and corners found by each and by both, how far apart the common corners are, detection time
(reading included), cv2.calibrateCamera's RMS on each finder's corners (all, and those both
found); then `lucent scan calibrate-camera --pattern charuco` as a whole process.

usage: opencv_charuco.py DIR SQUARES_X SQUARES_Y SQUARE MARKER DICT [--legacy]
       e.g. feiran-l/Structured-light-stereo's data/stereo_calib_flir/left 25 18 7.5 5.6 DICT_5X5_1000 --legacy
Needs numpy, opencv-contrib-python-headless and the lucent package; LUCENT=path/to/lucent (default
target/release/lucent).
"""
import argparse, glob, json, os, subprocess, time
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import cv2
import numpy as np
import lucent

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('dir')
    ap.add_argument('sx', type=int)
    ap.add_argument('sy', type=int)
    ap.add_argument('square', type=float)
    ap.add_argument('marker', type=float)
    ap.add_argument('dict')
    ap.add_argument('--legacy', action='store_true')
    a = ap.parse_args()
    files = sorted(glob.glob(os.path.join(a.dir, '*.png')) + glob.glob(os.path.join(a.dir, '*.jpg')))
    exe = os.environ.get('LUCENT', os.path.join(ROOT, 'target', 'release', 'lucent'))
    A = cv2.aruco
    board = A.CharucoBoard((a.sx, a.sy), a.square, a.marker, A.getPredefinedDictionary(getattr(A, a.dict)))
    board.setLegacyPattern(a.legacy)
    det = A.CharucoDetector(board)
    lb = lucent.CharucoBoard((a.sx, a.sy), a.square, a.marker, a.dict, legacy=a.legacy)
    obj = board.getChessboardCorners()
    found = {'lucent': [], 'OpenCV': []}
    times = {'lucent': 0.0, 'OpenCV': 0.0}
    markers = {'lucent': [0, 0], 'OpenCV': [0, 0]}
    dist, size = [], None
    for f in files:
        t = time.perf_counter()
        g = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
        cc, ci, mc, mi = det.detectBoard(g)
        times['OpenCV'] += time.perf_counter() - t
        t = time.perf_counter()
        g = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
        lc, li, lmc, lmi = lb.detect_board(g)
        times['lucent'] += time.perf_counter() - t
        size = g.shape[::-1]
        sets = {'OpenCV': ({} if ci is None else dict(zip(ci.ravel().tolist(), cc.reshape(-1, 2))), set() if mi is None else set(mi.ravel().tolist())),
                'lucent': ({} if li is None else dict(zip(li.ravel().tolist(), lc.reshape(-1, 2))), set() if lmi is None else set(lmi.ravel().tolist()))}
        for name, (c, m) in sets.items():
            found[name].append(c)
            markers[name][0] += len(m)
            markers[name][1] += len(m & sets['lucent' if name == 'OpenCV' else 'OpenCV'][1])
        both = set(sets['OpenCV'][0]) & set(sets['lucent'][0])
        dist += [float(np.hypot(*(sets['OpenCV'][0][i] - sets['lucent'][0][i]))) for i in both]

    def rms(views, common):
        objs, imgs = [], []
        for k, c in enumerate(views):
            ids = sorted(set(c) & set(found['OpenCV'][k]) & set(found['lucent'][k])) if common else sorted(c)
            if len(ids) >= 6:
                objs.append(obj[ids].astype(np.float32))
                imgs.append(np.array([c[i] for i in ids], np.float32))
        return cv2.calibrateCamera(objs, imgs, size, None, None)[0], sum(len(o) for o in objs), len(objs)

    print(f"{len(files)} photographs, OpenCV {cv2.__version__}")
    for name in ('lucent', 'OpenCV'):
        r_all, n_all, v_all = rms(found[name], False)
        r_common, n_common, _ = rms(found[name], True)
        print(f"{name:7s} markers {markers[name][0]} ({markers[name][1]} also by the other), corners {sum(len(c) for c in found[name])}, "
              f"detection {times[name]:.2f} s; calibrateCamera RMS {r_all:.4f} px ({v_all} views, {n_all} corners), "
              f"on the common corners {r_common:.4f} px ({n_common})")
    d = np.array(dist)
    print(f"common corners {len(d)}: distance median {np.median(d):.3f} px, 90th percentile {np.percentile(d, 90):.3f}, max {d.max():.3f}")
    cmd = [exe, 'scan', 'calibrate-camera', *files, '--pattern', 'charuco', '--squares', f'{a.sx}x{a.sy}', '--square', str(a.square),
           '--marker-length', str(a.marker), '--dictionary', a.dict, '--skip-missing', '--json'] + (['--legacy-pattern'] if a.legacy else [])
    t = time.perf_counter()
    v = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)
    print(f"lucent scan calibrate-camera: {len(v['views'])} views, RMS {v['rms_px']:.4f} px, fx {v['fx']:.1f} fy {v['fy']:.1f} "
          f"cx {v['cx']:.1f} cy {v['cy']:.1f}, {time.perf_counter() - t:.2f} s")

if __name__ == '__main__':
    main()
