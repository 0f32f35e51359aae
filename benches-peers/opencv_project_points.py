"""OpenCV's projectPoints with the full 14-coefficient model (rational, thin prism, tilted sensor):
the reference values of the `camera` test suite's `opencv_14_coefficients_match_opencv_project_points`.

Usage: python3 benches-peers/opencv_project_points.py      (needs numpy and opencv-python)

Prints the camera and, for a fixed set of world points, the pixel positions cv2.projectPoints
gives, as Rust array literals.
"""
import numpy as np
import cv2

K = np.array([[812.5, 0.0, 331.25], [0.0, 805.0, 236.75], [0.0, 0.0, 1.0]])
# k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4, tau_x, tau_y
D = np.array([-0.21, 0.08, 0.0012, -0.0009, -0.02, 0.05, 0.01, -0.004, 0.0021, -0.0013, -0.0017, 0.0008, 0.031, -0.022])
rvec = np.array([0.11, -0.23, 0.07])
tvec = np.array([0.05, -0.12, 1.9])
pts = np.array([[x, y, z] for x in (-0.45, 0.0, 0.38) for y in (-0.3, 0.1, 0.33) for z in (-0.2, 0.25)])


def main():
    img, _ = cv2.projectPoints(pts, rvec, tvec, K, D)
    img = img.reshape(-1, 2)
    print(f'// OpenCV {cv2.__version__} cv2.projectPoints')
    print('const POINTS: [[f64; 3]; %d] = [' % len(pts) + ', '.join('[%r, %r, %r]' % tuple(float(v) for v in p) for p in pts) + '];')
    print('const PIXELS: [[f64; 2]; %d] = [' % len(pts) + ', '.join('[%.12f, %.12f]' % tuple(q) for q in img) + '];')
    # And the inverse: undistortPoints of those pixels gives the normalised camera directions.
    und = cv2.undistortPoints(img.reshape(-1, 1, 2), K, D, R=np.eye(3), P=np.eye(3), criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15)).reshape(-1, 2)
    R, _ = cv2.Rodrigues(rvec)
    cam = pts @ R.T + tvec
    err = np.abs(und - cam[:, :2] / cam[:, 2:]).max()
    print(f'// undistortPoints round trip: max |error| {err:.2e} (normalised)')


if __name__ == '__main__':
    main()
