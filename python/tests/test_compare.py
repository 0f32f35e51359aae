"""lucent.compare: the metrics of `lucent compare --json` on arrays, masks, colour fits."""

import numpy as np
import pytest

import lucent
from conftest import cli_json
from test_render import read_pfm


def write_pfm(path, img):
    h, w, _ = img.shape
    with open(path, "wb") as f:
        f.write(f"PF\n{w} {h}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(img[::-1], dtype="<f4").tobytes())


def images():
    rng = np.random.default_rng(4)
    a = rng.uniform(0.05, 0.9, (24, 32, 3)).astype(np.float32)
    b = np.clip(a * np.array([1.1, 0.95, 0.9], dtype=np.float32) + rng.normal(0, 0.01, a.shape).astype(np.float32), 0, None)
    return a, b.astype(np.float32)


def test_identical_images():
    a, _ = images()
    r = lucent.compare(a, a)
    assert r.rmse == 0 and r.psnr_db is None and r.ssim == pytest.approx(1.0) and r.delta_e2000_mean == 0
    assert r.pixels == 24 * 32 and r.delta_e2000_map.shape == (24, 32)


@pytest.mark.parametrize("extra", [[], ["--color-correct"], ["--color-correct", "affine"]])
def test_equals_cli_json(tmp_path, extra):
    a, b = images()
    pa, pb, pm = tmp_path / "a.pfm", tmp_path / "b.pfm", tmp_path / "m.pfm"
    write_pfm(pa, a)
    write_pfm(pb, b)
    mask = np.zeros((24, 32, 3), np.float32)
    mask[4:20, 6:30] = 1
    write_pfm(pm, mask)
    assert np.array_equal(read_pfm(pa), a)
    j = cli_json("compare", pa, pb, "--mask", pm, *extra, "--json")
    cc = {0: None, 1: True, 2: "affine"}[len(extra)]
    r = lucent.compare(a, b, mask=mask, color_correct=cc)
    for k, v in j.items():
        assert r[k] == v, k
    # the same mask as booleans
    r2 = lucent.compare(a, b, mask=mask[..., 0] > 0.5, color_correct=cc)
    assert r2.rmse == r.rmse and r2.pixels == 16 * 24


def test_float64_input_is_compared_in_float32():
    a, b = images()
    assert lucent.compare(a.astype(np.float64), b).rmse == lucent.compare(a, b).rmse


@pytest.mark.parametrize(
    "call,message",
    [
        (lambda a, b: lucent.compare(a, b[:10]), "b: image is 32×10 but a is 32×24"),
        (lambda a, b: lucent.compare(a[..., 0], b), "a: expected an (H, W, 3) array"),
        (lambda a, b: lucent.compare(a, b, mask=np.zeros((24, 32), bool)), "mask: selects no pixels"),
        (lambda a, b: lucent.compare(a, b, mask=np.ones((3, 3))), "mask: expected an (24, 32) bool array"),
        (lambda a, b: lucent.compare(a, b, color_correct="cubic"), "unknown colour model `cubic`"),
        (lambda a, b: lucent.compare(np.full_like(a, np.nan), b), "non-finite"),
    ],
)
def test_bad_arguments(call, message):
    a, b = images()
    with pytest.raises(ValueError) as e:
        call(a, b)
    assert message in str(e.value)
