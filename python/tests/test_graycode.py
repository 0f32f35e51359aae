"""Gray-code structured light from Python: `gray_code_patterns` and `decode_gray_code` against
the definition of the code, the `lucent scan decode` command and (where installed) OpenCV's
reading of the frames."""

import json

import numpy as np
import pytest

import lucent
from conftest import ROOT, cli

CAPTURE = ROOT.parent / "shared" / "data" / "structured-light" / "procam-sample" / "capture_0"


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        a = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    return a.reshape(h, w, 3 if kind == b"PF" else 1)[::-1]


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
    with pytest.raises(ValueError, match="image 5"):
        lucent.decode_gray_code(frames[:5] + [frames[5][:, :20].copy()] + frames[6:], (40, 24))
    with pytest.raises(ValueError, match="white_black"):
        lucent.decode_gray_code(frames, (40, 24), white_black="middle")
    with pytest.raises(ValueError, match="white_threshold"):
        lucent.decode_gray_code(frames, (40, 24), white_threshold=300)
    with pytest.raises(ValueError, match="projector_size"):
        lucent.gray_code_patterns((0, 24))
    with pytest.raises(OSError):
        lucent.decode_gray_code(tmp_path / "no-such-capture", (40, 24))
