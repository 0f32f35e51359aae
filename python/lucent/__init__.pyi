# Type stubs of the lucent package (python/lucent/__init__.py; the Scene class is in Rust).
# Units are in the names: _m metres, _nm nanometres, _mm millimetres, _per_mm mm⁻¹, _percent
# weight percent, _mpa megapascal, _deg degrees, _s seconds.
from os import PathLike
from typing import Any, Callable, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import fisheye as fisheye

__version__: str
MILK_PROTEIN_PERCENT: float
MILK_PRESSURE_MPA: float
SLAB_MAX_STEPS_PER_PHOTON: int
CALIB_ZERO_TANGENT_DIST: int
CALIB_FIX_K3: int
CALIB_RATIONAL_MODEL: int
CALIB_THIN_PRISM_MODEL: int
CALIB_TILTED_MODEL: int
CALIB_CB_SYMMETRIC_GRID: int
CALIB_CB_ASYMMETRIC_GRID: int
CALIB_CB_CLUSTERING: int
CALIB_CB_ADAPTIVE_THRESH: int
CALIB_CB_NORMALIZE_IMAGE: int
CALIB_CB_FILTER_QUADS: int
CALIB_CB_FAST_CHECK: int
CALIB_CB_PLAIN: int
CALIB_USE_INTRINSIC_GUESS: int
CALIB_FIX_INTRINSIC: int
CALIB_USE_EXTRINSIC_GUESS: int

_Real = Union[float, npt.ArrayLike]
_Complex = Union[complex, float, npt.ArrayLike]
_Path = Union[str, PathLike[str]]

class Result(dict[str, Any]):
    def __getattr__(self, name: str) -> Any: ...

def mie(x: _Real, m: _Complex, angles_deg: Optional[_Real] = None, *, threads: Optional[int] = None) -> Result:
    """Q_ext, Q_sca, Q_abs, Q_back, g (and S1, S2, phase_per_sr at angles_deg) of spheres of size
    parameter x and relative index m (Im m ≥ 0 absorbs), broadcast like numpy."""

def mie_sphere(radius_m: _Real, wavelength_m: _Real, n_particle: _Complex, n_medium: _Complex = 1.0,
               angles_deg: Optional[_Real] = None, *, threads: Optional[int] = None) -> Result:
    """Cross sections (m²) and efficiencies of spheres in a possibly absorbing host."""

def milk(fat_percent: float, protein_percent: float = 3.4, pressure_mpa: float = 20.0,
         wavelengths_nm: Optional[_Real] = None, *, phase_angles: int = 181) -> Result:
    """σ_s, σ_a, σ_t (mm⁻¹), g per wavelength and the tabulated phase function of milk."""

def medium(recipe: Union[_Path, dict[str, Any]], wavelengths_nm: Optional[_Real] = None, *,
           phase_angles: Optional[int] = None) -> Result:
    """Bulk optical properties of a medium recipe (file or dict)."""

def dipole(eta: _Real, sigma_s_per_mm: _Real, sigma_a_per_mm: _Real, g: _Real = 0.0, *, model: str = "standard",
           profile_mm: Optional[_Real] = None, rd: Optional[bool] = None) -> Result:
    """Dipole BSSRDF: rd, rd_closed_form and the profile R_d(r) in mm⁻²."""

def slab(layers: Sequence[Union[Sequence[Union[float, str]], dict[str, Any]]], *, n_above: float = 1.0, n_below: float = 1.0,
         photons: int = 1_000_000, seed: int = 1, radial_bins: Optional[int] = None, radial_max_mm: Optional[float] = None,
         incidence_deg: float = 0.0, line_bins: Optional[int] = None, line_max_mm: Optional[float] = None,
         max_steps_per_photon: int = 1_000_000, threads: Optional[int] = None) -> Result:
    """Layered-slab Monte Carlo photon transport (the keys of `lucent slab --json`)."""

def fit_reflectance(r_mm: _Real, reflectance: _Real, eta: float, model: str = "dipole", *, stderr: Optional[_Real] = None,
                    relative: bool = False, r_min_mm: float = 0.0, r_max_mm: Optional[float] = None, noise: float = 0.01,
                    table: Optional[_Path] = None) -> Result:
    """σ_a and σ'_s (mm⁻¹) with 95 % intervals from R(r)."""

def fit_particles(wavelength_nm: _Real, sigma_s_prime_per_mm: _Real, sigma_a_per_mm: Optional[_Real] = None, *,
                  medium: str = "milk", particle: Optional[str] = None, protein_percent: float = 3.4) -> Result:
    """Fat content and homogenization pressure of milk (or a recipe particle's size) from σ'_s spectra."""

def compare(a: npt.ArrayLike, b: npt.ArrayLike, mask: Optional[npt.ArrayLike] = None, *,
            color_correct: Union[None, bool, str] = None, saturation: float = 1.0) -> Result:
    """RMSE, relMSE, PSNR, SSIM, mean ΔE2000 of two (H, W, 3) linear sRGB images."""

def write_vol(path: _Path, density: npt.ArrayLike, min: Sequence[float] = (0.0, 0.0, 0.0), max: Sequence[float] = (1.0, 1.0, 1.0)) -> None:
    """A (nz, ny, nx) density grid, or an (nz, ny, nx, 3) grid of colours, as a Mitsuba volume file (a scene's `density = { file = … }` or its `albedo`)."""

def read_vol(path: _Path) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(values (nz, ny, nx) or (nz, ny, nx, 3), min, max) of a Mitsuba volume file of one or three float32 channels."""

def project_points(object_points: npt.ArrayLike, rvec: npt.ArrayLike, tvec: npt.ArrayLike, camera_matrix: npt.ArrayLike,
                   dist_coeffs: Optional[npt.ArrayLike] = None) -> npt.NDArray[np.float64]:
    """Pixels of (N, 3) points through an OpenCV camera (cv2.projectPoints), 0–14 distortion terms."""
def undistort_points(image_points: npt.ArrayLike, camera_matrix: npt.ArrayLike,
                     dist_coeffs: Optional[npt.ArrayLike] = None, dst: Optional[npt.ArrayLike] = None,
                     R: Optional[npt.ArrayLike] = None, P: Optional[npt.ArrayLike] = None,
                     criteria: Optional[Tuple[int, int, float]] = None) -> npt.NDArray[np.float64]:
    """Undistorted coordinates of (N, 2) pixels (cv2.undistortPoints): normalised, or through R and P."""
def find_chessboard_corners(image: npt.ArrayLike, pattern_size: Tuple[int, int], corners: Optional[npt.NDArray[Any]] = None,
                            flags: int = ...) -> Tuple[bool, Optional[npt.NDArray[np.float32]]]:
    """(found, (N, 1, 2) corners) of a chessboard in an 8-bit grey or BGR image (cv2.findChessboardCorners + cornerSubPix)."""
def detect_markers(image: npt.ArrayLike, dictionary: Union[str, int] = "DICT_4X4_50", refine: bool = False
                   ) -> Tuple[Tuple[npt.NDArray[np.float32], ...], Optional[npt.NDArray[np.int32]], Tuple[()]]:
    """(corners, ids, rejected) of a predefined dictionary's ArUco markers (cv2.aruco.ArucoDetector.detectMarkers)."""
class CharucoBoard:
    """A ChArUco board (cv2.aruco.CharucoBoard; legacy=True is setLegacyPattern(True))."""
    size: Tuple[int, int]
    square_length: float
    marker_length: float
    dictionary: str
    legacy: bool
    def __init__(self, size: Tuple[int, int], square_length: float, marker_length: float, dictionary: Union[str, int],
                 legacy: bool = False) -> None: ...
    def getChessboardCorners(self) -> npt.NDArray[np.float32]: ...
    def getObjPoints(self) -> Tuple[npt.NDArray[np.float32], ...]: ...
    def getIds(self) -> npt.NDArray[np.int32]: ...
    def generateImage(self, out_size: Tuple[int, int], margin_size: int = 0) -> npt.NDArray[np.uint8]: ...
    def detect_board(self, image: npt.ArrayLike) -> Tuple[Optional[npt.NDArray[np.float32]], Optional[npt.NDArray[np.int32]],
                                                         Tuple[npt.NDArray[np.float32], ...], Optional[npt.NDArray[np.int32]]]: ...
    def detectBoard(self, image: npt.ArrayLike) -> Tuple[Optional[npt.NDArray[np.float32]], Optional[npt.NDArray[np.int32]],
                                                        Tuple[npt.NDArray[np.float32], ...], Optional[npt.NDArray[np.int32]]]: ...
def find_circles_grid(image: npt.ArrayLike, pattern_size: Tuple[int, int], centers: Union[None, int, npt.NDArray[Any]] = None,
                      flags: Optional[int] = None, blobDetector: None = None) -> Tuple[bool, Optional[npt.NDArray[np.float32]]]:
    """(found, (N, 1, 2) disc centres) of a symmetric or asymmetric circle grid in an 8-bit image (cv2.findCirclesGrid)."""
def stereo_calibrate(object_points: Sequence[npt.ArrayLike], image_points1: Sequence[npt.ArrayLike], image_points2: Sequence[npt.ArrayLike],
                     camera_matrix1: Optional[npt.ArrayLike], dist_coeffs1: Optional[npt.ArrayLike],
                     camera_matrix2: Optional[npt.ArrayLike], dist_coeffs2: Optional[npt.ArrayLike],
                     image_size: Tuple[int, int], flags: int = ..., R: Optional[npt.ArrayLike] = None, T: Optional[npt.ArrayLike] = None,
                     criteria: Optional[Tuple[int, int, float]] = None
                     ) -> Tuple[float, npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(rms, K1, D1, K2, D2, R, T, E, F) of two cameras from one planar target (cv2.stereoCalibrate; flags 0 fits everything; CALIB_USE_EXTRINSIC_GUESS starts from R, T)."""
SOLVEPNP_ITERATIVE: int
SOLVEPNP_EPNP: int
SOLVEPNP_P3P: int
SOLVEPNP_AP3P: int
SOLVEPNP_IPPE: int
SOLVEPNP_IPPE_SQUARE: int
SOLVEPNP_SQPNP: int
def solve_pnp_generic(objectPoints: npt.ArrayLike, imagePoints: npt.ArrayLike, cameraMatrix: npt.ArrayLike,
                      distCoeffs: Optional[npt.ArrayLike], rvecs: Any = None, tvecs: Any = None, useExtrinsicGuess: bool = False,
                      flags: int = 0, rvec: Optional[npt.ArrayLike] = None, tvec: Optional[npt.ArrayLike] = None,
                      reprojectionError: Any = None
                      ) -> Tuple[int, Tuple[npt.NDArray[np.float64], ...], Tuple[npt.NDArray[np.float64], ...], npt.NDArray[np.float64]]:
    """(count, rvecs, tvecs, reprojectionError) of every pose a SOLVEPNP_* method finds, best first (cv2.solvePnPGeneric)."""
def solve_pnp_refine_lm(objectPoints: npt.ArrayLike, imagePoints: npt.ArrayLike, cameraMatrix: npt.ArrayLike,
                        distCoeffs: Optional[npt.ArrayLike], rvec: npt.ArrayLike, tvec: npt.ArrayLike, criteria: Any = None
                        ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(rvec, tvec) refined by Levenberg-Marquardt on the reprojection error (cv2.solvePnPRefineLM)."""
def solve_pnp(object_points: npt.ArrayLike, image_points: npt.ArrayLike, camera_matrix: npt.ArrayLike,
              dist_coeffs: Optional[npt.ArrayLike], rvec: Optional[npt.ArrayLike] = None, tvec: Optional[npt.ArrayLike] = None,
              useExtrinsicGuess: bool = False, flags: int = 0) -> Tuple[bool, npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(True, rvec, tvec) of a known object seen by a calibrated camera (cv2.solvePnP; flags: SOLVEPNP_ITERATIVE (useExtrinsicGuess starts from rvec, tvec), EPNP, P3P, AP3P, IPPE, IPPE_SQUARE, SQPNP)."""
def solve_pnp_ransac(object_points: npt.ArrayLike, image_points: npt.ArrayLike, camera_matrix: npt.ArrayLike,
                     dist_coeffs: Optional[npt.ArrayLike], rvec: Optional[npt.ArrayLike] = None, tvec: Optional[npt.ArrayLike] = None,
                     useExtrinsicGuess: bool = False, iterationsCount: int = 100, reprojectionError: float = 8.0,
                     confidence: float = 0.99, flags: int = 0
                     ) -> Tuple[bool, Optional[npt.NDArray[np.float64]], Optional[npt.NDArray[np.float64]], Optional[npt.NDArray[np.int32]]]:
    """(retval, rvec, tvec, inliers) of a known object from partly wrong correspondences (cv2.solvePnPRansac, iterative); (False, None, None, None) without a consensus."""
def undistort(src: npt.ArrayLike, camera_matrix: npt.ArrayLike, dist_coeffs: Optional[npt.ArrayLike],
              dst: Optional[npt.ArrayLike] = None, new_camera_matrix: Optional[npt.ArrayLike] = None,
              newCameraMatrix: Optional[npt.ArrayLike] = None) -> npt.NDArray[np.uint8]:
    """A uint8 photograph with its lens distortion removed (cv2.undistort)."""
def calibrate_camera(object_points: Sequence[npt.ArrayLike], image_points: Sequence[npt.ArrayLike], image_size: Tuple[int, int],
                     camera_matrix: Optional[npt.ArrayLike] = None, dist_coeffs: Optional[npt.ArrayLike] = None, flags: int = 0,
                     criteria: Optional[Tuple[int, int, float]] = None
                     ) -> Tuple[float, npt.NDArray[np.float64], npt.NDArray[np.float64], Tuple[npt.NDArray[np.float64], ...], Tuple[npt.NDArray[np.float64], ...]]:
    """(rms, K, dist, rvecs, tvecs) from views of one planar target (cv2.calibrateCamera; CALIB_* flags above)."""
def calibrate_procam(captures: Sequence[_Path], projector_size: Tuple[int, int], pattern_size: Tuple[int, int], square: float,
                     flags: int = 0, step: int = 1, black_threshold: int = 40, white_threshold: int = 5,
                     white_black: Literal["last", "first"] = "last") -> Result:
    """Projector–camera calibration from Gray-code captures (the keys of `lucent scan calibrate --json`)."""

def gray_code_patterns(projector_size: Tuple[int, int], step: int = 1) -> list[npt.NDArray[np.uint8]]:
    """The frames `lucent scan patterns` writes (OpenCV's GrayCodePattern order, then white and black)."""
def decode_gray_code(capture: Union[_Path, Sequence[npt.ArrayLike]], projector_size: Tuple[int, int], step: int = 1,
                     black_threshold: int = 40, white_threshold: int = 5, white_black: Literal["last", "first"] = "last",
                     refine: bool = True) -> Result:
    """Projector column and row per camera pixel (`lucent scan decode`): the JSON keys and the map arrays."""

def reconstruct_gray_code(capture: _Path, calibration: Union[_Path, dict[str, Any]], projector_size: Optional[Tuple[int, int]] = None,
                          step: int = 1, black_threshold: int = 40, white_threshold: int = 5,
                          white_black: Literal["last", "first"] = "last", refine: bool = True, fill_holes: int = 0,
                          max_edge_px: float = 20.0) -> Result:
    """A capture triangulated with a projector–camera calibration (`lucent scan reconstruct`): JSON keys and per-pixel arrays."""

class Scene:
    """A scene ready to render (docs/scene-format.md)."""
    @staticmethod
    def load(path: _Path) -> "Scene": ...
    @staticmethod
    def from_toml(text: str, name: str = "<string>", base_dir: Optional[_Path] = None) -> "Scene": ...
    @staticmethod
    def cornell_box() -> "Scene": ...
    @property
    def resolution(self) -> Tuple[int, int]: ...
    @property
    def source(self) -> str: ...
    @property
    def integrator(self) -> Tuple[str, int, int]: ...
    def render(self, spp: Optional[int] = None, seed: int = 0, integrator: Optional[str] = None, width: Optional[int] = None,
               height: Optional[int] = None, max_depth: Optional[int] = None, rr_depth: Optional[int] = None,
               threads: Optional[int] = None, time_s: Optional[float] = None,
               progress: Optional[Callable[[int, Optional[int], float], Optional[bool]]] = None) -> npt.NDArray[np.float32]:
        """Render to an (H, W, 3) float32 array of linear sRGB; progress(spp_done, spp_target, elapsed_s)
        is called after each pass (return False to stop); Ctrl-C stops between passes."""
