"""lucent.project_points / undistort_points against OpenCV's projectPoints.

The reference pixels are those OpenCV 5.1.0's cv2.projectPoints gives for a camera using all 14
distortion coefficients (benches-peers/opencv_project_points.py prints them); where cv2 is
installed the same comparison also runs live, on random cameras.
"""
import numpy as np
import pytest

import lucent

K = np.array([[812.5, 0.0, 331.25], [0.0, 805.0, 236.75], [0.0, 0.0, 1.0]])
D = [-0.21, 0.08, 0.0012, -0.0009, -0.02, 0.05, 0.01, -0.004, 0.0021, -0.0013, -0.0017, 0.0008, 0.031, -0.022]
RVEC, TVEC = [0.11, -0.23, 0.07], [0.05, -0.12, 1.9]
POINTS = np.array([[x, y, z] for x in (-0.45, 0.0, 0.38) for y in (-0.3, 0.1, 0.33) for z in (-0.2, 0.25)])
OPENCV_PIXELS = np.array([
    [173.666089138722, 30.321154942307], [168.099042053963, 54.075816954271], [157.601974706262, 225.333755649041],
    [155.546881104685, 207.463468393134], [150.973838531664, 335.834819047914], [149.962224446141, 294.946320278981],
    [387.862691526272, 51.492591913419], [338.339679459480, 69.488471125257], [372.234127832613, 237.950223199829],
    [325.949499260973, 218.043482187036], [362.911098398425, 343.527145997291], [318.972516918266, 302.698775162763],
    [549.167038915666, 72.148951711113], [471.676490195479, 84.301042310782], [534.277657507966, 247.465071483463],
    [459.606004622591, 226.612583771074], [523.586826912924, 346.808893731239], [451.807663695927, 307.708163661156],
])


def rodrigues(r):
    r = np.asarray(r, float)
    th = np.linalg.norm(r)
    k = r / th
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * kx + (1 - np.cos(th)) * kx @ kx


def test_project_points_matches_opencv_reference():
    got = lucent.project_points(POINTS, RVEC, TVEC, K, D)
    assert got.shape == (18, 2)
    assert np.abs(got - OPENCV_PIXELS).max() < 2e-9


def test_undistort_points_inverts_the_projection():
    cam = POINTS @ rodrigues(RVEC).T + np.array(TVEC)
    want = cam[:, :2] / cam[:, 2:]
    got = lucent.undistort_points(OPENCV_PIXELS, K, D)
    assert np.abs(got - want).max() < 1e-11


def test_undistort_points_has_no_ray_beyond_the_lens_fold():
    """With k1 = −2 the radial map r(1 − 2r²) reaches at most 0.272 (at r = 0.408); a pixel at
    distorted radius 0.5 has no ray (NaN), where Newton's method would find the root on the folded
    branch (r = 0.885, which the lens maps mirrored through the centre); one at radius 0.25 has
    its ray on the monotone branch."""
    k = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    d = [-2.0, 0, 0, 0]
    out = lucent.undistort_points([[0.0, 0.0], [320 + 160.0, 240 + 120.0]], k, d)
    assert np.isnan(out[0]).all()
    x, y = out[1]
    r = np.hypot(x, y)
    assert r < 1 / np.sqrt(6) and abs(r * (1 - 2 * r * r) - 0.25) < 1e-12


def test_fewer_coefficients_and_bad_input():
    # Five coefficients: the classic model; no coefficients: the pinhole.
    pin = lucent.project_points(POINTS, RVEC, TVEC, K)
    cam = POINTS @ rodrigues(RVEC).T + np.array(TVEC)
    assert np.abs(pin - (cam[:, :2] / cam[:, 2:] * [K[0, 0], K[1, 1]] + [K[0, 2], K[1, 2]])).max() < 1e-9
    with pytest.raises(ValueError, match="coefficients"):
        lucent.project_points(POINTS, RVEC, TVEC, K, [0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="skew"):
        lucent.project_points(POINTS, RVEC, TVEC, [[800, 1, 320], [0, 800, 240], [0, 0, 1]], D)
    behind = lucent.project_points([[0.0, 0.0, -5.0]], [0, 0, 0], [0, 0, 0], K, D)
    assert np.isnan(behind).all()


def test_against_live_opencv():
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(3)
    for _ in range(20):
        k = np.array([[rng.uniform(400, 900), 0, rng.uniform(300, 340)], [0, rng.uniform(400, 900), rng.uniform(220, 260)], [0, 0, 1.0]])
        d = np.concatenate([rng.uniform(-1, 1, 8) * [0.3, 0.1, 0.003, 0.003, 0.05, 0.2, 0.05, 0.02], rng.uniform(-1, 1, 6) * [0.004, 0.002, 0.004, 0.002, 0.08, 0.08]])
        r, t = rng.uniform(-0.5, 0.5, 3), rng.uniform(-0.3, 0.3, 3) + [0, 0, 3]
        p = rng.uniform(-0.8, 0.8, (50, 3))
        want, _ = cv2.projectPoints(p, r, t, k, d)
        assert np.abs(lucent.project_points(p, r, t, k, d) - want.reshape(-1, 2)).max() < 1e-8
