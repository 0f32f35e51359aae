"""Gray-code structured light from Python: `gray_code_patterns` and `decode_gray_code` against
the definition of the code, the `lucent scan decode` command and (where installed) OpenCV's
reading of the frames."""

import json

import numpy as np
import pytest

import lucent
from conftest import ROOT, cli
from test_render import read_pfm

CAPTURE = ROOT.parent / "shared" / "data" / "structured-light" / "procam-sample" / "capture_0"


def test_patterns_are_the_gray_code_and_decode_to_every_projector_pixel():
    frames = lucent.gray_code_patterns((40, 24))
    # 6 column bits and 5 row bits, each with its inverse, then white and black.
    assert len(frames) == 24 and all(f.shape == (24, 40) and f.dtype == np.uint8 for f in frames)
    x, y = np.arange(40), np.arange(24)
    gx, gy = x ^ (x >> 1), y ^ (y >> 1)
    for k in range(6):
        assert np.array_equal(frames[2 * k][7] == 255, ((gx >> (5 - k)) & 1) == 1), k
        assert np.array_equal(frames[2 * k + 1], 255 - frames[2 * k])
    for k in range(5):
        assert np.array_equal(frames[12 + 2 * k][:, 3] == 255, ((gy >> (4 - k)) & 1) == 1), k
    assert (frames[-2] == 255).all() and (frames[-1] == 0).all()
    # Seen by a camera that is the projector, every pixel decodes to its own coordinate.
    r = lucent.decode_gray_code(frames, (40, 24))
    assert (r.width, r.height, r.valid_pixels, r.valid_fraction) == (40, 24, 960, 1.0)
    yy, xx = np.mgrid[0:24, 0:40]
    assert np.array_equal(r.column, xx.astype(np.float32)) and np.array_equal(r.row, yy.astype(np.float32))
    assert np.array_equal(r.white, np.full((24, 40), 255, np.float32)) and not r.black.any()
    # The same frames with white and black first, read as such: the same map.
    first = lucent.decode_gray_code(frames[-2:] + frames[:-2], (40, 24), white_black="first")
    assert np.array_equal(first.column, r.column) and np.array_equal(first.row, r.row)
    # With a step of 3, 14 × 8 codes: 4 + 3 bits.
    assert len(lucent.gray_code_patterns((40, 24), step=3)) == 16


def test_decode_equals_the_command_on_the_shared_capture(tmp_path):
    if not CAPTURE.is_dir():
        pytest.skip("the shared procam captures are not here")
    r = lucent.decode_gray_code(CAPTURE, (1024, 768))
    out = cli("scan", "decode", CAPTURE, "--projector", "1024x768", "--out", tmp_path / "map.pfm", "--json")
    assert out.returncode == 0, out.stderr
    want = json.loads(out.stdout)
    assert {k: r[k] for k in want} == want
    m = read_pfm(tmp_path / "map.pfm")
    assert np.array_equal(r.column, m[..., 0], equal_nan=True) and np.array_equal(r.row, m[..., 1], equal_nan=True)
    assert np.array_equal(r.white / 255, m[..., 2])
    # Integer decoding and other thresholds, as the command's flags.
    i = lucent.decode_gray_code(str(CAPTURE), (1024, 768), black_threshold=60, white_threshold=4, refine=False)
    out = cli("scan", "decode", CAPTURE, "--projector", "1024x768", "--black-threshold", "60", "--white-threshold", "4", "--no-refine", "--json")
    assert {k: i[k] for k in json.loads(out.stdout)} == json.loads(out.stdout)
    assert i.refined_column_pixels == 0 and np.array_equal(i.column, np.round(i.column), equal_nan=True)


def test_decode_frames_read_by_opencv():
    cv2 = pytest.importorskip("cv2")
    if not CAPTURE.is_dir():
        pytest.skip("the shared procam captures are not here")
    frames = [cv2.imread(str(CAPTURE / f"graycode_{i:02d}.png"), cv2.IMREAD_GRAYSCALE) for i in range(42)]
    a, b = lucent.decode_gray_code(frames, (1024, 768)), lucent.decode_gray_code(CAPTURE, (1024, 768))
    assert a.valid_pixels == b.valid_pixels
    assert np.array_equal(a.column, b.column, equal_nan=True) and np.array_equal(a.row, b.row, equal_nan=True)


def test_bad_captures_are_refused_on_one_line(tmp_path):
    frames = lucent.gray_code_patterns((40, 24))
    with pytest.raises(ValueError, match="frames: 23 images"):
        lucent.decode_gray_code(frames[:-1], (40, 24))
    with pytest.raises(ValueError, match="frame 3"):
        lucent.decode_gray_code(frames[:3] + [frames[3].astype(np.float32)] + frames[4:], (40, 24))
    with pytest.raises(ValueError, match="frame 5 is 20×24"):
        lucent.decode_gray_code(frames[:5] + [frames[5][:, :20].copy()] + frames[6:], (40, 24))
    with pytest.raises(ValueError, match="white_black"):
        lucent.decode_gray_code(frames, (40, 24), white_black="middle")
    with pytest.raises(ValueError, match="white_threshold"):
        lucent.decode_gray_code(frames, (40, 24), white_threshold=300)
    with pytest.raises(ValueError, match="projector_size"):
        lucent.gray_code_patterns((0, 24))
    with pytest.raises(OSError):
        lucent.decode_gray_code(tmp_path / "no-such-capture", (40, 24))


def rodrigues(r):
    r = np.asarray(r, dtype=float).ravel()
    th = np.linalg.norm(r)
    k = r / th
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * kx + (1 - np.cos(th)) * kx @ kx


def test_reconstruct_equals_the_command_and_lies_on_the_board(tmp_path):
    caps = [CAPTURE.parent / f"capture_{i}" for i in range(3)]
    if not all(c.is_dir() for c in caps):
        pytest.skip("the shared procam captures are not here")
    calib = lucent.calibrate_procam(caps, (1024, 768), (9, 7), 75.0)
    path = tmp_path / "calib.json"
    path.write_text(json.dumps(calib))
    r = lucent.reconstruct_gray_code(CAPTURE, calib)
    out = cli("scan", "reconstruct", CAPTURE, "--calibration", path, "--out", tmp_path / "c.ply", "--json")
    assert out.returncode == 0, out.stderr
    want = json.loads(out.stdout)
    assert {k: r[k] for k in want} == want
    ok = np.isfinite(r.xyz[..., 2])
    assert ok.sum() == r.points and r.xyz.shape == (1024, 1280, 3)
    # The same from the calibration file, with holes filled as --fill-holes 4 fills them.
    f = lucent.reconstruct_gray_code(str(CAPTURE), path, fill_holes=4)
    out = cli("scan", "reconstruct", CAPTURE, "--calibration", path, "--out", tmp_path / "f.ply", "--fill-holes", "4", "--json")
    assert {k: f[k] for k in json.loads(out.stdout)} == json.loads(out.stdout) and f.filled > 0
    # Physics: the points that the chessboard's pose (from the camera's own view of its corners)
    # puts on the board lie on its plane: the board's inner corners span (0…8, 0…6) squares.
    pose = calib.captures[0]
    rot, t = rodrigues(pose["rvec"]), np.asarray(pose["tvec"], dtype=float).ravel()
    board = (r.xyz[ok] - t) @ rot  # camera frame → board frame
    inside = (board[:, 0] > 0) & (board[:, 0] < 8 * 75) & (board[:, 1] > 0) & (board[:, 1] < 6 * 75)
    assert inside.sum() > 50_000
    z = board[inside, 2]
    # Two independent routes (triangulation through the projector, PnP of the camera's corners)
    # agree to about a millimetre (docs/digitization.md: median offset 0.1 mm, 10th–90th
    # percentiles within ±1.2 mm).
    assert abs(np.median(z)) < 1.0 and np.percentile(np.abs(z), 90) < 3.0, (np.median(z), np.percentile(np.abs(z), 90))
    with pytest.raises(ValueError, match="fill_holes"):
        lucent.reconstruct_gray_code(CAPTURE, path, fill_holes=65)
    with pytest.raises(OSError):
        lucent.reconstruct_gray_code(CAPTURE, tmp_path / "no-such.json")
