"""Per-frame and total relative RMSE of a `lucent fit photo` run, as the tables of docs/digitization.md.

Usage: python3 scripts/procam_fit_table.py [--fitted 0-9,20-29,40,41] FIT.json [FIT.json ...]

One FIT.json: a markdown table with a row per frame (fitted or not, as --fitted lists the frames
given to `fit photo --fit-frames`, the walk-through's by default; the relative RMSE after each
step of the refinement; the full render with the fit; each predicted capture; each predicted
capture with one exposure factor, `exposure_matched`) and a row of totals. Several: one summary
line each (fitted capture, its full render's relative RMSE, each prediction and its ratio to the
fitted error, the exposure factors). Standard library only.
"""
import json, os, sys


def name_of(capture):
    return os.path.basename(os.path.normpath(capture))


def frame_set(spec):
    out = set()
    for part in spec.split(','):
        a, _, b = part.partition('-')
        out.update(range(int(a), int(b or a) + 1))
    return out


def table(d, fitted):
    steps = d['steps']
    preds = d.get('predict', [])
    head = ['frame', 'fitted'] + [s['name'] for s in steps] + ['full render']
    head += [f'{name_of(p["capture"])} predicted' for p in preds]
    head += [f'{name_of(p["capture"])}, one exposure' for p in preds]
    print('| ' + ' | '.join(head) + ' |')
    print('|' + '---|' * len(head))
    names = [f['name'] for f in d['verify']['frames']]
    def frame(block, n):
        for f in block['frames']:
            if f['name'] == n:
                return f['whole']['rel_rmse']
        return float('nan')
    for n in names:
        index = n.replace('graycode_', '')
        row = [index, 'yes' if index.isdigit() and int(index) in fitted else '']
        row += [f'{frame(s, n):.3f}' for s in steps] + [f'{frame(d["verify"], n):.3f}']
        row += [f'{frame(p, n):.3f}' for p in preds]
        row += [f'{frame(p["exposure_matched"], n):.3f}' for p in preds]
        print('| ' + ' | '.join(row) + ' |')
    row = [f'all {len(names)}', '']
    row += [f'{s["total"]["rel_rmse"]:.3f}' for s in steps] + [f'{d["verify"]["total"]["rel_rmse"]:.3f}']
    row += [f'{p["total"]["rel_rmse"]:.3f}' for p in preds]
    row += [f'{p["exposure_matched"]["total"]["rel_rmse"]:.3f} (×{p["exposure_matched"]["scale"]:.3f})' for p in preds]
    print('| ' + ' | '.join(row) + ' |')


def summary(path, d):
    own = d['verify']['total']['rel_rmse']
    parts = [f'{path}: fitted {own:.3f}']
    for p in d.get('predict', []):
        e = p['total']['rel_rmse']
        parts.append(f'{name_of(p["capture"])} {e:.3f} ({e / own:.2f}×, one exposure ×{p["exposure_matched"]["scale"]:.3f}: '
                     f'{p["exposure_matched"]["total"]["rel_rmse"]:.3f})')
    print('; '.join(parts))


def main(argv):
    fitted = frame_set('0-9,20-29,40,41')
    if len(argv) >= 2 and argv[0] == '--fitted':
        try:
            fitted = frame_set(argv[1])
        except ValueError:
            sys.exit(f'--fitted {argv[1]}: not a list of frames and ranges such as 0-9,20-29,40,41')
        argv = argv[2:]
    if not argv:
        sys.exit(__doc__.strip().splitlines()[2])
    runs = []
    for path in argv:
        try:
            with open(path) as f:
                runs.append((path, json.load(f)))
        except (OSError, ValueError) as e:
            sys.exit(f'{path}: {e}')
    if len(runs) == 1:
        table(runs[0][1], fitted)
    else:
        for path, d in runs:
            summary(path, d)


if __name__ == '__main__':
    main(sys.argv[1:])
