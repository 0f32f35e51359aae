"""lucent.fisheye (cv2.fisheye's projectPoints, distortPoints, undistortPoints,
initUndistortRectifyMap, calibrate, stereoCalibrate, stereoRectify and solvePnP) on data with a known truth: the equidistant projection's
closed form, round trips through the inverse, and calibration from the projections of a known
lens; where cv2 is installed, also against OpenCV on the same points.
"""
import numpy as np
import pytest

import lucent
from lucent import fisheye as fe

K = np.array([[352.4, 0.0, 641.3], [0.0, 351.1, 478.9], [0.0, 0.0, 1.0]])
D = np.array([0.052, -0.021, 0.0043, -0.0004])
SIZE = (1280, 960)
# A 9 × 6 board of 60-unit squares; each view puts the board's centre at `centre`, turned by `r`.
OBJ = np.zeros((54, 3))
OBJ[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2) * 60.0
VIEWS = [([0.05, -0.03, 0.02], [0, 0, 300]), ([0.5, 0.1, -0.05], [-150, -100, 260]), ([-0.5, 0.2, 0.1], [150, 120, 250]),
         ([0.1, 0.6, 0.05], [-250, 50, 230]), ([0.2, -0.5, -0.1], [220, -40, 270]), ([-0.3, -0.4, 0.3], [120, -180, 260]),
         ([0.4, 0.4, -0.2], [-200, 180, 250]), ([-0.2, 0.1, 0.9], [0, 0, 200])]


def rodrigues(v):
    v = np.asarray(v, dtype=float)
    th = np.linalg.norm(v)
    a = v / th
    x = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(th) * x + (1 - np.cos(th)) * x @ x


def poses():
    centre = np.array([240.0, 150.0, 0.0])
    return [(np.array(r, dtype=float), np.array(c, dtype=float) - rodrigues(r) @ centre) for r, c in VIEWS]


def views(k=K, d=D, noise=0.0, seed=3):
    rng = np.random.default_rng(seed)
    return [fe.project_points(OBJ, r, t, k, d) + rng.normal(0.0, noise, (len(OBJ), 2)) for r, t in poses()]


def test_equidistant_projection_puts_the_angle_at_the_radius():
    # k = 0: the image radius is fx·θ, θ the angle off the axis, out to 85°.
    k = np.array([[300.0, 0.0, 10.0], [0.0, 300.0, 20.0], [0.0, 0.0, 1.0]])
    th = np.radians([1.0, 30.0, 60.0, 85.0])
    phi = np.array([0.2, 1.9, 3.5, 5.0])
    pts = np.c_[np.sin(th) * np.cos(phi), np.sin(th) * np.sin(phi), np.cos(th)]
    p = fe.project_points(pts, [0, 0, 0], [0, 0, 0], k, np.zeros(4))
    want = np.c_[10 + 300 * th * np.cos(phi), 20 + 300 * th * np.sin(phi)]
    assert np.abs(p - want).max() < 1e-10
    # At or behind the camera's plane there is no image.
    assert np.isnan(fe.project_points([[1.0, 0.0, 0.0], [0.0, 1.0, -2.0]], [0, 0, 0], [0, 0, 0], k, np.zeros(4))).all()


def test_undistort_points_inverts_the_projection_with_skew():
    k = K.copy()
    k[0, 1] = 0.004 * K[0, 0]
    rng = np.random.default_rng(1)
    th, phi = 1.45 * rng.uniform(size=500), 2 * np.pi * rng.uniform(size=500)
    n = np.c_[np.tan(th) * np.cos(phi), np.tan(th) * np.sin(phi)]
    px = fe.distort_points(n, k, D)
    back = fe.undistort_points(px, k, D)
    assert np.abs(back - n).max() < 1e-12 * (1 + np.abs(n).max())
    # Beyond the range where θ_d increases (1 + 3 k1 θ² = 0 at k1 = −0.5) there is no ray.
    fold = np.array([-0.5, 0.0, 0.0, 0.0])
    tm = np.sqrt(1 / 1.5)
    td = tm * (1 - 0.5 * tm ** 2)
    q = np.array([[641.3 + 352.4 * 0.99 * td, 478.9], [641.3 + 352.4 * 1.01 * td, 478.9]])
    u = fe.undistort_points(q, K, fold)
    assert np.isfinite(u[0]).all() and np.isnan(u[1]).all()


def test_calibrate_recovers_a_known_fisheye():
    rms, k, d, rvecs, tvecs = fe.calibrate([OBJ] * len(VIEWS), views(), SIZE, flags=fe.CALIB_FIX_SKEW)
    assert rms < 1e-9
    assert np.abs(k - K).max() < 1e-8 * K[0, 0] and d.shape == (4, 1) and np.abs(d.ravel() - D).max() < 1e-9
    for (r, t), rv, tv in zip(poses(), rvecs, tvecs):
        assert np.abs(rv.ravel() - r).max() < 1e-9 and np.abs(tv.ravel() - t).max() < 1e-7
    # CALIB_FIX_INTRINSIC fits the poses alone: K and D stay exactly where they were given.
    k_off = K * np.array([[1.01], [1.0], [1.0]])
    rms, k, d, _, _ = fe.calibrate([OBJ] * len(VIEWS), views(), SIZE, k_off, D, flags=fe.CALIB_FIX_INTRINSIC)
    assert np.array_equal(k, k_off) and np.array_equal(d.ravel(), D) and rms > 0.5
    # OpenCV 4's numbering of the fisheye flags (2 = CALIB_RECOMPUTE_EXTRINSIC there) is refused.
    with pytest.raises(ValueError, match="OpenCV 4"):
        fe.calibrate([OBJ] * len(VIEWS), views(), SIZE, flags=2)


def test_new_camera_matrix_fits_the_edge_midpoints():
    # Square pixels. balance 1: every edge midpoint's ray lands inside the new pinhole image, one
    # on its border; balance 0: every one on or outside the border, one on it.
    k = np.array([[504.0, 0.0, 641.3], [0.0, 504.0, 478.9], [0.0, 0.0, 1.0]])
    w, h = SIZE
    edges = np.array([[w // 2, 0], [w, h // 2], [w // 2, h], [0, h // 2]], dtype=float)
    rays = fe.undistort_points(edges, k, D)
    for balance in (1.0, 0.0):
        p = fe.estimate_new_camera_matrix_for_undistort_rectify(k, D, SIZE, balance=balance)
        q = rays @ p[:2, :2].T + p[:2, 2]
        margin = np.minimum(np.minimum(q[:, 0], w - q[:, 0]), np.minimum(q[:, 1], h - q[:, 1]))
        if balance == 1.0:
            assert margin.min() > -1e-9 and abs(margin).min() < 1e-9, margin
        else:
            assert margin.max() < 1e-9 and abs(margin).min() < 1e-9, margin


def test_undistort_image_shows_each_ray_where_the_pinhole_puts_it():
    # A fisheye photograph of a smooth pattern g on the plane z = 1 (each pixel's value g at its
    # ray); seen through a pinhole Knew, pixel q must show g at Knew⁻¹ q (to bilinear
    # interpolation's error on this smooth g, a level or two of 255).
    k = np.array([[420.4, 0.0, 641.3], [0.0, 419.1, 478.9], [0.0, 0.0, 1.0]])
    g = lambda x, y: 127.5 + 100.0 * np.sin(3.0 * x) * np.cos(2.0 * y)
    v, u = np.mgrid[0:960, 0:1280]
    rays = fe.undistort_points(np.c_[u.ravel(), v.ravel()].astype(float), k, D)
    # (The image corners beyond the lens's range, which have no ray, stay black.)
    photo = np.round(np.nan_to_num(g(rays[:, 0], rays[:, 1]))).reshape(960, 1280).astype(np.uint8)
    knew = np.array([[300.0, 0.0, 320.0], [0.0, 300.0, 240.0], [0.0, 0.0, 1.0]])
    out = fe.undistort_image(photo, k, D, Knew=knew, new_size=(640, 480))
    qv, qu = np.mgrid[0:480, 0:640]
    want = g((qu - 320.0) / 300.0, (qv - 240.0) / 300.0)
    err = np.abs(out.astype(float) - want)
    assert out.shape == (480, 640) and err.max() < 2.0 and err.mean() < 0.5, (err.max(), err.mean())


def test_fisheye_agrees_with_live_opencv():
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(2)
    pts = rng.uniform(-1, 1, (200, 3)) * [400, 300, 50] + [0, 0, 200]
    r, t = np.array([0.1, -0.2, 0.05]), np.array([10.0, -5.0, 30.0])
    ours = fe.project_points(pts, r, t, K, D)
    theirs = cv2.fisheye.projectPoints(pts.reshape(-1, 1, 3), r, t, K, D)[0].reshape(-1, 2)
    assert np.abs(ours - theirs).max() < 1e-9
    n = rng.uniform(-1.5, 1.5, (100, 2))
    assert np.abs(fe.distort_points(n, K, D) - cv2.fisheye.distortPoints(n.reshape(-1, 1, 2), K, D).reshape(-1, 2)).max() < 1e-9
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-15)
    assert np.abs(fe.undistort_points(ours, K, D) - cv2.fisheye.undistortPoints(ours.reshape(-1, 1, 2), K, D, criteria=crit).reshape(-1, 2)).max() < 1e-12
    P = np.array([[300.0, 0, 320], [0, 300, 240], [0, 0, 1]])
    w = np.array([0.01, 0.02, -0.03])
    theirs = cv2.fisheye.undistortPoints(ours.reshape(-1, 1, 2), K, D, R=cv2.Rodrigues(w)[0], P=P, criteria=crit).reshape(-1, 2)
    assert np.abs(fe.undistort_points(ours, K, D, R=w, P=P) - theirs).max() < 1e-9
    mx, my = fe.init_undistort_rectify_map(K, D, None, P, (640, 480))
    cx, cy = cv2.fisheye.initUndistortRectifyMap(K, D, np.eye(3), P, (640, 480), cv2.CV_32FC1)
    assert np.abs(mx - cx).max() < 1e-3 and np.abs(my - cy).max() < 1e-3
    k = K @ np.diag([1.2, 1.2, 1.0])
    k[:2, 2] = K[:2, 2]
    for balance, R, size, fov in ((0.0, None, None, 1.0), (0.3, np.array([0.02, -0.01, 0.03]), (640, 480), 1.3), (1.0, None, (1281, 961), 0.8)):
        ours = fe.estimate_new_camera_matrix_for_undistort_rectify(k, D, SIZE, R=R, balance=balance, new_size=size, fov_scale=fov)
        theirs = cv2.fisheye.estimateNewCameraMatrixForUndistortRectify(k, D, SIZE, np.eye(3) if R is None else cv2.Rodrigues(R)[0],
                                                                         balance=balance, new_size=size or (0, 0), fov_scale=fov)
        assert np.abs(ours - theirs).max() < 1e-9
    # undistortImage: OpenCV weighs the four neighbours in 1/32 px; within a level on 99.9 % of
    # the pixels, a few levels on steep gradients.
    y, x = np.mgrid[0:960, 0:1280]
    img = (127 + 100 * np.sin(x / 37.0) * np.cos(y / 23.0)).astype(np.uint8)
    knew = fe.estimate_new_camera_matrix_for_undistort_rectify(k, D, SIZE, balance=0.5)
    d = np.abs(fe.undistort_image(img, k, D, Knew=knew).astype(int) - cv2.fisheye.undistortImage(img, k, D, Knew=knew).astype(int))
    assert d.max() <= 4 and (d > 1).mean() < 1e-3
    # Calibration on views with 0.3 px of noise: the same minimum, with the skew held and free
    # (OpenCV 5's flag values; float64 points and tight criteria for OpenCV).
    noisy = views(noise=0.3)
    for flags in (fe.CALIB_RECOMPUTE_EXTRINSIC | fe.CALIB_FIX_SKEW, fe.CALIB_RECOMPUTE_EXTRINSIC):
        ours = fe.calibrate([OBJ] * len(noisy), noisy, SIZE, flags=flags)
        theirs = cv2.fisheye.calibrate([OBJ.reshape(-1, 1, 3)] * len(noisy), [v.reshape(-1, 1, 2) for v in noisy], SIZE, None, None,
                                       flags=flags, criteria=(cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 300, 1e-16))
        assert abs(ours[0] - theirs[0]) < 1e-9 * theirs[0]
        assert np.abs(ours[1] - theirs[1]).max() < 1e-5 and np.abs(ours[2] - theirs[2]).max() < 1e-6
    # OpenCV's positional call, as its fisheye tutorials write it (output placeholders rvecs and
    # tvecs, then flags and criteria), runs unchanged and gives lucent's result.
    flags = fe.CALIB_RECOMPUTE_EXTRINSIC | fe.CALIB_FIX_SKEW
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-6)
    k0, d0 = np.zeros((3, 3)), np.zeros((4, 1))
    rv = [np.zeros((1, 1, 3), dtype=np.float64) for _ in noisy]
    tv = [np.zeros((1, 1, 3), dtype=np.float64) for _ in noisy]
    opencv_form = fe.calibrate([OBJ.reshape(-1, 1, 3)] * len(noisy), [v.reshape(-1, 1, 2) for v in noisy], SIZE, k0, d0, rv, tv, flags, crit)
    ours = fe.calibrate([OBJ] * len(noisy), noisy, SIZE, flags=flags)
    assert opencv_form[0] == ours[0] and np.array_equal(opencv_form[1], ours[1]) and np.array_equal(opencv_form[2], ours[2])
    assert fe.calibrate([OBJ] * len(noisy), noisy, SIZE, None, None, flags)[0] == ours[0]
    with pytest.raises(TypeError, match="flags"):
        fe.calibrate([OBJ] * len(noisy), noisy, SIZE, None, None, flags, None, flags=flags)


K2 = np.array([[410.0, 0.0, 630.2], [0.0, 409.1, 489.5], [0.0, 0.0, 1.0]])
D2 = np.array([0.047, -0.018, 0.0031, -0.0002])
R12 = rodrigues([0.02, -0.12, 0.01])
T12 = np.array([-60.0, 2.0, 5.0])


def stereo_views(noise=0.0, seed=5):
    """The views of the first camera (K, D) and of the second (K2, D2 at X₂ = R12 X₁ + T12)."""
    rng = np.random.default_rng(seed)
    v1, v2 = [], []
    for r, t in poses():
        r2 = R12 @ rodrigues(r)
        th = np.arccos(np.clip((np.trace(r2) - 1) / 2, -1, 1))
        w = np.array([r2[2, 1] - r2[1, 2], r2[0, 2] - r2[2, 0], r2[1, 0] - r2[0, 1]]) * th / (2 * np.sin(th))
        v1.append(fe.project_points(OBJ, r, t, K, D) + rng.normal(0.0, noise, (len(OBJ), 2)))
        v2.append(fe.project_points(OBJ, w, R12 @ t + T12, K2, D2) + rng.normal(0.0, noise, (len(OBJ), 2)))
    return v1, v2


def test_stereo_calibrate_recovers_a_known_fisheye_pair():
    v1, v2 = stereo_views()
    n = len(v1)
    rms, k1, d1, k2, d2, r, t, rvecs, tvecs = fe.stereo_calibrate([OBJ] * n, v1, v2, None, None, None, None, SIZE,
                                                                  flags=fe.CALIB_FIX_SKEW)
    assert rms < 1e-9 and np.abs(k1 - K).max() < 1e-7 and np.abs(k2 - K2).max() < 1e-7
    assert np.abs(d1.ravel() - D).max() < 1e-9 and np.abs(d2.ravel() - D2).max() < 1e-9
    assert np.abs(r - R12).max() < 1e-10 and np.abs(t.ravel() - T12).max() < 1e-8
    # The default, as OpenCV's: CALIB_FIX_INTRINSIC, the lenses given exactly and kept.
    out = fe.stereo_calibrate([OBJ] * n, v1, v2, K, D, K2, D2, SIZE)
    assert np.array_equal(out[1], K) and np.array_equal(out[3], K2) and np.abs(out[6].ravel() - T12).max() < 1e-8
    with pytest.raises(ValueError, match="K1"):
        fe.stereo_calibrate([OBJ] * n, v1, v2, None, None, K2, D2, SIZE)


def test_fisheye_stereo_agrees_with_live_opencv():
    cv2 = pytest.importorskip("cv2")
    v1, v2 = stereo_views(noise=0.3)
    n = len(v1)
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 300, 1e-16)
    for flags in (fe.CALIB_FIX_SKEW | fe.CALIB_RECOMPUTE_EXTRINSIC, fe.CALIB_FIX_INTRINSIC):
        ours = fe.stereo_calibrate([OBJ] * n, v1, v2, K, D, K2, D2, SIZE, flags=flags)
        theirs = cv2.fisheye.stereoCalibrate([OBJ.reshape(-1, 1, 3)] * n, [v.reshape(-1, 1, 2) for v in v1], [v.reshape(-1, 1, 2) for v in v2],
                                             K.copy(), D.copy(), K2.copy(), D2.copy(), SIZE, flags=flags, criteria=crit)
        assert abs(ours[0] - theirs[0]) < 1e-9 * theirs[0]
        assert np.abs(ours[1] - theirs[1]).max() < 1e-5 and np.abs(ours[3] - theirs[3]).max() < 1e-5
        assert np.abs(ours[2] - theirs[2]).max() < 1e-6 and np.abs(ours[4] - theirs[4]).max() < 1e-6
        assert np.abs(ours[5] - theirs[5]).max() < 1e-9 and np.abs(ours[6] - theirs[6]).max() < 1e-6


# Longer lenses for rectification: the edge midpoints of K and K2 (f ≈ 350 px over 1280 × 960)
# lie more than 90° off the axis, where no pinhole image reaches (lucent refuses them).
KR = np.array([[504.0, 0.0, 641.3], [0.0, 501.0, 478.9], [0.0, 0.0, 1.0]])
KR2 = np.array([[515.0, 0.0, 630.2], [0.0, 514.0, 489.5], [0.0, 0.0, 1.0]])


def test_stereo_rectify_puts_matching_points_on_one_row():
    # The rectified pixels of a point, mapped through each camera's own fisheye pixel, share a
    # row; Q takes (u, v, disparity) back to the point in the first rectified frame.
    K, K2 = KR, KR2
    for flags, T in ((fe.CALIB_ZERO_DISPARITY, T12), (0, np.array([95.0, -8.0, 4.0]))):
        r1, r2, p1, p2, q = fe.stereo_rectify(K, D, K2, D2, SIZE, R12, T, flags, balance=0.5)
        x = np.array([[60.0, -40.0, 400.0], [-150.0, 90.0, 700.0], [10.0, 200.0, 350.0]])
        px1 = fe.project_points(x, np.zeros(3), np.zeros(3), K, D)
        px2 = fe.project_points(x @ R12.T + T, np.zeros(3), np.zeros(3), K2, D2)
        a = fe.undistort_points(px1, K, D, R=r1, P=p1)
        b = fe.undistort_points(px2, K2, D2, R=r2, P=p2)
        assert np.abs(a[:, 1] - b[:, 1]).max() < 1e-8, (a, b)
        h = np.c_[a, a[:, 0] - b[:, 0], np.ones(3)] @ q.T
        assert np.abs(h[:, :3] / h[:, 3:] - x @ r1.T).max() < 1e-8 * 700
        assert (p1[0, 2] == p2[0, 2]) == bool(flags)


def test_solve_pnp_recovers_a_known_pose():
    r, t = poses()[3]
    px = fe.project_points(OBJ, r, t, K, D)
    ok, rv, tv = fe.solve_pnp(OBJ, px, K, D)
    assert ok and np.abs(rv.ravel() - r).max() < 1e-9 and np.abs(tv.ravel() - t).max() < 1e-7
    ok, rv, tv = fe.solve_pnp(OBJ, px, K, D, rvec=r + 0.05, tvec=t + 10.0, useExtrinsicGuess=True)
    assert np.abs(rv.ravel() - r).max() < 1e-9
    far = px.copy()
    far[5] = (K[0, 2] + 100 * K[0, 0], K[1, 2])
    with pytest.raises(ValueError, match="image point 5"):
        fe.solve_pnp(OBJ, far, K, D)
    # An edge midpoint more than 90° off the axis has no place in a pinhole image.
    with pytest.raises(ValueError, match="edge midpoint"):
        fe.stereo_rectify(K, D, K2, D2, SIZE, R12, T12)


def test_stereo_rectify_and_solve_pnp_agree_with_live_opencv():
    cv2 = pytest.importorskip("cv2")
    K, K2 = KR, KR2
    for flags in (cv2.fisheye.CALIB_ZERO_DISPARITY, 0):
        for balance, new_size, fov_scale in ((0.0, (0, 0), 1.0), (0.4, (1600, 1200), 1.0), (1.0, (640, 480), 1.3)):
            ours = fe.stereo_rectify(K, D, K2, D2, SIZE, R12, T12, flags, newImageSize=new_size, balance=balance, fov_scale=fov_scale)
            theirs = cv2.fisheye.stereoRectify(K, D, K2, D2, SIZE, R12, T12, flags, newImageSize=new_size, balance=balance,
                                               fov_scale=fov_scale)
            for a, b in zip(ours, theirs):
                assert np.abs(a - b).max() < 1e-10 * max(1.0, np.abs(b).max()), (a, b)
    # solvePnP: OpenCV undistorts to the pixels of the pinhole K and solves there; with its
    # inverse run to convergence its pose is lucent's to the precision of its own stopping rule.
    rng = np.random.default_rng(11)
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-15)
    for r, t in poses():
        px = fe.project_points(OBJ, r, t, K, D) + rng.normal(0.0, 0.3, (len(OBJ), 2))
        _, rv, tv = fe.solve_pnp(OBJ, px, K, D)
        _, rq, tq = cv2.fisheye.solvePnP(OBJ.reshape(-1, 1, 3), px.reshape(-1, 1, 2), K, D, criteria=crit)
        assert np.abs(rv - rq).max() < 1e-6 and np.abs(tv - tq).max() < 1e-6 * np.linalg.norm(tq), (rv, rq, tv, tq)


def test_solve_pnp_ransac_leaves_out_gross_outliers_and_agrees_with_live_opencv():
    rng = np.random.default_rng(23)
    r, t = poses()[2]
    px = fe.project_points(OBJ, r, t, K, D)
    bad = np.arange(len(OBJ))[1::4]
    ang, mag = rng.uniform(0, 2 * np.pi, len(bad)), rng.uniform(30, 100, len(bad))
    px[bad] += np.c_[np.cos(ang), np.sin(ang)] * mag[:, None]
    good = np.setdiff1d(np.arange(len(OBJ)), bad)
    ok, rv, tv, inl = fe.solve_pnp_ransac(OBJ, px, K, D)
    assert ok and np.array_equal(inl.ravel(), good)
    assert np.abs(rv.ravel() - r).max() < 1e-9 and np.abs(tv.ravel() - t).max() < 1e-7
    cv2 = pytest.importorskip("cv2")
    noisy = px + rng.normal(0, 0.3, px.shape)
    _, rv, tv, inl = fe.solve_pnp_ransac(OBJ, noisy, K, D)
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-15)
    ok, rc, tc, inc = cv2.fisheye.solvePnPRansac(OBJ.reshape(-1, 1, 3), noisy.reshape(-1, 1, 2), K, D, criteria=crit)
    assert ok and np.array_equal(np.sort(inl.ravel()), np.sort(inc.ravel()))
    assert np.abs(rv - rc).max() < 1e-5 and np.abs(tv - tc).max() < 1e-5 * np.linalg.norm(tc)

