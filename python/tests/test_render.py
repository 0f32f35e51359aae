"""lucent.Scene: the Cornell box rendered from Python equals `lucent render` bit for bit;
progress callback, GIL released, Ctrl-C and bad arguments."""

import os
import signal
import threading
import time

import numpy as np
import pytest

import lucent
from conftest import ROOT, cli


def read_pfm(path) -> np.ndarray:
    with open(path, "rb") as f:
        data = f.read()
    parts = data.split(b"\n", 3)
    assert parts[0] == b"PF"
    w, h = map(int, parts[1].split())
    scale = float(parts[2])
    dtype = "<f4" if scale < 0 else ">f4"
    img = np.frombuffer(parts[3], dtype=dtype, count=w * h * 3).reshape(h, w, 3)
    return img[::-1].astype(np.float32)  # PFM rows run bottom to top


def test_cornell_box_equals_cli_bit_for_bit(tmp_path):
    out = tmp_path / "cli.pfm"
    r = cli("render", "--spp", 4, "--width", 48, "--height", 40, "--seed", 11, "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    ref = read_pfm(out)
    img = lucent.Scene.cornell_box().render(spp=4, width=48, height=40, seed=11)
    assert img.dtype == np.float32 and img.shape == (40, 48, 3)
    assert np.array_equal(img.view(np.uint32), ref.view(np.uint32))
    # the same scene from its file, and from its text
    path = ROOT / "scenes" / "cornell-box.toml"
    from_file = lucent.Scene.load(path).render(spp=4, width=48, height=40, seed=11)
    assert np.array_equal(from_file, img)
    text = path.read_text()
    from_text = lucent.Scene.from_toml(text, name="cornell", base_dir=path.parent).render(spp=4, width=48, height=40, seed=11)
    assert np.array_equal(from_text, img)


def test_scene_file_with_integrator_and_threads_equals_cli(tmp_path):
    path = ROOT / "scenes" / "cornell-box.toml"
    out = tmp_path / "direct.pfm"
    r = cli("render", path, "--spp", 2, "--width", 32, "--seed", 5, "--integrator", "direct", "--threads", 1, "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    scene = lucent.Scene.load(path)
    img = scene.render(spp=2, width=32, seed=5, integrator="direct", threads=1)
    assert np.array_equal(img, read_pfm(out))
    # the scene keeps its own resolution after a render at another size
    assert scene.resolution == lucent.Scene.load(path).resolution


def test_seeds_differ_and_image_is_plausible():
    s = lucent.Scene.cornell_box()
    a = s.render(spp=2, width=32, height=32, seed=0)
    b = s.render(spp=2, width=32, height=32, seed=1)
    assert not np.array_equal(a, b)
    # linear sRGB of spectral colours may dip slightly below 0 (outside the sRGB gamut)
    assert np.all(np.isfinite(a)) and a.min() > -0.5 and 0.01 < a.mean() < 10


def test_progress_is_called_per_pass_and_can_stop():
    calls = []
    s = lucent.Scene.cornell_box()
    s.render(spp=5, width=16, height=16, progress=lambda done, total, elapsed: calls.append((done, total, elapsed)))
    assert [c[0] for c in calls] == [1, 2, 3, 4, 5] and all(c[1] == 5 for c in calls)
    assert all(c2[2] >= c1[2] for c1, c2 in zip(calls, calls[1:]))
    stops = []
    img = s.render(spp=1000, width=16, height=16, progress=lambda done, total, elapsed: stops.append(done) or done < 3)
    assert stops[-1] == 3 and img.shape == (16, 16, 3)


def test_progress_exception_propagates():
    def boom(done, total, elapsed):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        lucent.Scene.cornell_box().render(spp=100, width=16, height=16, progress=boom)


def test_render_releases_the_gil():
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    try:
        start = len(ticks)
        lucent.Scene.cornell_box().render(time_s=0.5, width=64, height=64)
        during = len(ticks) - start
    finally:
        stop.set()
        t.join()
    # a thread blocked by the GIL would not run at all; 10 leaves room for a loaded machine
    assert during > 10, f"another Python thread ran only {during} times during a 0.5 s render"


@pytest.mark.skipif(os.name != "posix", reason="SIGINT delivery")
def test_ctrl_c_stops_the_render():
    # A process started in the background by a non-interactive shell inherits SIGINT ignored, and
    # Python then installs no KeyboardInterrupt handler: install Python's own for this test.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
        start = time.monotonic()
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            lucent.Scene.cornell_box().render(spp=100000, width=64, height=64)
        assert time.monotonic() - start < 20
    finally:
        signal.signal(signal.SIGINT, previous)


@pytest.mark.parametrize(
    "call,exc,message",
    [
        (lambda: lucent.Scene.load("/nonexistent/scene.toml"), OSError, "/nonexistent/scene.toml: cannot read scene"),
        (lambda: lucent.Scene.from_toml("[camera]\nfov_deg = 'wide'\n", name="bad.toml"), ValueError, "bad.toml"),
        (lambda: lucent.Scene.cornell_box().render(spp=0), ValueError, "spp must be a whole number ≥ 1"),
        (lambda: lucent.Scene.cornell_box().render(spp=1, integrator="bidir"), ValueError, "integrator must be"),
        (lambda: lucent.Scene.cornell_box().render(spp=1, width=0), ValueError, "width must be a whole number ≥ 1"),
        (lambda: lucent.Scene.cornell_box().render(spp=1, time_s=1.0), ValueError, "give spp or time_s, not both"),
        (lambda: lucent.Scene.cornell_box().render(time_s=-1.0), ValueError, "time_s must be a number of seconds > 0"),
        (lambda: lucent.Scene.cornell_box().render(spp=1, width=100000, height=100000), ValueError, "is too large"),
    ],
)
def test_bad_arguments(call, exc, message):
    with pytest.raises(exc) as e:
        call()
    assert message in str(e.value) and "\n" not in str(e.value)


def test_negative_numbers_are_rejected_by_type():
    with pytest.raises((OverflowError, TypeError, ValueError)):
        lucent.Scene.cornell_box().render(spp=-5)


def test_density_grid_written_from_numpy_renders_as_the_inline_grid(tmp_path):
    """write_vol / read_vol round trip, and a scene whose medium reads the written file renders bit
    for bit as the same grid given inline (values x fastest); bad grids raise ValueError."""
    rng = np.random.default_rng(3)
    d = rng.uniform(0.0, 2.0, size=(3, 2, 4))  # (nz, ny, nx)
    lucent.write_vol(tmp_path / "g.vol", d, (-1, -1, -1), (1, 1, 1))
    back, lo, hi = lucent.read_vol(tmp_path / "g.vol")
    assert back.shape == (3, 2, 4) and np.array_equal(back, d.astype(np.float32))
    assert list(lo) == [-1, -1, -1] and list(hi) == [1, 1, 1]
    inline = ", ".join(repr(float(v)) for v in d.astype(np.float32).ravel())

    def scene(density):
        return f"""unit = "mm"
[camera]
eye = [0, 0, -5]
look_at = [0, 0, 0]
vfov_deg = 30
width = 12
height = 12
[integrator]
type = "volpath"
[materials.m]
type = "interface"
[[objects]]
material = "m"
sphere = {{ center = [0, 0, 0], radius = 1 }}
medium = {{ sigma_a_per_mm = 0.2, sigma_s_per_mm = 1.5, g = 0.3, density = {density} }}
[[lights]]
type = "environment"
radiance = 1
"""
    a = lucent.Scene.from_toml(scene('{ file = "g.vol" }'), base_dir=tmp_path).render(spp=2, seed=4)
    b = lucent.Scene.from_toml(scene(f"{{ resolution = [4, 2, 3], values = [{inline}], min = [-1, -1, -1], max = [1, 1, 1] }}")).render(spp=2, seed=4)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, lucent.Scene.from_toml(scene('{ file = "g.vol", scale = 0.5 }'), base_dir=tmp_path).render(spp=2, seed=4))
    with pytest.raises(ValueError, match="density"):
        lucent.write_vol(tmp_path / "bad.vol", -d)
    with pytest.raises(ValueError, match="min, max"):
        lucent.write_vol(tmp_path / "bad.vol", d, (0, 0, 0), (1, 0, 1))
    (tmp_path / "short.vol").write_bytes((tmp_path / "g.vol").read_bytes()[:60])
    with pytest.raises(ValueError, match="float32"):
        lucent.read_vol(tmp_path / "short.vol")
    with pytest.raises(ValueError, match="density.file"):
        lucent.Scene.from_toml(scene('{ file = "short.vol" }'), base_dir=tmp_path)
    # A grid of colours for the albedo: an (nz, ny, nx, 3) array round trips, and the scene that
    # reads it renders as the same colours inline ([r, g, b] per cell, x fastest).
    c = rng.uniform(0.0, 1.0, size=(3, 2, 4, 3))
    lucent.write_vol(tmp_path / "rgb.vol", c, (-1, -1, -1), (1, 1, 1))
    back, _, _ = lucent.read_vol(tmp_path / "rgb.vol")
    assert back.shape == (3, 2, 4, 3) and np.array_equal(back, c.astype(np.float32))
    triples = ", ".join("[" + ", ".join(repr(float(v)) for v in cell) + "]" for cell in c.astype(np.float32).reshape(-1, 3))
    a = lucent.Scene.from_toml(scene('{ file = "g.vol", albedo = { file = "rgb.vol" } }'), base_dir=tmp_path).render(spp=2, seed=4)
    b = lucent.Scene.from_toml(scene(f'{{ file = "g.vol", albedo = {{ resolution = [4, 2, 3], values = [{triples}], min = [-1, -1, -1], max = [1, 1, 1] }} }}'), base_dir=tmp_path).render(spp=2, seed=4)
    assert np.array_equal(a, b)
    with pytest.raises(ValueError, match="one value per cell"):
        lucent.Scene.from_toml(scene('{ file = "rgb.vol" }'), base_dir=tmp_path)
    with pytest.raises(ValueError, match="density"):
        lucent.write_vol(tmp_path / "bad.vol", np.ones((2, 2, 2, 2)))
