"""Does one fixed projector explain the brightness of the paper in every capture of a calibration?

Usage: python3 scripts/procam_irradiance_check.py CALIB.json [--corners 9x7] [--square 75]
       [--white 40] [--black 41] [--gamma 1.0]

Needs numpy and pillow (the venv of scripts/test-python.sh has both).

For every capture in CALIB.json (what `lucent scan calibrate` writes, lengths in the unit of its
`--square`), 16 points inside each square of the chessboard are placed by the capture's board
pose and projected into the camera (OpenCV model with distortion). At the points on white
squares, the white frame's code minus the black frame's, raised to `--gamma` (1: a linear
camera), is a Lambertian paper's radiance up to one factor, and a point projector of constant
output at the calibrated centre predicts it ∝ cos θᵢ / d² (θᵢ the incidence angle, d the
distance to the projector centre). The script prints, per capture, the ranges of cos θᵢ and d,
the median of the measured / predicted ratio relative to the first capture (1 for every
capture if the projector, the camera's exposure and the paper's reflectance were the same), the
image-wide mean and 99th percentile of the white frame's codes, the exponent of d fitted within
each capture alone (where the exposure is one constant; −2 for the point projector), and the
residual of two fits over all captures: one factor per capture, and one exponent of d for all.
It repeats the first of these for a projector whose pixels all pass the same power (lucent's
`profile = "irradiance"`, Mitsuba 3's `projector`): intensity ∝ 1/cos³θ_p, θ_p the angle off the
projector's optical axis. Finally it fits, within each capture alone, a power of the phase angle
(between the directions to projector and camera; a paper brighter toward backscatter) or of d,
and prints how far each such fit misses the other captures' level.
"""
import json, math, os, sys

import numpy as np
from PIL import Image


def rodrigues(r):
    r = np.asarray(r, float)
    th = np.linalg.norm(r)
    if th < 1e-15:
        return np.eye(3)
    k = r / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(th) * K + (1 - math.cos(th)) * K @ K


def project(cam, X):
    """OpenCV pinhole with (k1, k2, p1, p2, k3) distortion; pixel centres at integers."""
    x, y = X[:, 0] / X[:, 2], X[:, 1] / X[:, 2]
    k1, k2, p1, p2, k3 = (list(cam.get('distortion', [])) + [0.0] * 5)[:5]
    r2 = x * x + y * y
    rad = 1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3
    xd = x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([cam['fx'] * xd + cam['cx'], cam['fy'] * yd + cam['cy']], 1)


def sample(img, px):
    """Mean of the 3 × 3 pixels around each point."""
    h, w = img.shape
    x, y = np.round(px[:, 0]).astype(int), np.round(px[:, 1]).astype(int)
    out = np.zeros(len(px))
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            out += img[np.clip(y + dy, 0, h - 1), np.clip(x + dx, 0, w - 1)]
    return out / 9


def parse_options(argv, opts, usage, npos=1):
    """`--name value` options into `opts` (its keys are the known names, its values the
    defaults) and `npos` positional arguments (the one, or a list of them when `npos` > 1);
    exits with a one-line message otherwise."""
    pos, i = [], 0
    while i < len(argv):
        if argv[i] in opts and i + 1 < len(argv):
            opts[argv[i]] = argv[i + 1]
            i += 2
        elif argv[i].startswith('--'):
            sys.exit(f'{argv[i]}: unknown option or missing value')
        else:
            pos.append(argv[i])
            i += 1
    if len(pos) != npos:
        sys.exit(usage)
    return opts, (pos[0] if npos == 1 else pos)


def square_points(cols, rows, sq):
    """16 points inside each square of a board of cols × rows inner corners (board coordinates,
    origin at the first inner corner, squares of side sq)."""
    u = np.linspace(0.25, 0.75, 4)
    return np.array([((i - 1 + a) * sq, (j - 1 + b) * sq) for i in range(cols + 1) for j in range(rows + 1) for a in u for b in u])


def load_calib(path):
    """The calibration JSON, or a one-line exit naming the file."""
    try:
        with open(path) as f:
            calib = json.load(f)
        calib['rotation'], calib['translation'], calib['camera'], calib['captures']
    except (OSError, ValueError, KeyError, TypeError) as e:
        sys.exit(f'{path}: not a calibration of `lucent scan calibrate` ({e})')
    return calib


def main(argv):
    opts, calib_path = parse_options(argv, {'--corners': '9x7', '--square': '75', '--white': '40', '--black': '41', '--gamma': '1.0'},
                                     __doc__.strip().splitlines()[2])
    calib = load_calib(calib_path)
    cols, rows = (int(v) for v in opts['--corners'].split('x'))
    sq, gamma = float(opts['--square']), float(opts['--gamma'])
    Rp, Tp = np.array(calib['rotation']), np.array(calib['translation'])
    centre = -Rp.T @ Tp
    pts = square_points(cols, rows, sq)
    data = []
    for k, cap in enumerate(calib['captures']):
        R, t = rodrigues(cap['rvec']), np.array(cap['tvec'])
        X = np.c_[pts, np.zeros(len(pts))] @ R.T + t
        px = project(calib['camera'], X)
        frames = []
        for f in (opts['--white'], opts['--black']):
            path = os.path.join(cap['name'], f'graycode_{int(f):02d}.png')
            frames.append(np.asarray(Image.open(path).convert('L')).astype(float))
        white, black = sample(frames[0], px), sample(frames[1], px)
        d_vec = centre - X
        d = np.linalg.norm(d_vec, axis=1)
        cos_i = np.abs(d_vec @ R[:, 2]) / d
        paper = white > 0.9 * np.median(white)
        lit = paper & (white < 250)
        L = (white[lit] / 255) ** gamma - (black[lit] / 255) ** gamma
        keep = L > 0
        Xp = X @ Rp.T + Tp
        cos_p = Xp[:, 2] / np.linalg.norm(Xp, axis=1)
        # Phase angle: between the directions to the projector and to the camera (at the origin).
        to_cam = -X / np.linalg.norm(X, axis=1)[:, None]
        phase = np.arccos(np.clip(np.sum(d_vec / d[:, None] * to_cam, axis=1), -1, 1))
        data.append(dict(k=k, L=L[keep], cos=cos_i[lit][keep], d=d[lit][keep], cos_p=cos_p[lit][keep], phase=phase[lit][keep], img=frames[0]))
    ratio0 = None
    print('capture | cos θᵢ | d | measured / predicted (rel. capture 0) | white frame mean, p99 codes')
    for c in data:
        r = np.median(c['L'] / (c['cos'] / c['d'] ** 2))
        ratio0 = ratio0 or r
        print(f"{c['k']} | {c['cos'].min():.3f}–{c['cos'].max():.3f} | {c['d'].min():.0f}–{c['d'].max():.0f} | "
              f"{r / ratio0:.3f} | {c['img'].mean():.1f}, {np.percentile(c['img'], 99):.0f}")
    per = []
    for c in data:
        A = np.c_[np.ones(len(c['L'])), np.log(c['d'])]
        per.append(np.linalg.lstsq(A, np.log(c['L'] / c['cos']), rcond=None)[0][1])
    print('one exponent of d per capture (cos θᵢ held, exposure one constant within a capture): ' +
          ' '.join(f'd^{b:.2f}' for b in per))
    y = np.concatenate([np.log(c['L']) - np.log(c['cos']) + 2 * np.log(c['d']) for c in data])
    cap = np.concatenate([np.full(len(c['L']), c['k']) for c in data])
    logd = np.concatenate([np.log(c['d']) for c in data])
    fits = {
        'one factor per capture': np.stack([cap == k for k in range(len(data))], 1).astype(float),
        'one exponent of d for all': np.c_[np.ones(len(y)), logd],
    }
    for name, X in fits.items():
        coef = np.linalg.lstsq(X, y, rcond=None)[0]
        res = y - X @ coef
        rms = ' '.join(f'{np.sqrt(np.mean(res[cap == k] ** 2)):.3f}' for k in range(len(data)))
        extra = f'factors {np.round(np.exp(coef - coef[0]), 3)}' if name.startswith('one factor') else f'irradiance ∝ d^{coef[1] - 2:.2f}'
        print(f'{name}: rms of ln residual per capture {rms}; {extra}')
    # A paper brighter toward the backscatter direction (radiance ∝ phase^b) against a projector
    # whose irradiance falls slower than d^-2: the two are nearly collinear within a capture.
    print('phase angle between projector and camera per capture (deg): ' +
          ' '.join(f"{np.degrees(c['phase'].min()):.1f}–{np.degrees(c['phase'].max()):.1f}" for c in data))
    for name, col in (('phase', 'phase'), ('d', 'd')):
        line = []
        for src in data:
            A = np.c_[np.ones(len(src['L'])), np.log(src[col])]
            ys = np.log(src['L']) - np.log(src['cos']) + 2 * np.log(src['d'])
            coef = np.linalg.lstsq(A, ys, rcond=None)[0]
            pred = [np.mean(np.log(c['L']) - np.log(c['cos']) + 2 * np.log(c['d']) - coef[0] - coef[1] * np.log(c[col])) for c in data]
            line.append(f"{src['k']}: {name}^{coef[1]:.2f} → " + ' '.join(f'{v:+.3f}' for v in pred))
        print(f'fitted on one capture with a power of {name}, mean ln(measured / predicted) in each capture: ' + '; '.join(line))
    y3 = y + np.concatenate([3 * np.log(c['cos_p']) for c in data])
    X = fits['one factor per capture']
    coef = np.linalg.lstsq(X, y3, rcond=None)[0]
    res = y3 - X @ coef
    rms = ' '.join(f'{np.sqrt(np.mean(res[cap == k] ** 2)):.3f}' for k in range(len(data)))
    print(f'one factor per capture, projector of equal power per pixel (intensity ∝ 1/cos³θ_p, θ_p '
          f'{np.degrees(np.arccos(max(c["cos_p"].max() for c in data))):.1f}–{np.degrees(np.arccos(min(c["cos_p"].min() for c in data))):.1f}°): '
          f'rms of ln residual per capture {rms}; factors {np.round(np.exp(coef - coef[0]), 3)}')


if __name__ == '__main__':
    main(sys.argv[1:])
