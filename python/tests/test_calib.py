"""lucent.find_chessboard_corners / calibrate_camera (cv2.findChessboardCorners + cornerSubPix,
cv2.calibrateCamera) on data with a known truth: a chessboard drawn with a known homography and
anti-aliased by supersampling, and the projections of a known camera; where cv2 is installed,
also against OpenCV on the same points.
"""
import numpy as np
import pytest

import lucent

K = np.array([[905.0, 0.0, 322.5], [0.0, 899.0, 241.0], [0.0, 0.0, 1.0]])
DIST = np.array([-0.18, 0.11, 0.0008, -0.0005, -0.04])
COLS, ROWS, SQUARE = 9, 6, 25.0
OBJ = np.array([[(i % COLS) * SQUARE, (i // COLS) * SQUARE, 0.0] for i in range(COLS * ROWS)])
POSES = [([0.05, 0.03, 0.01], [-100.0, -60.0, 520.0]), ([0.42, -0.08, 0.04], [-95.0, -70.0, 560.0]),
         ([-0.35, 0.17, -0.06], [-105.0, -50.0, 500.0]), ([0.12, 0.47, 0.10], [-80.0, -65.0, 600.0]),
         ([-0.20, -0.38, 0.15], [-110.0, -55.0, 540.0])]


def views():
    return [lucent.project_points(OBJ, r, t, K, DIST) for r, t in POSES]


def test_calibrate_camera_recovers_a_known_camera():
    pts = views()
    rms, k, d, rvecs, tvecs = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480))
    assert rms < 1e-8
    assert np.abs(k - K).max() < 1e-6 * K[0, 0]
    assert d.shape == (1, 5) and np.abs(d.ravel() - DIST).max() < 1e-8
    for (r, t), rv, tv in zip(POSES, rvecs, tvecs):
        assert rv.shape == (3, 1) and np.abs(rv.ravel() - r).max() < 1e-9
        assert np.abs(tv.ravel() - t).max() < 1e-6
    # Held terms stay exactly zero; the flags are OpenCV's values.
    _, _, d, _, _ = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480), flags=lucent.CALIB_FIX_K3 | lucent.CALIB_ZERO_TANGENT_DIST)
    assert d[0, 2] == 0.0 and d[0, 3] == 0.0 and d[0, 4] == 0.0
    _, _, d, _, _ = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480), flags=lucent.CALIB_THIN_PRISM_MODEL)
    assert d.shape == (1, 12)
    # A tilted sensor (OpenCV's 14-coefficient model) is recovered with CALIB_TILTED_MODEL.
    tilted = np.r_[DIST, np.zeros(7), 0.015, -0.02]
    pts = [lucent.project_points(OBJ, r, t, K, tilted) for r, t in POSES]
    rms, k, d, _, _ = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480), flags=lucent.CALIB_TILTED_MODEL)
    assert d.shape == (1, 14) and rms < 1e-8
    assert np.abs(d.ravel() - tilted).max() < 1e-8 and np.abs(k - K).max() < 1e-6 * K[0, 0]


def test_calibrate_camera_holds_what_opencv_holds():
    # A camera whose principal point is the image centre ((w − 1)/2, (h − 1)/2, where OpenCV puts
    # a held one) and whose fx/fy is known: held, they stay exact and the rest is the truth.
    kc = K.copy()
    kc[0, 2], kc[1, 2] = 319.5, 239.5
    pts = [lucent.project_points(OBJ, r, t, kc, DIST) for r, t in POSES]
    ratio = np.diag([kc[0, 0] / kc[1, 1], 1.0, 1.0])
    rms, k, d, _, _ = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480), ratio, None,
                                              flags=lucent.CALIB_FIX_PRINCIPAL_POINT | lucent.CALIB_FIX_ASPECT_RATIO)
    assert k[0, 2] == 319.5 and k[1, 2] == 239.5 and abs(k[0, 0] / k[1, 1] - ratio[0, 0]) < 1e-15
    assert rms < 1e-8 and np.abs(k - kc).max() < 1e-6 * kc[0, 0] and np.abs(d.ravel() - DIST).max() < 1e-8
    # From a guess, CALIB_FIX_K1 and CALIB_FIX_K3 keep the guess's values exactly and the fit
    # cannot then reach the truth; with the true k1 and k3 held it does.
    guess_k, guess_d = kc + np.array([[9.0, 0, 4.0], [0, -6.0, -3.0], [0, 0, 0]]), DIST + [0.01, -0.03, 0.0, 0.0, 0.02]
    flags = lucent.CALIB_USE_INTRINSIC_GUESS | lucent.CALIB_FIX_K1 | lucent.CALIB_FIX_K3
    rms, k, d, _, _ = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480), guess_k, guess_d, flags=flags)
    assert d[0, 0] == guess_d[0] and d[0, 4] == guess_d[4] and rms > 1e-3
    right = guess_d.copy()
    right[[0, 4]] = DIST[[0, 4]]
    rms, k, d, _, _ = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480), guess_k, right, flags=flags)
    assert rms < 1e-8 and np.abs(k - kc).max() < 1e-6 * kc[0, 0] and np.abs(d.ravel() - DIST).max() < 1e-8
    # Without a guess CALIB_FIX_K1 holds k1 at 0.
    _, _, d, _, _ = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480), flags=lucent.CALIB_FIX_K1 | lucent.CALIB_FIX_TANGENT_DIST)
    assert d[0, 0] == 0.0 and d[0, 2] == 0.0 and d[0, 3] == 0.0
    # The solver's and skew flags change nothing: the model has no skew, the solver is lucent's.
    plain = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480))
    same = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480), flags=lucent.CALIB_FIX_SKEW | lucent.CALIB_USE_LU | lucent.CALIB_USE_QR)
    assert same[0] == plain[0] and np.array_equal(same[1], plain[1]) and np.array_equal(same[2], plain[2])


def test_calibrate_camera_hold_flags_agree_with_live_opencv():
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(3)
    pts = [p + rng.normal(0, 0.2, p.shape) for p in views()]
    guess_k, guess_d = np.array([[880.0, 0, 330.0], [0, 890.0, 230.0], [0, 0, 1]]), np.array([-0.1, 0.05, 0.0, 0.0, 0.0])
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 300, 1e-15)
    for flags, k0, d0 in [(cv2.CALIB_FIX_PRINCIPAL_POINT | cv2.CALIB_FIX_ASPECT_RATIO, np.eye(3), None),
                          (cv2.CALIB_FIX_ASPECT_RATIO, None, None),
                          (cv2.CALIB_FIX_K1 | cv2.CALIB_ZERO_TANGENT_DIST | cv2.CALIB_FIX_K3, None, None),
                          (cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_K1 | cv2.CALIB_FIX_FOCAL_LENGTH, guess_k, guess_d),
                          (cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_PRINCIPAL_POINT | cv2.CALIB_FIX_K3, guess_k, guess_d),
                          (cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_ASPECT_RATIO, guess_k, guess_d),
                          (cv2.CALIB_FIX_TANGENT_DIST | cv2.CALIB_FIX_K2, None, None)]:
        copy = lambda a: None if a is None else a.copy()
        ours = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480), copy(k0), copy(d0), flags=flags)
        theirs = cv2.calibrateCamera([OBJ.astype(np.float32)] * len(pts), [p.astype(np.float32).reshape(-1, 1, 2) for p in pts],
                                     (640, 480), copy(k0), copy(d0), flags=flags, criteria=crit)
        # The same constrained least-squares problem (float32 pixels in OpenCV): the same minimum.
        assert abs(ours[0] - theirs[0]) < 1e-4 * theirs[0], flags
        assert np.abs(ours[1] - theirs[1]).max() < 1e-6 * K[0, 0], flags
        assert np.abs(ours[2] - theirs[2]).max() < 1e-3, flags


def test_calibrate_camera_refuses_what_it_does_not_do():
    pts = views()
    with pytest.raises(ValueError, match="flags"):
        lucent.calibrate_camera([OBJ] * 5, pts, (640, 480), flags=512)  # CALIB_SAME_FOCAL_LENGTH, a stereo flag
    with pytest.raises(ValueError, match="camera_matrix"):
        lucent.calibrate_camera([OBJ] * 5, pts, (640, 480), flags=lucent.CALIB_USE_INTRINSIC_GUESS)
    # Without a camera matrix CALIB_FIX_ASPECT_RATIO holds fx = fy, as cv2 does.
    held = lucent.calibrate_camera([OBJ] * 5, pts, (640, 480), flags=lucent.CALIB_FIX_ASPECT_RATIO)
    assert held[1][0, 0] == held[1][1, 1]
    with pytest.raises(ValueError, match="positive fx and fy"):
        lucent.calibrate_camera([OBJ] * 5, pts, (640, 480), np.zeros((3, 3)), None, flags=lucent.CALIB_FIX_ASPECT_RATIO)
    bent = OBJ.copy()
    bent[3, 2] = 1.0
    with pytest.raises(ValueError, match="z = 0"):
        lucent.calibrate_camera([bent] * 5, pts, (640, 480))
    with pytest.raises(ValueError, match="at least 3 views"):
        lucent.calibrate_camera([OBJ] * 2, pts[:2], (640, 480))
    with pytest.raises(ValueError, match="image_size"):
        lucent.calibrate_camera([OBJ] * 5, pts, (-640, 480))
    with pytest.raises(ValueError, match="pattern_size"):
        lucent.find_chessboard_corners(np.zeros((480, 640), np.uint8), (-9, 6))
    with pytest.raises(ValueError, match="8×8"):
        lucent.find_chessboard_corners(np.zeros((4, 4), np.uint8), (9, 6))


def supersampled(h_board_to_px, shade, width=640, height=480, ss=4):
    """The mean over ss × ss samples per pixel (pixel centres at integers) of shade(bx, by), the
    value at board position (bx, by) seen through the homography."""
    off = (np.arange(ss) + 0.5) / ss - 0.5
    ys, xs = np.mgrid[0:height, 0:width].astype(float)
    acc = np.zeros((height, width))
    hinv = np.linalg.inv(h_board_to_px)
    for dy in off:
        for dx in off:
            p = np.stack([xs + dx, ys + dy, np.ones_like(xs)], -1) @ hinv.T
            acc += shade(p[..., 0] / p[..., 2], p[..., 1] / p[..., 2])
    return acc / ss ** 2


def chessboard_image(h_board_to_px, width=640, height=480, ss=4):
    """8-bit image of a chessboard (squares of SQUARE; inner corner (i, j) at (i, j)·SQUARE) seen
    through a homography, each pixel the mean of ss × ss samples."""
    def shade(bx, by):
        sx, sy = np.floor(bx / SQUARE + 1), np.floor(by / SQUARE + 1)
        inside = (sx >= 0) & (sx <= COLS) & (sy >= 0) & (sy <= ROWS)
        return np.where(((sx + sy) % 2 == 0) & inside, 30.0, 220.0)
    return np.round(supersampled(h_board_to_px, shade, width, height, ss)).astype(np.uint8)


def test_find_chessboard_corners_on_a_drawn_board():
    # A board tilted in perspective: the homography of a pinhole camera (no distortion) looking
    # at it from an angle.
    th = 0.35
    r = np.array([[np.cos(th), 0, np.sin(th)], [0, 1, 0], [-np.sin(th), 0, np.cos(th)]]) @ \
        np.array([[1, 0, 0], [0, np.cos(0.2), -np.sin(0.2)], [0, np.sin(0.2), np.cos(0.2)]])
    t = np.array([-95.0, -70.0, 520.0])
    h = K @ np.column_stack([r[:, 0], r[:, 1], t])
    img = chessboard_image(h)
    found, corners = lucent.find_chessboard_corners(img, (COLS, ROWS))
    assert found and corners.shape == (COLS * ROWS, 1, 2) and corners.dtype == np.float32
    truth = OBJ.copy()
    truth[:, 2] = 1.0
    q = truth @ h.T
    q = q[:, :2] / q[:, 2:]
    got = corners.reshape(-1, 2).astype(float)
    # lucent starts at the corner nearest the image's top-left; the drawn board's first corner
    # is there too, but allow the reversed order of a symmetric board.
    e = min((np.linalg.norm(g - q, axis=1) for g in (got, got[::-1])), key=lambda e: e.mean())
    # 16 grey levels of anti-aliasing per edge limit the corners; OpenCV's cornerSubPix on this
    # image: median 0.065 px, max 0.20 px (lucent: 0.031, 0.14).
    assert np.median(e) < 0.05 and e.max() < 0.2, (np.median(e), e.max())
    # The same image in BGR gives the same corners; an empty image has none.
    found3, corners3 = lucent.find_chessboard_corners(np.dstack([img] * 3), (COLS, ROWS))
    assert found3 and np.abs(corners3 - corners).max() < 1e-3
    assert lucent.find_chessboard_corners(np.full((480, 640), 128, np.uint8), (COLS, ROWS)) == (False, None)
    # OpenCV's call as written in its tutorials (an output placeholder and the flags) runs and
    # gives the same corners; flags of findChessboardCornersSB (CALIB_CB_LARGER = 64) and a
    # placeholder that is not an array are refused.
    flags = lucent.CALIB_CB_ADAPTIVE_THRESH | lucent.CALIB_CB_NORMALIZE_IMAGE | lucent.CALIB_CB_FAST_CHECK
    found_cv, corners_cv = lucent.find_chessboard_corners(img, (COLS, ROWS), None, flags)
    assert found_cv and np.array_equal(corners_cv, corners)
    assert np.array_equal(lucent.find_chessboard_corners(img, (COLS, ROWS), flags=lucent.CALIB_CB_PLAIN)[1], corners)
    with pytest.raises(ValueError, match="flags"):
        lucent.find_chessboard_corners(img, (COLS, ROWS), None, 64)
    with pytest.raises(ValueError, match="corners"):
        lucent.find_chessboard_corners(img, (COLS, ROWS), "out")


def test_calibrate_camera_agrees_with_live_opencv():
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(3)
    pts = [p + rng.normal(0, 0.2, p.shape) for p in views()]
    ours = lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480))
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 200, 1e-14)
    theirs = cv2.calibrateCamera([OBJ.astype(np.float32)] * len(pts), [p.astype(np.float32).reshape(-1, 1, 2) for p in pts],
                                 (640, 480), None, None, criteria=crit)
    # The same least-squares problem (float32 image points in OpenCV): the same minimum.
    assert abs(ours[0] - theirs[0]) < 1e-3 * theirs[0]
    assert np.abs(ours[1] - theirs[1]).max() < 1e-3 * K[0, 0]
    assert np.abs(ours[2] - theirs[2]).max() < 2e-3
    # The same call with OpenCV's arguments, criteria included, runs unchanged and gives lucent's
    # result; a criteria that is not OpenCV's triple is refused.
    same = lucent.calibrate_camera([OBJ.astype(np.float32)] * len(pts), [p.astype(np.float32).reshape(-1, 1, 2) for p in pts],
                                   (640, 480), None, None, criteria=crit)
    again = lucent.calibrate_camera([OBJ] * len(pts), [p.astype(np.float32) for p in pts], (640, 480))
    assert same[0] == again[0] and np.array_equal(same[1], again[1]) and np.array_equal(same[2], again[2])
    with pytest.raises(ValueError, match="criteria"):
        lucent.calibrate_camera([OBJ] * len(pts), pts, (640, 480), criteria=200)


def test_calibrate_procam_equals_the_command():
    import json
    from conftest import ROOT, cli
    caps = [ROOT.parent / "shared" / "data" / "structured-light" / "procam-sample" / f"capture_{i}" for i in range(3)]
    if not all(c.is_dir() for c in caps):
        pytest.skip("the shared procam captures are not here")
    r = lucent.calibrate_procam(caps, (1024, 768), (9, 7), 75.0, flags=lucent.CALIB_FIX_K3)
    out = cli("scan", "calibrate", *caps, "--projector", "1024x768", "--corners", "9x7", "--square", "75", "--fix-k3", "--json")
    assert out.returncode == 0, out.stderr
    want = json.loads(out.stdout)
    assert r == want
    assert r.camera["distortion"][4] == 0.0 and r.rms_px < 0.6
    with pytest.raises(ValueError, match="at least 3"):
        lucent.calibrate_procam(caps[:2], (1024, 768), (9, 7), 75.0)
    with pytest.raises(OSError):
        lucent.calibrate_procam([caps[0], caps[1], ROOT / "no-such-capture"], (1024, 768), (9, 7), 75.0)


def test_calibrate_procam_white_and_black_first(tmp_path):
    """The shared captures with their white and black frames moved in front of the patterns (as
    some capture tools save them): ``white_black="first"`` gives the calibration of the captures
    in their own order, exactly."""
    import shutil
    from conftest import ROOT
    caps = [ROOT.parent / "shared" / "data" / "structured-light" / "procam-sample" / f"capture_{i}" for i in range(3)]
    if not all(c.is_dir() for c in caps):
        pytest.skip("the shared procam captures are not here")
    moved = []
    for c in caps:
        d = tmp_path / c.name
        d.mkdir()
        for i in range(42):
            shutil.copy(c / f"graycode_{i:02d}.png", d / f"graycode_{(i + 2) % 42:02d}.png")
        moved.append(d)
    want = lucent.calibrate_procam(caps, (1024, 768), (9, 7), 75.0, flags=lucent.CALIB_FIX_K3)
    got = lucent.calibrate_procam(moved, (1024, 768), (9, 7), 75.0, flags=lucent.CALIB_FIX_K3, white_black="first")
    assert got.camera == want.camera and got.projector == want.projector
    assert got.rotation == want.rotation and got.translation == want.translation and got.rms_px == want.rms_px
    with pytest.raises(ValueError, match="white_black"):
        lucent.calibrate_procam(caps, (1024, 768), (9, 7), 75.0, white_black="middle")


def circle_grid_image(h_board_to_px, centres, radius, width=640, height=480, ss=4):
    """8-bit sRGB image of dark discs (linear 0.05) on white paper (linear 0.75) seen through a
    homography, each pixel the mean of ss × ss linear samples, then encoded."""
    def shade(bx, by):
        d2 = np.full(bx.shape, np.inf)
        for cx, cy in centres:
            d2 = np.minimum(d2, (bx - cx) ** 2 + (by - cy) ** 2)
        return np.where(d2 < radius ** 2, 0.05, 0.75)
    lin = supersampled(h_board_to_px, shade, width, height, ss)
    enc = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    return np.round(255 * enc).astype(np.uint8)


def ellipse_centres(h, centres, radius):
    """Exact centres of the image ellipses of board circles under the homography h."""
    hinv = np.linalg.inv(h)
    out = []
    for cx, cy in centres:
        c = np.array([[1, 0, -cx], [0, 1, -cy], [-cx, -cy, cx * cx + cy * cy - radius ** 2]])
        q = hinv.T @ c @ hinv
        out.append(-np.linalg.solve(q[:2, :2], q[:2, 2]))
    return np.array(out)


def drawn_asymmetric_grid():
    """OpenCV's 4 × 11 asymmetric grid (spacing 10, disc radius 3) turned and tilted before the
    camera K: (cols, rows, homography, object points, 8-bit image)."""
    cols, rows, s = 4, 11, 10.0
    obj = np.array([[(2 * j + i % 2) * s, i * s] for i in range(rows) for j in range(cols)])
    th = 0.4
    r = np.array([[np.cos(th), 0, np.sin(th)], [0, 1, 0], [-np.sin(th), 0, np.cos(th)]]) @ \
        np.array([[np.cos(2.0), -np.sin(2.0), 0], [np.sin(2.0), np.cos(2.0), 0], [0, 0, 1]])
    t = np.array([0.0, 0.0, 300.0]) - r @ np.array([35.0, 50.0, 0.0])
    h = K @ np.column_stack([r[:, 0], r[:, 1], t])
    return cols, rows, h, obj, circle_grid_image(h, obj, 3.0)


def test_find_circles_grid_on_a_drawn_asymmetric_grid():
    cols, rows, h, obj, img = drawn_asymmetric_grid()
    found, centres = lucent.find_circles_grid(img, (cols, rows), lucent.CALIB_CB_ASYMMETRIC_GRID)
    assert found and centres.shape == (cols * rows, 1, 2) and centres.dtype == np.float32
    # The order is OpenCV's object-point order: point k is obj[k], whatever the board's turn.
    e = np.linalg.norm(centres.reshape(-1, 2) - ellipse_centres(h, obj, 3.0), axis=1)
    assert np.median(e) < 0.02 and e.max() < 0.05, (np.median(e), e.max())
    # The symmetric layout is not in this image; bad flags and sizes are ValueErrors.
    assert lucent.find_circles_grid(img, (cols, rows), lucent.CALIB_CB_SYMMETRIC_GRID) == (False, None)
    with pytest.raises(ValueError, match="flags"):
        lucent.find_circles_grid(img, (cols, rows), 3)
    with pytest.raises(ValueError, match="pattern_size"):
        lucent.find_circles_grid(img, (-4, 11))
    # OpenCV's call forms: the output placeholder third, the flags fourth or by name, with
    # CALIB_CB_CLUSTERING; the same centres. A custom blob detector is refused.
    for call in (lambda: lucent.find_circles_grid(img, (cols, rows), None, lucent.CALIB_CB_ASYMMETRIC_GRID),
                 lambda: lucent.find_circles_grid(img, (cols, rows), flags=lucent.CALIB_CB_ASYMMETRIC_GRID | lucent.CALIB_CB_CLUSTERING),
                 lambda: lucent.find_circles_grid(img, (cols, rows), np.zeros((1, 1, 2), np.float32), lucent.CALIB_CB_ASYMMETRIC_GRID, None)):
        ok, c = call()
        assert ok and np.array_equal(c, centres)
    assert lucent.find_circles_grid(img, (cols, rows), None) == (False, None)  # symmetric by default
    with pytest.raises(ValueError, match="blobDetector"):
        lucent.find_circles_grid(img, (cols, rows), None, lucent.CALIB_CB_ASYMMETRIC_GRID, object())
    with pytest.raises(ValueError, match="flags"):
        lucent.find_circles_grid(img, (cols, rows), None, 8)


def test_find_circles_grid_against_live_opencv():
    cv2 = pytest.importorskip("cv2")
    cols, rows, h, obj, img = drawn_asymmetric_grid()
    found, centres = lucent.find_circles_grid(img, (cols, rows), lucent.CALIB_CB_ASYMMETRIC_GRID)
    e = np.linalg.norm(centres.reshape(-1, 2) - ellipse_centres(h, obj, 3.0), axis=1)
    ok, theirs = cv2.findCirclesGrid(img, (cols, rows), flags=cv2.CALIB_CB_ASYMMETRIC_GRID)
    assert ok
    # The same discs in the same order as OpenCV's, about as exact: median / max error 0.0165 /
    # 0.036 px against lucent's 0.015 / 0.040 (OpenCV 5.1.0). Both take the codes as they are;
    # decoding this image's sRGB first gives lucent 0.0063 / 0.022, but the real photographs of
    # docs/scanning.md ("Circle grids") fit better as they are.
    theirs = np.asarray(theirs).reshape(-1, 2)
    assert np.abs(theirs - centres.reshape(-1, 2)).max() < 0.5
    e_cv = np.linalg.norm(theirs.reshape(-1, 2) - ellipse_centres(h, obj, 3.0), axis=1)
    print(f"centre error, median / max: lucent {np.median(e):.4f} / {e.max():.4f} px, OpenCV {np.median(e_cv):.4f} / {e_cv.max():.4f} px")
    # OpenCV's positional call form, the same arguments to both: both find the grid, and lucent
    # returns what its own call form returns.
    args = (img, (cols, rows), None, cv2.CALIB_CB_ASYMMETRIC_GRID | cv2.CALIB_CB_CLUSTERING)
    ok_cv, _ = cv2.findCirclesGrid(*args)
    ok_lu, c_lu = lucent.find_circles_grid(*args)
    assert ok_cv and ok_lu and np.array_equal(c_lu, centres)


def rodrigues(r):
    r = np.asarray(r, dtype=float)
    th = np.linalg.norm(r)
    if th == 0:
        return np.eye(3)
    k = r / th
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * kx + (1 - np.cos(th)) * kx @ kx


K2 = np.array([[870.0, 0.0, 330.0], [0.0, 868.0, 236.5], [0.0, 0.0, 1.0]])
DIST2 = np.array([-0.12, 0.05, -0.0004, 0.0007, 0.0])
R12 = rodrigues([0.01, -0.17, 0.02])   # X₂ = R X₁ + T
T12 = np.array([-120.0, 2.0, 8.0])


def stereo_views(dist1=DIST, dist2=DIST2):
    p1, p2 = [], []
    for r, t in POSES:
        r1 = rodrigues(r)
        p1.append(lucent.project_points(OBJ, r, t, K, dist1))
        # The same board in the second camera: R₂ = R R₁, t₂ = R t₁ + T, as a Rodrigues vector.
        r2 = R12 @ r1
        th = np.arccos(np.clip((np.trace(r2) - 1) / 2, -1, 1))
        w = np.array([r2[2, 1] - r2[1, 2], r2[0, 2] - r2[2, 0], r2[1, 0] - r2[0, 1]]) * th / (2 * np.sin(th))
        p2.append(lucent.project_points(OBJ, w, R12 @ np.asarray(t) + T12, K2, dist2))
    return p1, p2


def test_stereo_calibrate_recovers_a_known_rig():
    p1, p2 = stereo_views()
    rms, k1, d1, k2, d2, r, t, e, f = lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, None, None, None, None, (640, 480))
    assert rms < 1e-8
    assert np.abs(k1 - K).max() < 1e-6 * K[0, 0] and np.abs(k2 - K2).max() < 1e-6 * K2[0, 0]
    assert np.abs(d1.ravel() - DIST).max() < 1e-8 and np.abs(d2.ravel() - DIST2).max() < 1e-8
    assert np.abs(r - R12).max() < 1e-9 and np.abs(t.ravel() - T12).max() < 1e-6
    # OpenCV's stopping rule is accepted (as cv2.stereoCalibrate's criteria) and changes nothing.
    with_crit = lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, None, None, None, None, (640, 480), criteria=(3, 100, 1e-5))
    assert with_crit[0] == rms and np.array_equal(with_crit[5], r) and np.array_equal(with_crit[6], t)
    # E = [T]ₓ R; with distortion-free cameras F relates the pixels: x₂ᵀ F x₁ = 0.
    q1, q2 = stereo_views(np.zeros(5), np.zeros(5))
    _, k1, _, k2, _, r, t, e, f = lucent.stereo_calibrate([OBJ] * len(q1), q1, q2, None, None, None, None, (640, 480), flags=lucent.CALIB_FIX_K3 | lucent.CALIB_ZERO_TANGENT_DIST)
    assert np.abs(e - np.cross(np.eye(3), t.ravel()) @ r).max() < 1e-9 * np.linalg.norm(t)
    x1 = np.c_[q1[0], np.ones(len(OBJ))]
    x2 = np.c_[q2[0], np.ones(len(OBJ))]
    assert np.abs(np.einsum('ij,jk,ik->i', x2, f, x1)).max() < 1e-9 * np.abs(f).max() * 640 ** 2
    # Held intrinsics (CALIB_FIX_INTRINSIC): wrong ones stay exactly where they were put.
    k_wrong = K * np.array([[1.01], [1.01], [1.0]])
    _, k1, d1, _, _, r, t, _, _ = lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, k_wrong, DIST, K2, DIST2, (640, 480), flags=lucent.CALIB_FIX_INTRINSIC)
    assert np.array_equal(k1, k_wrong) and np.array_equal(d1.ravel(), DIST)
    with pytest.raises(ValueError, match="camera_matrix1"):
        lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, None, None, None, None, (640, 480), flags=lucent.CALIB_FIX_INTRINSIC)
    with pytest.raises(ValueError, match="views"):
        lucent.stereo_calibrate([OBJ] * len(p1), p1, p2[:-1], None, None, None, None, (640, 480))
    # A relative pose to start from (CALIB_USE_EXTRINSIC_GUESS), 0.1 rad and 20 units off: the
    # same exact rig again; an R that is not a rotation, or a missing T, is a ValueError.
    guess = dict(R=R12 @ rodrigues([0.05, -0.06, 0.05]), T=T12 + 20.0)
    rms, _, _, _, _, r, t, _, _ = lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, None, None, None, None, (640, 480),
                                                        flags=lucent.CALIB_USE_EXTRINSIC_GUESS, **guess)
    assert rms < 1e-8 and np.abs(r - R12).max() < 1e-9 and np.abs(t.ravel() - T12).max() < 1e-6
    # On views with 0.2 px of noise the guess leads to the minimum the fit finds without it.
    rng = np.random.default_rng(9)
    n1 = [p + rng.normal(0, 0.2, p.shape) for p in p1]
    n2 = [p + rng.normal(0, 0.2, p.shape) for p in p2]
    plain = lucent.stereo_calibrate([OBJ] * len(n1), n1, n2, None, None, None, None, (640, 480))
    guessed = lucent.stereo_calibrate([OBJ] * len(n1), n1, n2, None, None, None, None, (640, 480),
                                      flags=lucent.CALIB_USE_EXTRINSIC_GUESS, **guess)
    assert abs(guessed[0] - plain[0]) < 1e-6 * plain[0] and np.abs(guessed[5] - plain[5]).max() < 1e-6
    assert np.abs(guessed[6] - plain[6]).max() < 1e-5 * np.linalg.norm(T12)
    # The guess is the start: one 2 rad off and on the wrong side leads the fit away from the
    # rig (it does not converge), where the same views without a guess give the rig exactly.
    with pytest.raises(ValueError, match="converge"):
        lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, None, None, None, None, (640, 480),
                                flags=lucent.CALIB_USE_EXTRINSIC_GUESS, R=R12 @ rodrigues([0.0, 2.0, 0.0]), T=-T12)
    # One about π off (2.5 rad) reaches a mirror image of the rig, which reprojects exactly with
    # the board behind the second camera and fy < 0: refused, not returned.
    with pytest.raises(ValueError, match="mirror image"):
        lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, None, None, None, None, (640, 480),
                                flags=lucent.CALIB_USE_EXTRINSIC_GUESS, R=R12 @ rodrigues([0.0, 2.5, 0.0]), T=T12)
    with pytest.raises(ValueError, match="rotation"):
        lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, None, None, None, None, (640, 480),
                                flags=lucent.CALIB_USE_EXTRINSIC_GUESS, R=2 * R12, T=T12)
    with pytest.raises(ValueError, match="R, T"):
        lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, None, None, None, None, (640, 480),
                                flags=lucent.CALIB_USE_EXTRINSIC_GUESS, R=R12)


def noisy_stereo_for_cv2(cv2, seed):
    """The rig's views with 0.2 px of noise, OpenCV's float32 forms of them, and each camera as
    cv2.calibrateCamera finds it: (p1, p2, obj, f32, crit, (k1, d1), (k2, d2))."""
    rng = np.random.default_rng(seed)
    p1, p2 = stereo_views()
    p1 = [p + rng.normal(0, 0.2, p.shape) for p in p1]
    p2 = [p + rng.normal(0, 0.2, p.shape) for p in p2]
    obj = [OBJ.astype(np.float32)] * len(p1)
    f32 = lambda ps: [p.astype(np.float32).reshape(-1, 1, 2) for p in ps]
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 300, 1e-15)
    _, k1, d1, _, _ = cv2.calibrateCamera(obj, f32(p1), (640, 480), None, None, criteria=crit)
    _, k2, d2, _, _ = cv2.calibrateCamera(obj, f32(p2), (640, 480), None, None, criteria=crit)
    return p1, p2, obj, f32, crit, (k1, d1), (k2, d2)


def test_stereo_calibrate_agrees_with_live_opencv():
    cv2 = pytest.importorskip("cv2")
    p1, p2, obj, f32, crit, (k1, d1), (k2, d2) = noisy_stereo_for_cv2(cv2, 5)
    ours = lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, None, None, None, None, (640, 480))
    theirs = cv2.stereoCalibrate(obj, f32(p1), f32(p2), k1, d1, k2, d2, (640, 480), flags=cv2.CALIB_USE_INTRINSIC_GUESS, criteria=crit)
    # One least-squares problem (float32 pixels in OpenCV): the same minimum.
    assert abs(ours[0] - theirs[0]) < 1e-3 * theirs[0]
    assert np.abs(ours[5] - theirs[5]).max() < 1e-4 and np.abs(ours[6] - theirs[6]).max() < 1e-3 * np.linalg.norm(T12)
    assert np.abs(ours[1] - theirs[1]).max() < 1e-3 * K[0, 0] and np.abs(ours[3] - theirs[3]).max() < 1e-3 * K2[0, 0]


def test_stereo_calibrate_hold_flags_agree_with_live_opencv():
    cv2 = pytest.importorskip("cv2")
    p1, p2, obj, f32, crit, (k1, d1), (k2, d2) = noisy_stereo_for_cv2(cv2, 6)
    # Held terms: the same minimum.
    held = cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_ASPECT_RATIO | cv2.CALIB_ZERO_TANGENT_DIST | cv2.CALIB_FIX_PRINCIPAL_POINT | cv2.CALIB_FIX_K3
    ours = lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, k1.copy(), d1.copy(), k2.copy(), d2.copy(), (640, 480), flags=held)
    theirs = cv2.stereoCalibrate(obj, f32(p1), f32(p2), k1.copy(), d1.copy(), k2.copy(), d2.copy(), (640, 480), flags=held, criteria=crit)
    assert abs(ours[0] - theirs[0]) < 1e-4 * theirs[0]
    for i in (1, 3):
        assert np.abs(ours[i] - theirs[i]).max() < 1e-3, i
    assert np.abs(ours[5] - theirs[5]).max() < 1e-5 and np.abs(ours[6] - theirs[6]).max() < 1e-4 * np.linalg.norm(T12)
    assert ours[1][0, 2] == k1[0, 2] and ours[3][1, 2] == k2[1, 2] and ours[2][0, 4] == d1[0, 4]
    assert ours[1][0, 0] / ours[1][1, 1] == pytest.approx(k1[0, 0] / k1[1, 1], rel=1e-15)
    # OpenCV's stereo sample's flags, one focal length for both cameras (started, and its ratio
    # held, from the two matrices' mean, as OpenCV does). Here cv2 stops above the minimum: its
    # own intrinsics with the best poses give less than the RMS it reports. lucent's solution,
    # evaluated by cv2 with its intrinsics held, has lucent's RMS, below cv2's.
    for flags in (cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_ASPECT_RATIO | cv2.CALIB_ZERO_TANGENT_DIST | cv2.CALIB_SAME_FOCAL_LENGTH | cv2.CALIB_FIX_K3,
                  cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_ASPECT_RATIO | cv2.CALIB_ZERO_TANGENT_DIST | cv2.CALIB_SAME_FOCAL_LENGTH
                  | cv2.CALIB_RATIONAL_MODEL | cv2.CALIB_FIX_K3 | cv2.CALIB_FIX_K4 | cv2.CALIB_FIX_K5):
        ours = lucent.stereo_calibrate([OBJ] * len(p1), p1, p2, k1.copy(), d1.copy(), k2.copy(), d2.copy(), (640, 480), flags=flags)
        theirs = cv2.stereoCalibrate(obj, f32(p1), f32(p2), k1.copy(), d1.copy(), k2.copy(), d2.copy(), (640, 480), flags=flags, criteria=crit)
        check = cv2.stereoCalibrate(obj, f32(p1), f32(p2), ours[1], ours[2], ours[3], ours[4], (640, 480), R=ours[5], T=ours[6],
                                    flags=cv2.CALIB_FIX_INTRINSIC | (flags & cv2.CALIB_RATIONAL_MODEL), criteria=crit)
        assert abs(check[0] - ours[0]) < 1e-4 * ours[0] and ours[0] < theirs[0], (flags, ours[0], check[0], theirs[0])
        assert ours[1][0, 0] == ours[3][0, 0] and ours[1][1, 1] == ours[3][1, 1]
        mean = (k1 + k2) / 2
        assert ours[1][0, 0] / ours[1][1, 1] == pytest.approx(mean[0, 0] / mean[1, 1], rel=1e-14)


def test_undistort_identity_colour_and_bad_input():
    th = 0.35
    r = np.array([[np.cos(th), 0, np.sin(th)], [0, 1, 0], [-np.sin(th), 0, np.cos(th)]])
    img = chessboard_image(K @ np.column_stack([r[:, 0], r[:, 1], [-95.0, -70.0, 520.0]]))
    # Without distortion every output pixel samples its own pixel: the image unchanged.
    assert np.array_equal(lucent.undistort(img, K, None), img)
    colour = np.dstack([img, 255 - img, img // 2])
    ours = lucent.undistort(colour, K, DIST)
    assert ours.shape == colour.shape and ours.dtype == np.uint8
    assert np.array_equal(ours[..., 0], lucent.undistort(img, K, DIST))
    with pytest.raises(ValueError, match="src"):
        lucent.undistort(img.astype(float), K, DIST)


def test_undistort_against_live_opencv():
    cv2 = pytest.importorskip("cv2")
    th = 0.35
    r = np.array([[np.cos(th), 0, np.sin(th)], [0, 1, 0], [-np.sin(th), 0, np.cos(th)]])
    img = chessboard_image(K @ np.column_stack([r[:, 0], r[:, 1], [-95.0, -70.0, 520.0]]))
    colour = np.dstack([img, 255 - img, img // 2])
    ours = lucent.undistort(colour, K, DIST)
    theirs = cv2.undistort(colour, K, DIST)
    d = np.abs(ours.astype(int) - theirs.astype(int))
    # The same remap: OpenCV rounds the interpolation weights to 1/32 px, so the two differ by
    # about a level at the board's edges and agree elsewhere (measured: mean 0.024, 99.9th
    # percentile 2, max 4 levels; OpenCV 5.1.0).
    assert d.mean() < 0.2 and np.percentile(d, 99.9) <= 6, (d.mean(), np.percentile(d, 99.9), d.max())
    print(f"undistort against cv2: mean {d.mean():.3f}, 99.9th percentile {np.percentile(d, 99.9)}, max {d.max()} levels")
    # OpenCV's call form with a new camera matrix (the tutorials' undistort(img, K, dist, None,
    # K_new)) runs unchanged; lucent's shorter form and both keyword names give the same image.
    k_new = K.copy()
    k_new[0, 0] *= 0.8
    k_new[1, 1] *= 0.8
    ours = lucent.undistort(colour, K, DIST, None, k_new)
    for other in (lucent.undistort(colour, K, DIST, k_new), lucent.undistort(colour, K, DIST, new_camera_matrix=k_new),
                  lucent.undistort(colour, K, DIST, newCameraMatrix=k_new)):
        assert np.array_equal(ours, other)
    d = np.abs(ours.astype(int) - cv2.undistort(colour, K, DIST, None, k_new).astype(int))
    assert d.mean() < 0.2 and np.percentile(d, 99.9) <= 6, (d.mean(), np.percentile(d, 99.9), d.max())
    with pytest.raises(ValueError, match="twice"):
        lucent.undistort(colour, K, DIST, None, k_new, k_new)


def test_solve_pnp_recovers_a_known_pose():
    rng = np.random.default_rng(11)
    cloud = rng.uniform(-60, 60, (12, 3))
    r, t = np.array([0.3, -0.45, 0.2]), np.array([-40.0, 25.0, 520.0])
    for obj in (cloud, OBJ):
        px = lucent.project_points(obj, r, t, K, DIST)
        ok, rv, tv = lucent.solve_pnp(obj, px, K, DIST)
        assert ok and rv.shape == (3, 1) and tv.shape == (3, 1)
        assert np.abs(rv.ravel() - r).max() < 1e-9 and np.abs(tv.ravel() - t).max() < 1e-7
    with pytest.raises(ValueError, match="at least 4"):
        lucent.solve_pnp(OBJ[:3], lucent.project_points(OBJ[:3], r, t, K, DIST), K, DIST)
    # From a guess (useExtrinsicGuess), five points off a plane, too few without one.
    five = cloud[:5]
    px = lucent.project_points(five, r, t, K, DIST)
    with pytest.raises(ValueError, match="at least 6"):
        lucent.solve_pnp(five, px, K, DIST)
    ok, rv, tv = lucent.solve_pnp(five, px, K, DIST, r + 0.05, t + 20.0, True)
    assert np.abs(rv.ravel() - r).max() < 1e-9 and np.abs(tv.ravel() - t).max() < 1e-7
    with pytest.raises(ValueError, match="rvec and tvec"):
        lucent.solve_pnp(five, px, K, DIST, useExtrinsicGuess=True)
    with pytest.raises(ValueError, match="SOLVEPNP"):
        lucent.solve_pnp(five, px, K, DIST, flags=7)


SQUARE_CORNERS = np.array([[-15.0, 15, 0], [15, 15, 0], [15, -15, 0], [-15, -15, 0]])


def test_every_solve_pnp_method_recovers_a_known_pose():
    """Each of OpenCV 5's methods, by its number, poses exact pixels through the distorted lens."""
    rng = np.random.default_rng(13)
    cloud = rng.uniform(-60, 60, (12, 3))
    r, t = np.array([0.3, -0.45, 0.2]), np.array([-40.0, 25.0, 520.0])
    cases = [(lucent.SOLVEPNP_EPNP, cloud), (lucent.SOLVEPNP_P3P, cloud[:4]), (lucent.SOLVEPNP_AP3P, cloud[4:8]),
             (lucent.SOLVEPNP_IPPE, OBJ), (lucent.SOLVEPNP_IPPE_SQUARE, SQUARE_CORNERS), (lucent.SOLVEPNP_SQPNP, cloud),
             (lucent.SOLVEPNP_SQPNP, OBJ)]
    assert [c[0] for c in cases] == [1, 2, 3, 4, 5, 6, 6]
    for flag, obj in cases:
        px = lucent.project_points(obj, r, t, K, DIST)
        ok, rv, tv = lucent.solve_pnp(obj, px, K, DIST, flags=flag)
        assert ok and rv.shape == (3, 1), flag
        assert np.abs(rv.ravel() - r).max() < 1e-7 and np.abs(tv.ravel() - t).max() < 1e-5, flag
        n, rvs, tvs, err = lucent.solve_pnp_generic(obj, px, K, DIST, flags=flag)
        # IPPE: a plane's two poses; P3P/AP3P: every pose of the first three points (up to 4).
        assert n == len(rvs) == len(tvs) == err.shape[0]
        assert n == 2 if flag in (4, 5) else (1 <= n <= 4 if flag in (2, 3) else n == 1), (flag, n)
        assert np.allclose(rvs[0], rv) and err[0, 0] < 1e-6 and all(err[i, 0] >= err[0, 0] for i in range(n))
    # The refinement from any of them lands on the iterative solver's minimum.
    px = lucent.project_points(cloud, r, t, K, DIST) + rng.normal(0, 0.3, (len(cloud), 2))
    _, r0, t0 = lucent.solve_pnp(cloud, px, K, DIST, flags=lucent.SOLVEPNP_EPNP)
    r1, t1 = lucent.solve_pnp_refine_lm(cloud, px, K, DIST, r0, t0)
    _, r2, t2 = lucent.solve_pnp(cloud, px, K, DIST)
    assert np.abs(r1 - r2).max() < 1e-9 and np.abs(t1 - t2).max() < 1e-7
    with pytest.raises(ValueError, match="exactly 4"):
        lucent.solve_pnp(cloud[:5], lucent.project_points(cloud[:5], r, t, K, DIST), K, DIST, flags=lucent.SOLVEPNP_P3P)
    with pytest.raises(ValueError, match="plane"):
        lucent.solve_pnp(cloud, lucent.project_points(cloud, r, t, K, DIST), K, DIST, flags=lucent.SOLVEPNP_IPPE)


def test_solve_pnp_methods_agree_with_live_opencv():
    """Against cv2 on the same noisy pixels (0.3 px): P3P, AP3P and IPPE_SQUARE are closed forms of
    the same solutions (equal to 1e-9); SQPnP is the global minimum of the same object-space error
    (lucent's error never above OpenCV's, whose iteration stops earlier; poses within 1e-3 rad); IPPE
    on a board within 1e-3 rad (the homographies differ: Hartley's against Harker and O'Leary's);
    EPnP off a plane equal to 1e-6 (OpenCV's undistortPoints stops after 5 steps)."""
    cv2 = pytest.importorskip("cv2")
    assert (cv2.SOLVEPNP_EPNP, cv2.SOLVEPNP_P3P, cv2.SOLVEPNP_AP3P, cv2.SOLVEPNP_IPPE, cv2.SOLVEPNP_IPPE_SQUARE,
            cv2.SOLVEPNP_SQPNP) == (lucent.SOLVEPNP_EPNP, lucent.SOLVEPNP_P3P, lucent.SOLVEPNP_AP3P, lucent.SOLVEPNP_IPPE,
                                    lucent.SOLVEPNP_IPPE_SQUARE, lucent.SOLVEPNP_SQPNP)
    rng = np.random.default_rng(14)
    Kc = np.array([[910.0, 0, 322.0], [0, 905.0, 241.5], [0, 0, 1]])

    def angle(a, b):
        return np.linalg.norm(cv2.Rodrigues(cv2.Rodrigues(a)[0] @ cv2.Rodrigues(b)[0].T)[0])

    def obj_err(obj, px, rv, tv):
        R = cv2.Rodrigues(rv)[0]
        x = np.c_[lucent.undistort_points(px, Kc, DIST), np.ones(len(px))]
        return sum(np.sum(((np.eye(3) - np.outer(v, v) / v.dot(v)) @ (R @ X + tv.ravel())) ** 2) for X, v in zip(obj, x))

    def rep(obj, px, rv, tv):
        return np.sqrt(np.mean(np.sum((lucent.project_points(obj, rv.ravel(), tv.ravel(), Kc, DIST) - px) ** 2, axis=1)))

    ep_lu, ep_cv = [], []
    for trial in range(20):
        r, t = rng.normal(0, 0.4, 3), np.array([rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(400, 800)])
        cloud = rng.uniform(-60, 60, (20, 3))
        for flag, obj in ((cv2.SOLVEPNP_P3P, cloud[:4]), (cv2.SOLVEPNP_AP3P, cloud[:4]), (cv2.SOLVEPNP_IPPE_SQUARE, SQUARE_CORNERS),
                          (cv2.SOLVEPNP_SQPNP, cloud), (cv2.SOLVEPNP_SQPNP, OBJ), (cv2.SOLVEPNP_IPPE, OBJ), (cv2.SOLVEPNP_EPNP, cloud)):
            px = lucent.project_points(obj, r, t, Kc, DIST) + rng.normal(0, 0.3, (len(obj), 2))
            ok, rc, tc = cv2.solvePnP(obj, px, Kc, DIST, flags=flag)
            _, rl, tl = lucent.solve_pnp(obj, px, Kc, DIST, flags=flag)
            if flag in (cv2.SOLVEPNP_P3P, cv2.SOLVEPNP_AP3P, cv2.SOLVEPNP_IPPE_SQUARE):
                # OpenCV's undistortPoints stops after 5 fixed-point steps: equal to its precision.
                assert angle(rl, rc) < 1e-6 and np.linalg.norm(tl - tc) < 1e-6 * np.linalg.norm(tc), (trial, flag)
            elif flag == cv2.SOLVEPNP_SQPNP:
                assert obj_err(obj, px, rl, tl) <= obj_err(obj, px, rc, tc) * (1 + 1e-6), trial
                if len(obj) > 4:
                    assert angle(rl, rc) < 1e-3, trial
            elif flag == cv2.SOLVEPNP_IPPE:
                assert angle(rl, rc) < 1e-3, trial
            else:
                # EPnP off a plane: the same control points (OpenCV's SVD signs), the same pose.
                assert angle(rl, rc) < 1e-6 and np.linalg.norm(tl - tc) < 1e-6 * np.linalg.norm(tc), trial
                ep_lu.append(rep(obj, px, rl, tl))
                ep_cv.append(rep(obj, px, rc, tc))
    assert abs(np.mean(ep_lu) / np.mean(ep_cv) - 1) < 1e-6


def test_solve_pnp_agrees_with_live_opencv():
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(12)
    r, t = np.array([0.3, -0.45, 0.2]), np.array([-40.0, 25.0, 520.0])
    for obj in (rng.uniform(-60, 60, (12, 3)), OBJ):
        px = lucent.project_points(obj, r, t, K, DIST) + rng.normal(0, 0.3, (len(obj), 2))
        _, rv, tv = lucent.solve_pnp(obj, px, K, DIST)
        ok, rc, tc = cv2.solvePnP(obj, px, K, DIST, flags=cv2.SOLVEPNP_ITERATIVE)
        # The same least-squares minimum.
        assert ok and np.abs(rv - rc).max() < 1e-5 and np.abs(tv - tc).max() < 1e-4 * np.linalg.norm(t)
        # And from the same guess (useExtrinsicGuess), the same minimum again.
        g_r, g_t = (r + 0.04).reshape(3, 1), (t + 15.0).reshape(3, 1)
        _, rv, tv = lucent.solve_pnp(obj, px, K, DIST, g_r, g_t, True)
        ok, rc, tc = cv2.solvePnP(obj, px, K, DIST, g_r.copy(), g_t.copy(), True, cv2.SOLVEPNP_ITERATIVE)
        assert ok and np.abs(rv - rc).max() < 1e-5 and np.abs(tv - tc).max() < 1e-4 * np.linalg.norm(t)


def outliers(px, rng, share=4):
    """A copy of `px` with every `share`-th correspondence moved 30–100 px in a random direction,
    and the indices left as they were."""
    bad = np.arange(len(px))[1::share]
    ang, mag = rng.uniform(0, 2 * np.pi, len(bad)), rng.uniform(30, 100, len(bad))
    out = px.copy()
    out[bad] += np.c_[np.cos(ang), np.sin(ang)] * mag[:, None]
    return out, np.setdiff1d(np.arange(len(px)), bad)


def test_solve_pnp_ransac_leaves_out_gross_outliers():
    rng = np.random.default_rng(21)
    cloud = rng.uniform(-60, 60, (40, 3))
    r, t = np.array([0.3, -0.45, 0.2]), np.array([-40.0, 25.0, 520.0])
    for obj in (cloud, OBJ):
        px, good = outliers(lucent.project_points(obj, r, t, K, DIST), rng)
        ok, rv, tv, inl = lucent.solve_pnp_ransac(obj, px, K, DIST)
        assert ok and inl.dtype == np.int32 and inl.shape == (len(good), 1) and np.array_equal(inl.ravel(), good)
        assert np.abs(rv.ravel() - r).max() < 1e-9 and np.abs(tv.ravel() - t).max() < 1e-7
    # Correspondences that fit no pose: OpenCV's (False, …).
    scrambled = rng.uniform(0, 640, (len(OBJ), 2))
    assert lucent.solve_pnp_ransac(OBJ, scrambled, K, DIST, reprojectionError=0.5)[0] is False
    with pytest.raises(ValueError, match="at least 4"):
        lucent.solve_pnp_ransac(OBJ[:3], scrambled[:3], K, DIST)


def test_solve_pnp_ransac_agrees_with_live_opencv():
    # With 0.3-px noise and a quarter of the correspondences 30–100 px off, both find the same
    # inliers and, refined on them, the same pose.
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(22)
    r, t = np.array([0.3, -0.45, 0.2]), np.array([-40.0, 25.0, 520.0])
    for obj in (rng.uniform(-60, 60, (40, 3)), OBJ):
        px, _ = outliers(lucent.project_points(obj, r, t, K, DIST) + rng.normal(0, 0.3, (len(obj), 2)), rng)
        _, rv, tv, inl = lucent.solve_pnp_ransac(obj, px, K, DIST)
        ok, rc, tc, inc = cv2.solvePnPRansac(obj, px, K, DIST)
        assert ok and np.array_equal(np.sort(inl.ravel()), np.sort(inc.ravel()))
        assert np.abs(rv - rc).max() < 1e-5 and np.abs(tv - tc).max() < 1e-4 * np.linalg.norm(t)


RECT_K1 = np.array([[905.0, 0, 322.5], [0, 899.0, 241.0], [0, 0, 1]])
RECT_D1 = np.array([-0.12, 0.05, 0.001, -0.0007, 0.0])
RECT_K2 = np.array([[870.0, 0, 330.0], [0, 866.0, 236.0], [0, 0, 1]])
RECT_D2 = np.array([-0.08, 0.02, 0.0, 0.0005, 0.0])
RECT_RVEC = np.array([0.02, -0.05, 0.01])
RECT_T = np.array([-120.0, 3.0, 5.0])


def test_stereo_rectify_puts_matches_on_one_row():
    # Points seen by both cameras (lucent's own projection through the lenses), undistorted and
    # rectified through the maps' inverse, land on one row, and Q turns (u, v, disparity) back
    # into the point in the first rectified camera's frame.
    r1, r2, p1, p2, q, roi1, roi2 = lucent.stereo_rectify(RECT_K1, RECT_D1, RECT_K2, RECT_D2, (640, 480), RECT_RVEC, RECT_T)
    for r in (r1, r2):
        assert np.abs(r @ r.T - np.eye(3)).max() < 1e-12 and abs(np.linalg.det(r) - 1) < 1e-12
    assert p1[0, 2] == p2[0, 2] and p1[1, 2] == p2[1, 2] and p1[0, 0] == p2[1, 1]  # CALIB_ZERO_DISPARITY
    rot = lucent._rodrigues(RECT_RVEC)
    x = np.array([[30.0, -20.0, 900.0], [-80.0, 60.0, 1400.0], [5.0, 5.0, 600.0]])
    a = lucent.project_points(x, np.zeros(3), np.zeros(3), RECT_K1, RECT_D1)
    b = lucent.project_points(x @ rot.T + RECT_T, np.zeros(3), np.zeros(3), RECT_K2, RECT_D2)
    ua = lucent.undistort_points(a, RECT_K1, RECT_D1)
    ub = lucent.undistort_points(b, RECT_K2, RECT_D2)
    rect = lambda u, r, p: (lambda h: h[:, :2] / h[:, 2:])(np.c_[u, np.ones(len(u))] @ r.T @ p[:, :3].T)
    ra, rb = rect(ua.reshape(-1, 2), r1, p1), rect(ub.reshape(-1, 2), r2, p2)
    assert np.abs(ra[:, 1] - rb[:, 1]).max() < 1e-7, (ra, rb)
    h = np.c_[ra, ra[:, 0] - rb[:, 0], np.ones(len(ra))] @ q.T
    back = h[:, :3] / h[:, 3:]
    assert np.abs(back - x @ r1.T).max() < 1e-6 * 1400
    assert all(0 <= v for v in roi1 + roi2) and roi1[2] > 500 and roi2[3] > 400
    # The rectified cameras triangulate the points back (linear DLT, as cv2.triangulatePoints).
    h = lucent.triangulate_points(p1, p2, ra.T, rb.T)
    assert h.shape == (4, 3) and np.all(h[3] > 0) and np.allclose(np.linalg.norm(h, axis=0), 1.0)
    assert np.abs(h[:3] / h[3] - (x @ r1.T).T).max() < 1e-6 * 1400
    with pytest.raises(ValueError, match="flags"):
        lucent.stereo_rectify(RECT_K1, RECT_D1, RECT_K2, RECT_D2, (640, 480), RECT_RVEC, RECT_T, flags=1)
    with pytest.raises(ValueError, match="share a centre"):
        lucent.stereo_rectify(RECT_K1, RECT_D1, RECT_K2, RECT_D2, (640, 480), RECT_RVEC, np.zeros(3))


def test_rectification_agrees_with_live_opencv():
    cv2 = pytest.importorskip("cv2")
    rot = cv2.Rodrigues(RECT_RVEC)[0]
    t = RECT_T.reshape(3, 1)
    # A horizontal pair either way round, and a vertical one.
    cases = [(tt, flags, alpha) for tt in (t, -t, np.array([[4.0], [-110.0], [-6.0]]))
             for flags, alpha in [(cv2.CALIB_ZERO_DISPARITY, -1), (0, -1), (cv2.CALIB_ZERO_DISPARITY, 0), (cv2.CALIB_ZERO_DISPARITY, 1), (0, 0.5)]]
    for tt, flags, alpha in cases:
        ours = lucent.stereo_rectify(RECT_K1, RECT_D1, RECT_K2, RECT_D2, (640, 480), rot, tt, flags=flags, alpha=alpha)
        theirs = cv2.stereoRectify(RECT_K1, RECT_D1, RECT_K2, RECT_D2, (640, 480), rot, tt, flags=flags, alpha=alpha)
        # The rotations are closed forms; P and Q depend on undistorted image corners, which
        # OpenCV finds by five fixed-point iterations in float32.
        assert np.abs(ours[0] - theirs[0]).max() < 1e-12 and np.abs(ours[1] - theirs[1]).max() < 1e-12
        for o, c in zip(ours[2:5], theirs[2:5]):
            assert np.abs(o - c).max() < 1e-7 * np.abs(c).max(), (flags, alpha)
        assert tuple(ours[5]) == tuple(theirs[5]) and tuple(ours[6]) == tuple(theirs[6]), (flags, alpha)
    for alpha in (0.0, 0.5, 1.0):
        ours = lucent.get_optimal_new_camera_matrix(RECT_K1, RECT_D1, (640, 480), alpha)
        theirs = cv2.getOptimalNewCameraMatrix(RECT_K1, RECT_D1, (640, 480), alpha)
        assert np.abs(ours[0] - theirs[0]).max() < 1e-5 and tuple(ours[1]) == tuple(theirs[1]), alpha
    ours = lucent.get_optimal_new_camera_matrix(RECT_K1, RECT_D1, (640, 480), 0.3, (800, 600))
    theirs = cv2.getOptimalNewCameraMatrix(RECT_K1, RECT_D1, (640, 480), 0.3, (800, 600))
    assert np.abs(ours[0] - theirs[0]).max() < 1e-5 and tuple(ours[1]) == tuple(theirs[1])
    r1, _, p1, _, _, _, _ = lucent.stereo_rectify(RECT_K1, RECT_D1, RECT_K2, RECT_D2, (640, 480), rot, t)
    mx, my = lucent.init_undistort_rectify_map(RECT_K1, RECT_D1, r1, p1, (640, 480))
    cx, cy = cv2.initUndistortRectifyMap(RECT_K1, RECT_D1, r1, p1, (640, 480), cv2.CV_32FC1)
    assert mx.dtype == np.float32 and mx.shape == (480, 640)
    assert np.abs(mx - cx).max() < 1e-3 and np.abs(my - cy).max() < 1e-3
    # Without a new camera matrix: OpenCV's default one, the principal point at the centre.
    mx, my = lucent.init_undistort_rectify_map(RECT_K1, RECT_D1, None, None, (640, 480))
    cx, cy = cv2.initUndistortRectifyMap(RECT_K1, RECT_D1, None, None, (640, 480), cv2.CV_32FC1)
    assert np.abs(mx - cx).max() < 1e-3 and np.abs(my - cy).max() < 1e-3
    # OpenCV's other map formats: one two-channel float map, and the fixed-point maps whose
    # conversion from lucent's float maps is cv2.convertMaps's, entry for entry.
    r1, _, p1, _, _, _, _ = lucent.stereo_rectify(RECT_K1, RECT_D1, RECT_K2, RECT_D2, (640, 480), rot, t)
    mx, my = lucent.init_undistort_rectify_map(RECT_K1, RECT_D1, r1, p1, (640, 480))
    m2, none = lucent.init_undistort_rectify_map(RECT_K1, RECT_D1, r1, p1, (640, 480), lucent.CV_32FC2)
    assert none is None and m2.dtype == np.float32 and np.array_equal(m2, np.dstack([mx, my]))
    xy, frac = lucent.init_undistort_rectify_map(RECT_K1, RECT_D1, r1, p1, (640, 480), lucent.CV_16SC2)
    cxy, cfrac = cv2.convertMaps(mx, my, cv2.CV_16SC2)
    assert xy.dtype == np.int16 and xy.shape == (480, 640, 2) and frac.dtype == np.uint16
    assert np.array_equal(xy, cxy) and np.array_equal(frac, cfrac)
    # Against OpenCV's own fixed-point maps: the same but where the two float maps straddle a
    # 1/32-pixel rounding boundary (measured: 0.08 % of the entries, OpenCV 5.1.0).
    oxy, ofrac = cv2.initUndistortRectifyMap(RECT_K1, RECT_D1, r1, p1, (640, 480), cv2.CV_16SC2)
    assert (np.any(xy != oxy, axis=2) | (frac != ofrac)).mean() < 0.005
    # undistortPoints with R and P (the rectified pixels of the left camera), as cv2 computes them.
    rng = np.random.default_rng(5)
    px = rng.uniform([40, 40], [600, 440], (50, 2))
    ours = lucent.undistort_points(px, RECT_K1, RECT_D1, None, r1, p1)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    theirs = cv2.undistortPoints(px.reshape(-1, 1, 2), RECT_K1, RECT_D1, None, r1, p1, crit).reshape(-1, 2)
    assert np.abs(ours - theirs).max() < 1e-6, np.abs(ours - theirs).max()  # measured 6·10⁻¹⁰ px
    assert np.abs(lucent.undistort_points(px, RECT_K1, RECT_D1, P=RECT_K1) - cv2.undistortPoints(
        px.reshape(-1, 1, 2), RECT_K1, RECT_D1, None, None, RECT_K1, crit).reshape(-1, 2)).max() < 1e-6
    # OpenCV's argument list as it stands, criteria included: lucent's result.
    assert np.array_equal(lucent.undistort_points(px, RECT_K1, RECT_D1, None, r1, p1, crit), ours)
    with pytest.raises(ValueError, match="m1type"):
        lucent.init_undistort_rectify_map(RECT_K1, RECT_D1, r1, p1, (640, 480), 0)
    with pytest.raises(ValueError, match="R"):
        lucent.undistort_points(px, RECT_K1, RECT_D1, None, np.eye(2))
    # triangulatePoints on noisy pixels: the same points.
    rng = np.random.default_rng(9)
    pts1, pts2 = rng.uniform(100, 500, (2, 20)), rng.uniform(100, 500, (2, 20))
    _, _, p1, p2, _, _, _ = lucent.stereo_rectify(RECT_K1, RECT_D1, RECT_K2, RECT_D2, (640, 480), rot, t)
    ours, theirs = lucent.triangulate_points(p1, p2, pts1, pts2), cv2.triangulatePoints(p1, p2, pts1, pts2)
    assert np.abs(ours[:3] / ours[3] - theirs[:3] / theirs[3]).max() < 1e-8 * np.abs(theirs[:3] / theirs[3]).max()


def test_bad_point_lists_and_sizes_are_value_errors():
    """Refused on one line naming the argument, where a panic, an abort or a silent reshape
    would otherwise follow: RANSAC on fewer than 4 points, a closed-form method on points at one
    spot or on one line, a transposed (3, N) point list, maps or images beyond 2^28 pixels, a
    non-8-bit image for the chessboard finder, a NaN alpha."""
    obj = np.random.default_rng(3).uniform(-50, 50, (8, 3))
    px = lucent.project_points(obj, np.array([0.1, 0.2, 0.0]), np.array([0.0, 0.0, 500.0]), K, DIST)
    for n in (0, 2):
        with pytest.raises(ValueError, match="at least 4"):
            lucent.solve_pnp_ransac(obj[:n], px[:n], K, DIST)
    with pytest.raises(ValueError, match="one line or at one point"):
        lucent.solve_pnp(np.zeros((6, 3)), np.full((6, 2), 100.0), K, None, flags=lucent.SOLVEPNP_SQPNP)
    line = np.c_[np.arange(6.0) * 30, np.zeros(6), np.zeros(6)]
    with pytest.raises(ValueError, match="one line"):
        lucent.solve_pnp(line, px[:6], K, None, flags=lucent.SOLVEPNP_EPNP)
    with pytest.raises(ValueError, match="objectPoints"):
        lucent.solve_pnp(obj.T, px, K, DIST)
    with pytest.raises(ValueError, match="object_points"):
        lucent.project_points(obj[:4].T, np.zeros(3), np.array([0.0, 0.0, 500.0]), K, DIST)
    fk, fd = np.array([[350.0, 0, 320], [0, 350, 240], [0, 0, 1]]), np.array([0.05, -0.02, 0.004, 0.0])
    with pytest.raises(ValueError, match="object_points"):
        lucent.fisheye.project_points(obj[:5].T, np.zeros(3), np.array([0.0, 0.0, 500.0]), fk, fd)
    with pytest.raises(ValueError, match="undistorted"):
        lucent.fisheye.distort_points(np.zeros((2, 5)), fk, fd)
    with pytest.raises(ValueError, match="distorted"):
        lucent.fisheye.undistort_points(np.zeros((2, 5)), fk, fd)
    with pytest.raises(ValueError, match="too large"):
        lucent.init_undistort_rectify_map(K, DIST, None, K, (100000, 100000))
    with pytest.raises(ValueError, match="beyond"):
        lucent.init_undistort_rectify_map(K, DIST, None, K, (10**10, 1))
    with pytest.raises(ValueError, match="uint8"):
        lucent.find_chessboard_corners(np.zeros((480, 640)), (9, 6))
    with pytest.raises(ValueError, match="alpha"):
        lucent.stereo_rectify(K, DIST, K, DIST, (640, 480), np.eye(3), np.array([-50.0, 0, 0]), alpha=float("nan"))
    with pytest.raises(ValueError, match="finite"):
        lucent.triangulate_points(np.eye(3, 4), np.eye(3, 4), [[np.nan], [200.0]], [[300.0], [200.0]])


def test_init_undistort_rectify_map_default_new_camera_centres_the_principal_point():
    """Without a new camera matrix the map is that of ``camera_matrix`` with its principal point
    at ((w − 1)/2, (h − 1)/2), OpenCV's ``getDefaultNewCameraMatrix(…, True)``; a pixel of the new
    image maps to the source pixel that projects its ray (checked through ``project_points``)."""
    w, h = 640, 480
    mx, my = lucent.init_undistort_rectify_map(K, DIST, None, None, (w, h))
    kc = np.array(K, dtype=float)
    kc[0, 2], kc[1, 2] = (w - 1) / 2, (h - 1) / 2
    ex, ey = lucent.init_undistort_rectify_map(K, DIST, None, kc, (w, h))
    assert np.array_equal(mx, ex) and np.array_equal(my, ey)
    for u, v in [(0, 0), (319.5, 239.5), (600, 50), (100, 400)]:
        ray = np.array([[(u - kc[0, 2]) / kc[0, 0], (v - kc[1, 2]) / kc[1, 1], 1.0]])
        px = lucent.project_points(ray, np.zeros(3), np.zeros(3), K, DIST)[0]
        i, j = int(v), int(u)
        if (i, j) == (v, u):
            assert abs(mx[i, j] - px[0]) < 1e-3 and abs(my[i, j] - px[1]) < 1e-3, (u, v, px, mx[i, j], my[i, j])


def _rodrigues_matrix(r):
    th = np.linalg.norm(r)
    k = r / th
    x = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * x + (1 - np.cos(th)) * x @ x


def test_rational_fit_from_a_guess_with_a_near_cancelling_denominator():
    """CALIB_RATIONAL_MODEL | CALIB_USE_INTRINSIC_GUESS from OpenCV 5.1.0's own optimum for these
    views (k1 = −20.7 over k4 = −20.4: numerator and denominator nearly cancel, so the numerator
    alone is no lens) converges, to the minimum the unguided fit finds (within 1e-4 px RMS); it
    ended at 145 px when the guess's numerator was first fitted on its own."""
    k_true = np.array([[800.0, 0, 330.0], [0, 760.0, 250.0], [0, 0, 1]])
    d_true = np.array([-0.28, 0.09, 0.0012, -0.0009, -0.015])
    rng = np.random.default_rng(104)
    obj = np.zeros((54, 3))
    obj[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2) * 0.025
    imgs = []
    while len(imgs) < 15:
        r = rng.uniform(-0.5, 0.5, 3) * np.array([1, 1, 0.5])
        t = np.array([rng.uniform(-0.08, 0.08), rng.uniform(-0.06, 0.06), rng.uniform(0.3, 0.55)]) - _rodrigues_matrix(r) @ obj.mean(0)
        p = lucent.project_points(obj, r, t, k_true, d_true)
        if (p[:, 0] < 5).any() or (p[:, 0] > 634).any() or (p[:, 1] < 5).any() or (p[:, 1] > 474).any():
            continue
        imgs.append((p + rng.normal(0, 0.2, p.shape)).astype(np.float32).reshape(-1, 1, 2))
    objs = [obj.astype(np.float32)] * 15
    k_cv = np.array([[798.2086344361006, 0, 329.11013894709305], [0, 758.4692698903584, 250.9142305996442], [0, 0, 1]])
    d_cv = np.array([-20.671083698013053, 107.16401859271483, 8.5740596651610889e-04, -8.8845725619432980e-04,
                     -3.5175490797355065, -20.393104183995263, 101.42649847496178, 26.088171080339499])
    free = lucent.calibrate_camera(objs, imgs, (640, 480), flags=lucent.CALIB_RATIONAL_MODEL)
    guided = lucent.calibrate_camera(objs, imgs, (640, 480), k_cv, d_cv, lucent.CALIB_RATIONAL_MODEL | lucent.CALIB_USE_INTRINSIC_GUESS)
    assert guided[0] < 0.3 and abs(guided[0] - free[0]) < 1e-4, (guided[0], free[0])


def test_p3p_generic_returns_every_pose_as_opencv():
    """``solve_pnp_generic`` with P3P and AP3P returns what ``cv2.solvePnPGeneric`` returns: every
    pose of the first three points with the fourth in front (the same count), best first, the
    reprojection errors equal to 1e-6 px."""
    cv2 = pytest.importorskip("cv2")
    kc = np.array([[800.0, 0, 320.0], [0, 800.0, 240.0], [0, 0, 1]])
    rng = np.random.default_rng(3)
    for _ in range(6):
        obj = rng.uniform(-60, 60, (4, 3))
        px = lucent.project_points(obj, rng.normal(0, 0.4, 3), np.array([0, 0, 600.0]), kc, None) + rng.normal(0, 0.3, (4, 2))
        for flag in (cv2.SOLVEPNP_P3P, cv2.SOLVEPNP_AP3P):
            n, _, _, err = cv2.solvePnPGeneric(obj, px, kc, None, flags=flag)
            nl, _, _, el = lucent.solve_pnp_generic(obj, px, kc, None, flags=flag)
            assert nl == n and np.allclose(np.sort(el.ravel()), np.sort(err.ravel()), atol=1e-6), (flag, el.ravel(), err.ravel())
