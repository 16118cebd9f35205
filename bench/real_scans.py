#!/usr/bin/env python3
"""Real LiDAR scans as a local accuracy and coverage benchmark (not part of CI).

The scans come from public repositories whose licences forbid committing them here: hku-mars/BALM
(GPL-2.0: datas/benchmark_realworld, 177 real 64-beam scans with LiDAR odometry poses) and
polben/PointcloudProcessing (KITTI raw, CC BY-NC-SA: sample_data/, 30 HDL-64E sweeps with OXTS and
KITTI's calib_imu_to_velo.txt). They are extracted at run time from git mirrors
(`git --git-dir=DIR archive COMMIT PATH | tar -x`) into an ignored folder (bench/real_data/).

BALM: the scans have no INS, so one is synthesised through a known extrinsic from the odometry,
T_world_ins(t) = T_world_lidar(t) * T_ins_lidar^-1, with INS-like noise (white position and
attitude noise, optionally a 3-axis position random walk), for several extrinsics and noise draws.
Each case is calibrated from a wrong --init (no fiducials, as a user with only a drive would) and
compared with the extrinsic it was made with: error per DOF against the stated stddev, and whether
a DOF reported determined lies within 3 stated sigma (the coverage study on real geometry).
KITTI: the real OXTS poses and KITTI's own calibration as the reference (itself a calibration, not
a truth); the 3 s drive mostly shows whether the tool says what it cannot determine.

Usage: python3 bench/real_scans.py [--insalign build/src/insalign] [--mirror /work/.mirror]
                                   [--mounts 3] [--seeds 2] [--walk-mm 0,5] [--set KEY=VALUE ...]
"""
import argparse
import json
import math
import os
import random
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
DOFS = ["tx", "ty", "tz", "roll", "pitch", "yaw"]


# --- 3x3 / 4x4 matrices as nested lists ---------------------------------------------------------
def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(len(b))) for j in range(len(b[0]))] for i in range(len(a))]


def transpose(a):
    return [list(r) for r in zip(*a)]


def rot_x(r):
    c, s = math.cos(r), math.sin(r)
    return [[1, 0, 0], [0, c, -s], [0, s, c]]


def rot_y(r):
    c, s = math.cos(r), math.sin(r)
    return [[c, 0, s], [0, 1, 0], [-s, 0, c]]


def rot_z(r):
    c, s = math.cos(r), math.sin(r)
    return [[c, -s, 0], [s, c, 0], [0, 0, 1]]


def rot_rpy_deg(roll, pitch, yaw):  # ZYX: R = Rz(yaw) Ry(pitch) Rx(roll)
    return matmul(rot_z(math.radians(yaw)), matmul(rot_y(math.radians(pitch)), rot_x(math.radians(roll))))


def rpy_deg(R):
    pitch = math.asin(max(-1.0, min(1.0, -R[2][0])))
    return [math.degrees(math.atan2(R[2][1], R[2][2])), math.degrees(pitch), math.degrees(math.atan2(R[1][0], R[0][0]))]


def rot_axis_angle(axis, angle):
    n = math.sqrt(sum(a * a for a in axis))
    x, y, z = (a / n for a in axis)
    c, s, C = math.cos(angle), math.sin(angle), 1 - math.cos(angle)
    return [[c + x * x * C, x * y * C - z * s, x * z * C + y * s], [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
            [z * x * C - y * s, z * y * C + x * s, c + z * z * C]]


def make_T(R, t):
    return [R[0] + [t[0]], R[1] + [t[1]], R[2] + [t[2]], [0, 0, 0, 1]]


def T_R(T):
    return [row[:3] for row in T[:3]]


def T_t(T):
    return [T[0][3], T[1][3], T[2][3]]


def inverse(T):
    Rt = transpose(T_R(T))
    t = T_t(T)
    return make_T(Rt, [-sum(Rt[i][k] * t[k] for k in range(3)) for i in range(3)])


def quat_xyzw(R):
    tr = R[0][0] + R[1][1] + R[2][2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        return [(R[2][1] - R[1][2]) / s, (R[0][2] - R[2][0]) / s, (R[1][0] - R[0][1]) / s, 0.25 * s]
    i = max(range(3), key=lambda k: R[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s = math.sqrt(1.0 + R[i][i] - R[j][j] - R[k][k]) * 2
    q = [0.0, 0.0, 0.0, 0.0]
    q[i] = 0.25 * s
    q[j] = (R[j][i] + R[i][j]) / s
    q[k] = (R[k][i] + R[i][k]) / s
    q[3] = (R[k][j] - R[j][k]) / s
    return q


def error_ins_frame(T_est, T_gt):
    """CONVENTIONS.md: dt = t_est - t_gt per axis (m); dR = R_est R_gt^T as ZYX roll, pitch, yaw (deg)."""
    dt = [a - b for a, b in zip(T_t(T_est), T_t(T_gt))]
    return dt + rpy_deg(matmul(T_R(T_est), transpose(T_R(T_gt))))


# --- extraction ---------------------------------------------------------------------------------
def extract(git_dir, paths, into):
    """git archive of `paths` at the mirror's HEAD, unpacked under `into` (once); returns the first."""
    if not os.path.isdir(git_dir):
        sys.exit(f"{git_dir}: no git mirror (fetch the repository first); CI does not need it")
    done = os.path.join(into, ".extracted")
    if not os.path.exists(done):
        os.makedirs(into, exist_ok=True)
        commit = subprocess.check_output(["git", "--git-dir", git_dir, "rev-parse", "HEAD"], text=True).strip()
        archive = subprocess.Popen(["git", "--git-dir", git_dir, "archive", commit] + paths, stdout=subprocess.PIPE)
        subprocess.check_call(["tar", "-x", "-C", into], stdin=archive.stdout)
        if archive.wait() != 0:
            raise RuntimeError(f"git archive {paths} from {git_dir} failed")
        open(done, "w").write(commit + "\n")
    return os.path.join(into, paths[0])


def balm_poses(folder):
    """alidarPose.csv: per scan 4 lines, row-major T_world_lidar with the time in place of its (3,3)."""
    rows = [[float(v) for v in line.strip().rstrip(",").split(",")] for line in open(os.path.join(folder, "alidarPose.csv"))
            if line.strip()]
    out = []
    for k in range(0, len(rows) - 3, 4):
        m = rows[k:k + 4]
        out.append((m[3][3], [m[0][:4], m[1][:4], m[2][:4], [0, 0, 0, 1]]))
    return out


# --- one BALM case --------------------------------------------------------------------------------
MOUNTS = [  # T_ins_lidar: rpy deg, t m (roof-like mounts turned about the vertical)
    ((0.5, -1.0, 90.0), (0.30, -0.20, 1.10)),
    ((-2.0, 1.5, -30.0), (-0.50, 0.40, 0.80)),
    ((1.0, 0.5, 180.0), (1.20, 0.10, 1.50)),
    ((0.0, 3.0, 45.0), (0.00, 0.60, 1.30)),
]


def write_balm_case(scans, src, case_dir, T_ins_lidar, rng, walk_mm, init_rot_deg, init_trans_m, noise_scale=1.0):
    lidar_dir = os.path.join(case_dir, "lidar")
    os.makedirs(lidar_dir, exist_ok=True)
    T_lidar_ins = inverse(T_ins_lidar)
    walk = [0.0, 0.0, 0.0]
    t_prev = None
    with open(os.path.join(case_dir, "poses.txt"), "w") as f:
        for k, (t, T_world_lidar) in enumerate(scans):
            name = f"{round(t * 1e6):016d}.pcd"
            dst = os.path.join(lidar_dir, name)
            if not os.path.exists(dst):
                os.link(os.path.join(src, f"full{k}.pcd"), dst) if os.stat(src).st_dev == os.stat(lidar_dir).st_dev \
                    else shutil.copy(os.path.join(src, f"full{k}.pcd"), dst)
            if t_prev is not None:  # 3-axis position random walk, walk_mm per sqrt(s)
                walk = [w + rng.gauss(0.0, 1e-3 * walk_mm * math.sqrt(t - t_prev)) for w in walk]
            t_prev = t
            T_world_ins = matmul(T_world_lidar, T_lidar_ins)
            # White noise of an RTK-fixed INS: 5 mm per axis, 0.005 deg per axis.
            dR = rot_rpy_deg(*(rng.gauss(0.0, 0.005 * noise_scale) for _ in range(3)))
            R = matmul(dR, T_R(T_world_ins))
            p = [a + w + rng.gauss(0.0, 0.005 * noise_scale) for a, w in zip(T_t(T_world_ins), walk)]
            q = quat_xyzw(R)
            f.write(f"{t:.6f} {p[0]:.6f} {p[1]:.6f} {p[2]:.6f} {q[0]:.9f} {q[1]:.9f} {q[2]:.9f} {q[3]:.9f}\n")
    axis = [rng.gauss(0, 1) for _ in range(3)]
    direction = [rng.gauss(0, 1) for _ in range(3)]
    n = math.sqrt(sum(d * d for d in direction))
    R_init = matmul(rot_axis_angle(axis, math.radians(init_rot_deg)), T_R(T_ins_lidar))
    t_init = [a + init_trans_m * d / n for a, d in zip(T_t(T_ins_lidar), direction)]
    T_init = make_T(R_init, t_init)
    with open(os.path.join(case_dir, "init.json"), "w") as f:
        json.dump({"gnss-to-lidar-extrinsic": {"param_type": "extrinsic", "sensor_name": "gnss",
                   "target_sensor_name": "lidar", "device_type": "relational",
                   "param": {"sensor_calib": {"rows": 4, "cols": 4, "type": 6, "continuous": True,
                                              "data": inverse(T_init)}}}}, f, indent=1)
    return T_init


def run_calibrate(insalign, case_dir, extra, sets):
    out = os.path.join(case_dir, "out")
    shutil.rmtree(out, ignore_errors=True)
    cmd = [insalign, "calibrate", "--lidar-dir", os.path.join(case_dir, "lidar"), "--poses",
           os.path.join(case_dir, "poses.txt"), "--init", os.path.join(case_dir, "init.json"), "--out", out, "-q",
           "--no-report"] + extra
    for s in sets:
        cmd += ["--set", s]
    t0 = time.time()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.time() - t0
    result = None
    if proc.returncode == 0:
        result = json.load(open(os.path.join(out, "extrinsic.json")))
    return proc.returncode, result, wall, proc.stderr.strip().splitlines()[-1:] if proc.returncode else []


def stddev_of(result):
    s = result["stddev"]
    keys = ["tx_m", "ty_m", "tz_m", "roll_deg", "pitch_deg", "yaw_deg"]
    return [float("inf") if s[k] is None else s[k] for k in keys]


def fmt_err(i, e):
    return f"{1e3 * e:.1f}" if i < 3 else f"{e:.3f}"


def balm_study(args, rows, tally):
    src = extract(os.path.join(args.mirror, "hku-mars+BALM", "repo"), ["datas/benchmark_realworld"],
                  os.path.join(args.work, "balm"))
    scans = balm_poses(src)
    for walk_mm in args.walk_mm:
        for m in range(args.first_mount, args.first_mount + args.mounts):
            (rpy, t) = MOUNTS[m % len(MOUNTS)]
            T_gt = make_T(rot_rpy_deg(*rpy), list(t))
            for seed in range(1, args.seeds + 1):
                rng = random.Random(1000 * m + seed + int(100 * walk_mm))
                case = os.path.join(args.work, "cases", f"balm-m{m}-s{seed}-w{walk_mm:g}")
                shutil.rmtree(case, ignore_errors=True)
                os.makedirs(case)
                write_balm_case(scans, src, case, T_gt, rng, walk_mm, args.init_rot_deg, args.init_trans_m,
                                args.noise_scale)
                code, result, wall, err = run_calibrate(args.insalign, case, [], args.set)
                label = f"BALM mount {m}, seed {seed}, walk {walk_mm:g} mm/sqrt(s)"
                record(label, code, result, wall, err, T_gt, rows, tally)
                shutil.rmtree(os.path.join(case, "lidar"), ignore_errors=True)


def kitti_study(args, rows, tally):
    git_dir = os.path.join(args.mirror, "polben+PointcloudProcessing", "repo")
    base = os.path.dirname(extract(git_dir, ["sample_data/velodyne_points", "sample_data/oxts", "sample_data/sample_calib"],
                                   os.path.join(args.work, "kitti-src")))
    day = os.path.join(args.work, "kitti", "2011_09_26")
    drive = os.path.join(day, "2011_09_26_drive_sample_sync")
    if not os.path.exists(drive):
        os.makedirs(drive)
        for sub in ("velodyne_points", "oxts"):
            shutil.copytree(os.path.join(base, sub), os.path.join(drive, sub))
        shutil.copy(os.path.join(base, "sample_calib", "2011_09_26", "calib_imu_to_velo.txt"), day)
        # The sample is the start of a longer drive: its start/end time lists run on; cut them to the sweeps.
        velo = os.path.join(drive, "velodyne_points")
        n = len(open(os.path.join(velo, "timestamps.txt")).read().splitlines())
        for name in ("timestamps_start.txt", "timestamps_end.txt"):
            lines = open(os.path.join(velo, name)).read().splitlines()[:n]
            open(os.path.join(velo, name), "w").write("\n".join(lines) + "\n")
    # KITTI's own T_velo_imu, inverted: the reference T_ins_lidar.
    calib = {l.split(":")[0]: [float(v) for v in l.split(":")[1].split()] for l in
             open(os.path.join(day, "calib_imu_to_velo.txt")) if l.startswith(("R:", "T:"))}
    R, t = calib["R"], calib["T"]
    T_ref = inverse(make_T([R[0:3], R[3:6], R[6:9]], t))
    out = os.path.join(args.work, "kitti", "out")
    shutil.rmtree(out, ignore_errors=True)
    cmd = [args.insalign, "calibrate", "--kitti-raw", drive, "--out", out, "-q", "--no-report"]
    for s in args.set:
        cmd += ["--set", s]
    t0 = time.time()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    result = json.load(open(os.path.join(out, "extrinsic.json"))) if proc.returncode == 0 else None
    record("KITTI raw sample (30 sweeps, 3 s), vs KITTI's calibration", proc.returncode, result, time.time() - t0,
           proc.stderr.strip().splitlines()[-1:], T_ref, rows, tally)


def record(label, code, result, wall, err, T_gt, rows, tally):
    if result is None:
        rows.append(f"| {label} | exit {code} | {' '.join(err)[:160]} | | | | {wall:.1f} |")
        return
    T_est = result["T_ins_lidar"]
    e = error_ins_frame(T_est, T_gt)
    sd = stddev_of(result)
    det = [result["determined"][d] for d in DOFS]
    cells = []
    for i in range(6):
        sd_i = sd[i] if i < 3 else sd[i]
        ratio = abs(e[i]) / sd_i if math.isfinite(sd_i) and sd_i > 0 else float("nan")
        t = tally.setdefault(DOFS[i], {"runs": 0, "covered": 0, "undetermined": 0, "misses": []})
        t["runs"] += 1
        if not det[i]:
            t["undetermined"] += 1
            t["covered"] += 1
            cells.append(f"{fmt_err(i, e[i])} (u)")
            continue
        ok = math.isfinite(ratio) and ratio <= 3.0
        t["covered"] += ok
        if not ok:
            t["misses"].append(f"{label}: {ratio:.1f} sigma")
        cells.append(f"{fmt_err(i, e[i])} / {fmt_err(i, sd_i)}{'' if ok else ' **MISS**'}")
    offset_ms = 1e3 * result.get("time_offset_s", float("nan"))
    rows.append(f"| {label} | {' | '.join(cells)} | {result.get('tz_source', '?')} | {offset_ms:.1f} | {wall:.1f} |")


def case_arguments(ap):
    """The options that choose the BALM cases (shared with bench/real_check.py)."""
    ap.add_argument("--insalign", default=os.path.join(HERE, "..", "build", "src", "insalign"))
    ap.add_argument("--mirror", default="/work/.mirror", help="folder holding owner+name/repo git mirrors")
    ap.add_argument("--work", default=os.path.join(HERE, "real_data"), help="ignored folder for the extracted scans")
    ap.add_argument("--mounts", type=int, default=3)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--walk-mm", default="0,5", help="INS position random walk per axis, mm/sqrt(s), comma-separated")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    case_arguments(ap)
    ap.add_argument("--init-rot-deg", type=float, default=3.0)
    ap.add_argument("--init-trans-m", type=float, default=0.1)
    ap.add_argument("--noise-scale", type=float, default=1.0, help="scale of the INS's white noise (0: exact odometry)")
    ap.add_argument("--first-mount", type=int, default=0)
    ap.add_argument("--no-kitti", action="store_true")
    ap.add_argument("--set", action="append", default=[], help="passed to calibrate as --set KEY=VALUE")
    args = ap.parse_args()
    args.walk_mm = [float(w) for w in args.walk_mm.split(",")]
    args.insalign = os.path.abspath(args.insalign)
    rows, tally = [], {}
    balm_study(args, rows, tally)
    if not args.no_kitti:
        kitti_study(args, rows, tally)
    print("| case | tx mm | ty mm | tz mm | roll deg | pitch deg | yaw deg | tz from | time offset ms | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    print("\n(cells: |error| / stated stddev; (u): reported not determined; **MISS**: determined, beyond 3 stddev)\n")
    runs = sum(t["runs"] for t in tally.values())
    covered = sum(t["covered"] for t in tally.values())
    print("| DOF | within 3 stddev | of which not determined |")
    print("|---|---|---|")
    for d in DOFS:
        t = tally.get(d, {"runs": 0, "covered": 0, "undetermined": 0})
        print(f"| {d} | {t['covered']}/{t['runs']} | {t['undetermined']} |")
    print(f"| all | {covered}/{runs} ({100.0 * covered / max(runs, 1):.1f}%) | |")
    misses = [m for t in tally.values() for m in t["misses"]]
    return 0 if not misses else 1


if __name__ == "__main__":
    sys.exit(main())
