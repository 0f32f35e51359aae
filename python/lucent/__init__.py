"""lucent: material appearance from composition, for numpy.

Lorenz–Mie theory (also in absorbing hosts), bulk optical properties of media from a content
declaration (milk) or a particle recipe, dipole BSSRDFs, layered-slab Monte Carlo, reflectometry
fits, a spectral path tracer and image comparison — the physics of the ``lucent`` command,
called in-process on numpy arrays. Every function computes what the command computes with the
same defaults, so values equal its ``--json`` output to the last digit.

Units are SI unless a name says otherwise (``_nm``, ``_mm``, ``_per_mm``, ``_percent``, ``_mpa``).
Bad arguments raise ``ValueError`` and unreadable files ``OSError``, with the command's
one-line message.

Quick start::

    import lucent
    r = lucent.mie([1.0, 10.0, 100.0], 1.5 + 0.01j)        # r.qext, r.qsca, r.g, ...
    milk = lucent.milk(3.5)                                 # sigma_s_per_mm, g per wavelength
    img = lucent.Scene.cornell_box().render(spp=16, width=128, height=128)   # (128, 128, 3) float32
"""

from __future__ import annotations

import json as _json
import os as _os
from typing import Any, Callable, Optional, Sequence, Union

import numpy as _np

from . import _lucent
from ._lucent import Scene

__version__ = _lucent.__version__

__all__ = [
    "detect_markers",
    "CharucoBoard",
    "Result",
    "mie",
    "mie_sphere",
    "milk",
    "medium",
    "dipole",
    "slab",
    "fit_reflectance",
    "fit_particles",
    "compare",
    "write_vol",
    "read_vol",
    "project_points",
    "undistort_points",
    "find_chessboard_corners",
    "find_circles_grid",
    "CALIB_CB_SYMMETRIC_GRID",
    "CALIB_CB_ASYMMETRIC_GRID",
    "calibrate_camera",
    "stereo_calibrate",
    "undistort",
    "solve_pnp",
    "CALIB_USE_INTRINSIC_GUESS",
    "CALIB_FIX_INTRINSIC",
    "calibrate_procam",
    "CALIB_ZERO_TANGENT_DIST",
    "CALIB_FIX_K3",
    "CALIB_RATIONAL_MODEL",
    "CALIB_THIN_PRISM_MODEL",
    "CALIB_TILTED_MODEL",
    "CALIB_FIX_ASPECT_RATIO",
    "CALIB_FIX_PRINCIPAL_POINT",
    "CALIB_FIX_FOCAL_LENGTH",
    "CALIB_FIX_K1",
    "CALIB_FIX_K2",
    "CALIB_FIX_K4",
    "CALIB_FIX_K5",
    "CALIB_FIX_K6",
    "CALIB_FIX_S1_S2_S3_S4",
    "CALIB_FIX_TAUX_TAUY",
    "CALIB_FIX_TANGENT_DIST",
    "CALIB_SAME_FOCAL_LENGTH",
    "CALIB_USE_EXTRINSIC_GUESS",
    "CALIB_ZERO_DISPARITY",
    "SOLVEPNP_ITERATIVE",
    "SOLVEPNP_EPNP",
    "SOLVEPNP_P3P",
    "SOLVEPNP_AP3P",
    "SOLVEPNP_IPPE",
    "SOLVEPNP_IPPE_SQUARE",
    "SOLVEPNP_SQPNP",
    "solve_pnp_generic",
    "solve_pnp_refine_lm",
    "solve_pnp_ransac",
    "CALIB_FIX_SKEW",
    "CALIB_USE_LU",
    "CALIB_USE_QR",
    "CALIB_DISABLE_SCHUR_COMPLEMENT",
    "get_optimal_new_camera_matrix",
    "stereo_rectify",
    "init_undistort_rectify_map",
    "triangulate_points",
    "CV_32FC1",
    "Scene",
    "fisheye",
]

#: Default protein content of milk, weight percent (as ``lucent medium milk``).
MILK_PROTEIN_PERCENT = 3.4
#: Default homogenization pressure of milk, MPa.
MILK_PRESSURE_MPA = 20.0
#: Default most free-flight steps per photon packet of ``slab`` (as ``lucent slab``).
SLAB_MAX_STEPS_PER_PHOTON = 1_000_000


class Result(dict):
    """The results of a call: a dict whose keys (those of the command's ``--json`` output) can
    also be read as attributes (``r.qext`` is ``r["qext"]``)."""

    def __getattr__(self, name: str) -> Any:
        try:
            return self[name]
        except KeyError:
            raise AttributeError(f"no result named {name!r} (results: {', '.join(self)})") from None

    def __dir__(self):
        return list(super().__dir__()) + list(self.keys())


def _real(name: str, v) -> _np.ndarray:
    a = _np.asarray(v)
    if _np.iscomplexobj(a):
        raise ValueError(f"{name}: must be real, got a complex value")
    if a.dtype == object or a.dtype.kind in "USV":
        try:
            a = a.astype(_np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{name}: must be a number or an array of numbers") from None
    if a.dtype == bool:
        raise ValueError(f"{name}: must be a number, got a boolean")
    return a.astype(_np.float64, copy=False)


def _complex(name: str, v) -> _np.ndarray:
    a = _np.asarray(v)
    if a.dtype == object or a.dtype.kind in "USV":
        try:
            a = a.astype(_np.complex128)
        except (TypeError, ValueError):
            raise ValueError(f"{name}: must be a (complex) number or an array of them") from None
    if a.dtype == bool:
        raise ValueError(f"{name}: must be a number, got a boolean")
    return a.astype(_np.complex128, copy=False)


def _broadcast(**arrays: _np.ndarray):
    try:
        b = _np.broadcast_arrays(*arrays.values())
    except ValueError:
        shapes = ", ".join(f"{k} {v.shape}" for k, v in arrays.items())
        raise ValueError(f"shapes do not broadcast: {shapes}") from None
    shape = b[0].shape if b else ()
    return shape, [_np.ascontiguousarray(x.ravel()) for x in b]


def _shaped(a: _np.ndarray, shape) -> Any:
    """Flat result ``a`` in ``shape``; a numpy scalar for shape ()."""
    return a.reshape(shape)[()] if shape == () else a.reshape(shape)


def _angles(angles_deg):
    if angles_deg is None:
        return None, None
    a = _real("angles_deg", angles_deg)
    if not _np.all(_np.isfinite(a)):
        raise ValueError("angles_deg: angles must be finite")
    return a.shape, _np.ascontiguousarray(a.ravel())


def _mie_result(d: dict, shape, ang_shape) -> Result:
    out = Result()
    for k, v in d.items():
        if k == "theta_deg":
            out[k] = v.reshape(ang_shape)
        elif k in ("s1", "s2", "phase_per_sr"):
            out[k] = v.reshape(tuple(shape) + tuple(ang_shape))
        else:
            out[k] = _shaped(v, shape)
    return out


def _threads(threads) -> Optional[int]:
    if threads is None:
        return None
    if isinstance(threads, bool) or int(threads) != threads or threads < 1:
        raise ValueError(f"threads: must be a whole number ≥ 1, got {threads!r}")
    return int(threads)


def mie(x, m, angles_deg=None, *, threads: Optional[int] = None) -> Result:
    """Lorenz–Mie theory for homogeneous spheres in a non-absorbing host (``lucent mie``).

    Parameters
    ----------
    x : float or array
        Size parameter x = 2π r n_medium / λ (λ in vacuum), > 0.
    m : complex or array
        Relative refractive index m = n_particle / n_medium. The imaginary part is ≥ 0 and a
        positive imaginary part absorbs (time dependence e^(−iωt), Bohren & Huffman 1983).
        ``x`` and ``m`` broadcast against each other like numpy arrays.
    angles_deg : float or array, optional
        Scattering angles θ in degrees, each in [0, 180]; adds ``s1``, ``s2`` and ``phase_per_sr``.
    threads : int, optional
        Worker threads (default: all cores); ``threads=1`` runs single-threaded.

    Returns
    -------
    Result
        ``x``, ``m``, ``terms`` (series length M = ⌈x + 4.3 x^(1/3) + 1⌉), ``qext``, ``qsca``,
        ``qabs`` (efficiencies Q = C / (π r²)), ``qback`` (radar backscattering efficiency
        4|S1(180°)|²/x², Bohren & Huffman) and ``g`` (asymmetry ⟨cos θ⟩), each of the broadcast
        shape of ``x`` and ``m``; with angles also ``theta_deg`` and complex ``s1``, ``s2`` and
        real ``phase_per_sr`` of shape ``x.shape + angles.shape``.

    Notes
    -----
    S1 and S2 have the normalisation of Bohren & Huffman (1983, eqs. 4.74):
    S1 = Σ (2n+1)/(n(n+1)) (a_n π_n + b_n τ_n), S2 = Σ (2n+1)/(n(n+1)) (a_n τ_n + b_n π_n),
    dimensionless, so that ``qext = 4 Re S1(0°)/x²`` and ``qback = 4|S1(180°)|²/x²``.
    ``phase_per_sr`` = (|S1|² + |S2|²) / (4π Σ(2n+1)(|a_n|²+|b_n|²)) integrates to 1 over the
    sphere.

    miepython (3.3) writes m = n − ik with k > 0 absorbing (time dependence e^(+iωt)): pass
    it ``m.conjugate()``. Its ``S1_S2(m.conjugate(), x, cos θ, norm="bohren")`` then equals
    2 × the complex conjugate of these ``s1``, ``s2`` (its default ``norm="albedo"`` scales
    them instead so that ∫(|S1|² + |S2|²)/2 dΩ is the single-scattering albedo times π x²...
    see its documentation). ``qext``, ``qsca`` and ``g`` agree with
    ``miepython.efficiencies_mx(m.conjugate(), x)`` to 2e-10 for 0.5 ≤ x ≤ 1000 (python/tests);
    ``qback`` to 1e-9 up to x = 3 and ~1e-6 beyond, where both series' truncation limits it.
    """
    xa = _real("x", x)
    ma = _complex("m", m)
    shape, (xf, mf) = _broadcast(x=xa, m=ma)
    ang_shape, af = _angles(angles_deg)
    d = _lucent.mie_flat(xf, mf, af, _threads(threads))
    return _mie_result(d, shape, ang_shape)


def mie_sphere(radius_m, wavelength_m, n_particle, n_medium=1.0, angles_deg=None, *, threads: Optional[int] = None) -> Result:
    """Lorenz–Mie cross sections of spheres, possibly in an absorbing host (``lucent mie
    --radius-um … --wavelength-nm … --n-particle … --n-medium …``).

    Parameters
    ----------
    radius_m : float or array
        Sphere radius in metres.
    wavelength_m : float or array
        Vacuum wavelength in metres.
    n_particle, n_medium : complex or array
        Refractive indices of the particle and the host (default 1); imaginary parts ≥ 0 absorb
        (e^(−iωt)). An absorbing host follows Frisvad, Christensen & Jensen (ACM TOG 26(3),
        2007): efficiencies refer to the geometrical cross section π r² and the far field is
        taken at the particle's surface.
        All four arguments broadcast against each other.
    angles_deg : float or array, optional
        Scattering angles in degrees in [0, 180]; adds ``s1``, ``s2``, ``phase_per_sr``.
    threads : int, optional
        Worker threads (default: all cores).

    Returns
    -------
    Result
        ``x`` and ``x_im`` (host size parameter 2π r n_medium/λ, real and imaginary parts),
        ``m`` (= n_particle/n_medium), ``terms``, ``qext``, ``qsca``, ``qabs``, ``qback``, ``g``,
        and the cross sections ``c_ext_m2``, ``c_sca_m2``, ``c_abs_m2`` in m²; with angles
        ``theta_deg``, ``s1``, ``s2`` (Bohren–Huffman normalisation, see :func:`mie`) and
        ``phase_per_sr``.
    """
    arrays = dict(
        radius_m=_real("radius_m", radius_m),
        wavelength_m=_real("wavelength_m", wavelength_m),
        n_particle=_complex("n_particle", n_particle),
        n_medium=_complex("n_medium", n_medium),
    )
    shape, flat = _broadcast(**arrays)
    ang_shape, af = _angles(angles_deg)
    d = _lucent.mie_sphere_flat(*flat, af, _threads(threads))
    return _mie_result(d, shape, ang_shape)


def _wavelengths(w) -> Optional[list]:
    if w is None:
        return None
    a = _real("wavelengths_nm", w)
    if a.ndim > 1:
        raise ValueError(f"wavelengths_nm: expected a number or a 1-D array, got shape {a.shape}")
    return [float(v) for v in a.ravel()]


def _medium_result(d: dict) -> Result:
    out = Result(d)
    out["components"] = [Result(c) for c in d["components"]]
    return out


def milk(fat_percent: float, protein_percent: float = MILK_PROTEIN_PERCENT, pressure_mpa: float = MILK_PRESSURE_MPA,
         wavelengths_nm=None, *, phase_angles: int = 181) -> Result:
    """Bulk optical properties of milk from its content declaration (``lucent medium milk``;
    the Lorenz–Mie model of Frisvad, Christensen & Jensen 2007).

    Parameters
    ----------
    fat_percent : float
        Fat content, weight percent.
    protein_percent : float
        Protein content, weight percent (default 3.4).
    pressure_mpa : float
        Homogenization pressure in MPa (default 20; 0 = unhomogenized).
    wavelengths_nm : float or 1-D array, optional
        Vacuum wavelengths in nm (default 375, 400, …, 775).
    phase_angles : int
        Angles (0° to 180°) of the tabulated bulk phase function (default 181; 0 = none).

    Returns
    -------
    Result
        ``wavelength_nm``; ``sigma_s_per_mm``, ``sigma_a_per_mm``, ``sigma_t_per_mm`` (mm⁻¹) and
        ``g`` per wavelength; ``host_sigma_a_per_mm``; ``components`` (per particle type:
        ``name``, ``sigma_s_per_mm``, ``sigma_t_per_mm``, ``g``); ``name``; and with
        ``phase_angles`` > 0 ``theta_deg`` and ``phase_per_sr`` (shape wavelengths × angles,
        per steradian, normalised to 1 over the sphere).
    """
    f = float(_real("fat_percent", fat_percent))
    p = float(_real("protein_percent", protein_percent))
    h = float(_real("pressure_mpa", pressure_mpa))
    return _medium_result(_lucent.milk(f, p, h, _wavelengths(wavelengths_nm), _count("phase_angles", phase_angles)))


def _count(name: str, v) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, _np.integer)) or v < 0:
        raise ValueError(f"{name}: must be a whole number ≥ 0, got {v!r}")
    if v > 2**63 - 1:
        raise ValueError(f"{name}: {v} is beyond 2^63 - 1")
    return int(v)


def medium(recipe: Union[str, "_os.PathLike[str]", dict], wavelengths_nm=None, *, phase_angles: Optional[int] = None) -> Result:
    """Bulk optical properties of a host with particles (``lucent medium RECIPE.toml``).

    Parameters
    ----------
    recipe : path or dict
        A recipe file (TOML, docs/media.md), or a dict with the recipe's keys (``name``,
        ``host``, ``particle`` (a list of dicts), ``wavelengths_nm``, ``phase_angles``, ...).
    wavelengths_nm : float or 1-D array, optional
        Vacuum wavelengths in nm (default: the recipe's, else 375:775:25).
    phase_angles : int, optional
        Angles of the tabulated phase function (default: the recipe's).

    Returns
    -------
    Result
        The keys of :func:`milk`.
    """
    pa = None if phase_angles is None else _count("phase_angles", phase_angles)
    w = _wavelengths(wavelengths_nm)
    if isinstance(recipe, dict):
        try:
            text = _json.dumps(recipe, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise ValueError(f"recipe: cannot be written as a recipe ({e})") from None
        return _medium_result(_lucent.medium_json(text, w, pa))
    if isinstance(recipe, (str, _os.PathLike)):
        return _medium_result(_lucent.medium_file(_os.fspath(recipe), w, pa))
    raise ValueError(f"recipe: expected a file path or a dict, got {type(recipe).__name__}")


def dipole(eta, sigma_s_per_mm, sigma_a_per_mm, g=0.0, *, model: str = "standard", profile_mm=None, rd: Optional[bool] = None) -> Result:
    """Dipole BSSRDF models of a flat half-space (``lucent bssrdf``).

    Parameters
    ----------
    eta : float or array
        Relative index of refraction η = n_medium / n_outside.
    sigma_s_per_mm, sigma_a_per_mm : float or array
        Scattering and absorption coefficients in mm⁻¹.
    g : float or array
        Henyey–Greenstein asymmetry parameter (default 0).
        ``eta``, ``sigma_s_per_mm``, ``sigma_a_per_mm`` and ``g`` broadcast together.
    model : str
        ``standard`` (Jensen et al. 2001), ``directional`` (Frisvad et al. 2014, as published) or
        ``directional-corrected`` (the same theory with the refracted ray integrated as a line of
        sources).
    profile_mm : float or array, optional
        Distances r in mm at which to evaluate the profile R_d(r) = π S_d(r) in mm⁻².
    rd : bool, optional
        Compute ``rd`` (default: when no profile is asked for; ``True`` computes both).

    Returns
    -------
    Result
        ``model``, ``eta``, ``sigma_s_per_mm``, ``sigma_a_per_mm``, ``g``, ``alpha_prime``
        (reduced albedo), ``sigma_tr_per_mm``, ``d_mm`` (diffusion coefficient), ``a``
        (boundary term A); ``rd`` (π∫S_d dA under normal incidence, without T12, T21) and
        ``rd_closed_form`` (the standard dipole's), of the media's broadcast shape; and
        ``profile_mm``, ``profile`` (shape media + distances).
    """
    arrays = dict(eta=_real("eta", eta), sigma_s_per_mm=_real("sigma_s_per_mm", sigma_s_per_mm),
                  sigma_a_per_mm=_real("sigma_a_per_mm", sigma_a_per_mm), g=_real("g", g))
    shape, flat = _broadcast(**arrays)
    if not isinstance(model, str):
        raise ValueError(f"model: expected a name, got {model!r}")
    pshape, pf = (None, None)
    if profile_mm is not None:
        p = _real("profile_mm", profile_mm)
        pshape, pf = p.shape, _np.ascontiguousarray(p.ravel())
    d = _lucent.dipole_flat(model, *flat, pf, bool(rd))
    out = Result()
    for k, v in d.items():
        if k == "model":
            out[k] = v
        elif k == "profile_mm":
            out[k] = v.reshape(pshape)
        elif k == "profile":
            out[k] = v.reshape(tuple(shape) + tuple(pshape))
        else:
            out[k] = _shaped(v, shape)
    return out


_LAYER_KEYS = ("sigma_a_per_mm", "sigma_s_per_mm", "g", "n", "thickness_mm")
_LAYER_ALIASES = {"mua_per_mm": "sigma_a_per_mm", "mus_per_mm": "sigma_s_per_mm"}


def _layer(i: int, layer) -> list:
    if isinstance(layer, dict):
        d = {_LAYER_ALIASES.get(k, k): v for k, v in layer.items()}
        unknown = set(d) - set(_LAYER_KEYS)
        if unknown:
            raise ValueError(f"layers[{i}]: unknown key(s) {', '.join(sorted(unknown))} (expected {', '.join(_LAYER_KEYS)})")
        missing = [k for k in _LAYER_KEYS if k not in d]
        if missing:
            raise ValueError(f"layers[{i}]: missing {', '.join(missing)}")
        values = [d[k] for k in _LAYER_KEYS]
    else:
        values = list(layer)
        if len(values) != 5:
            raise ValueError(f"layers[{i}]: expected 5 values SIGMA_A,SIGMA_S,G,N,THICKNESS_MM, got {len(values)}")
    out = []
    for name, v in zip(("SIGMA_A", "SIGMA_S", "G", "N", "THICKNESS_MM"), values):
        if name == "THICKNESS_MM" and isinstance(v, str) and v.strip().lower() == "inf":
            v = float("inf")
        try:
            if isinstance(v, bool):
                raise TypeError
            out.append(float(v))
        except (TypeError, ValueError):
            raise ValueError(f"layers[{i}]: {name} = {v!r} is not a number") from None
    return out


def slab(layers: Sequence, *, n_above: float = 1.0, n_below: float = 1.0, photons: int = 1_000_000, seed: int = 1,
         radial_bins: Optional[int] = None, radial_max_mm: Optional[float] = None, incidence_deg: float = 0.0,
         line_bins: Optional[int] = None, line_max_mm: Optional[float] = None,
         max_steps_per_photon: int = SLAB_MAX_STEPS_PER_PHOTON, threads: Optional[int] = None) -> Result:
    """MCML-style Monte Carlo photon transport in a stack of plane-parallel layers (``lucent slab``).

    Parameters
    ----------
    layers : sequence
        Layers, top first, each ``(sigma_a_per_mm, sigma_s_per_mm, g, n, thickness_mm)`` or a
        dict with those keys; ``thickness_mm`` may be ``inf`` for a semi-infinite last layer
        (which must absorb if it scatters).
    n_above, n_below : float
        Refractive indices of the ambient media above and below.
    photons, seed : int
        Photon packets and the random seed; results are identical for equal seeds and photon
        counts whatever the number of threads.
    radial_bins, radial_max_mm : optional
        Radially resolved reflectance R(r) (default outer radius: ten transport mean free paths
        of the top layer).
    incidence_deg : float
        Angle of the beam from the normal, degrees.
    line_bins, line_max_mm : optional
        Reflectance along the plane of incidence R(x, y≈0).
    max_steps_per_photon : int
        Most free-flight steps per packet (longer ones are dropped and counted).
    threads : int, optional
        Worker threads (default: all cores).

    Returns
    -------
    Result
        The keys of ``lucent slab --json``: ``specular``, ``rd``, ``rd_stderr``, ``absorbed``,
        ``absorbed_stderr``, ``absorbed_per_layer``, ``tt``, ``tt_stderr``, ``roulette_gain``,
        ``photons_truncated``, ``truncated_weight``, ``rd_centroid_x_mm``, ``layers``, timings
        (``seconds``, ``photon_steps_per_s``, …) and ``radial`` / ``line`` dicts when asked.
    """
    if isinstance(layers, dict) or isinstance(layers, (str, bytes)):
        raise ValueError("layers: expected a list of layers (tuples or dicts)")
    ls = [_layer(i, l) for i, l in enumerate(layers)]
    for name, v in (("photons", photons), ("seed", seed), ("max_steps_per_photon", max_steps_per_photon)):
        _count(name, v)
    r = _lucent.slab(ls, float(n_above), float(n_below), int(photons), int(seed),
                     None if radial_bins is None else _count("radial_bins", radial_bins),
                     None if radial_max_mm is None else float(radial_max_mm), float(incidence_deg),
                     None if line_bins is None else _count("line_bins", line_bins),
                     None if line_max_mm is None else float(line_max_mm), int(max_steps_per_photon), _threads(threads))
    out = Result(r)
    out["layers"] = [Result(l) for l in r["layers"]]
    for k in ("radial", "line"):
        if k in r:
            out[k] = Result(r[k])
    return out


def _vector(name: str, v) -> list:
    a = _real(name, v)
    if a.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array, got shape {a.shape}")
    return [float(x) for x in a]


def fit_reflectance(r_mm, reflectance, eta: float, model: str = "dipole", *, stderr=None, relative: bool = False,
                    r_min_mm: float = 0.0, r_max_mm: Optional[float] = None, noise: float = 0.01,
                    table: Optional[Union[str, "_os.PathLike[str]"]] = None) -> Result:
    """Fit σ_a and σ'_s to a spatially resolved diffuse reflectance profile R(r)
    (``lucent fit reflectance``).

    Parameters
    ----------
    r_mm : 1-D array
        Distances from the point of incidence in mm, strictly increasing (uniform bin centres
        Δ/2, 3Δ/2, … as ``slab`` writes them are compared as annulus averages).
    reflectance : 1-D array
        R(r) in mm⁻² (absolute), or any units with ``relative=True`` (shape only).
    eta : float
        Relative refractive index of the medium.
    model : str
        ``dipole`` (Farrell, Patterson & Wilson 1992), ``directional`` or ``montecarlo``
        (tabulated ``slab`` runs: the bundled table for ``eta``, or ``table``).
    stderr : 1-D array, optional
        Standard errors of ``reflectance``.
    r_min_mm, r_max_mm : float
        Use only points with r_min_mm ≤ r ≤ r_max_mm.
    noise : float
        Relative noise of each point (added in quadrature to ``stderr``).

    Returns
    -------
    Result
        ``model``, ``eta``, ``relative``, ``sigma_a_per_mm``, ``sigma_s_prime_per_mm``,
        ``mu_eff_per_mm``, ``sigma_s_prime_over_sigma_a`` (None when not determined) with their
        95 % intervals ``*_ci*`` ([low, high]), ``residual_rms``, ``relative_rms``, ``points``,
        ``notes``.
    """
    r = _vector("r_mm", r_mm)
    v = _vector("reflectance", reflectance)
    s = None if stderr is None else _vector("stderr", stderr)
    if not isinstance(model, str):
        raise ValueError(f"model: expected a name, got {model!r}")
    t = None if table is None else _os.fspath(table)
    return Result(_lucent.fit_reflectance(r, v, float(eta), model, s, bool(relative), float(r_min_mm),
                                          None if r_max_mm is None else float(r_max_mm), float(noise), t))


def fit_particles(wavelength_nm, sigma_s_prime_per_mm, sigma_a_per_mm=None, *, medium: str = "milk",
                  particle: Optional[str] = None, protein_percent: float = MILK_PROTEIN_PERCENT) -> Result:
    """A product's composition from its reduced scattering spectrum (``lucent fit particles``).

    Parameters
    ----------
    wavelength_nm : 1-D array
        Wavelengths in nm, increasing (at least 3 for milk).
    sigma_s_prime_per_mm : 1-D array
        Reduced scattering coefficient σ'_s = σ_s(1 − g) in mm⁻¹.
    sigma_a_per_mm : 1-D array, optional
        Absorption coefficient in mm⁻¹, when measured.
    medium : str
        ``milk`` (fat content and homogenization pressure), or the path of a recipe TOML with
        ``particle`` naming the particle type whose mean radius and volume fraction are fitted.
    protein_percent : float
        Protein content of milk, weight percent.

    Returns
    -------
    Result
        Milk: ``medium``, ``protein_percent``, ``fat_percent``, ``fat_percent_ci``,
        ``pressure_mpa``, ``pressure_mpa_ci``, ``residual_rms``, ``fat_r_vs_um``,
        ``fat_volume_fraction``. A recipe: ``medium``, ``particle``, ``radius_um``,
        ``radius_um_ci``, ``volume_fraction``, ``volume_fraction_ci``, ``residual_rms``.
    """
    w = _vector("wavelength_nm", wavelength_nm)
    sp = _vector("sigma_s_prime_per_mm", sigma_s_prime_per_mm)
    sa = None if sigma_a_per_mm is None else _vector("sigma_a_per_mm", sigma_a_per_mm)
    return Result(_lucent.fit_particles(w, sp, sa, _os.fspath(medium), particle, float(protein_percent)))


def _image(name: str, a) -> _np.ndarray:
    x = _real(name, a)
    if x.ndim != 3 or x.shape[2] != 3:
        raise ValueError(f"{name}: expected an (H, W, 3) array of linear RGB, got shape {x.shape}")
    return x


def compare(a, b, mask=None, *, color_correct: Union[None, bool, str] = None, saturation: float = 1.0) -> Result:
    """Pixelwise comparison of a render ``a`` with a reference ``b`` (``lucent compare --json``).

    Parameters
    ----------
    a, b : (H, W, 3) arrays
        Linear sRGB (as ``Scene.render`` returns); compared in float32, as the command reads
        image files.
    mask : (H, W) bool array or (H, W, 3) image, optional
        Pixels compared: True, or where the image's channel mean exceeds 0.5.
    color_correct : None, True, "matrix" or "affine"
        Fit a robust colour transform a → b first (3×3, or 3×3 and an offset).
    saturation : float
        Pixels with a channel at or above this level in either image are left out of the fit.

    Returns
    -------
    Result
        ``rmse``, ``rel_mse``, ``psnr_db`` (None for identical images), ``ssim``,
        ``delta_e2000_mean``, ``pixels``; with a colour fit ``color_matrix``, ``color_model``,
        ``color_offset``, ``color_residual_rms``, ``color_robust_sigma``,
        ``color_pixels_used``, ``color_pixels_saturated``, ``color_pixels_nonfinite``,
        ``color_pixels_downweighted``, ``color_iterations``; and ``delta_e2000_map`` (H, W).
    """
    x, y = _image("a", a), _image("b", b)
    if x.shape != y.shape:
        raise ValueError(f"b: image is {y.shape[1]}×{y.shape[0]} but a is {x.shape[1]}×{x.shape[0]}")
    h, w = x.shape[:2]
    if h == 0 or w == 0:
        raise ValueError(f"a, b: empty images ({w}×{h})")
    flat = lambda v: _np.ascontiguousarray(v, dtype=_np.float32).ravel()
    mask_image = mask_flags = None
    if mask is not None:
        mk = _np.asarray(mask)
        if mk.dtype == bool and mk.shape == (h, w):
            mask_flags = [bool(v) for v in mk.ravel()]
        elif mk.shape == (h, w, 3):
            mask_image = flat(_real("mask", mk))
        elif mk.shape == (h, w):
            raise ValueError(f"mask: an ({h}, {w}) mask must be a bool array, got {mk.dtype}")
        else:
            raise ValueError(f"mask: expected an ({h}, {w}) bool array or an ({h}, {w}, 3) image, got shape {mk.shape}")
    if color_correct is True:
        color_correct = "matrix"
    elif color_correct is False:
        color_correct = None
    elif color_correct is not None and not isinstance(color_correct, str):
        raise ValueError(f"color_correct: expected None, True, 'matrix' or 'affine', got {color_correct!r}")
    return Result(_lucent.compare(flat(x), flat(y), w, h, mask_image, mask_flags, color_correct, float(saturation)))


def _camera_args(camera_matrix, dist_coeffs, name="camera_matrix", dist_name="dist_coeffs"):
    """A camera matrix (row-major, 9 floats: finite, fx, fy > 0, last row 0, 0, 1) and its
    distortion coefficients (finite), or ValueError naming the argument."""
    k = _np.asarray(camera_matrix, dtype=float)
    if k.shape != (3, 3):
        raise ValueError(f"{name}: expected a 3×3 matrix, got shape {k.shape}")
    if not _np.isfinite(k).all() or not (k[0, 0] > 0 and k[1, 1] > 0) or tuple(k[2]) != (0.0, 0.0, 1.0) or k[1, 0] != 0:
        raise ValueError(f"{name}: expected [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with finite fx, fy > 0, got {k.tolist()}")
    d = _np.asarray([] if dist_coeffs is None else dist_coeffs, dtype=float).ravel()
    if not _np.isfinite(d).all():
        raise ValueError(f"{dist_name}: the coefficients must be finite")
    return [float(v) for v in k.ravel()], [float(v) for v in d]


#: OpenCV's calibration flags that :func:`calibrate_camera` understands (the values of ``cv2.CALIB_*``).
CALIB_ZERO_TANGENT_DIST = 8
CALIB_FIX_K3 = 128
CALIB_RATIONAL_MODEL = 1 << 14
CALIB_THIN_PRISM_MODEL = 1 << 15
CALIB_TILTED_MODEL = 1 << 18
_CALIB_FLAGS = CALIB_ZERO_TANGENT_DIST | CALIB_FIX_K3 | CALIB_RATIONAL_MODEL | CALIB_THIN_PRISM_MODEL | CALIB_TILTED_MODEL
#: Flags that hold lens terms (the values of ``cv2.CALIB_*``): at the start's values, which are
#: the guess's with CALIB_USE_INTRINSIC_GUESS, else the image centre for the principal point and
#: 0 for distortion terms.
CALIB_USE_INTRINSIC_GUESS = 1
CALIB_FIX_ASPECT_RATIO = 2
CALIB_FIX_PRINCIPAL_POINT = 4
CALIB_FIX_FOCAL_LENGTH = 16
CALIB_FIX_K1 = 32
CALIB_FIX_K2 = 64
CALIB_FIX_K4 = 2048
CALIB_FIX_K5 = 4096
CALIB_FIX_K6 = 8192
CALIB_FIX_S1_S2_S3_S4 = 65536
CALIB_FIX_TAUX_TAUY = 524288
CALIB_FIX_TANGENT_DIST = 2097152
# Each holding flag and its bits in scan::calib::bundle::Free::held (lens terms in the order
# fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6, s1…s4, τx, τy).
_HELD_BITS = ((CALIB_FIX_FOCAL_LENGTH, 0b11), (CALIB_FIX_PRINCIPAL_POINT, 0b1100), (CALIB_FIX_K1, 1 << 4),
              (CALIB_FIX_K2, 1 << 5), (CALIB_FIX_TANGENT_DIST, 0b11 << 6), (CALIB_FIX_K4, 1 << 9),
              (CALIB_FIX_K5, 1 << 10), (CALIB_FIX_K6, 1 << 11), (CALIB_FIX_S1_S2_S3_S4, 0b1111 << 12),
              (CALIB_FIX_TAUX_TAUY, 0b11 << 16))
_HOLD_FLAGS = CALIB_FIX_ASPECT_RATIO | sum(f for f, _ in _HELD_BITS)
#: Flags accepted and without effect: lucent's model has no skew (CALIB_FIX_SKEW), and its
#: solver is its own (CALIB_USE_LU, CALIB_USE_QR, CALIB_DISABLE_SCHUR_COMPLEMENT choose OpenCV's).
CALIB_USE_LU = 1 << 17
CALIB_USE_QR = 1 << 20
CALIB_FIX_SKEW = 1 << 25
CALIB_DISABLE_SCHUR_COMPLEMENT = 1 << 27
_NO_EFFECT_FLAGS = CALIB_USE_LU | CALIB_USE_QR | CALIB_FIX_SKEW | CALIB_DISABLE_SCHUR_COMPLEMENT


def _pair(v, name, least):
    """Two whole numbers, each at least `least` (a size or a corner count), or ValueError."""
    try:
        a, b = (int(x) for x in v)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected two whole numbers, got {v!r}") from None
    if a < least or b < least:
        raise ValueError(f"{name}: each must be at least {least}, got ({a}, {b})")
    if a > 2**31 - 1 or b > 2**31 - 1:
        raise ValueError(f"{name}: ({a}, {b}) is beyond 2^31 - 1")
    return a, b


#: The most pixels an image, map or remapped image may have (as ``Scene.render``): 2^28.
MAX_PIXELS = 1 << 28


def _image_size(v, name):
    """A (width, height) of at least 1 × 1 and at most :data:`MAX_PIXELS` pixels, or ValueError."""
    w, h = _pair(v, name, 1)
    if w * h > MAX_PIXELS:
        raise ValueError(f"{name}: {w}×{h} pixels is too large (at most 2^28)")
    return w, h


def _grey_levels(image):
    """An 8-bit grey or BGR image (OpenCV's luma weights) as flat grey levels, width and height;
    ValueError for another shape or an image under 8 × 8 pixels."""
    a = _np.asarray(image)
    if a.dtype != _np.uint8:
        raise ValueError(f"image: expected 8-bit grey levels (uint8), as cv2.findChessboardCorners, got {a.dtype}")
    if a.ndim == 3 and a.shape[2] in (3, 4):
        # cv2.cvtColor(…, COLOR_BGR2GRAY): BT.601 weights in 14-bit fixed point, rounded.
        b, g, r = (a[..., i].astype(_np.uint32) for i in range(3))
        a = ((1868 * b + 9617 * g + 4899 * r + (1 << 13)) >> 14).astype(_np.uint8)
    elif a.ndim != 2:
        raise ValueError(f"image: expected an (H, W) grey or (H, W, 3) BGR array, got shape {a.shape}")
    h, w = a.shape
    if h < 8 or w < 8:
        raise ValueError(f"image: at least 8×8 pixels, got {w}×{h}")
    return _np.ascontiguousarray(a, dtype=_np.float32).reshape(-1), w, h


def _flat64(a) -> _np.ndarray:
    """A contiguous flat float64 copy or view of ``a``, as the extension's flat arguments take it."""
    return _np.ascontiguousarray(a, dtype=_np.float64).reshape(-1)


#: The flags of ``cv2.findChessboardCorners`` (OpenCV's values), accepted by
#: :func:`find_chessboard_corners` so that OpenCV calls run unchanged.
CALIB_CB_ADAPTIVE_THRESH = 1
CALIB_CB_NORMALIZE_IMAGE = 2
CALIB_CB_FILTER_QUADS = 4
CALIB_CB_FAST_CHECK = 8
CALIB_CB_PLAIN = 256
_CHESSBOARD_FLAGS = CALIB_CB_ADAPTIVE_THRESH | CALIB_CB_NORMALIZE_IMAGE | CALIB_CB_FILTER_QUADS | CALIB_CB_FAST_CHECK | CALIB_CB_PLAIN


def _no_output_array(value, name):
    """OpenCV's optional output argument (``corners``, ``centers``): None or an array, which
    is not written to (the result is returned, as cv2 returns it)."""
    if value is not None and not isinstance(value, _np.ndarray):
        raise ValueError(f"{name}: expected None or an array (OpenCV's output argument), got {type(value).__name__}")


def find_chessboard_corners(image, pattern_size, corners=None, flags=CALIB_CB_ADAPTIVE_THRESH | CALIB_CB_NORMALIZE_IMAGE):
    """The inner corners of a chessboard, as ``cv2.findChessboardCorners`` followed by
    ``cv2.cornerSubPix`` finds them. The arguments are ``cv2.findChessboardCorners``'s, so
    ``find_chessboard_corners(gray, (9, 6), None, flags)`` runs as OpenCV's call does.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) array
        8-bit grey levels; a colour image is taken in OpenCV's BGR order (as ``cv2.imread``
        gives it) and converted with OpenCV's luma weights.
    pattern_size : (cols, rows)
        Inner corners per row and per column, as OpenCV's ``patternSize``.
    corners : None or array
        OpenCV's output argument; not written to.
    flags : int
        Any of :data:`CALIB_CB_ADAPTIVE_THRESH`, :data:`CALIB_CB_NORMALIZE_IMAGE`,
        :data:`CALIB_CB_FILTER_QUADS`, :data:`CALIB_CB_FAST_CHECK` and :data:`CALIB_CB_PLAIN`.
        They choose among OpenCV's thresholding and quad-filtering steps; lucent's finder has one
        method, which these flags do not change. Other bits (``findChessboardCornersSB``'s) are
        refused.

    Returns
    -------
    (found, corners)
        ``found`` a bool; ``corners`` a (cols·rows, 1, 2) float32 array of pixel positions (OpenCV
        convention, integers at pixel centres), row by row in OpenCV's handedness (rows run left
        to right when the next row lies below, turned with the board), from the corner at the
        black outer square where the board's ends differ in colour (cols + rows odd), as OpenCV
        returns them, otherwise from the end nearer the image's top-left; None when no such
        lattice is found. The array goes as it is into
        ``cv2.calibrateCamera`` or :func:`calibrate_camera`.
    """
    cols, rows = _pair(pattern_size, "pattern_size", 3)
    _no_output_array(corners, "corners")
    if int(flags) & ~_CHESSBOARD_FLAGS:
        raise ValueError(f"flags: only CALIB_CB_ADAPTIVE_THRESH, CALIB_CB_NORMALIZE_IMAGE, CALIB_CB_FILTER_QUADS, CALIB_CB_FAST_CHECK and CALIB_CB_PLAIN (findChessboardCorners's) are accepted, got {flags!r}")
    grey, w, h = _grey_levels(image)
    c = _lucent.find_chessboard_flat(grey, w, h, cols, rows)
    if c is None:
        return False, None
    return True, _np.asarray(c, dtype=_np.float32).reshape(-1, 1, 2)


def _dictionary_name(dictionary):
    """A predefined ArUco dictionary given by OpenCV's name (``"DICT_4X4_50"``) or enum value
    (``cv2.aruco.DICT_4X4_50``, an int), as the name the extension takes."""
    if isinstance(dictionary, str):
        return dictionary
    if isinstance(dictionary, (int, _np.integer)) and not isinstance(dictionary, bool):
        return str(int(dictionary))
    raise ValueError(f"dictionary: expected OpenCV's name (e.g. 'DICT_4X4_50') or its cv2.aruco.DICT_* value, got {dictionary!r}")


def detect_markers(image, dictionary="DICT_4X4_50", refine=False):
    """The ArUco markers of a predefined dictionary in a photograph, as
    ``cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(d)).detectMarkers(image)`` finds
    them with its default parameters (docs/scanning.md, "ChArUco boards").

    Parameters
    ----------
    image : (H, W) or (H, W, 3) uint8 array
        Grey levels, or BGR as ``cv2.imread`` gives it.
    dictionary : str or int
        OpenCV's name (``"DICT_5X5_1000"``, ``"DICT_ARUCO_ORIGINAL"``, ``"DICT_APRILTAG_36h11"``)
        or its ``cv2.aruco.DICT_*`` value.
    refine : bool
        Corners at the intersections of lines fitted to the marker's sides (sub-pixel) instead of
        the polygon's vertices (OpenCV's default, ``CORNER_REFINE_NONE``).

    Returns
    -------
    (corners, ids, rejected)
        As OpenCV: ``corners`` a tuple of (1, 4, 2) float32 arrays (top-left, top-right,
        bottom-right, bottom-left of each marker), ``ids`` an (N, 1) int32 array or None when no
        marker is found, ``rejected`` an empty tuple (candidates are not reported).
    """
    grey, w, h = _grey_levels(image)
    ids, flat = _lucent.detect_markers_flat(grey, w, h, _dictionary_name(dictionary), bool(refine))
    if not ids:
        return (), None, ()
    c = _np.asarray(flat, dtype=_np.float32).reshape(-1, 1, 4, 2)
    return tuple(c), _np.asarray(ids, dtype=_np.int32).reshape(-1, 1), ()


class CharucoBoard:
    """A ChArUco board, as ``cv2.aruco.CharucoBoard(size, square_length, marker_length,
    dictionary)``: ``size`` = (squares per row, rows), the top-left square dark (OpenCV 4.6 and
    later) or, with ``legacy=True`` (OpenCV's ``setLegacyPattern(True)``), light where the row
    count is even. Board coordinates: x right, y down, z = 0, in the lengths' unit."""

    def __init__(self, size, square_length, marker_length, dictionary, legacy=False):
        self.size = _pair(size, "size", 2)
        self.square_length = float(square_length)
        self.marker_length = float(marker_length)
        self.dictionary = _dictionary_name(dictionary)
        self.legacy = bool(legacy)
        corners, markers, ids = _lucent.charuco_board_flat(self.size, self.square_length, self.marker_length, self.dictionary, self.legacy)
        self._corners = _np.asarray(corners, dtype=_np.float64).reshape(-1, 2)
        self._markers = _np.asarray(markers, dtype=_np.float64).reshape(-1, 4, 2)
        self._ids = _np.asarray(ids, dtype=_np.int32)

    def getChessboardCorners(self):
        """The chessboard corners (N, 3) float32, by id (OpenCV's name and layout)."""
        return _np.column_stack([self._corners, _np.zeros(len(self._corners))]).astype(_np.float32)

    def getObjPoints(self):
        """Each marker's corners on the board, a tuple of (4, 3) float32 arrays in board order."""
        return tuple(_np.column_stack([m, _np.zeros(4)]).astype(_np.float32) for m in self._markers)

    def getIds(self):
        """The markers' ids in board order, (N,) int32."""
        return self._ids.copy()

    def generateImage(self, out_size, margin_size=0):
        """The board upright in an image of ``out_size`` = (width, height) pixels with at least
        ``margin_size`` pixels of white around it (OpenCV's ``generateImage``): (H, W) uint8, dark
        0 and light 255, each pixel the mean of 4 × 4 samples."""
        w, h = _pair(out_size, "out_size", 8)
        flat = _lucent.charuco_image_flat(self.size, self.square_length, self.marker_length, self.dictionary, self.legacy, w, h, int(margin_size))
        return _np.frombuffer(bytes(flat), dtype=_np.uint8).reshape(h, w).copy()

    def detect_board(self, image):
        """The board's chessboard corners in a photograph, as ``cv2.aruco.CharucoDetector(board)
        .detectBoard(image)``: ``(charuco_corners, charuco_ids, marker_corners, marker_ids)``,
        the corners an (N, 1, 2) float32 array and their ids (N, 1) int32 (None when none is
        found), the markers as :func:`detect_markers` gives them. A corner counts when both
        neighbouring markers are found and agree on it; it is refined as ``cornerSubPix`` refines
        it. The corners and ids go as they are into :func:`calibrate_camera` via
        ``getChessboardCorners()[ids.ravel()]``."""
        grey, w, h = _grey_levels(image)
        cids, cflat, mids, mflat = _lucent.detect_charuco_flat(grey, w, h, self.size, self.square_length, self.marker_length, self.dictionary, self.legacy)
        markers = tuple(_np.asarray(mflat, dtype=_np.float32).reshape(-1, 1, 4, 2)) if mids else ()
        mid = _np.asarray(mids, dtype=_np.int32).reshape(-1, 1) if mids else None
        if not cids:
            return None, None, markers, mid
        return _np.asarray(cflat, dtype=_np.float32).reshape(-1, 1, 2), _np.asarray(cids, dtype=_np.int32).reshape(-1, 1), markers, mid

    detectBoard = detect_board


#: The circle-grid layouts of :func:`find_circles_grid` (the values of ``cv2.CALIB_CB_*``), and
#: OpenCV's clustering flag, accepted with either.
CALIB_CB_SYMMETRIC_GRID = 1
CALIB_CB_ASYMMETRIC_GRID = 2
CALIB_CB_CLUSTERING = 4


def find_circles_grid(image, pattern_size, centers=None, flags=None, blobDetector=None):
    """The disc centres of a circle grid, as ``cv2.findCirclesGrid`` finds them. The arguments
    are ``cv2.findCirclesGrid``'s (``find_circles_grid(gray, (4, 11), None,
    CALIB_CB_ASYMMETRIC_GRID)``); an integer in ``centers``' place is taken as the flags
    (``find_circles_grid(gray, (4, 11), CALIB_CB_ASYMMETRIC_GRID)``).

    Parameters
    ----------
    image : (H, W) or (H, W, 3) array
        8-bit grey levels, taken as they are (no response curve is undone, as OpenCV's blob
        detector thresholds them); a colour image is taken in OpenCV's BGR order and converted
        with OpenCV's luma weights.
    pattern_size : (cols, rows)
        Discs per row and rows, as OpenCV's ``patternSize``.
    centers : None or array
        OpenCV's output argument; not written to.
    flags : int
        :data:`CALIB_CB_SYMMETRIC_GRID` (a square lattice, the default) or
        :data:`CALIB_CB_ASYMMETRIC_GRID` (rows of discs 2s apart, every second row shifted by s),
        optionally with :data:`CALIB_CB_CLUSTERING`, which OpenCV uses to order discs under strong
        perspective and lucent's lattice growth does not need (accepted, no effect).
    blobDetector : None
        OpenCV's custom blob detector; lucent finds light and dark discs itself, so only None
        is accepted.

    Returns
    -------
    (found, centers)
        ``found`` a bool; ``centers`` a (cols·rows, 1, 2) float32 array of pixel positions (OpenCV
        convention), or None. They are in the order of OpenCV's object points: row i, disc j at
        (j·s, i·s) for a symmetric grid and ((2j + i mod 2)·s, i·s) for an asymmetric one. The
        centres are those of ellipses fitted to sub-pixel edge points of each disc (lucent's
        marker detector, docs/markers.md).
    """
    cols, rows = _pair(pattern_size, "pattern_size", 1)
    if isinstance(centers, (int, _np.integer)) and not isinstance(centers, bool) and flags is None:
        centers, flags = None, centers
    _no_output_array(centers, "centers")
    if blobDetector is not None:
        raise ValueError("blobDetector: only None is accepted (lucent finds light and dark discs itself)")
    flags = CALIB_CB_SYMMETRIC_GRID if flags is None else int(flags)
    kind = flags & (CALIB_CB_SYMMETRIC_GRID | CALIB_CB_ASYMMETRIC_GRID)
    if flags & ~(CALIB_CB_SYMMETRIC_GRID | CALIB_CB_ASYMMETRIC_GRID | CALIB_CB_CLUSTERING) or kind not in (CALIB_CB_SYMMETRIC_GRID, CALIB_CB_ASYMMETRIC_GRID):
        raise ValueError(f"flags: expected CALIB_CB_SYMMETRIC_GRID (1) or CALIB_CB_ASYMMETRIC_GRID (2), with or without CALIB_CB_CLUSTERING (4), got {flags!r}")
    grey, w, h = _grey_levels(image)
    c = _lucent.find_circles_grid_flat(grey, w, h, cols, rows, kind == CALIB_CB_ASYMMETRIC_GRID)
    if c is None:
        return False, None
    return True, _np.asarray(c, dtype=_np.float32).reshape(-1, 1, 2)


def calibrate_camera(object_points, image_points, image_size, camera_matrix=None, dist_coeffs=None, flags=0, criteria=None):
    """Calibrate a camera from views of a planar target, as ``cv2.calibrateCamera``: Zhang's
    closed form, then Levenberg–Marquardt over all points (lucent's own implementation).

    Parameters
    ----------
    object_points : list of (N, 3) or (N, 1, 3) arrays, one per view
        The target's points; they must lie in the plane z = 0 and be the same in every view
        (one planar target, as a chessboard).
    image_points : list of (N, 2) or (N, 1, 2) arrays, one per view
        Their pixel positions in each view (OpenCV convention); NaN for a point not seen.
    image_size : (width, height)
        Pixels.
    camera_matrix, dist_coeffs : None or arrays
        The start of the fit with CALIB_USE_INTRINSIC_GUESS (dist_coeffs may be None: zeros);
        with CALIB_FIX_ASPECT_RATIO, camera_matrix gives fx/fy (None: fx = fy, as cv2 holds it);
        otherwise ignored, as by OpenCV.
    flags : int
        A combination of OpenCV's values: the model (CALIB_RATIONAL_MODEL, CALIB_THIN_PRISM_MODEL,
        CALIB_TILTED_MODEL), CALIB_USE_INTRINSIC_GUESS, and terms held during the fit:
        CALIB_ZERO_TANGENT_DIST (p1 = p2 = 0), CALIB_FIX_PRINCIPAL_POINT (at the image centre
        ((w − 1)/2, (h − 1)/2), or the guess's), CALIB_FIX_ASPECT_RATIO (fx/fy of camera_matrix,
        fy fitted), CALIB_FIX_FOCAL_LENGTH, CALIB_FIX_K1 … CALIB_FIX_K6,
        CALIB_FIX_TANGENT_DIST, CALIB_FIX_S1_S2_S3_S4, CALIB_FIX_TAUX_TAUY (at the guess's values
        with CALIB_USE_INTRINSIC_GUESS, else at 0 for distortion terms). CALIB_FIX_SKEW,
        CALIB_USE_LU, CALIB_USE_QR and CALIB_DISABLE_SCHUR_COMPLEMENT are accepted and change
        nothing (no skew in the model; lucent's own solver). Other flags are refused.
    criteria : None or (type, max_count, epsilon)
        OpenCV's stopping rule, accepted so that OpenCV calls run unchanged; lucent's
        Levenberg–Marquardt runs to its own convergence whatever it says.

    Returns
    -------
    (rms, camera_matrix, dist_coeffs, rvecs, tvecs)
        As OpenCV: the RMS reprojection error in pixels, the 3×3 camera matrix, the (1, n)
        distortion coefficients (n = 5, 8 with CALIB_RATIONAL_MODEL, 12 with
        CALIB_THIN_PRISM_MODEL, 14 with CALIB_TILTED_MODEL), and per view the (3, 1) Rodrigues vector and translation (in the
        object points' unit) of the target → camera transform.
    """
    _criteria(criteria)
    flags = int(flags) & ~_NO_EFFECT_FLAGS
    if flags & ~(_CALIB_FLAGS | _HOLD_FLAGS | CALIB_USE_INTRINSIC_GUESS):
        raise ValueError(f"flags: {flags & ~(_CALIB_FLAGS | _HOLD_FLAGS | CALIB_USE_INTRINSIC_GUESS)} is not a flag lucent.calibrate_camera knows "
                         "(the model, CALIB_USE_INTRINSIC_GUESS and the CALIB_FIX_* / CALIB_ZERO_TANGENT_DIST holds are)")
    obj, img = _planar_target(object_points, image_points, "image_points")
    w, h = _pair(image_size, "image_size", 1)
    guess = None
    if flags & CALIB_USE_INTRINSIC_GUESS:
        if camera_matrix is None:
            raise ValueError("camera_matrix: CALIB_USE_INTRINSIC_GUESS starts from it; got None")
        guess = _camera_args(camera_matrix, dist_coeffs)
    aspect = _aspect(camera_matrix, "camera_matrix") if flags & CALIB_FIX_ASPECT_RATIO else None
    rms, (fx, fy, cx, cy), dist, rvecs, tvecs = _lucent.calibrate_camera_flat(
        [float(v) for v in obj.ravel()], [[float(v) for v in p.ravel()] for p in img], w, h,
        _lens_flags(flags, guess is not None), _held(flags, guess is not None), aspect, guess)
    k = _np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    return (rms, k, _np.asarray(dist, dtype=float).reshape(1, -1),
            tuple(_np.asarray(r, dtype=float).reshape(3, 1) for r in rvecs),
            tuple(_np.asarray(t, dtype=float).reshape(3, 1) for t in tvecs))


#: Stereo flags of :func:`stereo_calibrate` (the values of ``cv2.CALIB_*``).
CALIB_FIX_INTRINSIC = 256
CALIB_SAME_FOCAL_LENGTH = 512
CALIB_USE_EXTRINSIC_GUESS = 1 << 22


def _criteria(criteria):
    """OpenCV's ``criteria`` argument: None or (type, max_count, epsilon), accepted and not used."""
    if criteria is None:
        return
    try:
        kind, count, eps = criteria
        int(kind), int(count), float(eps)
    except (TypeError, ValueError):
        raise ValueError(f"criteria: expected None or OpenCV's (type, max_count, epsilon), got {criteria!r}") from None


def _planar_target(object_points, image_points, name):
    """The one planar target's (N, 2) points and each view's (N, 2) pixels, or ValueError."""
    if len(object_points) != len(image_points):
        raise ValueError(f"object_points and {name}: {len(object_points)} and {len(image_points)} views")
    if len(object_points) == 0:
        raise ValueError("object_points: no views")
    obj = [_np.asarray(o, dtype=float).reshape(-1, 3) for o in object_points]
    img = [_np.asarray(p, dtype=float).reshape(-1, 2) for p in image_points]
    for k, (o, p) in enumerate(zip(obj, img)):
        if _np.any(o[:, 2] != 0):
            raise ValueError("object_points: the target must lie in the plane z = 0")
        if len(o) != len(p):
            raise ValueError(f"object_points and {name}: view {k} has {len(o)} and {len(p)} points")
    if all(o.shape == obj[0].shape and _np.array_equal(o, obj[0]) for o in obj):
        return obj[0][:, :2], img
    # Views of different parts of one target (a ChArUco board's corners by id): the union of
    # their points, each view's pixels NaN where it lacks a point (the fit leaves those out).
    index = {}
    for o in obj:
        for q in map(tuple, o[:, :2]):
            index.setdefault(q, len(index))
    union = _np.array(list(index), dtype=float).reshape(-1, 2)
    views = []
    for k, (o, p) in enumerate(zip(obj, img)):
        full = _np.full((len(union), 2), _np.nan)
        at = [index[q] for q in map(tuple, o[:, :2])]
        if len(set(at)) != len(at):
            raise ValueError(f"object_points: view {k} repeats a point")
        full[at] = p
        views.append(full)
    return union, views


def _lens_flags(flags, guessed=False):
    # CALIB_FIX_K3 holds k3 at 0 (left out of the model), or at the guess's value with a guess.
    return (bool(flags & CALIB_FIX_K3) and not guessed, bool(flags & CALIB_ZERO_TANGENT_DIST), bool(flags & CALIB_RATIONAL_MODEL),
            bool(flags & CALIB_THIN_PRISM_MODEL), bool(flags & CALIB_TILTED_MODEL))


def _held(flags, guessed):
    held = sum(bits for f, bits in _HELD_BITS if flags & f)
    return held | (1 << 8 if guessed and flags & CALIB_FIX_K3 else 0)


def _aspect(camera_matrix, name):
    """fx/fy of a camera matrix, for CALIB_FIX_ASPECT_RATIO; 1 without one (cv2 then holds
    fx = fy)."""
    if camera_matrix is None:
        return 1.0
    k = _np.asarray(camera_matrix, dtype=float)
    if k.shape != (3, 3):
        raise ValueError(f"{name}: expected a 3×3 matrix, got shape {k.shape}")
    a = k[0, 0] / k[1, 1] if k[1, 1] != 0 else _np.nan
    if not (_np.isfinite(a) and a > 0):
        raise ValueError(f"{name}: CALIB_FIX_ASPECT_RATIO needs positive fx and fy, got {k[0, 0]} and {k[1, 1]}")
    return float(a)


def _stereo_aspect(flags, camera_matrix1, camera_matrix2):
    """Each camera's held fx/fy: its matrix's, or with CALIB_SAME_FOCAL_LENGTH that of the two
    matrices' mean, as cv2.stereoCalibrate averages them first."""
    if not flags & CALIB_FIX_ASPECT_RATIO:
        return None, None
    a1, a2 = _aspect(camera_matrix1, "camera_matrix1"), _aspect(camera_matrix2, "camera_matrix2")
    if flags & CALIB_SAME_FOCAL_LENGTH:
        k1, k2 = _np.asarray(camera_matrix1, dtype=float), _np.asarray(camera_matrix2, dtype=float)
        a1 = a2 = float((k1[0, 0] + k2[0, 0]) / (k1[1, 1] + k2[1, 1]))
    return a1, a2


def stereo_calibrate(object_points, image_points1, image_points2, camera_matrix1, dist_coeffs1,
                     camera_matrix2, dist_coeffs2, image_size, flags=0, R=None, T=None, criteria=None):
    """Calibrate two cameras and their relative pose from views of one planar target seen by both,
    as ``cv2.stereoCalibrate`` (lucent's own fit, that of ``lucent scan calibrate-stereo``).

    Parameters
    ----------
    object_points : list of (N, 3) arrays, one per view
        The target's points, in the plane z = 0, the same in every view.
    image_points1, image_points2 : lists of (N, 2) or (N, 1, 2) arrays
        Their pixels in the first and second camera.
    camera_matrix1, dist_coeffs1, camera_matrix2, dist_coeffs2
        Used with CALIB_USE_INTRINSIC_GUESS (the start of the fit) or CALIB_FIX_INTRINSIC (held);
        otherwise ignored (None is accepted) and each camera starts from its own calibration.
    image_size : (width, height)
        Pixels, of both cameras.
    flags : int
        0 (all free), CALIB_USE_INTRINSIC_GUESS or CALIB_FIX_INTRINSIC, combined with the model
        and hold flags of :func:`calibrate_camera`, which apply to both cameras
        (CALIB_FIX_ASPECT_RATIO takes each camera's fx/fy from its matrix), and
        CALIB_SAME_FOCAL_LENGTH (the second camera's fx, fy are the first's), and
        CALIB_USE_EXTRINSIC_GUESS (the fit's relative pose starts from ``R``, ``T``, as in
        OpenCV 4; OpenCV 5.1's stereoCalibrate rejects the flag). Unlike cv2, whose default is
        CALIB_FIX_INTRINSIC, 0 fits everything.
    R, T : (3, 3) and 3-vector, optional
        The start of the relative pose, with CALIB_USE_EXTRINSIC_GUESS (keywords here; cv2 takes
        them before ``flags``).
    criteria : None or (type, max_count, epsilon)
        OpenCV's stopping rule, accepted so that OpenCV calls run unchanged (as
        :func:`calibrate_camera`'s).

    Returns
    -------
    (rms, camera_matrix1, dist_coeffs1, camera_matrix2, dist_coeffs2, R, T, E, F)
        As OpenCV: the RMS reprojection error over both cameras (pixels), the cameras, the
        rotation and (3, 1) translation with X₂ = R X₁ + T, the essential matrix E = [T]ₓ R and
        the fundamental matrix F = K₂⁻ᵀ E K₁⁻¹.
    """
    _criteria(criteria)
    flags = int(flags) & ~_NO_EFFECT_FLAGS
    allowed = (_CALIB_FLAGS | _HOLD_FLAGS | CALIB_USE_INTRINSIC_GUESS | CALIB_FIX_INTRINSIC | CALIB_SAME_FOCAL_LENGTH
               | CALIB_USE_EXTRINSIC_GUESS)
    if flags & ~allowed:
        raise ValueError(f"flags: {flags & ~allowed} is not a flag lucent.stereo_calibrate knows "
                         "(CALIB_USE_INTRINSIC_GUESS, CALIB_FIX_INTRINSIC, CALIB_SAME_FOCAL_LENGTH, "
                         "CALIB_USE_EXTRINSIC_GUESS and the flags of calibrate_camera are)")
    extrinsic = None
    if flags & CALIB_USE_EXTRINSIC_GUESS:
        if R is None or T is None:
            raise ValueError("R, T: CALIB_USE_EXTRINSIC_GUESS needs both")
        r, t = _np.asarray(R, dtype=float), _np.asarray(T, dtype=float).ravel()
        if r.shape != (3, 3) or t.size != 3:
            raise ValueError(f"R, T: need a 3×3 matrix and 3 values, got {r.shape} and {t.size}")
        extrinsic = ([[float(v) for v in row] for row in r], [float(v) for v in t])
    if len(image_points1) != len(image_points2):
        raise ValueError(f"image_points1 and image_points2: {len(image_points1)} and {len(image_points2)} views")
    obj, img1 = _planar_target(object_points, image_points1, "image_points1")
    _, img2 = _planar_target(object_points, image_points2, "image_points2")
    w, h = _pair(image_size, "image_size", 1)
    guess = None
    if flags & (CALIB_USE_INTRINSIC_GUESS | CALIB_FIX_INTRINSIC):
        if camera_matrix1 is None or camera_matrix2 is None:
            raise ValueError("camera_matrix1, camera_matrix2: CALIB_USE_INTRINSIC_GUESS and CALIB_FIX_INTRINSIC need both cameras")
        guess = (_camera_args(camera_matrix1, dist_coeffs1, "camera_matrix1", "dist_coeffs1"),
                 _camera_args(camera_matrix2, dist_coeffs2, "camera_matrix2", "dist_coeffs2"))
    rms, c1, d1, c2, d2, r, t = _lucent.stereo_calibrate_flat(
        [float(v) for v in obj.ravel()], [[float(v) for v in p.ravel()] for p in img1], [[float(v) for v in p.ravel()] for p in img2],
        w, h, guess, bool(flags & CALIB_FIX_INTRINSIC), _lens_flags(flags, guess is not None), _held(flags, guess is not None),
        _stereo_aspect(flags, camera_matrix1, camera_matrix2), bool(flags & CALIB_SAME_FOCAL_LENGTH), extrinsic)
    k = lambda c: _np.array([[c[0], 0.0, c[2]], [0.0, c[1], c[3]], [0.0, 0.0, 1.0]])
    k1, k2, r, t = k(c1), k(c2), _np.asarray(r, dtype=float), _np.asarray(t, dtype=float).reshape(3, 1)
    tx = _np.array([[0.0, -t[2, 0], t[1, 0]], [t[2, 0], 0.0, -t[0, 0]], [-t[1, 0], t[0, 0], 0.0]])
    e = tx @ r
    f = _np.linalg.inv(k2).T @ e @ _np.linalg.inv(k1)
    return (rms, k1, _np.asarray(d1, dtype=float).reshape(1, -1), k2, _np.asarray(d2, dtype=float).reshape(1, -1), r, t, e, f)


# OpenCV 5's numbers (OpenCV 4 had DLS 3 and UPNP 4, and numbered the last four 5-8).
SOLVEPNP_ITERATIVE = 0
SOLVEPNP_EPNP = 1
SOLVEPNP_P3P = 2
SOLVEPNP_AP3P = 3
SOLVEPNP_IPPE = 4
SOLVEPNP_IPPE_SQUARE = 5
SOLVEPNP_SQPNP = 6


def _points(v, dim, name):
    """An (N, dim) float array from (N, dim), (N, 1, dim) or (1, N, dim), as OpenCV takes point
    lists; other shapes (a transposed (dim, N) list included) are a ValueError naming ``name``."""
    a = _np.asarray(v)
    if a.dtype == object or _np.iscomplexobj(a) or not (_np.issubdtype(a.dtype, _np.number) or a.dtype == bool):
        raise ValueError(f"{name}: expected real numbers, got an array of {a.dtype}")
    a = a.astype(float)
    if a.ndim == 2 and a.shape[1] == dim:
        return a
    if a.ndim == 3 and a.shape[2] == dim and 1 in a.shape[:2]:
        return a.reshape(-1, dim)
    raise ValueError(f"{name}: expected an (N, {dim}) or (N, 1, {dim}) array of points, got shape {a.shape}")


def _pnp_points(object_points, image_points):
    """Object and image points as flat float lists (N × 3 and N × 2)."""
    obj = _points(object_points, 3, "objectPoints")
    img = _points(image_points, 2, "imagePoints")
    return [float(v) for v in obj.ravel()], [float(v) for v in img.ravel()]


def _pinhole_generic(lens):
    """The closed-form methods' solver for the pinhole ``lens`` = (k, d): (object, image, flags)
    → [(rvec, tvec, rms)], best first."""
    k, d = lens
    return lambda obj, img, flags: _lucent.solve_pnp_generic_flat(obj, img, k, d, int(flags))


def _check_flags(flags):
    if isinstance(flags, bool) or not isinstance(flags, (int, _np.integer)) or not 0 <= int(flags) <= SOLVEPNP_SQPNP:
        raise ValueError(f"flags: expected one of OpenCV 5's SOLVEPNP_* methods (0-6), got {flags!r}")
    return int(flags)


def _solve_pnp_with(solver, object_points, image_points, lens, rvec, tvec, useExtrinsicGuess, flags, generic=None):
    """The argument handling of :func:`solve_pnp` and :func:`lucent.fisheye.solve_pnp` around
    their Rust solvers: ``solver`` for ``SOLVEPNP_ITERATIVE`` (flat points, the lens as ``lens`` =
    (k, d), the guess or None), ``generic`` (default: the pinhole lens's) for the other methods."""
    flags = _check_flags(flags)
    obj, img = _pnp_points(object_points, image_points)
    if flags != SOLVEPNP_ITERATIVE:
        # OpenCV ignores the guess for the other methods.
        r, t, _ = (generic or _pinhole_generic(lens))(obj, img, flags)[0]
    else:
        k, d = lens
        r, t, _ = solver(obj, img, k, d, _pnp_guess(rvec, tvec, useExtrinsicGuess))
    return True, _np.asarray(r, dtype=float).reshape(3, 1), _np.asarray(t, dtype=float).reshape(3, 1)


def solve_pnp(object_points, image_points, camera_matrix, dist_coeffs, rvec=None, tvec=None,
              useExtrinsicGuess=False, flags=SOLVEPNP_ITERATIVE):
    """The pose of a known object from its image, as ``cv2.solvePnP``. With
    ``SOLVEPNP_ITERATIVE`` (the default): a closed-form start (the plane's homography for
    coplanar points, at least 4; the direct linear transform otherwise, at least 6), or ``rvec``,
    ``tvec`` with ``useExtrinsicGuess`` (at least 4 points), then Levenberg–Marquardt on the
    reprojection error through the full lens model. The other ``flags`` are OpenCV's
    non-iterative methods, on the pixels taken through the lens's inverse and without a refinement
    in pixels (:func:`solve_pnp_generic`; lucent's own implementations), numbered as in OpenCV 5:
    ``SOLVEPNP_EPNP``, ``SOLVEPNP_P3P`` and
    ``SOLVEPNP_AP3P`` (exactly 4 points), ``SOLVEPNP_IPPE`` (points on a plane),
    ``SOLVEPNP_IPPE_SQUARE`` (a square's corners in OpenCV's order) and ``SOLVEPNP_SQPNP`` (at
    least 3 points).

    Parameters
    ----------
    object_points : (N, 3) or (N, 1, 3) array
        The object's points, in its own frame.
    image_points : (N, 2) or (N, 1, 2) array
        Their pixels (OpenCV convention).
    camera_matrix, dist_coeffs
        The camera (OpenCV's 3×3 matrix and 0–14 distortion coefficients).

    Returns
    -------
    (retval, rvec, tvec)
        As OpenCV: True, and the (3, 1) Rodrigues vector and translation of the object → camera
        transform. Configurations that determine no pose raise ``ValueError``.
    """
    return _solve_pnp_with(_lucent.solve_pnp_flat, object_points, image_points, _camera_args(camera_matrix, dist_coeffs), rvec, tvec, useExtrinsicGuess, flags)


def _pnp_guess(rvec, tvec, useExtrinsicGuess):
    """The (rvec, tvec) guess of a solve_pnp call as Rust takes it, or None."""
    if not useExtrinsicGuess:
        return None
    if rvec is None or tvec is None:
        raise ValueError("useExtrinsicGuess needs rvec and tvec")
    rv, tv = _np.asarray(rvec, dtype=float).ravel(), _np.asarray(tvec, dtype=float).ravel()
    if rv.size != 3 or tv.size != 3:
        raise ValueError(f"rvec and tvec: need 3 values each, got {rv.size} and {tv.size}")
    return (tuple(float(v) for v in rv), tuple(float(v) for v in tv))


def solve_pnp_generic(objectPoints, imagePoints, cameraMatrix, distCoeffs, rvecs=None, tvecs=None, useExtrinsicGuess=False,
                      flags=SOLVEPNP_ITERATIVE, rvec=None, tvec=None, reprojectionError=None):
    """Every pose a method finds, best first, as ``cv2.solvePnPGeneric``: one for
    ``SOLVEPNP_ITERATIVE``, EPnP and SQPnP (its global minimum of the object-space error); for
    P3P/AP3P every pose of the first three points that puts the fourth in front of the camera (up
    to four; the first, with the fourth point nearest its pixel, is ``solve_pnp``'s); two for IPPE
    and IPPE_SQUARE (a plane's two poses). The closed-form methods (``scan::calib::pnp``'s ``epnp``, ``p3p``, ``ippe``,
    ``sqpnp``; lucent's own implementations) run on the pixels taken exactly through the lens's
    inverse (OpenCV's ``undistortPoints`` stops after 5 fixed-point steps) and are not refined in
    pixels; :func:`solve_pnp_refine_lm` refines any of them. IPPE's homography is the
    Hartley-normalised direct linear transform (OpenCV's is Harker and O'Leary's; they agree on
    exact data). ``rvecs``, ``tvecs`` and ``reprojectionError`` are OpenCV's output arguments and
    are ignored.

    Returns
    -------
    (retval, rvecs, tvecs, reprojectionError)
        The number of poses, tuples of (3, 1) Rodrigues vectors and translations, and an (n, 1)
        array of each pose's RMS reprojection error as OpenCV defines it (over the 2N coordinates,
        pixels). Bad input and configurations with no pose raise ``ValueError``.
    """
    flags = _check_flags(flags)
    k, d = _camera_args(cameraMatrix, distCoeffs)
    obj, img = _pnp_points(objectPoints, imagePoints)
    guess = _pnp_guess(rvec, tvec, useExtrinsicGuess) if flags == SOLVEPNP_ITERATIVE else None
    poses = _lucent.solve_pnp_generic_flat(obj, img, k, d, flags, guess)
    rv = tuple(_np.asarray(r, dtype=float).reshape(3, 1) for r, _, _ in poses)
    tv = tuple(_np.asarray(t, dtype=float).reshape(3, 1) for _, t, _ in poses)
    err = _np.asarray([e / _np.sqrt(2.0) for _, _, e in poses], dtype=float).reshape(-1, 1)
    return len(poses), rv, tv, err


def solve_pnp_refine_lm(objectPoints, imagePoints, cameraMatrix, distCoeffs, rvec, tvec, criteria=None):
    """A pose refined from ``rvec``, ``tvec`` by Levenberg–Marquardt on the reprojection error
    through the full lens, as ``cv2.solvePnPRefineLM`` (at least 4 points; lucent iterates to
    convergence, so ``criteria`` is ignored).

    Returns
    -------
    (rvec, tvec)
        (3, 1) arrays.
    """
    _, r, t = solve_pnp(objectPoints, imagePoints, cameraMatrix, distCoeffs, rvec, tvec, useExtrinsicGuess=True)
    return r, t


def _solve_pnp_ransac_with(solver, object_points, image_points, lens, rvec, tvec, useExtrinsicGuess, iterationsCount,
                           reprojectionError, confidence, flags, generic=None):
    """The argument handling of :func:`solve_pnp_ransac` and :func:`lucent.fisheye.solve_pnp_ransac`."""
    flags = _check_flags(flags)
    obj, img = _pnp_points(object_points, image_points)
    k, d = lens
    out = solver(obj, img, k, d, _pnp_guess(rvec, tvec, useExtrinsicGuess), _count("iterationsCount", iterationsCount),
                 float(reprojectionError), float(confidence))
    if out is None:
        return False, None, None, None
    r, t, inliers, _ = out
    if flags != SOLVEPNP_ITERATIVE:
        # The final pose by the method asked for on the inliers (EPnP for P3P and AP3P, as OpenCV).
        method = SOLVEPNP_EPNP if flags in (SOLVEPNP_P3P, SOLVEPNP_AP3P) else flags
        sub_obj = [v for i in inliers for v in obj[3 * i:3 * i + 3]]
        sub_img = [v for i in inliers for v in img[2 * i:2 * i + 2]]
        r, t, _ = (generic or _pinhole_generic(lens))(sub_obj, sub_img, method)[0]
    return (True, _np.asarray(r, dtype=float).reshape(3, 1), _np.asarray(t, dtype=float).reshape(3, 1),
            _np.asarray(inliers, dtype=_np.int32).reshape(-1, 1))


def solve_pnp_ransac(object_points, image_points, camera_matrix, dist_coeffs, rvec=None, tvec=None, useExtrinsicGuess=False,
                     iterationsCount=100, reprojectionError=8.0, confidence=0.99, flags=SOLVEPNP_ITERATIVE):
    """The pose of a known object from correspondences of which some are wrong, as
    ``cv2.solvePnPRansac`` (``scan::calib::pnp_ransac``): random sets of five points (a fixed
    seed, so calls repeat) posed by EPnP, as OpenCV draws them (with ``useExtrinsicGuess``, sets
    of 4 coplanar or 6 points refined from the guess), the pose with the most correspondences
    reprojecting within ``reprojectionError`` pixels through the full lens kept, at most
    ``iterationsCount`` sets and no more than ``confidence`` asks, then the pose refined on its
    inliers; on the same data lucent and OpenCV find the same inliers and, refined on them, the
    same pose. With other ``flags`` the final pose on the inliers is that method's
    (:func:`solve_pnp_generic`; EPnP for ``SOLVEPNP_P3P`` and ``SOLVEPNP_AP3P``, as OpenCV); the
    hypotheses stay lucent's.

    Returns (retval, rvec, tvec, inliers) as OpenCV: True, the (3, 1) Rodrigues vector and
    translation, and the inliers' indices as an (M, 1) int32 array; (False, None, None, None) when
    no pose has a minimal set of inliers. Bad input raises ``ValueError``.
    """
    return _solve_pnp_ransac_with(_lucent.solve_pnp_ransac_flat, object_points, image_points,
                                  _camera_args(camera_matrix, dist_coeffs), rvec, tvec, useExtrinsicGuess, iterationsCount,
                                  reprojectionError, confidence, flags)


CALIB_ZERO_DISPARITY = 1024


def get_optimal_new_camera_matrix(camera_matrix, dist_coeffs, image_size, alpha, new_image_size=None):
    """The pinhole camera an undistorted image is best shown through, as
    ``cv2.getOptimalNewCameraMatrix`` (principal point not forced to the centre).

    ``alpha`` 0 keeps only valid pixels, 1 keeps every source pixel (black borders), values in
    between interpolate. Returns (new_camera_matrix, roi): the 3×3 matrix and the (x, y, width,
    height) rectangle of valid pixels in the new image (``new_image_size``, default
    ``image_size``). The undistortion is exact (lucent's Newton inverse), where OpenCV stops
    after five iterations; with strong distortion the two differ at the image corners.
    """
    k, d = _camera_args(camera_matrix, dist_coeffs)
    size = _pair(image_size, "image_size", 1)
    new = size if new_image_size is None or tuple(new_image_size) == (0, 0) else _pair(new_image_size, "new_image_size", 1)
    (fx, fy, cx, cy), roi = _lucent.optimal_new_camera_matrix_flat(k, d, size, float(alpha), new)
    return _np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]]), tuple(roi)


def stereo_rectify(camera_matrix1, dist_coeffs1, camera_matrix2, dist_coeffs2, image_size, R, T,
                   flags=CALIB_ZERO_DISPARITY, alpha=-1.0, new_image_size=(0, 0)):
    """Rectifying rotations and projections of a calibrated stereo pair, as ``cv2.stereoRectify``
    (Bouguet's algorithm as OpenCV implements it; ``scan::calib::rectify``).

    ``R``, ``T``: the pair's pose, X₂ = R X₁ + T (3×3 or a Rodrigues vector; as
    :func:`stereo_calibrate` returns it). ``flags``: CALIB_ZERO_DISPARITY (the default, as in
    OpenCV) or 0. ``alpha``: −1 for the default scale, or 0…1 as in
    :func:`get_optimal_new_camera_matrix`. Returns (R1, R2, P1, P2, Q, roi1, roi2) as OpenCV:
    each camera's rotation into the rectified frame, their 3×4 projections (P2 carries the
    baseline), the 4×4 disparity-to-depth matrix and each image's rectangle of valid pixels.
    """
    if not (_np.isfinite(float(alpha)) and (float(alpha) == -1.0 or 0.0 <= float(alpha) <= 1.0)):
        raise ValueError(f"alpha: -1 (the default scale) or a number in [0, 1], got {alpha!r}")
    flags = int(flags)
    if flags & ~CALIB_ZERO_DISPARITY:
        raise ValueError(f"flags: only CALIB_ZERO_DISPARITY ({CALIB_ZERO_DISPARITY}) or 0, got {flags}")
    k1, d1 = _camera_args(camera_matrix1, dist_coeffs1, "camera_matrix1", "dist_coeffs1")
    k2, d2 = _camera_args(camera_matrix2, dist_coeffs2, "camera_matrix2", "dist_coeffs2")
    r = _np.asarray(R, dtype=float)
    if r.size == 3:
        r = _rodrigues(r.ravel())
    if r.shape != (3, 3):
        raise ValueError(f"R: expected a 3×3 matrix or a Rodrigues vector, got shape {r.shape}")
    t = _np.asarray(T, dtype=float).ravel()
    if t.size != 3:
        raise ValueError(f"T: expected 3 values, got {t.size}")
    size = _pair(image_size, "image_size", 1)
    new = (0, 0) if new_image_size is None or tuple(new_image_size) == (0, 0) else _pair(new_image_size, "new_image_size", 1)
    r1, r2, p1, p2, q, roi1, roi2 = _lucent.stereo_rectify_flat(
        k1, d1, k2, d2, size, [float(v) for v in r.ravel()], [float(v) for v in t], bool(flags & CALIB_ZERO_DISPARITY),
        float(alpha), new)
    m = lambda v, rows: _np.asarray(v, dtype=float).reshape(rows, -1)
    return m(r1, 3), m(r2, 3), m(p1, 3), m(p2, 3), m(q, 4), tuple(roi1), tuple(roi2)


def _rodrigues(v):
    th = float(_np.linalg.norm(v))
    if th == 0.0:
        return _np.eye(3)
    k = v / th
    kx = _np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return _np.eye(3) + _np.sin(th) * kx + (1.0 - _np.cos(th)) * kx @ kx


def _left_3x3(m, name):
    """The left 3×3 of a 3×3 camera matrix or a 3×4 projection, or ValueError."""
    p = _np.asarray(m, dtype=float)
    if p.shape == (3, 4):
        p = p[:, :3]
    if p.shape != (3, 3):
        raise ValueError(f"{name}: expected 3×3 or 3×4, got shape {p.shape}")
    return p


#: ``cv2.CV_32FC1``, ``CV_32FC2`` and ``CV_16SC2``: the map types :func:`init_undistort_rectify_map` returns.
CV_32FC1 = 5
CV_32FC2 = 13
CV_16SC2 = 11


def init_undistort_rectify_map(camera_matrix, dist_coeffs, R, new_camera_matrix, size, m1type=CV_32FC1):
    """The remapping of ``cv2.initUndistortRectifyMap``: for each pixel of the new image (the
    pinhole camera ``new_camera_matrix``, or the left 3×3 of a projection P from
    :func:`stereo_rectify`, turned by ``R``, None for the identity), the source pixel whose ray it
    shows; ``cv2.remap`` takes the maps as they are. Without ``new_camera_matrix`` the new camera
    is ``camera_matrix`` with its principal point moved to the image's centre ((w − 1)/2,
    (h − 1)/2), as OpenCV's ``getDefaultNewCameraMatrix(…, centerPrincipalPoint=True)`` makes it
    here (``undistort`` keeps ``camera_matrix`` itself).

    ``m1type`` chooses OpenCV's map formats: :data:`CV_32FC1` (default), (map_x, map_y), each a
    (height, width) float32 array; :data:`CV_32FC2`, one (height, width, 2) float32 array and
    None; :data:`CV_16SC2`, OpenCV's fixed-point maps: the integer pixel (height, width, 2) int16
    and a (height, width) uint16 index of the 1/32-pixel fraction (row fraction × 32 + column
    fraction), the float coordinates times 32 rounded to the nearest integer as
    ``cv2.convertMaps`` rounds them.
    """
    m1type = int(m1type)
    if m1type not in (CV_32FC1, CV_32FC2, CV_16SC2):
        raise ValueError(f"m1type: CV_32FC1 ({CV_32FC1}), CV_32FC2 ({CV_32FC2}) or CV_16SC2 ({CV_16SC2}), got {m1type}")
    k, d = _camera_args(camera_matrix, dist_coeffs)
    r = _np.eye(3) if R is None or _np.asarray(R).size == 0 else _np.asarray(R, dtype=float)
    if r.shape != (3, 3):
        raise ValueError(f"R: expected a 3×3 matrix, got shape {r.shape}")
    w, h = _image_size(size, "size")
    if new_camera_matrix is None:
        p = _np.array(_np.asarray(k, dtype=float).reshape(3, 3))
        p[0, 2], p[1, 2] = (w - 1) * 0.5, (h - 1) * 0.5
    else:
        p = _left_3x3(new_camera_matrix, "new_camera_matrix")
    mx, my = _lucent.undistort_rectify_map_flat(k, d, [float(v) for v in r.ravel()], [float(v) for v in p.ravel()], w, h)
    mx = _np.frombuffer(mx, dtype=_np.float32).reshape(h, w).copy()
    my = _np.frombuffer(my, dtype=_np.float32).reshape(h, w).copy()
    if m1type == CV_32FC1:
        return mx, my
    if m1type == CV_32FC2:
        return _np.dstack([mx, my]), None
    # Fixed point with 5 fractional bits (OpenCV's INTER_BITS), rounded half to even as cvRound.
    ix = _np.clip(_np.rint(mx.astype(_np.float64) * 32.0), -2.0**31, 2.0**31 - 1).astype(_np.int32)
    iy = _np.clip(_np.rint(my.astype(_np.float64) * 32.0), -2.0**31, 2.0**31 - 1).astype(_np.int32)
    xy = _np.dstack([_np.clip(ix >> 5, -32768, 32767), _np.clip(iy >> 5, -32768, 32767)]).astype(_np.int16)
    frac = ((iy & 31) * 32 + (ix & 31)).astype(_np.uint16)
    return xy, frac


def triangulate_points(proj_matr1, proj_matr2, proj_points1, proj_points2):
    """Points from their pixels in two views, as ``cv2.triangulatePoints`` (the linear DLT
    method; ``scan::triangulate::triangulate_dlt``).

    ``proj_matr1``, ``proj_matr2``: 3×4 projection matrices (e.g. P1, P2 of
    :func:`stereo_rectify`, or K[R|t]); ``proj_points1``, ``proj_points2``: the pixels, 2×N as
    OpenCV takes them (or N×2 and N×1×2 for N ≠ 2). Returns a 4×N array of homogeneous coordinates, each column
    of unit length with w ≥ 0 (OpenCV leaves the sign as its SVD gives it); X = column[:3] / column[3].
    """
    p1, p2 = _np.asarray(proj_matr1, dtype=float), _np.asarray(proj_matr2, dtype=float)
    if p1.shape != (3, 4) or p2.shape != (3, 4):
        raise ValueError(f"proj_matr1, proj_matr2: expected 3×4 matrices, got shapes {p1.shape} and {p2.shape}")

    def pts(v, name):
        a = _np.asarray(v, dtype=float)
        if a.ndim == 2 and a.shape[0] == 2:  # OpenCV's 2×N (a 2×2 array too)
            a = a.T
        a = _points(a, 2, name)
        if not _np.isfinite(a).all():
            raise ValueError(f"{name}: pixels must be finite")
        return a
    a, b = pts(proj_points1, "proj_points1"), pts(proj_points2, "proj_points2")
    if len(a) != len(b):
        raise ValueError(f"proj_points1, proj_points2: {len(a)} and {len(b)} points")
    h = _lucent.triangulate_points_flat([float(v) for v in p1.ravel()], [float(v) for v in p2.ravel()], _flat64(a), _flat64(b))
    return _np.asarray(h, dtype=float).reshape(-1, 4).T


def undistort(src, camera_matrix, dist_coeffs, dst=None, new_camera_matrix=None, newCameraMatrix=None):
    """A photograph with its lens distortion removed, as ``cv2.undistort`` (lucent's own remap,
    that of ``lucent scan undistort``). OpenCV's call ``undistort(img, K, dist, None, K_new)``
    runs unchanged, and so does the shorter ``undistort(img, K, dist, K_new)``.

    Parameters
    ----------
    src : (H, W) or (H, W, C) uint8 array
        The photograph.
    camera_matrix, dist_coeffs
        Its camera (OpenCV's 3×3 matrix and 0–14 distortion coefficients).
    dst : None or array
        OpenCV's output argument; not written to. A 3 × 3 matrix in this place is taken as
        ``new_camera_matrix``.
    new_camera_matrix (or OpenCV's name, newCameraMatrix) : 3×3, optional
        The output's pinhole camera (``camera_matrix`` by default, as OpenCV).

    Returns
    -------
    ndarray of the shape and dtype of ``src``: each output pixel the photograph's value where the
    lens puts that pixel's ray, blended bilinearly; black where the photograph does not see it.
    The values are interpolated as stored (as OpenCV); OpenCV quantises the weights to 1/32 px.
    """
    a = _np.asarray(src)
    if a.dtype != _np.uint8 or a.ndim not in (2, 3):
        raise ValueError(f"src: expected an (H, W) or (H, W, C) uint8 array, got {a.dtype} of shape {a.shape}")
    h, w = a.shape[:2]
    _image_size((w, h), "src")
    c = 1 if a.ndim == 2 else a.shape[2]
    k, d = _camera_args(camera_matrix, dist_coeffs)
    if dst is not None and _np.shape(dst) == (3, 3) and new_camera_matrix is None and newCameraMatrix is None:
        dst, new_camera_matrix = None, dst
    _no_output_array(dst, "dst")
    if new_camera_matrix is not None and newCameraMatrix is not None:
        raise ValueError("new_camera_matrix: given twice (also as newCameraMatrix)")
    new_camera_matrix = newCameraMatrix if new_camera_matrix is None else new_camera_matrix
    k_new = None if new_camera_matrix is None else _camera_args(new_camera_matrix, None, "new_camera_matrix")[0]
    out = _lucent.undistort_flat(_np.ascontiguousarray(a).tobytes(), w, h, c, k, d, k_new)
    return _np.frombuffer(out, dtype=_np.uint8).reshape(a.shape).copy()


def calibrate_procam(captures, projector_size, pattern_size, square, flags=0, step=1, black_threshold=40, white_threshold=5, white_black="last") -> Result:
    """Projector–camera calibration from Gray-code captures of a chessboard, as ``lucent scan
    calibrate`` (and kamino410/procam-calibration's ``calibrate.py``) computes it.

    Parameters
    ----------
    captures : list of folders
        One folder per board pose, each with ``graycode_00.png`` … (the patterns of
        ``lucent scan patterns``, white and black last unless ``white_black="first"``); at least 3.
    projector_size : (width, height)
        The projector's resolution, pixels.
    pattern_size : (cols, rows)
        Inner corners of the chessboard per row and per column.
    square : float
        Square size; the translation and board poses come out in this unit.
    flags : int
        CALIB_FIX_K3, CALIB_ZERO_TANGENT_DIST, CALIB_RATIONAL_MODEL, CALIB_THIN_PRISM_MODEL,
        CALIB_TILTED_MODEL (OpenCV's values), for both devices.
    step, black_threshold, white_threshold
        As ``lucent scan calibrate --step --black-threshold --white-threshold``.
    white_black : "last" or "first"
        Where each capture's white and black frames are, as ``--white-black``: after the patterns
        (OpenCV's ``GrayCodePattern`` order) or before them.

    Returns
    -------
    Result
        The keys of ``lucent scan calibrate --json``: ``camera`` and ``projector`` (width, height,
        fx, fy, cx, cy, distortion, rms_px), ``rotation`` and ``translation`` (camera → projector,
        X_p = R X_c + T), ``rms_px`` and the board pose of each capture.
    """
    flags = int(flags)
    if flags & ~_CALIB_FLAGS:
        raise ValueError(f"flags: only CALIB_ZERO_TANGENT_DIST, CALIB_FIX_K3, CALIB_RATIONAL_MODEL, CALIB_THIN_PRISM_MODEL and CALIB_TILTED_MODEL are supported, got {flags}")
    if isinstance(captures, (str, bytes, _os.PathLike)):
        raise ValueError(f"captures: expected a list of capture folders, got the single path {captures!r}")
    pw, ph = _pair(projector_size, "projector_size", 1)
    cols, rows = _pair(pattern_size, "pattern_size", 3)
    bits = (bool(flags & CALIB_FIX_K3), bool(flags & CALIB_ZERO_TANGENT_DIST), bool(flags & CALIB_RATIONAL_MODEL),
            bool(flags & CALIB_THIN_PRISM_MODEL), bool(flags & CALIB_TILTED_MODEL))
    if white_black not in ("last", "first"):
        raise ValueError(f"white_black: expected \"last\" or \"first\", got {white_black!r}")
    text = _lucent.calibrate_procam_json([str(c) for c in captures], (pw, ph), cols, rows, float(square), bits, int(step),
                                         (int(black_threshold), int(white_threshold)), white_black == "first")
    return Result(_json.loads(text))


def gray_code_patterns(projector_size, step=1) -> list:
    """The Gray-code frames ``lucent scan patterns`` writes for a projector, in capture order:
    OpenCV's ``GrayCodePattern`` order (each column bit, most significant first, then its
    inverse; then the row bits), then white and black.

    Parameters
    ----------
    projector_size : (width, height)
        The projector's resolution, pixels.
    step : int
        Projector pixels per code (1: every pixel its own code).

    Returns
    -------
    list of (height, width) uint8 arrays, 255 lit and 0 dark.
    """
    pw, ph = _pair(projector_size, "projector_size", 1)
    frames = _lucent.gray_code_patterns_flat((pw, ph), int(step))
    return [_np.frombuffer(bytes(f), dtype=_np.uint8).reshape(ph, pw).copy() for f in frames]


def decode_gray_code(capture, projector_size, step=1, black_threshold=40, white_threshold=5, white_black="last",
                     refine=True) -> Result:
    """Projector column and row per camera pixel from a Gray-code capture, as ``lucent scan
    decode`` computes them (docs/scanning.md, "Decoding").

    Parameters
    ----------
    capture : folder, or sequence of (H, W) uint8 arrays
        A capture folder as ``lucent scan decode`` reads it (``graycode_00.png`` …, or PNG/JPEG
        files in natural order), or its frames in capture order (8-bit grey, as
        ``cv2.imread(…, cv2.IMREAD_GRAYSCALE)`` gives them).
    projector_size : (width, height)
        The projector's resolution, pixels.
    step, black_threshold, white_threshold, white_black
        As ``--step``, ``--black-threshold``, ``--white-threshold`` and ``--white-black``
        ("last" or "first").
    refine : bool
        Sub-pixel coordinates from the stripe edges (``False``: ``--no-refine``).

    Returns
    -------
    Result
        The keys of ``lucent scan decode --json`` (``width``, ``height``, ``valid_pixels``,
        ``valid_fraction``, ``refined_column_pixels``, ``refined_row_pixels``) and the map:
        ``column`` and ``row`` (height, width) float32 arrays of projector pixels (OpenCV
        convention, NaN where invalid), ``white`` and ``black`` the white and black frames'
        levels (float32).
    """
    pw, ph = _pair(projector_size, "projector_size", 1)
    if white_black not in ("last", "first"):
        raise ValueError(f"white_black: expected \"last\" or \"first\", got {white_black!r}")
    args = ((pw, ph), int(step), (int(black_threshold), int(white_threshold)), bool(refine), white_black == "first")
    if isinstance(capture, (str, bytes, _os.PathLike)):
        out = _lucent.decode_capture_dir(_os.fsdecode(capture), *args)
    else:
        frames = [_np.asarray(f) for f in capture]
        if not frames:
            raise ValueError("capture: no frames")
        for i, f in enumerate(frames):
            if f.dtype != _np.uint8 or f.ndim != 2:
                raise ValueError(f"capture: frame {i} is {f.dtype} of shape {f.shape}; expected (H, W) uint8 grey levels")
        h, w = frames[0].shape
        for i, f in enumerate(frames):
            if f.shape != (h, w):
                raise ValueError(f"capture: frame {i} is {f.shape[1]}×{f.shape[0]}, frame 0 {w}×{h}")
        out = _lucent.decode_frames_flat(_np.stack(frames).ravel(), len(frames), w, h, *args)
    w, h, col, row, white, black, valid, refined_c, refined_r = out
    grid = lambda v: _np.asarray(v, dtype=_np.float32).reshape(h, w)
    return Result({"width": w, "height": h, "valid_pixels": valid, "valid_fraction": valid / (w * h),
                   "refined_column_pixels": refined_c, "refined_row_pixels": refined_r,
                   "column": grid(col), "row": grid(row), "white": grid(white), "black": grid(black)})


def reconstruct_gray_code(capture, calibration, projector_size=None, step=1, black_threshold=40, white_threshold=5,
                          white_black="last", refine=True, fill_holes=0, max_edge_px=20.0) -> Result:
    """A Gray-code capture triangulated with a projector–camera calibration, as ``lucent scan
    reconstruct`` computes it (docs/scanning.md, "Reconstruction").

    Parameters
    ----------
    capture : folder
        A capture folder as ``lucent scan decode`` reads it.
    calibration : path or dict
        The calibration: lucent's JSON (what ``lucent scan calibrate`` writes, or the result of
        :func:`calibrate_procam`) or procam-calibration's ``calibration_result.xml``.
    projector_size : (width, height), optional
        The projector's resolution, needed for OpenCV FileStorage (``--projector``).
    step, black_threshold, white_threshold, white_black, refine
        As :func:`decode_gray_code`.
    fill_holes, max_edge_px
        As ``--fill-holes`` (0: off) and ``--max-edge`` (camera-pixel footprints within which
        neighbours are joined for the normals).

    Returns
    -------
    Result
        The keys of ``lucent scan reconstruct --json`` (``points``, ``bbox`` with ``min`` and
        ``max``, ``median_ray_gap``, and ``filled`` with ``fill_holes``) and per camera pixel
        ``xyz`` and ``normals`` ((height, width, 3) arrays, camera frame, the calibration's
        length unit; NaN where nothing was triangulated, normals zero where no neighbour is
        joined) and ``ray_gap`` ((height, width)).
    """
    if white_black not in ("last", "first"):
        raise ValueError(f"white_black: expected \"last\" or \"first\", got {white_black!r}")
    proj = None if projector_size is None else _pair(projector_size, "projector_size", 1)
    args = (proj, int(step), (int(black_threshold), int(white_threshold)), bool(refine), white_black == "first",
            int(fill_holes), float(max_edge_px))
    if isinstance(calibration, dict):
        import tempfile
        with tempfile.TemporaryDirectory() as d:
            path = _os.path.join(d, "calibration.json")
            with open(path, "w") as f:
                _json.dump(calibration, f)
            out = _lucent.reconstruct_capture_dir(_os.fsdecode(capture), path, *args)
    else:
        out = _lucent.reconstruct_capture_dir(_os.fsdecode(capture), _os.fsdecode(calibration), *args)
    w, h, xyz, normals, gap, n, lo, hi, median_gap, filled = out
    r = Result({"points": n, "bbox": {"min": list(lo), "max": list(hi)}, "median_ray_gap": median_gap})
    if fill_holes > 0:
        r["filled"] = filled
    r["xyz"] = _np.asarray(xyz, dtype=float).reshape(h, w, 3)
    r["normals"] = _np.asarray(normals, dtype=float).reshape(h, w, 3)
    r["ray_gap"] = _np.asarray(gap, dtype=float).reshape(h, w)
    return r


def _pose_args(rvec, tvec):
    """A Rodrigues vector and a translation as two lists of 3 floats, or ValueError."""
    r = [float(v) for v in _np.asarray(rvec, dtype=float).ravel()]
    t = [float(v) for v in _np.asarray(tvec, dtype=float).ravel()]
    if len(r) != 3 or len(t) != 3:
        raise ValueError("rvec, tvec: expected 3 numbers each")
    return r, t


def project_points(object_points, rvec, tvec, camera_matrix, dist_coeffs=None) -> _np.ndarray:
    """Pixel positions of 3-D points through an OpenCV camera, as ``cv2.projectPoints`` computes
    them (without its Jacobian): lucent's camera model with all of OpenCV's distortion terms.

    Parameters
    ----------
    object_points : (N, 3) array
        Points in the world frame (any length unit, the unit of ``tvec``).
    rvec, tvec : 3 numbers each
        World → camera rotation (Rodrigues vector, radians) and translation.
    camera_matrix : (3, 3) array
        [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], pixels (no skew).
    dist_coeffs : 0, 4, 5, 8, 12 or 14 numbers, optional
        OpenCV's (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4[, τx, τy]]]]), τ in radians.

    Returns
    -------
    (N, 2) float array
        OpenCV pixel coordinates (integers at pixel centres); NaN for points at or behind the
        camera.
    """
    p = _points(object_points, 3, "object_points")
    k, d = _camera_args(camera_matrix, dist_coeffs)
    r, t = _pose_args(rvec, tvec)
    out = _lucent.project_points_flat(_flat64(p), r, t, k, d)
    return _np.asarray(out, dtype=float).reshape(-1, 2)


def undistort_points(image_points, camera_matrix, dist_coeffs=None, dst=None, R=None, P=None, criteria=None) -> _np.ndarray:
    """Undistorted coordinates of pixel positions, as ``cv2.undistortPoints``, inverted to 1e-9 px
    (Newton's method; the tilt exactly): the normalised (x/z, y/z) without ``R`` and ``P``; with
    them, (x, y, 1) turned by ``R`` and mapped by the left 3 × 3 of ``P`` (a new camera matrix or
    a rectified projection from :func:`stereo_rectify`), then divided by its third component, as
    OpenCV does. The arguments are OpenCV's (``undistort_points(pts, K, dist, None, R, P)``).

    Parameters
    ----------
    image_points : (N, 2) or (N, 1, 2) array
        OpenCV pixel coordinates.
    camera_matrix, dist_coeffs
        As for :func:`project_points`.
    dst : None or array
        OpenCV's output argument; not written to.
    R : 3 × 3, optional
        Rectification rotation (identity by default).
    P : 3 × 3 or 3 × 4, optional
        New camera matrix or projection (identity by default: normalised coordinates).
    criteria : None or (type, max_count, epsilon)
        OpenCV 5's stopping rule for its iterations, accepted and not used (the inverse here
        converges to 1e-9 px).

    Returns
    -------
    (N, 2) float array
        NaN where the inverse does not converge or the pixel has no ray (beyond the radius where
        the lens folds over, e.g. r(1 + k1 r²) at its largest for k1 < 0).
    """
    q = _points(image_points, 2, "image_points")
    k, d = _camera_args(camera_matrix, dist_coeffs)
    _no_output_array(dst, "dst")
    _criteria(criteria)
    out = _np.asarray(_lucent.undistort_points_flat(_flat64(q), k, d), dtype=float).reshape(-1, 2)
    if R is None and P is None:
        return out
    rr = _np.eye(3)
    if R is not None:
        r = _np.asarray(R, dtype=float)
        if r.shape != (3, 3):
            raise ValueError(f"R: expected a 3×3 matrix, got shape {r.shape}")
        rr = r
    if P is not None:
        rr = _left_3x3(P, "P") @ rr
    v = _np.column_stack([out, _np.ones(len(out))]) @ rr.T
    return v[:, :2] / v[:, 2:3]


def write_vol(path, density, min=(0.0, 0.0, 0.0), max=(1.0, 1.0, 1.0)) -> None:
    """Write a density grid, or a grid of colours, as a Mitsuba volume file ("VOL" version 3,
    float32), which a scene's ``medium = { …, density = { file = "…" } }`` (or its ``albedo``)
    reads (docs/scene-format.md, "Density grids"; Mitsuba 3's ``gridvolume`` reads it too).

    Parameters
    ----------
    path : str or os.PathLike
        The file to write (written to a temporary name and renamed).
    density : (nz, ny, nx) or (nz, ny, nx, 3) array
        Values ≥ 0, ``density[z, y, x]`` (one channel: a density or a grey albedo) or
        ``density[z, y, x, c]`` (three channels: a linear-sRGB albedo): value (x, y, z) sits at
        the centre of its cell of the box.
    min, max : 3 numbers
        The box stored in the file (the scene's units, used when the scene gives no ``min`` /
        ``max``).
    """
    d = _np.asarray(density, dtype=float)
    if not (d.ndim == 3 or (d.ndim == 4 and d.shape[3] == 3)) or 0 in d.shape:
        raise ValueError(f"density: expected a non-empty (nz, ny, nx) or (nz, ny, nx, 3) array, got shape {d.shape}")
    if not _np.all(_np.isfinite(d)) or _np.any(d < 0):
        raise ValueError("density: values must be finite and >= 0")
    lo, hi = _np.asarray(min, dtype=float).reshape(-1), _np.asarray(max, dtype=float).reshape(-1)
    if lo.size != 3 or hi.size != 3 or not _np.all(hi > lo):
        raise ValueError(f"min, max: expected three numbers each with max > min, got {min}, {max}")
    nz, ny, nx = d.shape[:3]
    channels = 1 if d.ndim == 3 else 3
    head = b"VOL" + bytes([3]) + _np.array([1, nx, ny, nz, channels], dtype="<i4").tobytes() + _np.concatenate([lo, hi]).astype("<f4").tobytes()
    tmp = f"{_os.fspath(path)}.tmp{_os.getpid()}"
    with open(tmp, "wb") as f:
        f.write(head + _np.ascontiguousarray(d, dtype="<f4").tobytes())
    _os.replace(tmp, path)


def read_vol(path):
    """Read a Mitsuba volume file of float32 values, one or three channels (as :func:`write_vol`
    writes).

    Returns
    -------
    (density, min, max)
        ``density`` as an (nz, ny, nx) float32 array (one channel) or (nz, ny, nx, 3) (three),
        and the box stored in the file.
    """
    with open(path, "rb") as f:
        raw = f.read()
    if len(raw) < 48 or raw[:3] != b"VOL" or raw[3] != 3:
        raise ValueError(f"{_os.fspath(path)}: not a Mitsuba volume file of version 3")
    enc, nx, ny, nz, ch = (int(v) for v in _np.frombuffer(raw[4:24], dtype="<i4"))
    if enc != 1 or ch not in (1, 3) or min(nx, ny, nz) <= 0 or len(raw) != 48 + 4 * nx * ny * nz * ch:
        raise ValueError(f"{_os.fspath(path)}: expected float32 data of one or three channels for {nx}×{ny}×{nz} cells")
    box = _np.frombuffer(raw[24:48], dtype="<f4").astype(float)
    shape = (nz, ny, nx) if ch == 1 else (nz, ny, nx, 3)
    d = _np.frombuffer(raw[48:], dtype="<f4").reshape(shape).copy()
    return d, box[:3], box[3:]


# OpenCV's fisheye model (``cv2.fisheye``), imported last: it uses the helpers above.
from . import fisheye  # noqa: E402
