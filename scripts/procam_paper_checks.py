"""Three checks of what could make the paper of the procam captures depart from cos θᵢ / d².

Usage: python3 scripts/procam_paper_checks.py CALIB.json [--scan SCAN.ply] [--corners 9x7]
       [--square 75]

Needs numpy and pillow (the venv of scripts/test-python.sh has both). CALIB.json is what
`lucent scan calibrate` writes; SCAN.ply, optional, is the point cloud of `lucent scan
reconstruct` of the first capture (binary, x y z first), used to place the wall behind the board.

1. A gloss lobe. For every white-square point, θ_h is the angle between the board normal and the
   half vector of the directions to the projector and the camera. A specular lobe on top of a
   Lambertian paper makes the paper brighter, relative to cos θᵢ / d², where θ_h is small. The
   script prints ln(measured / (cos θᵢ / d²)), relative to the first capture's median, in six bins
   of θ_h per capture.
2. Light carried sideways by the print (a translucent sheet lit from behind by the wall it
   stands in front of, or any other transport over a distance). Where a coarse Gray-code frame
   (0, 1, 20, 21: the most significant column and row bits and their inverses) has its one
   edge on the paper, the frame's code divided by the white frame's (both minus the black frame)
   is profiled across the edge at the bright pixels, median over the rows (columns) that hold one
   edge. Light moved sideways over about the print-to-wall distance would raise the dark side
   and lower the lit side over that distance, by how much depending on that distance.
3. With --scan: the wall plane is fitted to the scanned points 40 to 300 units behind the first
   capture's board plane, and the residual of 1. is binned by each point's distance in front of
   the wall.
"""
import json, os, sys

import numpy as np
from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from procam_irradiance_check import load_calib, parse_options, project, rodrigues, sample, square_points  # noqa: E402


def frame(capture, index):
    path = os.path.join(capture, f'graycode_{index:02d}.png')
    return np.asarray(Image.open(path).convert('L')).astype(float)


def read_ply_xyz(path):
    with open(path, 'rb') as f:
        header, props, count, element = [], [], 0, None
        while True:
            line = f.readline()
            if not line:
                sys.exit(f'{path}: no end_header')
            line = line.strip().decode('ascii', 'replace')
            header.append(line)
            if line.startswith('element '):
                element = line.split()[1]
                if element == 'vertex':
                    count = int(line.split()[2])
            elif line.startswith('property') and element == 'vertex':
                props.append(line.split()[1:])
            if line == 'end_header':
                break
        if 'format binary_little_endian 1.0' not in header:
            sys.exit(f'{path}: only binary little-endian PLY is read')
        sizes = {'float': 'f4', 'double': 'f8', 'uchar': 'u1', 'int': 'i4', 'uint': 'u4', 'short': 'i2', 'ushort': 'u2'}
        dt = np.dtype([(name, '<' + sizes[kind]) for kind, name in props if kind in sizes])
        data = np.frombuffer(f.read(dt.itemsize * count), dtype=dt, count=count)
    return np.stack([data['x'], data['y'], data['z']], 1).astype(float)


def edge_profile(cap, index, white, black, offsets):
    img = frame(cap, index)
    den = white - black
    r = (img - black) / np.maximum(den, 1)
    bright = den > 0.8 * np.percentile(den, 90)
    columns = index < 20
    n = img.shape[0] if columns else img.shape[1]
    prof = {}
    for y in range(150, n - 150, 2):
        line, ok = (r[y, :], bright[y, :]) if columns else (r[:, y], bright[:, y])
        s = np.convolve(line, np.ones(5) / 5, 'same')
        idx = [i for i in np.where((s[:-1] - 0.5) * (s[1:] - 0.5) < 0)[0] if 100 < i < len(line) - 100]
        if len(idx) != 1:
            continue
        i0 = idx[0]
        sign = 1 if s[i0 + 5] > s[i0 - 5] else -1
        for dx in offsets:
            j = i0 + dx * sign
            if ok[j]:
                prof.setdefault(dx, []).append(line[j])
    return [np.median(prof[dx]) if len(prof.get(dx, [])) > 10 else float('nan') for dx in offsets]


def main(argv):
    opts, calib_path = parse_options(argv, {'--corners': '9x7', '--square': '75', '--scan': None}, __doc__.strip().splitlines()[2])
    calib = load_calib(calib_path)
    cols, rows = (int(v) for v in opts['--corners'].split('x'))
    sq = float(opts['--square'])
    Rp, Tp = np.array(calib['rotation']), np.array(calib['translation'])
    centre = -Rp.T @ Tp
    pts = square_points(cols, rows, sq)
    wall = None
    if opts['--scan']:
        try:
            X = read_ply_xyz(opts['--scan'])
        except (OSError, ValueError, KeyError) as e:
            sys.exit(f"{opts['--scan']}: not a binary PLY point cloud with x, y, z ({e})")
        R0, t0 = rodrigues(calib['captures'][0]['rvec']), np.array(calib['captures'][0]['tvec'])
        s = (X - t0) @ R0[:, 2]
        W = X[(s > 40) & (s < 300)]
        keep = np.ones(len(W), bool)
        for _ in range(4):
            c = W[keep].mean(0)
            nw = np.linalg.svd(W[keep] - c, full_matrices=False)[2][2]
            nw = nw if nw @ R0[:, 2] > 0 else -nw
            dist = (W - c) @ nw
            keep = np.abs(dist) < 2.5 * dist[keep].std()
        wall = (c, nw)
        print(f'wall: {keep.sum()} scanned points, normal {np.round(nw, 3)}, rms {dist[keep].std():.1f}')
    offsets = [-80, -40, -20, -10, -3, 3, 10, 20, 40, 80]
    ref = None
    for k, cap in enumerate(calib['captures']):
        R, t = rodrigues(cap['rvec']), np.array(cap['tvec'])
        X = np.c_[pts, np.zeros(len(pts))] @ R.T + t
        px = project(calib['camera'], X)
        white, black = frame(cap['name'], 40), frame(cap['name'], 41)
        w, b = sample(white, px), sample(black, px)
        n = R[:, 2]
        to_p = centre - X
        d = np.linalg.norm(to_p, axis=1)
        to_p /= d[:, None]
        to_c = -X / np.linalg.norm(X, axis=1)[:, None]
        n = n if (to_c @ n).mean() > 0 else -n
        h = to_p + to_c
        h /= np.linalg.norm(h, axis=1)[:, None]
        th = np.degrees(np.arccos(np.clip(h @ n, -1, 1)))
        paper = (w > 0.9 * np.median(w)) & (w < 250)
        res = np.log((w - b)[paper] / ((to_p @ n)[paper] / d[paper] ** 2))
        ref = np.median(res) if ref is None else ref
        res -= ref
        th = th[paper]
        edges = np.linspace(th.min(), th.max() + 1e-9, 7)
        bins = np.digitize(th, edges)
        print(f'capture {k}: ln(measured / (cos θᵢ / d²)) by θ_h: ' +
              ' '.join(f'{th[bins == i].mean():.1f}°: {res[bins == i].mean():+.3f}' for i in range(1, 7) if (bins == i).sum() > 5))
        if wall is not None:
            hw = ((wall[0] - X) @ wall[1])[paper]
            e = np.linspace(hw.min(), hw.max() + 1e-9, 7)
            bw = np.digitize(hw, e)
            print(f'capture {k}: the same by distance in front of the wall: ' +
                  ' '.join(f'{hw[bw == i].mean():.0f}: {res[bw == i].mean():+.3f}' for i in range(1, 7) if (bw == i).sum() > 5))
        for f in (0, 1, 20, 21):
            prof = edge_profile(cap['name'], f, white, black, offsets)
            print(f'capture {k}, frame {f:02d} across its edge (px, dark side negative): ' +
                  ' '.join(f'{dx}: {v:.3f}' for dx, v in zip(offsets, prof)))


if __name__ == '__main__':
    main(sys.argv[1:])
