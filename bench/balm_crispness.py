#!/usr/bin/env python3
"""Independent check of BALM's (scans, odometry) consistency: how crisp is the map of the scans
placed with the odometry poses when every scan is first rotated by a small lidar-frame rotation
delta? If the odometry were exact, delta = 0 would be the crispest. Metric: point-to-plane
distance of sample points to a plane fitted to their nearest neighbours from OTHER scans, with the
associations frozen at delta = 0 (bench/results/honest.md, "The BALM yaw").

Usage (numpy and scipy: Debian's python3-numpy python3-scipy; the scans extracted by
bench/real_scans.py into WORK/balm):
  /usr/bin/python3 bench/balm_crispness.py POINTS_PER_SCAN AXIS ANGLES_DEG [BALM_DIR]
  /usr/bin/python3 bench/balm_crispness.py 4000 0,0,1 -0.3,-0.15,0,0.15,0.3 bench/real_data/balm/datas/benchmark_realworld
"""
import sys, math, numpy as np
from scipy.spatial import cKDTree
sys.path.insert(0, __import__('os').path.dirname(__import__('os').path.abspath(__file__)))
from real_scans import balm_poses
src = sys.argv[4] if len(sys.argv) > 4 else 'bench/real_data/balm/datas/benchmark_realworld'
P = balm_poses(src)
rng = np.random.default_rng(1)
scans = []
for k in range(len(P)):
    raw = open(f'{src}/full{k}.pcd', 'rb').read()
    hdr_end = raw.index(b'DATA binary\n') + len(b'DATA binary\n')
    a = np.frombuffer(raw[hdr_end:], dtype=np.float32).reshape(-1, 8)[:, :3].astype(np.float64)
    r = np.linalg.norm(a, axis=1)
    a = a[(r > 1.0) & (r < 40.0)]
    a = a[rng.choice(len(a), size=min(len(a), int(sys.argv[1]) if len(sys.argv) > 1 else 3000), replace=False)]
    scans.append(a)
T = [np.array(p[1]) for p in P]
sid = np.concatenate([np.full(len(s), k) for k, s in enumerate(scans)])
def rotvec(v):
    th = np.linalg.norm(v)
    if th < 1e-15: return np.eye(3)
    k = v / th; K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(th) * K + (1 - math.cos(th)) * K @ K
def place(delta_deg):
    D = rotvec(np.radians(delta_deg))
    return np.concatenate([(T[k][:3, :3] @ (D @ s.T)).T + T[k][:3, 3] for k, s in enumerate(scans)])
# Associations frozen at delta = 0 (the same points and neighbours for every delta).
W0 = place(np.zeros(3))
tree = cKDTree(W0)
q = np.arange(0, len(W0), 3)
d, idx = tree.query(W0[q], k=40, distance_upper_bound=1.0)
assoc = []
for j, i in enumerate(q):
    nb = idx[j][idx[j] < len(W0)]
    nb = nb[sid[nb] != sid[i]]
    if len(nb) < 10: continue
    X = W0[nb]; c = X.mean(0); w, v = np.linalg.eigh((X - c).T @ (X - c))
    if w[0] > 0.05 * w[1]: continue
    if abs((W0[i] - c) @ v[:, 0]) > 0.1: continue
    assoc.append((i, nb))
print(len(assoc), "frozen associations", flush=True)
def metric(delta_deg):
    W = place(delta_deg)
    res = []
    for i, nb in assoc:
        X = W[nb]; c = X.mean(0); w, v = np.linalg.eigh((X - c).T @ (X - c))
        res.append(abs((W[i] - c) @ v[:, 0]))
    res = np.array(res)
    return np.sqrt(np.mean(np.minimum(res, 0.1) ** 2)), np.median(res), len(res)
axis = np.array([float(x) for x in (sys.argv[2] if len(sys.argv) > 2 else "0,0,1").split(",")])
for a in [float(x) for x in (sys.argv[3] if len(sys.argv) > 3 else "-0.3,-0.15,0,0.15,0.3,0.45").split(",")]:
    rms, med, n = metric(a * axis)
    print(f"delta {a:+.3f} deg about lidar axis {axis}: clipped RMS {1e3*rms:.3f} mm, median {1e3*med:.3f} mm, {n} points", flush=True)
