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
4. Light reflected onto the paper by the rest of the scene (the wall beside a turned board). In
   each of the five coarsest column and row bits (frames 0-9 and 20-29), a paper point is dark
   in one of the pattern and its inverse; there, more than 40 camera pixels from the lit region,
   (frame - black) / (white - black) is the indirect light from the lit half of the scene (plus
   the lens's stray light). Twice its mean over the 20 frame pairs estimates the indirect share
   I of the white frame (a random half of the scene is lit in each pair). The script prints I
   per capture and the level and within-capture exponent of d of 1. with the white frame's code
   scaled by (1 - I).
5. A sheen: with the codes of 4. (indirect light removed), a Lambertian paper plus a GGX lobe
   of roughness alpha (Smith shadowing, Fresnel of n = 1.5, weight k_s relative to the diffuse
   term) is fitted by a grid over alpha and k_s, on all captures together and on each capture
   alone; the latter prints the level it predicts for the other captures (mean ln residual,
   0 for a right prediction).
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


def box(a, r):
    """Sum of `a` over the (2r + 1)² window around each pixel, the window clipped at the image
    border (an integral image)."""
    h, w = a.shape
    ii = np.zeros((h + 1, w + 1))
    ii[1:, 1:] = np.cumsum(np.cumsum(a, 0), 1)
    y0, y1 = np.clip(np.arange(h) - r, 0, h), np.clip(np.arange(h) + r + 1, 0, h)
    x0, x1 = np.clip(np.arange(w) - r, 0, w), np.clip(np.arange(w) + r + 1, 0, w)
    return ii[y1][:, x1] - ii[y0][:, x1] - ii[y1][:, x0] + ii[y0][:, x0]


def far_from_edges(mask, r):
    """True where the (2r + 1)² window around a pixel lies wholly inside or wholly outside
    `mask` (the window clipped at the image border)."""
    s, area = box(mask.astype(float), r), box(np.ones(mask.shape), r)
    return (s == 0) | (s == area)


def indirect_share(cap, white, black, px, bits=5, margin=40):
    """Check 4: the indirect share I of the white frame at camera points `px` (nan where fewer
    than 3 frame pairs have the point far from a lit edge)."""
    den = np.maximum(white - black, 1)
    total, count = np.zeros(len(px)), np.zeros(len(px))
    for base in (0, 20):
        for j in range(bits):
            a, c = frame(cap, base + 2 * j), frame(cap, base + 2 * j + 1)
            ra, rc = (a - black) / den, (c - black) / den
            lit = ra > rc
            dark = np.where(lit, rc, ra)
            v, ok = sample(dark, px), sample(far_from_edges(lit, margin).astype(float), px) > 0.99
            total[ok] += v[ok]
            count[ok] += 1
    return np.where(count >= 3, 2 * total / np.maximum(count, 1), np.nan)


def ggx_sheen(cos_i, cos_v, cos_h, cos_d, alpha, n=1.5):
    """GGX lobe (Smith shadowing, unpolarised Fresnel of a dielectric of index n) times π, so
    that 1 + k_s · this is the paper's radiance relative to its diffuse term."""
    a2 = alpha * alpha
    D = a2 / (np.pi * (cos_h ** 2 * (a2 - 1) + 1) ** 2)

    def g1(c):
        return 2 / (1 + np.sqrt(1 + a2 * (1 - c * c) / (c * c)))
    ct = np.sqrt(np.maximum(0, 1 - (1 - cos_d ** 2) / n ** 2))
    F = (((cos_d - n * ct) / (cos_d + n * ct)) ** 2 + ((ct - n * cos_d) / (ct + n * cos_d)) ** 2) / 2
    return np.pi * D * g1(cos_i) * g1(cos_v) * F / (4 * cos_i * cos_v)


def sheen_fit(geo, rows, alphas, ks_grid):
    """Best (rms, alpha, k_s, per-capture mean residual) over the grid for ln(code / (cos θᵢ / d²))
    = level + ln(1 + k_s · lobe), the level fitted on `rows` (indices into the global lists)."""
    best = None
    for a in alphas:
        lobes = [ggx_sheen(g['cos'], g['cos_v'], g['cos_h'], g['cos_d'], a) for g in geo]
        for ks in ks_grid:
            res = [g['y'] - np.log1p(ks * lobe) for g, lobe in zip(geo, lobes)]
            fitted = np.concatenate([res[k] for k in rows])
            level = fitted.mean()
            e = np.sqrt(np.mean((fitted - level) ** 2))
            if best is None or e < best[0]:
                best = (e, a, ks, [float(np.mean(r - level)) for r in res])
    return best



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
    geo = []
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
        share = indirect_share(cap['name'], white, black, px)[paper]
        ok = np.isfinite(share)
        cos_v = to_c @ n
        geo.append(dict(k=k, share=share[ok], d=d[paper][ok], cos=(to_p @ n)[paper][ok], cos_v=cos_v[paper][ok],
                        cos_h=(h @ n)[paper][ok], cos_d=np.sum(h * to_p, 1)[paper][ok],
                        raw=np.log((w - b)[paper][ok] / ((to_p @ n)[paper][ok] / d[paper][ok] ** 2))))
    print('indirect share I of the white frame (check 4), and ln(code / (cos θᵢ / d²)) before and after removing it:')
    ref = {}
    for g in geo:
        g['y'] = g['raw'] + np.log(1 - g['share'])
        for key in ('raw', 'y'):
            ref.setdefault(key, np.median(g[key]))
        A = np.c_[np.ones(len(g['d'])), np.log(g['d'])]
        e_raw, e_cor = (np.linalg.lstsq(A, g[key], rcond=None)[0][1] - 2 for key in ('raw', 'y'))
        print(f"capture {g['k']}: I median {np.median(g['share']):.3f} (10th-90th percentile "
              f"{np.percentile(g['share'], 10):.3f}-{np.percentile(g['share'], 90):.3f}); level relative to capture 0 "
              f"{np.exp(np.median(g['raw']) - ref['raw']):.3f} -> {np.exp(np.median(g['y']) - ref['y']):.3f}; "
              f"exponent of d within the capture {e_raw:.2f} -> {e_cor:.2f}; correlation of I with d {np.corrcoef(g['share'], g['d'])[0, 1]:.2f}")
    alphas, ks_grid = [0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.6, 0.8], np.linspace(0, 40, 401)
    print('sheen (check 5), on the codes without indirect light; rms of the ln residual, alpha, k_s, mean ln residual per capture:')
    flat = np.concatenate([g['y'] for g in geo])
    print(f'  Lambertian, all captures: {np.sqrt(np.mean((flat - flat.mean()) ** 2)):.3f}, ' +
          ' '.join(f"{np.mean(g['y'] - flat.mean()):+.3f}" for g in geo))
    for name, rows in [('all captures', list(range(len(geo))))] + [(f'capture {k} alone', [k]) for k in range(len(geo))]:
        e, a, ks, means = sheen_fit(geo, rows, alphas, ks_grid)
        print(f'  {name}: {e:.3f}, alpha {a:.2f}, k_s {ks:.1f}, ' + ' '.join(f'{m:+.3f}' for m in means))
        if name == 'all captures':
            share = [np.median(ks * ggx_sheen(g['cos'], g['cos_v'], g['cos_h'], g['cos_d'], a)) for g in geo]
            print('    median share of that sheen in the white code: ' + ' '.join(f'{x / (1 + x):.3f}' for x in share))


if __name__ == '__main__':
    main(sys.argv[1:])
