"""Scene of a calibrated chessboard capture for `lucent fit photo`, labelled from the board geometry.

Usage: python3 scripts/procam_board_scene.py CALIB.json CAPTURE_INDEX OUT_DIR
       [--corners 9x7] [--square 75] [--margin 0.4] [--first black|white] [--pattern PNG]
       [--reference I]

CALIB.json is what `lucent scan calibrate` writes (lengths in the unit of its `--square`, which
`--square` here must repeat); the board
pose of capture CAPTURE_INDEX (`captures[i].rvec`, `tvec`, board -> camera) places the board
plane. The squares are known from that pose, so the labels need no segmentation:

  label0  the black squares       (OUT_DIR/board<i>_label0.ply)
  label1  the white squares       (OUT_DIR/board<i>_label1.ply)
  label2  the paper margin: a band `--margin` squares wide around the squares (default 0.4)

Squares are numbered from the board origin (corner 0 of the calibration); square (0, 0) spans
corners 0, 1, cols, cols + 1 and is `--first` (default black). The meshes are ASCII PLY in
camera coordinates (square units), as the labelling tool's `<stem>_label<k>.ply`; the scene
(OUT_DIR/scene<i>.toml) has the calibration's camera, the projector as a light (its calibration
with matrix_node = "projector", showing `--pattern`, default a white image written beside), a
constant environment as the ambient term (both D65 white, linear sRGB (1, 1, 1)), and starting albedos 0.05 / 0.7 / 0.7. The projector
intensity is chosen so that an albedo of 0.7 at the board centre of capture `--reference`
(default 0) would read about 0.5 linear; it is the same for every CAPTURE_INDEX of one
calibration, since one projector lit every capture (a scene of another capture predicts it only
with the same light).
"""
import json, math, os, sys, struct, zlib


def rodrigues(r):
    th = math.sqrt(sum(v * v for v in r))
    if th < 1e-15:
        return [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    k = [v / th for v in r]
    c, s, C = math.cos(th), math.sin(th), 1 - math.cos(th)
    x, y, z = k
    return [[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
            [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
            [z * x * C - y * s, z * y * C + x * s, c + z * z * C]]


def write_white_png(path, w, h):
    raw = b''.join(b'\x00' + b'\xff' * w for _ in range(h))
    chunk = lambda t, d: struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
    png = b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 0, 0, 0, 0)) + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b'')
    open(path, 'wb').write(png)


def main(argv):
    args = [a for a in argv]
    opts = {'--corners': '9x7', '--square': '75', '--margin': '0.4', '--first': 'black', '--pattern': None, '--reference': '0'}
    pos = []
    i = 0
    while i < len(args):
        if args[i] in opts:
            if i + 1 >= len(args):
                sys.exit(f'{args[i]} needs a value')
            opts[args[i]] = args[i + 1]
            i += 2
        else:
            pos.append(args[i])
            i += 1
    if len(pos) != 3:
        sys.exit(__doc__.strip().splitlines()[2])
    calib_path, idx, out = pos[0], int(pos[1]), pos[2]
    cols, rows = (int(v) for v in opts['--corners'].split('x'))
    margin = float(opts['--margin'])
    sq = float(opts['--square'])
    calib = json.load(open(calib_path))
    cap = calib['captures'][idx]
    R, t = rodrigues(cap['rvec']), cap['tvec']
    os.makedirs(out, exist_ok=True)
    to_cam = lambda x, y: [R[r][0] * x * sq + R[r][1] * y * sq + t[r] for r in range(3)]
    # Squares: (cols + 1) x (rows + 1), square (i, j) spans [i-1, i] x [j-1, j] in corner units.
    quads = {0: [], 1: [], 2: []}
    first_black = opts['--first'] == 'black'
    for j in range(-1, rows):
        for i in range(-1, cols):
            black = ((i + j) % 2 == 0) == first_black
            quads[0 if black else 1].append([(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)])
    x0, y0, x1, y1 = -1 - margin, -1 - margin, cols + margin, rows + margin
    xa, ya, xb, yb = -1, -1, cols, rows
    quads[2] += [[(x0, y0), (x1, y0), (x1, ya), (x0, ya)], [(x0, yb), (x1, yb), (x1, y1), (x0, y1)],
                 [(x0, ya), (xa, ya), (xa, yb), (x0, yb)], [(xb, ya), (x1, ya), (x1, yb), (xb, yb)]]
    names = []
    for k, qs in quads.items():
        verts, faces = [], []
        for q in qs:
            base = len(verts)
            verts += [to_cam(x, y) for x, y in q]
            faces += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
        name = f'board{idx}_label{k}.ply'
        with open(os.path.join(out, name), 'w') as f:
            f.write(f'ply\nformat ascii 1.0\nelement vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n'
                    f'element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n')
            for v in verts:
                f.write(f'{v[0]:.6f} {v[1]:.6f} {v[2]:.6f}\n')
            for a, b, c in faces:
                f.write(f'3 {a} {b} {c}\n')
        names.append(name)
    # Projector centre in camera coordinates: -R^T T.
    Rp, T = calib['rotation'], calib['translation']
    cp = [-(Rp[0][r] * T[0] + Rp[1][r] * T[1] + Rp[2][r] * T[2]) for r in range(3)]
    ref = calib['captures'][int(opts['--reference'])]
    Rr, tr = rodrigues(ref['rvec']), ref['tvec']
    centre = [Rr[r][0] * (cols / 2 - 0.5) * sq + Rr[r][1] * (rows / 2 - 0.5) * sq + tr[r] for r in range(3)]
    r2 = sum((centre[r] - cp[r]) ** 2 for r in range(3))
    intensity = 0.5 * math.pi * r2 / 0.7
    pw, ph = calib['projector']['width'], calib['projector']['height']
    pattern = opts['--pattern']
    if pattern is None:
        pattern = 'white.png'
        write_white_png(os.path.join(out, pattern), pw, ph)
    calib_rel = os.path.relpath(os.path.abspath(calib_path), os.path.abspath(out))
    pattern_rel = os.path.relpath(os.path.abspath(os.path.join(out, pattern)) if opts['--pattern'] is None else os.path.abspath(pattern), os.path.abspath(out))
    albedo = {0: 0.05, 1: 0.7, 2: 0.7}
    toml = [f'# {cap["name"]} of {calib_path}: board plane from the calibration, labels from the squares (scripts/procam_board_scene.py)',
            '[camera]', f'calibration = "{calib_rel}"', '', '[integrator]', 'type = "direct"', '']
    for k in range(3):
        toml += [f'[materials.label{k}]', 'type = "lambertian"', f'albedo = {albedo[k]}', '']
    for k, name in enumerate(names):
        toml += ['[[objects]]', f'name = "{["black_squares", "white_squares", "margin"][k]}"', f'material = "label{k}"', f'mesh = "{name}"', '']
    toml += ['[[lights]]', 'type = "projector"', f'image = "{pattern_rel}"', f'intensity = {{ rgb = [1, 1, 1], scale = {intensity:.6g} }}',
             f'camera = {{ calibration = "{calib_rel}", matrix_node = "projector" }}', '',
             '[[lights]]', 'type = "environment"', 'radiance = { rgb = [1, 1, 1], scale = 0.01 }', '']
    path = os.path.join(out, f'scene{idx}.toml')
    open(path, 'w').write('\n'.join(toml))
    print(path)


if __name__ == '__main__':
    main(sys.argv[1:])
