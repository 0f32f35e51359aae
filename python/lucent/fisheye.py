"""OpenCV's fisheye camera model, as ``cv2.fisheye``: the Kannala–Brandt projection with OpenCV's
four odd terms (Kannala & Brandt, IEEE PAMI 28(8), 2006), lucent's own implementation
(``scan::calib::fisheye``; docs/scanning.md, "Fisheye lenses").

A point (X, Y, Z) in camera coordinates (Z > 0) projects as a = X/Z, b = Y/Z, r = √(a² + b²),
θ = atan r, θ_d = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸), (x_d, y_d) = (θ_d/r)(a, b),
u = fx(x_d + α y_d) + cx, v = fy y_d + cy, with K = [[fx, α fx, cx], [0, fy, cy], [0, 0, 1]] and
D = (k1, k2, k3, k4).

Where lucent differs from OpenCV 4/5, by choice:

- the skew α is read from K (K₀₁ / K₀₀) everywhere, so that the K that :func:`calibrate` returns
  means the same in :func:`project_points` and :func:`undistort_points`; OpenCV's
  ``projectPoints`` takes it from its ``alpha`` argument instead (default 0), and its
  ``undistortPoints`` ignores it. With α = 0 the results are the same;
- :func:`undistort_points` solves θ_d(θ) = ‖(x_d, y_d)‖ within the range where θ_d increases and
  returns NaN beyond it, where OpenCV returns (−10⁶, −10⁶) for rays it cannot invert;
- points at or behind the camera's plane project to NaN (OpenCV mirrors them through the centre);
- :func:`calibrate` always refines the poses together with the lens (the result OpenCV reaches
  with ``CALIB_RECOMPUTE_EXTRINSIC``, which every OpenCV fisheye example passes).
"""

from __future__ import annotations

import numpy as _np

# The package's helpers; this module is imported at the end of lucent/__init__.py.
from . import (CALIB_ZERO_DISPARITY, CV_32FC1, SOLVEPNP_ITERATIVE, _flat64, _image_size, _left_3x3, _lucent, _pair, _planar_target, _points, _pose_args,
               _rodrigues, _solve_pnp_ransac_with, _solve_pnp_with)

__all__ = [
    "project_points",
    "distort_points",
    "undistort_points",
    "calibrate",
    "stereo_calibrate",
    "init_undistort_rectify_map",
    "estimate_new_camera_matrix_for_undistort_rectify",
    "undistort_image",
    "stereo_rectify",
    "solve_pnp",
    "solve_pnp_ransac",
    "CALIB_ZERO_DISPARITY",
    "CALIB_USE_INTRINSIC_GUESS",
    "CALIB_RECOMPUTE_EXTRINSIC",
    "CALIB_CHECK_COND",
    "CALIB_FIX_SKEW",
    "CALIB_FIX_K1",
    "CALIB_FIX_K2",
    "CALIB_FIX_K3",
    "CALIB_FIX_K4",
    "CALIB_FIX_INTRINSIC",
    "CALIB_FIX_PRINCIPAL_POINT",
    "CALIB_FIX_FOCAL_LENGTH",
]

#: Flags of :func:`calibrate`: OpenCV 5's values of ``cv2.fisheye.CALIB_*``, which are those of the
#: pinhole ``cv2.CALIB_*`` (and of ``lucent.CALIB_*``). OpenCV 4 numbered the fisheye flags apart
#: (1, 2, 4, …, 2048); such numbers are refused where they mean nothing here, as OpenCV 5 refuses
#: them.
CALIB_USE_INTRINSIC_GUESS = 1
CALIB_FIX_PRINCIPAL_POINT = 4
CALIB_FIX_FOCAL_LENGTH = 16
CALIB_FIX_K1 = 32
CALIB_FIX_K2 = 64
CALIB_FIX_K3 = 128
CALIB_FIX_INTRINSIC = 256
CALIB_FIX_K4 = 2048
CALIB_RECOMPUTE_EXTRINSIC = 1 << 23
CALIB_CHECK_COND = 1 << 24
CALIB_FIX_SKEW = 1 << 25

_KNOWN = (CALIB_USE_INTRINSIC_GUESS | CALIB_RECOMPUTE_EXTRINSIC | CALIB_CHECK_COND | CALIB_FIX_SKEW | CALIB_FIX_K1
          | CALIB_FIX_K2 | CALIB_FIX_K3 | CALIB_FIX_K4 | CALIB_FIX_INTRINSIC | CALIB_FIX_PRINCIPAL_POINT
          | CALIB_FIX_FOCAL_LENGTH)


def _lens(K, D, alpha=None):
    """K (row-major, 9 floats, the skew set from ``alpha`` when given) and D (4 floats)."""
    k = _np.asarray(K, dtype=float)
    if k.shape != (3, 3):
        raise ValueError(f"K: expected a 3×3 camera matrix, got shape {k.shape}")
    d = _np.zeros(4) if D is None else _np.asarray(D, dtype=float).ravel()
    if d.size != 4:
        raise ValueError(f"D: expected the 4 coefficients k1, k2, k3, k4, got {d.size}")
    k = k.copy()
    if alpha is not None:
        k[0, 1] = float(alpha) * k[0, 0]
    return [float(v) for v in k.ravel()], [float(v) for v in d]


def project_points(object_points, rvec, tvec, K, D, alpha=None) -> _np.ndarray:
    """Pixels of 3-D points through a fisheye camera, as ``cv2.fisheye.projectPoints`` computes
    them (without its Jacobian).

    Parameters
    ----------
    object_points : (N, 3) or (N, 1, 3) array
        Points in the world frame (the unit of ``tvec``).
    rvec, tvec : 3 numbers each
        World → camera rotation (Rodrigues vector, radians) and translation.
    K : (3, 3) array
        [[fx, α fx, cx], [0, fy, cy], [0, 0, 1]], pixels.
    D : 4 numbers
        k1, k2, k3, k4.
    alpha : float, optional
        The skew α, replacing K₀₁/K₀₀ when given.

    Returns
    -------
    (N, 2) float array
        OpenCV pixel coordinates; NaN at or behind the camera's plane.
    """
    p = _points(object_points, 3, "object_points")
    k, d = _lens(K, D, alpha)
    r, t = _pose_args(rvec, tvec)
    out = _lucent.fisheye_project_flat(_flat64(p), r, t, k, d)
    return _np.asarray(out, dtype=float).reshape(-1, 2)


def distort_points(undistorted, K, D, alpha=None) -> _np.ndarray:
    """Pixels of undistorted normalised coordinates (x/z, y/z), as ``cv2.fisheye.distortPoints``.

    Returns an (N, 2) float array.
    """
    q = _points(undistorted, 2, "undistorted")
    k, d = _lens(K, D, alpha)
    return _np.asarray(_lucent.fisheye_distort_flat(_flat64(q), k, d), dtype=float).reshape(-1, 2)


def _rotation(R):
    """A 3×3 rotation from a matrix or a Rodrigues vector (None: the identity)."""
    if R is None or _np.asarray(R).size == 0:
        return _np.eye(3)
    r = _np.asarray(R, dtype=float)
    if r.size == 3:
        return _rodrigues(r.ravel())
    if r.shape != (3, 3):
        raise ValueError(f"R: expected a 3×3 matrix or a Rodrigues vector, got shape {r.shape}")
    return r


def undistort_points(distorted, K, D, R=None, P=None) -> _np.ndarray:
    """Undistorted coordinates of pixels, as ``cv2.fisheye.undistortPoints``: normalised (x/z, y/z)
    without ``R`` and ``P``; with them, the ray turned by ``R`` (3×3 or a Rodrigues vector) and
    projected by the pinhole ``P`` (3×3 or 3×4).

    Returns an (N, 2) float array, NaN where the ray would lie beyond the range where θ_d
    increases (or at or behind the camera after ``R``).
    """
    q = _points(distorted, 2, "distorted")
    k, d = _lens(K, D)
    x = _np.asarray(_lucent.fisheye_undistort_flat(_flat64(q), k, d), dtype=float).reshape(-1, 2)
    if R is None and P is None:
        return x
    m = _rotation(R)
    if P is not None:
        m = _left_3x3(P, "P") @ m
    h = _np.c_[x, _np.ones(len(x))] @ m.T
    with _np.errstate(divide="ignore", invalid="ignore"):
        out = h[:, :2] / h[:, 2:3]
    out[~(h[:, 2] > 0)] = _np.nan
    return out


def init_undistort_rectify_map(K, D, R, P, size, m1type=CV_32FC1):
    """The remapping of ``cv2.fisheye.initUndistortRectifyMap`` with float maps (``m1type``
    CV_32FC1 = 5): (map_x, map_y), each a (height, width) float32 array giving, for each pixel of
    the new pinhole image ``P`` (3×3 or 3×4) turned by ``R`` (None: the identity), the fisheye
    pixel whose ray it shows; ``cv2.remap`` takes them as they are. Pixels whose ray lies at or
    behind the camera's plane get NaN.
    """
    if int(m1type) != CV_32FC1:
        raise ValueError(f"m1type: only CV_32FC1 ({CV_32FC1}) float maps, got {m1type}")
    w, h = _image_size(size, "size")
    p = _left_3x3(K if P is None else P, "P")
    k, d = _lens(K, D)
    flat = _lucent.fisheye_undistort_rectify_map_flat(k, d, [float(v) for v in _rotation(R).ravel()],
                                                      [float(v) for v in p.ravel()], w, h)
    out = _np.asarray(flat, dtype=float).reshape(h, w, 2)
    return out[:, :, 0].astype(_np.float32), out[:, :, 1].astype(_np.float32)


def estimate_new_camera_matrix_for_undistort_rectify(K, D, image_size, R=None, balance=0.0, new_size=None, fov_scale=1.0):
    """A pinhole camera matrix for the undistorted (and ``R``-turned) view of a fisheye image, as
    ``cv2.fisheye.estimateNewCameraMatrixForUndistortRectify``: the rays of the four edge
    midpoints (w/2, 0), (w, h/2), (w/2, h), (0, h/2) (integer halves, as OpenCV) are undistorted;
    their mean is the new principal direction; the focal length that fits them into the image
    ranges from the largest (``balance`` 0, no edge midpoint outside) to the smallest (1, every
    one inside), divided by ``fov_scale``, with K's aspect ratio kept. ``new_size`` scales the
    result to another image size.

    Returns the 3×3 matrix.
    """
    w, h = _pair(image_size, "image_size", 1)
    new = (0, 0) if new_size is None or tuple(new_size) == (0, 0) else _pair(new_size, "new_size", 1)
    k, d = _lens(K, D)
    fx, fy, cx, cy = _lucent.fisheye_new_camera_matrix_flat(k, d, (w, h), [float(v) for v in _rotation(R).ravel()],
                                                           float(balance), new, float(fov_scale))
    return _np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def stereo_rectify(K1, D1, K2, D2, imageSize, R, tvec, flags=CALIB_ZERO_DISPARITY, newImageSize=None, balance=0.0,
                   fov_scale=1.0):
    """Rectifying rotations and projections of a calibrated fisheye pair, as
    ``cv2.fisheye.stereoRectify`` (``scan::calib::fisheye::rectify``): each camera turned by half
    the relative rotation, then both by the rotation that puts the baseline on the x axis; each
    turned view's :func:`estimate_new_camera_matrix_for_undistort_rectify` (``balance``,
    ``newImageSize``, ``fov_scale``); the pair shares the smaller vertical focal length and the
    mean principal point (both coordinates with CALIB_ZERO_DISPARITY, the vertical one with 0).

    ``R``, ``tvec``: the pair's pose, X₂ = R X₁ + T (3×3 or a Rodrigues vector; as
    :func:`stereo_calibrate` returns it). ``flags`` is required in OpenCV's Python binding and
    defaults to CALIB_ZERO_DISPARITY here.

    Returns (R1, R2, P1, P2, Q) as OpenCV: each camera's rotation into the rectified frame, their
    3×4 projections (P2 carries the baseline times the focal length) and the 4×4
    disparity-to-depth matrix. :func:`init_undistort_rectify_map` with (R1, P1) and (R2, P2) gives
    the maps.
    """
    flags = int(flags)
    if flags & ~CALIB_ZERO_DISPARITY:
        raise ValueError(f"flags: only CALIB_ZERO_DISPARITY ({CALIB_ZERO_DISPARITY}) or 0, got {flags}")
    w, h = _pair(imageSize, "imageSize", 1)
    new = (0, 0) if newImageSize is None or tuple(newImageSize) == (0, 0) else _pair(newImageSize, "newImageSize", 1)
    k1, d1 = _lens(K1, D1)
    k2, d2 = _lens(K2, D2)
    t = _np.asarray(tvec, dtype=float).ravel()
    if t.size != 3:
        raise ValueError(f"tvec: expected 3 values, got {t.size}")
    r1, r2, p1, p2, q = _lucent.fisheye_stereo_rectify_flat(
        k1, d1, k2, d2, (w, h), [float(v) for v in _rotation(R).ravel()], [float(v) for v in t],
        bool(flags & CALIB_ZERO_DISPARITY), new, float(balance), float(fov_scale))
    m = lambda v, rows: _np.asarray(v, dtype=float).reshape(rows, -1)
    return m(r1, 3), m(r2, 3), m(p1, 3), m(p2, 3), m(q, 4)


def solve_pnp(objectPoints, imagePoints, cameraMatrix, distCoeffs, rvec=None, tvec=None, useExtrinsicGuess=False,
              flags=SOLVEPNP_ITERATIVE, criteria=None):
    """The pose of a known object from its image in a fisheye camera, as ``cv2.fisheye.solvePnP``
    (``SOLVEPNP_ITERATIVE``, or OpenCV 5's other ``flags`` as :func:`lucent.solve_pnp` takes
    them): the pixels taken through the lens's inverse to the pixels of the
    distortion-free pinhole camera with K's fx, fy, cx, cy, then :func:`lucent.solve_pnp`'s
    closed-form start (or ``rvec``, ``tvec`` with ``useExtrinsicGuess``) and
    Levenberg–Marquardt there, as OpenCV does (its ``undistortPoints`` with P = K, then
    ``solvePnP`` with K; lucent leaves the skew out of that pinhole camera). A pixel beyond the
    range where θ_d increases raises ``ValueError`` (OpenCV moves it to (−10⁶, −10⁶) and goes
    on). ``criteria`` is ignored (the inverse is exact to 10⁻¹⁵).

    Returns (True, rvec, tvec): the (3, 1) Rodrigues vector and translation of the object →
    camera transform.
    """
    return _solve_pnp_with(_lucent.fisheye_solve_pnp_flat, objectPoints, imagePoints, _lens(cameraMatrix, distCoeffs), rvec,
                           tvec, useExtrinsicGuess, flags, _pinhole_generic_of(cameraMatrix, distCoeffs))


def solve_pnp_ransac(objectPoints, imagePoints, cameraMatrix, distCoeffs, rvec=None, tvec=None, useExtrinsicGuess=False,
                     iterationsCount=100, reprojectionError=8.0, confidence=0.99, flags=SOLVEPNP_ITERATIVE, criteria=None):
    """The pose of a known object from partly wrong correspondences in a fisheye camera, as
    ``cv2.fisheye.solvePnPRansac``: :func:`lucent.solve_pnp_ransac` on the pixels of the pinhole
    camera with K's fx, fy, cx, cy after the lens's inverse (``reprojectionError`` in those
    pixels, as OpenCV's). A pixel beyond the range where θ_d increases is an outlier.
    ``criteria`` is ignored (the inverse is exact).

    Returns (retval, rvec, tvec, inliers) as :func:`lucent.solve_pnp_ransac`.
    """
    return _solve_pnp_ransac_with(_lucent.fisheye_solve_pnp_ransac_flat, objectPoints, imagePoints,
                                  _lens(cameraMatrix, distCoeffs), rvec, tvec, useExtrinsicGuess, iterationsCount,
                                  reprojectionError, confidence, flags, _pinhole_generic_of(cameraMatrix, distCoeffs))


def _pinhole_generic_of(K, D):
    """OpenCV's non-iterative ``SOLVEPNP_*`` methods for a fisheye camera: the pixels through the
    lens's inverse to those of the distortion-free pinhole camera with K's fx, fy, cx, cy (the
    skew left out), then :func:`lucent.solve_pnp_generic`'s solver there, as OpenCV's
    ``fisheye::solvePnP`` (``undistortPoints`` with P = K, then ``solvePnP``)."""
    k = _np.asarray(K, dtype=float).reshape(3, 3)
    pin = [k[0, 0], 0.0, k[0, 2], 0.0, k[1, 1], k[1, 2], 0.0, 0.0, 1.0]

    def solve(obj, img, flags):
        x = undistort_points(_np.asarray(img, dtype=float).reshape(-1, 1, 2), K, D).reshape(-1, 2)
        bad = ~_np.isfinite(x).all(axis=1)
        if bad.any():
            i = int(_np.flatnonzero(bad)[0])
            raise ValueError(f"image point {i} has no ray: it lies beyond the range where the lens's θ_d increases")
        px = _np.c_[pin[0] * x[:, 0] + pin[2], pin[4] * x[:, 1] + pin[5]]
        return _lucent.solve_pnp_generic_flat(obj, [float(v) for v in px.ravel()], pin, [], int(flags))
    return solve



def undistort_image(distorted, K, D, Knew=None, new_size=None):
    """A fisheye photograph seen through the pinhole camera ``Knew`` (``K`` by default; OpenCV takes
    an identity matrix then), as ``cv2.fisheye.undistortImage``: each output pixel the
    photograph's value where the fisheye lens puts that pixel's ray, blended bilinearly (lucent's
    remap, that of :func:`lucent.undistort`), black where the photograph does not see it.

    Parameters
    ----------
    distorted : (H, W) or (H, W, C) uint8 array
    K, D : the fisheye lens
    Knew : 3×3, optional
        The output's pinhole camera matrix.
    new_size : (width, height), optional
        The output's size (the photograph's by default).
    """
    a = _np.asarray(distorted)
    if a.dtype != _np.uint8 or a.ndim not in (2, 3):
        raise ValueError(f"distorted: expected an (H, W) or (H, W, C) uint8 array, got {a.dtype} of shape {a.shape}")
    h, w = a.shape[:2]
    c = 1 if a.ndim == 2 else a.shape[2]
    ow, oh = (w, h) if new_size is None else _image_size(new_size, "new_size")
    mx, my = init_undistort_rectify_map(K, D, None, K if Knew is None else Knew, (ow, oh))
    m = _np.stack([mx.ravel(), my.ravel()], axis=1).astype(float)
    out = _lucent.remap_flat(_np.ascontiguousarray(a).tobytes(), w, h, c, _flat64(m))
    return _np.frombuffer(out, dtype=_np.uint8).reshape((oh, ow) + a.shape[2:]).copy()


def calibrate(object_points, image_points, image_size, K=None, D=None, *args, flags=None, criteria=None):
    """Calibrate a fisheye camera from views of a planar target, as ``cv2.fisheye.calibrate``.
    OpenCV's positional form ``calibrate(obj, img, size, K, D, rvecs, tvecs, flags, criteria)``
    (``rvecs``, ``tvecs`` its output placeholders: None or lists, not written to) runs unchanged,
    as does lucent's shorter ``calibrate(obj, img, size, K, D, flags, criteria)``.

    Parameters
    ----------
    object_points : list of (N, 3) or (N, 1, 3) arrays, one per view
        The target's points; they must lie in the plane z = 0 and be the same in every view.
    image_points : list of (N, 2) or (N, 1, 2) arrays, one per view
        Their pixels (OpenCV convention); NaN for a point not seen.
    image_size : (width, height)
        Pixels.
    K, D : arrays or None
        The start with CALIB_USE_INTRINSIC_GUESS (as OpenCV: a held k_i starts at 0); otherwise
        fx = fy = max(w, h)/2 and the principal point (w/2 − ½, h/2 − ½).
    flags : int
        ``cv2.fisheye`` values: CALIB_USE_INTRINSIC_GUESS, CALIB_FIX_SKEW, CALIB_FIX_K1 … K4,
        CALIB_FIX_PRINCIPAL_POINT, CALIB_FIX_FOCAL_LENGTH, CALIB_FIX_INTRINSIC (every lens term
        held: the poses alone). CALIB_RECOMPUTE_EXTRINSIC and CALIB_CHECK_COND are accepted and
        change nothing (the poses are always refined with the lens).
    criteria : ignored
        lucent's Levenberg–Marquardt stops where the step or the decrease of the squared error
        falls below 10⁻¹⁵ relative.

    Returns
    -------
    (rms, K, D, rvecs, tvecs)
        The RMS reprojection error (pixels, √(Σ‖e‖²/N) over the N points, OpenCV's), the 3×3 K
        (with K₀₁ = α fx), D as a (4, 1) array, and per view the (3, 1) Rodrigues vector and
        translation of the target → camera transform.
    """
    if args and not isinstance(args[0], (int, _np.integer)):
        # OpenCV's order: the output placeholders rvecs, tvecs, then flags and criteria.
        for name, v in zip(("rvecs", "tvecs"), args[:2]):
            if v is not None and not isinstance(v, (list, tuple, _np.ndarray)):
                raise ValueError(f"{name}: expected None or a list (OpenCV's output argument), got {type(v).__name__}")
        args = args[2:]
    if len(args) > 2:
        raise TypeError(f"calibrate() takes at most 9 positional arguments ({5 + len(args)} given)")
    for name, v in zip(("flags", "criteria"), args):
        if (flags if name == "flags" else criteria) is not None:
            raise TypeError(f"calibrate() got multiple values for argument '{name}'")
        if name == "flags":
            flags = v
        else:
            criteria = v
    flags = 0 if flags is None else int(flags)
    if flags & ~_KNOWN:
        raise ValueError(f"flags: {flags & ~_KNOWN} is not a flag lucent.fisheye.calibrate knows (it takes OpenCV 5's "
                         "values, lucent.fisheye.CALIB_*; OpenCV 4's fisheye numbers differ)")
    obj, img = _planar_target(object_points, image_points, "image_points")
    w, h = _pair(image_size, "image_size", 1)
    guess = None
    if flags & CALIB_USE_INTRINSIC_GUESS or flags & CALIB_FIX_INTRINSIC:
        if K is None:
            raise ValueError("K: CALIB_USE_INTRINSIC_GUESS and CALIB_FIX_INTRINSIC start from it; got None")
        k, d = _lens(K, D)
        d = [0.0 if flags & f else v for f, v in zip((CALIB_FIX_K1, CALIB_FIX_K2, CALIB_FIX_K3, CALIB_FIX_K4), d)]
        guess = (k, d)
    every = bool(flags & CALIB_FIX_INTRINSIC)
    hold = (every or bool(flags & CALIB_FIX_FOCAL_LENGTH), every or bool(flags & CALIB_FIX_PRINCIPAL_POINT),
            every or bool(flags & CALIB_FIX_SKEW),
            [every or bool(flags & f) for f in (CALIB_FIX_K1, CALIB_FIX_K2, CALIB_FIX_K3, CALIB_FIX_K4)])
    rms, k, d, rvecs, tvecs = _lucent.fisheye_calibrate_flat(
        [float(v) for v in obj.ravel()], [[float(v) for v in p.ravel()] for p in img], w, h, hold, guess)
    return (rms, _np.asarray(k, dtype=float).reshape(3, 3), _np.asarray(d, dtype=float).reshape(4, 1),
            tuple(_np.asarray(r, dtype=float).reshape(3, 1) for r in rvecs),
            tuple(_np.asarray(t, dtype=float).reshape(3, 1) for t in tvecs))


def stereo_calibrate(object_points, image_points1, image_points2, K1, D1, K2, D2, image_size, R=None, T=None,
                     flags=CALIB_FIX_INTRINSIC, criteria=None):
    """Calibrate a pair of fisheye cameras from the same views of a planar target, as
    ``cv2.fisheye.stereoCalibrate``: each camera alone first (or, with CALIB_FIX_INTRINSIC, the
    default as in OpenCV, posed through K1, D1 and K2, D2), the relative pose from the views'
    medians, then Levenberg–Marquardt over both lenses' free terms, the relative pose and every
    view's pose together.

    Parameters
    ----------
    object_points, image_points1, image_points2
        As for :func:`calibrate`; one list of pixels per camera, the same views in both.
    K1, D1, K2, D2
        The lenses: held with CALIB_FIX_INTRINSIC, starts with CALIB_USE_INTRINSIC_GUESS, else
        unused (None allowed).
    image_size : (width, height)
    R, T : ignored (OpenCV's outputs given as inputs)
    flags : int
        CALIB_FIX_INTRINSIC, CALIB_USE_INTRINSIC_GUESS, CALIB_FIX_SKEW, CALIB_FIX_K1 … K4,
        CALIB_FIX_PRINCIPAL_POINT, CALIB_FIX_FOCAL_LENGTH; CALIB_RECOMPUTE_EXTRINSIC and
        CALIB_CHECK_COND change nothing.
    criteria : ignored

    Returns
    -------
    (rms, K1, D1, K2, D2, R, T, rvecs, tvecs)
        The RMS reprojection error over both cameras' points (pixels), the lenses, the first →
        second camera rotation (3×3) and translation (3, 1), and per view the (3, 1) Rodrigues
        vector and translation of the target → first camera.
    """
    flags = int(flags)
    if flags & ~_KNOWN:
        raise ValueError(f"flags: {flags & ~_KNOWN} is not a flag lucent.fisheye.stereo_calibrate knows (it takes OpenCV 5's "
                         "values, lucent.fisheye.CALIB_*; OpenCV 4's fisheye numbers differ)")
    obj, img1 = _planar_target(object_points, image_points1, "image_points1")
    _, img2 = _planar_target(object_points, image_points2, "image_points2")
    w, h = _pair(image_size, "image_size", 1)
    fixed = bool(flags & CALIB_FIX_INTRINSIC)
    guesses = []
    for name, K, D in (("1", K1, D1), ("2", K2, D2)):
        if fixed or flags & CALIB_USE_INTRINSIC_GUESS:
            if K is None:
                raise ValueError(f"K{name}: CALIB_FIX_INTRINSIC and CALIB_USE_INTRINSIC_GUESS start from it; got None")
            k, d = _lens(K, D)
            if not fixed:
                d = [0.0 if flags & f else v for f, v in zip((CALIB_FIX_K1, CALIB_FIX_K2, CALIB_FIX_K3, CALIB_FIX_K4), d)]
            guesses.append((k, d))
        else:
            guesses.append(None)
    hold = (bool(flags & CALIB_FIX_FOCAL_LENGTH), bool(flags & CALIB_FIX_PRINCIPAL_POINT), bool(flags & CALIB_FIX_SKEW),
            [bool(flags & f) for f in (CALIB_FIX_K1, CALIB_FIX_K2, CALIB_FIX_K3, CALIB_FIX_K4)])
    rms, k1, d1, k2, d2, r, t, rvecs, tvecs = _lucent.fisheye_stereo_calibrate_flat(
        [float(v) for v in obj.ravel()], [[float(v) for v in p.ravel()] for p in img1], [[float(v) for v in p.ravel()] for p in img2],
        w, h, hold, fixed, tuple(guesses))
    m = lambda a: _np.asarray(a, dtype=float).reshape(3, 3)
    return (rms, m(k1), _np.asarray(d1, dtype=float).reshape(4, 1), m(k2), _np.asarray(d2, dtype=float).reshape(4, 1), m(r),
            _np.asarray(t, dtype=float).reshape(3, 1),
            tuple(_np.asarray(v, dtype=float).reshape(3, 1) for v in rvecs), tuple(_np.asarray(v, dtype=float).reshape(3, 1) for v in tvecs))
