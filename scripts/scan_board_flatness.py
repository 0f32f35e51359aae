"""RMS distance to the best-fit plane of the reconstructed points inside the chessboard corner hull.
Usage: python3 scripts/scan_board_flatness.py POINTS.ply CAPTURE/graycode_40.png CALIB.json
(needs opencv-python and numpy; the hull is found with cv2.findChessboardCorners, 9x7 inner corners,
in the white frame, and points are mapped to camera pixels by projecting them with the calibrated camera)."""
import numpy as np, cv2, json, sys
ply, white, calib = sys.argv[1], sys.argv[2], sys.argv[3]
c = json.load(open(calib))['camera']
K = np.array([[c['fx'],0,c['cx']],[0,c['fy'],c['cy']],[0,0,1]]); D = np.array(c['distortion'])
data = open(ply,'rb').read(); i = data.index(b'end_header\n')+11
n = int([l for l in data[:i].decode().splitlines() if l.startswith('element vertex')][0].split()[2])
dt = np.dtype([('p','<f4',3),('n','<f4',3),('c','u1',3)])
v = np.frombuffer(data[i:i+n*dt.itemsize], dt); P = v['p'].astype(np.float64)
img = cv2.imread(white, 0)
ok, corners = cv2.findChessboardCorners(img, (9,7))
assert ok
hull = cv2.convexHull(corners.reshape(-1,2).astype(np.float32))
uv,_ = cv2.projectPoints(P, np.zeros(3), np.zeros(3), K, D); uv = uv.reshape(-1,2)
inside = np.array([cv2.pointPolygonTest(hull, (float(a),float(b)), False) >= 0 for a,b in uv])
Q = P[inside]; m = Q.mean(0); _,s,vt = np.linalg.svd(Q-m, full_matrices=False); nrm = vt[2]
d = (Q-m)@nrm
print(json.dumps({'points_in_hull': int(inside.sum()), 'plane_rms': float(np.sqrt((d**2).mean())), 'median_abs': float(np.median(abs(d)))}))
