"""ArUco markers and ChArUco boards (lucent.detect_markers, lucent.CharucoBoard) against the
boards' own geometry and, where OpenCV is installed, against cv2.aruco on the same images."""
import numpy as np
import pytest

import lucent


def _tilted(img, h):
    """`img` (white paper) seen through the homography h (pixels → pixels), bilinear."""
    H, W = img.shape
    inv = np.linalg.inv(h)
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float64)
    p = inv @ np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)])
    u, v = p[0] / p[2], p[1] / p[2]
    u0, v0 = np.floor(u).astype(int), np.floor(v).astype(int)
    fu, fv = u - u0, v - v0
    pad = np.pad(img.astype(np.float64), 1, constant_values=255.0)
    def at(a, b):
        return pad[np.clip(b + 1, 0, H + 1), np.clip(a + 1, 0, W + 1)]
    out = (at(u0, v0) * (1 - fu) * (1 - fv) + at(u0 + 1, v0) * fu * (1 - fv) + at(u0, v0 + 1) * (1 - fu) * fv + at(u0 + 1, v0 + 1) * fu * fv)
    return np.clip(np.round(out), 0, 255).astype(np.uint8).reshape(H, W)


def test_board_layout_and_an_upright_image():
    b = lucent.CharucoBoard((5, 7), 0.04, 0.02, "DICT_4X4_50")
    # OpenCV's layout (cv2.aruco.CharucoBoard((5, 7), 0.04, 0.02, DICT_4X4_50).getObjPoints()[0]):
    # marker 0 in square (1, 0), corners clockwise from its top left, y down.
    np.testing.assert_allclose(b.getObjPoints()[0][:, :2], [[0.05, 0.01], [0.07, 0.01], [0.07, 0.03], [0.05, 0.03]], atol=1e-12)
    np.testing.assert_allclose(b.getChessboardCorners()[:2], [[0.04, 0.04, 0], [0.08, 0.04, 0]], atol=1e-12)
    assert len(b.getIds()) == 17 and len(b.getChessboardCorners()) == 24
    img = b.generateImage((500, 700))
    assert img.shape == (700, 500) and img[20, 20] == 0 and img[20, 120] == 255
    corners, ids, markers, mids = b.detect_board(img)
    assert len(mids) == 17 and sorted(mids.ravel()) == list(range(17))
    # 100 px squares from the image's corner: corner k = (i, j) at (100 (i + 1) − 0.5, 100 (j + 1) − 0.5).
    truth = (b.getChessboardCorners()[ids.ravel(), :2] / 0.04) * 100 - 0.5
    assert len(ids) == 24
    np.testing.assert_allclose(corners.reshape(-1, 2), truth, atol=0.05)


def test_tilted_and_half_covered_board():
    b = lucent.CharucoBoard((7, 5), 30.0, 18.0, "DICT_5X5_100", legacy=False)
    flat = b.generateImage((700, 500), 0)
    h = np.array([[0.8, 0.12, 60.0], [-0.1, 0.75, 80.0], [0.0002, -0.0001, 1.0]])
    img = _tilted(flat, h)
    corners, ids, _, mids = b.detect_board(img)
    assert len(ids) == 24
    scale = 100.0  # generateImage: 700 / 7 px per square
    truth = b.getChessboardCorners()[ids.ravel(), :2] / 30.0 * scale - 0.5
    t = np.column_stack([truth, np.ones(len(truth))]) @ h.T
    np.testing.assert_allclose(corners.reshape(-1, 2), t[:, :2] / t[:, 2:], atol=0.15)
    img[:, :300] = 128
    c2, i2, _, m2 = b.detect_board(img)
    assert 0 < len(i2) < 24 and set(i2.ravel()) <= set(ids.ravel())
    assert (c2[:, 0, 0] > 300).all()
    corners_m, ids_m, rejected = lucent.detect_markers(img, "DICT_5X5_100")
    assert rejected == () and sorted(ids_m.ravel()) == sorted(m2.ravel())
    with pytest.raises(ValueError, match="dictionary"):
        lucent.detect_markers(img, "DICT_9X9_1")


def test_against_opencv():
    cv2 = pytest.importorskip("cv2")
    A = cv2.aruco
    d = A.getPredefinedDictionary(A.DICT_6X6_250)
    cvb = A.CharucoBoard((8, 6), 0.03, 0.022, d)
    lb = lucent.CharucoBoard((8, 6), 0.03, 0.022, A.DICT_6X6_250)
    np.testing.assert_allclose(lb.getChessboardCorners(), cvb.getChessboardCorners(), atol=1e-7)
    for a, o in zip(lb.getObjPoints(), cvb.getObjPoints()):
        np.testing.assert_allclose(a, o, atol=1e-7)
    # OpenCV's image of the board, tilted: the same markers and corners from both detectors.
    img = _tilted(cvb.generateImage((800, 600), marginSize=20), np.array([[0.85, 0.1, 50.0], [-0.08, 0.8, 40.0], [0.00015, -0.0001, 1.0]]))
    cc, ci, mc, mi = A.CharucoDetector(cvb).detectBoard(img)
    lc, li, lmc, lmi = lb.detect_board(img)
    assert sorted(lmi.ravel()) == sorted(mi.ravel())
    cv_m = {int(i): c.reshape(4, 2) for c, i in zip(mc, mi.ravel())}
    for c, i in zip(lmc, lmi.ravel()):
        assert np.abs(c.reshape(4, 2) - cv_m[int(i)]).max() <= 1.0
    assert set(li.ravel()) == set(ci.ravel())
    cv_c = {int(i): p for i, p in zip(ci.ravel(), cc.reshape(-1, 2))}
    dist = [np.hypot(*(p - cv_c[int(i)])) for i, p in zip(li.ravel(), lc.reshape(-1, 2))]
    # Two estimates of the same corners (each finder's sub-pixel refinement): within 0.1 px at
    # the median, 0.5 px everywhere.
    assert np.median(dist) < 0.1 and max(dist) < 0.5, dist
    # lucent's image, read by OpenCV.
    limg = lb.generateImage((800, 600), 20)
    cc2, ci2, _, mi2 = A.CharucoDetector(cvb).detectBoard(limg)
    assert len(mi2) == len(lb.getIds()) and len(ci2) == len(lb.getChessboardCorners())


def _pose_homography(k, spin, tilt, dist, centre):
    """Board units → pixels for a board turned by `spin` (deg) about its normal, tilted by `tilt`
    (rad about x, y) and `dist` away, its point `centre` on the optical axis."""
    def rot(axis, a):
        c, s = np.cos(a), np.sin(a)
        i, j = [(1, 2), (0, 2), (0, 1)][axis]
        r = np.eye(3)
        r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
        return r
    r = rot(0, tilt[0]) @ rot(1, tilt[1]) @ rot(2, np.radians(spin))
    t = np.array([0.0, 0.0, dist]) - r @ np.array([centre[0], centre[1], 0.0])
    return k @ np.column_stack([r[:, 0], r[:, 1], t])


def test_calibrate_camera_from_partial_charuco_views():
    # Four views of a 9 × 6 board through a known distortion-free camera, two of them partly
    # covered: lucent.calibrate_camera takes each view's own corners (the union of the board's
    # points, NaN where a view lacks one) and recovers the camera.
    b = lucent.CharucoBoard((9, 6), 20.0, 12.0, "DICT_4X4_250")
    flat = b.generateImage((900, 600))  # 100 px per square: board units → image pixels
    s = np.array([[5.0, 0, -0.5], [0, 5.0, -0.5], [0, 0, 1]])
    k = np.array([[800.0, 0, 330.0], [0, 795.0, 245.0], [0, 0, 1]])
    objs, imgs, errors = [], [], []
    for n, (spin, tilt) in enumerate([(5, (0.4, 0.0)), (95, (0.0, 0.45)), (185, (-0.4, 0.25)), (275, (0.3, -0.4)), (20, (-0.2, -0.3))]):
        board_to_px = _pose_homography(k, spin, tilt, 320.0, (90.0, 60.0))
        img = _tilted(flat, board_to_px @ np.linalg.inv(s))[:480, :640].copy()
        if n in (1, 3):
            img[:, :260] = 128
        c, ids, _, _ = b.detect_board(img)
        assert ids is not None and len(ids) >= 6
        if n in (1, 3):
            assert len(ids) < 40
        o = b.getChessboardCorners()[ids.ravel()]
        t = np.column_stack([o[:, :2], np.ones(len(o))]) @ board_to_px.T
        errors.extend(np.hypot(*(c.reshape(-1, 2) - t[:, :2] / t[:, 2:]).T))
        objs.append(o)
        imgs.append(c)
    # The corners against the truth. The photographs are bilinear resamplings of a board drawn
    # at twice their scale, which alias its edges: on them OpenCV 5.1.0's CharucoDetector
    # gives a median of 0.078 px and a maximum of 0.68 px (lucent 0.039 and 0.29).
    assert np.median(errors) < 0.06 and max(errors) < 0.35, (np.median(errors), max(errors))
    flags = lucent.CALIB_ZERO_TANGENT_DIST | lucent.CALIB_FIX_K3
    rms, km, dist, rvecs, tvecs = lucent.calibrate_camera(objs, imgs, (640, 480), None, None, flags=flags)
    assert rms < 0.15
    assert abs(km[0, 0] / 800 - 1) < 3e-3 and abs(km[1, 1] / 795 - 1) < 3e-3, km
    # The principal point within 2 px (OpenCV's corners of these photographs give 1.8 px off).
    assert abs(km[0, 2] - 330) < 2 and abs(km[1, 2] - 245) < 2, km
    assert len(rvecs) == 5
    try:
        import cv2
    except ImportError:
        return
    r2, k2, d2, _, _ = cv2.calibrateCamera([o.astype(np.float32) for o in objs], imgs, (640, 480), None, None, flags=flags)
    assert abs(rms - r2) < 1e-3 and np.allclose(km, k2, rtol=1e-3), (rms, r2, km, k2)
