"""lucent.dipole, lucent.slab, lucent.fit_reflectance and lucent.fit_particles: equality with
the command's JSON, broadcasting, round trips with known truth, and bad arguments."""

import numpy as np
import pytest

import lucent
from conftest import ROOT, cli_json

DIPOLE_KEYS = ("eta", "sigma_s_per_mm", "sigma_a_per_mm", "g", "alpha_prime", "sigma_tr_per_mm", "d_mm", "a", "rd", "rd_closed_form")


@pytest.mark.parametrize("model", ["standard", "directional", "directional-corrected"])
def test_dipole_equals_cli_json(model):
    j = cli_json("bssrdf", "--model", model, "--eta", 1.3, "--sigma-s-per-mm", 2.29, "--sigma-a-per-mm", 0.003, "--g", 0.1,
                 "--rd", "--profile-mm", "0,0.5,1,4", "--json")
    r = lucent.dipole(1.3, 2.29, 0.003, 0.1, model=model, rd=True, profile_mm=[0.0, 0.5, 1.0, 4.0])
    for k in DIPOLE_KEYS:
        assert float(r[k]) == j[k], k
    assert r.profile.tolist() == j["profile"] and r.profile_mm.tolist() == j["profile_mm"] and r.model == model


def test_dipole_standard_rd_matches_closed_form_and_broadcasts():
    """Jensen et al. 2001's apple (red): Rd = 0.85 published; numerical π∫S_d dA = closed form."""
    sa = np.array([0.003, 0.01, 0.1])[:, None]
    eta = np.array([1.0, 1.3])
    r = lucent.dipole(eta, 2.29, sa)
    assert r.rd.shape == (3, 2) and "profile" not in r
    assert np.allclose(r.rd, r.rd_closed_form, rtol=2e-4)
    assert abs(r.rd_closed_form[0, 1] - 0.85) < 0.005
    p = lucent.dipole(1.3, [1.0, 2.0], 0.01, profile_mm=np.array([[0.1, 1.0], [2.0, 3.0]]))
    assert p.profile.shape == (2, 2, 2) and "rd" not in p
    assert np.all(np.diff(p.profile.reshape(2, 4), axis=1) < 0)


def test_dipole_bad_arguments():
    with pytest.raises(ValueError, match="model: unknown dipole model 'quadrupole'"):
        lucent.dipole(1.3, 1.0, 0.01, model="quadrupole")
    with pytest.raises(ValueError, match="invalid medium"):
        lucent.dipole(1.3, -1.0, 0.01)
    with pytest.raises(ValueError, match="profile_mm: distance -1"):
        lucent.dipole(1.3, 1.0, 0.01, profile_mm=[-1.0])


SLAB_DETERMINISTIC = ("specular", "rd", "rd_stderr", "absorbed", "absorbed_stderr", "absorbed_per_layer", "tt", "tt_stderr",
                      "roulette_gain", "photons_truncated", "truncated_weight", "max_steps_per_photon", "photons", "seed",
                      "incidence_deg", "rd_centroid_x_mm", "n_above", "n_below", "photon_steps")


def test_slab_equals_cli_json():
    j = cli_json("slab", "--layer", "1,9,0.75,1.4,0.2", "--layer", "0.5,20,0.9,1.37,inf", "--photons", 20000, "--seed", 7,
                 "--radial-bins", 8, "--json")
    r = lucent.slab([(1, 9, 0.75, 1.4, 0.2), {"sigma_a_per_mm": 0.5, "sigma_s_per_mm": 20, "g": 0.9, "n": 1.37, "thickness_mm": "inf"}],
                    photons=20000, seed=7, radial_bins=8)
    for k in SLAB_DETERMINISTIC:
        assert np.asarray(r[k]).tolist() == j[k], k
    for k in ("r_mm", "rd_per_mm2", "rd_per_mm2_stderr", "dr_mm", "rd_beyond_max"):
        assert np.asarray(r.radial[k]).tolist() == j["radial"][k], k
    assert r.layers[1].thickness_mm == float("inf") and j["layers"][1]["thickness_mm"] == "inf"
    for k in ("seconds", "threads", "photon_steps_per_s", "photon_steps_per_s_per_thread"):
        assert k in r


def test_slab_energy_is_conserved_and_threads_do_not_change_results():
    a = lucent.slab([(0.1, 10, 0.9, 1.4, 1.0)], photons=20000, seed=3, threads=1)
    b = lucent.slab([(0.1, 10, 0.9, 1.4, 1.0)], photons=20000, seed=3)
    assert a.rd == b.rd and a.tt == b.tt
    total = a.specular + a.rd + a.absorbed + a.tt + a.truncated_weight
    assert abs(total - 1) < 1e-9


def test_slab_bad_arguments():
    with pytest.raises(ValueError, match=r"layers\[0\]: expected 5 values"):
        lucent.slab([(1, 2, 3)])
    with pytest.raises(ValueError, match=r"layers\[0\]: only the last layer may be semi-infinite"):
        lucent.slab([(1, 9, 0.7, 1.4, "inf"), (1, 9, 0.7, 1.4, 1.0)])
    with pytest.raises(ValueError, match=r"layers\[0\]"):
        lucent.slab([(1, 9, 1.5, 1.4, 1.0)])
    with pytest.raises(ValueError, match="radial_max_mm needs radial_bins"):
        lucent.slab([(1, 9, 0.7, 1.4, 1.0)], radial_max_mm=3.0)
    with pytest.raises(ValueError, match="layers: at least one layer"):
        lucent.slab([])


def write_csv(path, r, v, se=None):
    with open(path, "w") as f:
        f.write("r_mm,reflectance" + (",stderr" if se is not None else "") + "\n")
        for i in range(len(r)):
            f.write(f"{float(r[i])!r},{float(v[i])!r}" + (f",{float(se[i])!r}" if se is not None else "") + "\n")


def test_fit_reflectance_of_a_dipole_profile_equals_cli_json(tmp_path):
    """A smooth diffusion-like profile (the standard dipole's R_d(r), 0.2 % ripple) fitted by the
    FPW dipole model: the same data through `lucent fit reflectance` give the same JSON, and the
    estimates lie inside their intervals, near the generating medium (the two dipoles differ by
    their source terms, so only to ~10 %)."""
    r = np.linspace(1.0, 10.0, 40)
    truth = lucent.dipole(1.33, 1.0, 0.01, profile_mm=r).profile
    data = truth * (1 + 0.002 * np.sin(7 * r))
    f = lucent.fit_reflectance(r, data, 1.33)
    assert abs(f.sigma_a_per_mm / 0.01 - 1) < 0.15 and abs(f.sigma_s_prime_per_mm - 1) < 0.15
    lo, hi = f.sigma_a_ci_per_mm
    assert lo < f.sigma_a_per_mm < hi
    csv = tmp_path / "rd.csv"
    write_csv(csv, r, data)
    j = cli_json("fit", "reflectance", csv, "--eta", 1.33, "--json")
    for k, v in j.items():
        assert f[k] == v, k


def test_fit_reflectance_montecarlo_recovers_slab_truth_and_equals_cli_json(tmp_path):
    """Round trip with known truth: R(r) of a semi-infinite slab (σ_a = 0.05, σ_s = 5 mm⁻¹, g = 0,
    n = 1.3) from Monte Carlo, fitted with the bundled Monte Carlo table for η = 1.3."""
    s = lucent.slab([(0.05, 5.0, 0.0, 1.3, "inf")], photons=200000, seed=2, radial_bins=40, radial_max_mm=4.0)
    rad = s.radial
    f = lucent.fit_reflectance(rad.r_mm, rad.rd_per_mm2, 1.3, model="montecarlo", stderr=rad.rd_per_mm2_stderr)
    assert f.sigma_a_ci_per_mm[0] < 0.05 * 1.15 and f.sigma_a_ci_per_mm[1] > 0.05 * 0.85, f
    assert abs(f.sigma_s_prime_per_mm / 5.0 - 1) < 0.1, f
    csv = tmp_path / "slab.csv"
    write_csv(csv, rad.r_mm, rad.rd_per_mm2, rad.rd_per_mm2_stderr)
    j = cli_json("fit", "reflectance", csv, "--eta", 1.3, "--model", "montecarlo", "--json")
    for k, v in j.items():
        assert f[k] == v, k
    assert any("bins" in n for n in f.notes)


def test_fit_reflectance_bad_arguments():
    with pytest.raises(ValueError, match="eta must be finite and > 0"):
        lucent.fit_reflectance([1, 2, 3], [3, 2, 1], -1)
    with pytest.raises(ValueError, match=r"r_mm\[2\]: 2 does not increase \(previous 3\)"):
        lucent.fit_reflectance([1, 3, 2], [3, 2, 1], 1.3)
    with pytest.raises(ValueError, match="reflectance: 2 values for 3 distances"):
        lucent.fit_reflectance([1, 2, 3], [3, 2], 1.3)
    with pytest.raises(ValueError, match="no bundled Monte Carlo table for eta 1.234"):
        lucent.fit_reflectance([1, 2, 3], [3, 2, 1], 1.234, model="montecarlo")
    with pytest.raises(OSError, match="cannot read /nonexistent.csv"):
        lucent.fit_reflectance([1, 2, 3], [3, 2, 1], 1.3, model="montecarlo", table="/nonexistent.csv")


def test_fit_particles_recovers_milk_and_equals_cli_json(tmp_path):
    lam = np.array([450.0, 550.0, 650.0, 750.0])
    m = lucent.milk(2.0, pressure_mpa=10.0, wavelengths_nm=lam, phase_angles=0)
    sp = m.sigma_s_per_mm * (1 - m.g)
    f = lucent.fit_particles(lam, sp)
    assert abs(f.fat_percent - 2.0) < 0.02 and abs(f.pressure_mpa / 10.0 - 1) < 0.05
    csv = tmp_path / "sp.csv"
    with open(csv, "w") as fh:
        fh.write("wavelength_nm,sigma_s_prime_per_mm\n")
        for a, b in zip(lam, sp):
            fh.write(f"{float(a)!r},{float(b)!r}\n")
    j = cli_json("fit", "particles", csv, "--medium", "milk", "--json")
    for k, v in j.items():
        assert f[k] == v, k


def test_fit_particles_bad_arguments():
    with pytest.raises(ValueError, match="at least 3 wavelengths"):
        lucent.fit_particles([500.0, 600.0], [1.0, 0.9])
    with pytest.raises(ValueError, match=r"wavelength_nm\[1\]: 500 does not increase"):
        lucent.fit_particles([500.0, 500.0, 600.0], [1.0, 0.9, 0.8])
    with pytest.raises(ValueError, match="particle=NAME is needed"):
        lucent.fit_particles([450.0, 550.0, 650.0], [1.0, 0.9, 0.8], medium=str(ROOT / "media" / "polystyrene-beads.toml"))
