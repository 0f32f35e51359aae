"""lucent.milk and lucent.medium: equality with `lucent medium … --json`, scalar and array
wavelengths, a recipe as a file and as a dict, and bad arguments."""

import numpy as np
import pytest

import lucent
from conftest import ROOT, cli_json

ARRAYS = ("wavelength_nm", "sigma_s_per_mm", "sigma_a_per_mm", "sigma_t_per_mm", "g", "host_sigma_a_per_mm")


def same_as_cli(r, j):
    for k in ARRAYS:
        assert np.asarray(r[k]).tolist() == j[k], k
    assert r.name == j["name"]
    assert len(r.components) == len(j["components"])
    for c, cj in zip(r.components, j["components"]):
        assert c.name == cj["name"]
        for k in ("sigma_s_per_mm", "sigma_t_per_mm", "g"):
            assert np.asarray(c[k]).tolist() == cj[k], (c.name, k)
    if "phase_per_sr" in j:
        assert r.theta_deg.tolist() == j["theta_deg"]
        assert r.phase_per_sr.tolist() == j["phase_per_sr"]


def test_milk_equals_cli_json():
    j = cli_json("medium", "milk", "--fat-percent", 3.5, "--json")
    r = lucent.milk(3.5, phase_angles=0)
    same_as_cli(r, j)
    assert "phase_per_sr" not in r and r.sigma_s_per_mm.shape == (17,)


def test_milk_with_options_and_phase_table_equals_cli_json():
    j = cli_json("medium", "milk", "--fat-percent", 1.5, "--protein-percent", 3.1, "--pressure-mpa", 0,
                 "--wavelengths-nm", "450,550,650", "--phase-angles", 19, "--json")
    r = lucent.milk(1.5, 3.1, 0.0, wavelengths_nm=np.array([450.0, 550.0, 650.0]), phase_angles=19)
    same_as_cli(r, j)
    assert r.phase_per_sr.shape == (3, 19)


def test_milk_phase_table_is_normalised_and_has_mean_cosine_g():
    r = lucent.milk(1.5, wavelengths_nm=[450.0, 650.0], phase_angles=3601)
    mu = np.cos(np.radians(r.theta_deg))
    for row, g in zip(r.phase_per_sr, r.g):
        trap = lambda f: 2 * np.pi * np.sum(0.5 * (f[1:] + f[:-1]) * (mu[:-1] - mu[1:]))
        assert abs(trap(row) - 1) < 2e-3 and abs(trap(row * mu) - g) < 2e-3


def test_milk_scalar_wavelength_and_default_phase_table():
    r = lucent.milk(3.5, wavelengths_nm=550.0)
    assert r.wavelength_nm.tolist() == [550.0] and r.phase_per_sr.shape == (1, 181)
    full = lucent.milk(3.5, wavelengths_nm=[500.0, 550.0, 600.0])
    assert full.sigma_s_per_mm[1] == r.sigma_s_per_mm[0]
    # σ_t = σ_s + σ_a and σ'_s decreases with wavelength for milk
    assert np.allclose(full.sigma_t_per_mm, full.sigma_s_per_mm + full.sigma_a_per_mm, rtol=1e-12)
    sp = full.sigma_s_per_mm * (1 - full.g)
    assert np.all(np.diff(sp) < 0)


def test_recipe_file_and_dict_equal_cli_json():
    path = ROOT / "media" / "polystyrene-beads.toml"
    j = cli_json("medium", path, "--json")
    r = lucent.medium(path)
    same_as_cli(r, j)
    recipe = {
        "name": "beads",
        "wavelengths_nm": [450, 550, 650],
        "host": {"index": 1.333},
        "particle": [{"name": "polystyrene", "index": "1.59+0i", "volume_fraction": 0.001,
                      "size": {"distribution": "lognormal", "r_vs_um": 0.5, "c_s_um": 0.01}, "grid": {"bins": 200}}],
    }
    d = lucent.medium(recipe, phase_angles=0)
    f = lucent.medium(path, wavelengths_nm=[450.0, 550.0, 650.0], phase_angles=0)
    for k in ("sigma_s_per_mm", "sigma_a_per_mm", "g"):
        assert np.array_equal(d[k], f[k]), k
    assert d.name == "beads"


def test_skim_milk_recipe_reproduces_the_milk_model():
    """media/skim-milk.toml states it reproduces `lucent medium milk --fat-percent 0.1`."""
    r = lucent.medium(ROOT / "media" / "skim-milk.toml")
    m = lucent.milk(0.1, phase_angles=0)
    assert np.allclose(r.sigma_s_per_mm, m.sigma_s_per_mm, rtol=1e-9)
    assert np.allclose(r.g, m.g, rtol=1e-9)


@pytest.mark.parametrize(
    "call,exc,message",
    [
        (lambda: lucent.milk(-1.0), ValueError, "fat"),
        (lambda: lucent.milk(3.5, wavelengths_nm=[500.0, -1.0]), ValueError, "wavelengths_nm: wavelength"),
        (lambda: lucent.milk(3.5, wavelengths_nm=[]), ValueError, "wavelengths_nm: no wavelengths"),
        (lambda: lucent.milk(3.5, phase_angles=-1), ValueError, "phase_angles: must be a whole number"),
        (lambda: lucent.milk(3.5, phase_angles=10**6), ValueError, "phase_angles: at most"),
        (lambda: lucent.medium("/nonexistent/recipe.toml"), OSError, "cannot read recipe /nonexistent/recipe.toml"),
        (lambda: lucent.medium({"host": {"index": 1.33}, "colour": 3}), ValueError, "recipe: unknown field `colour`"),
        (lambda: lucent.medium(42), ValueError, "recipe: expected a file path or a dict"),
    ],
)
def test_bad_arguments(call, exc, message):
    with pytest.raises(exc) as e:
        call()
    assert message in str(e.value) and "\n" not in str(e.value)
