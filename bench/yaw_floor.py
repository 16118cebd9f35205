#!/usr/bin/env python3
"""The yaw error no method can avoid when the INS position drifts (issue 17, item 1).

For a level car, a map rotated by d about the vertical is the same map as the extrinsic yaw
turned by d with the trajectory rotated by d about the vertical: the LiDAR data cannot tell them
apart. Only the prior on the INS error can: correcting a drift d(t) by c(t) = d(t) + d z x p(t)
costs int |c'(t)|^2 / q^2 dt under a random-walk prior of intensity q (m/sqrt(s) per axis). The
best estimate therefore misses the yaw by delta = -int d'(t).(z x v(t)) dt / int |v|^2 dt, a
zero-mean Gaussian with sigma = q / sqrt(int |v(t)|^2 dt) on any drive, whatever the method.
A heading random walk of intensity h adds its drive mean, sigma h sqrt(T / 3).

The horizontal lever arm l has the same kind of floor: a change l moves the map by R(t) l, exactly
what the correction -R(t) l undoes, so only the prior tells them apart, through how fast the car
turns: the information on (yaw, lx, ly) is the integral of J^T J / q^2 with J's columns z x v,
dR/dt e_x and dR/dt e_y (horizontal parts), and the floor is its inverse's diagonal (about
q / sqrt(int yaw_rate^2 dt) per axis).

Roll and pitch have a floor of the same kind when each INS pose carries white attitude noise of
a (deg, per axis): an extrinsic roll turned by d is every frame's INS roll turned by d, so the data
fix the extrinsic only up to the mean attitude error of the frames a method uses: sigma a / sqrt(n)
for n frames weighed alike (more with unequal weights), a / sqrt(poses) for a method using every
pose's frame.

  python3 bench/yaw_floor.py POSES [q_m_per_sqrt_s=0.005] [runs=10] [bound_deg=0.01] [h_deg_per_sqrt_s=0]
                                   [a_tilt_deg=0] [frames_used=240]

POSES: an OpenCalib pose file (name = yyyy-mm-dd-hh-mm-ss-mmm, then the 3x4 T_world_ins row-major)
or a TUM file (t x y z qx qy qz qw).
"""
import math
import sys
from datetime import datetime


def read_positions(path):
    """(t, x, y, heading) per pose; the heading is the INS x axis's direction in the world."""
    out = []
    for line in open(path):
        f = line.split()
        if len(f) == 13:  # OpenCalib
            t = datetime.strptime(f[0][:19], '%Y-%m-%d-%H-%M-%S').timestamp() + int(f[0][20:]) / 1000.0
            out.append((t, float(f[4]), float(f[8]), math.atan2(float(f[5]), float(f[1]))))
        elif len(f) == 8 and not f[0].startswith('#'):  # TUM
            qx, qy, qz, qw = (float(v) for v in f[4:8])
            out.append((float(f[0]), float(f[1]), float(f[2]),
                        math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))))
    return out


def inverse3(m):
    a, b, c = m[0]
    d, e, f = m[1]
    g, h, i = m[2]
    co = [[e * i - f * h, -(d * i - f * g), d * h - e * g],
          [-(b * i - c * h), a * i - c * g, -(a * h - b * g)],
          [b * f - c * e, -(a * f - c * d), a * e - b * d]]
    det = a * co[0][0] + b * co[0][1] + c * co[0][2]
    return [[co[j][k] / det for j in range(3)] for k in range(3)]


def lever_arm_floor(p, q):
    """Floor sigma (m) of the horizontal lever arm x, y (INS frame), yaw estimated with it."""
    info = [[0.0] * 3 for _ in range(3)]
    for (t0, x0, y0, h0), (t1, x1, y1, h1) in zip(p, p[1:]):
        dt = t1 - t0
        if dt <= 0:
            continue
        vx, vy = (x1 - x0) / dt, (y1 - y0) / dt
        rate = math.remainder(h1 - h0, 2.0 * math.pi) / dt
        h = 0.5 * (h0 + h1)
        cols = [(-vy, vx), (-rate * math.sin(h), rate * math.cos(h)), (-rate * math.cos(h), -rate * math.sin(h))]
        for a in range(3):
            for b in range(3):
                info[a][b] += (cols[a][0] * cols[b][0] + cols[a][1] * cols[b][1]) * dt
    cov = inverse3(info)
    return q * math.sqrt(cov[1][1]), q * math.sqrt(cov[2][2])


def main():
    path = sys.argv[1]
    q = float(sys.argv[2]) if len(sys.argv) > 2 else 0.005
    runs = int(sys.argv[3]) if len(sys.argv) > 3 else 10
    bound = float(sys.argv[4]) if len(sys.argv) > 4 else 0.01
    h = float(sys.argv[5]) if len(sys.argv) > 5 else 0.0
    a_tilt = float(sys.argv[6]) if len(sys.argv) > 6 else 0.0
    frames_used = int(sys.argv[7]) if len(sys.argv) > 7 else 240
    p = read_positions(path)
    v2dt = 0.0
    for (t0, x0, y0, _), (t1, x1, y1, _) in zip(p, p[1:]):
        dt = t1 - t0
        if dt > 0:
            v2dt += ((x1 - x0) ** 2 + (y1 - y0) ** 2) / dt  # |v|^2 dt
    T = p[-1][0] - p[0][0]
    sigma_pos = math.degrees(q / math.sqrt(v2dt))
    sigma_head = h * math.sqrt(T / 3.0)
    sigma = math.hypot(sigma_pos, sigma_head)
    p_in = math.erf(bound / (sigma * math.sqrt(2.0)))
    print(f'{path}: {len(p)} poses over {T:.1f} s, rms speed {math.sqrt(v2dt / T):.2f} m/s')
    print(f'yaw floor sigma: {sigma_pos:.4f} deg from a position walk of {q} m/sqrt(s)'
          + (f', {sigma_head:.4f} deg from a heading walk of {h} deg/sqrt(s)' if h else '')
          + f'; together {sigma:.4f} deg')
    print(f'a perfect method: yaw MAE {sigma * math.sqrt(2 / math.pi):.4f} deg; one run within {bound} deg with '
          f'probability {p_in:.3f}; all {runs} runs {p_in ** runs:.3f}')
    for axis, sd in zip('xy', lever_arm_floor(p, q)):
        p5 = math.erf(0.005 / (sd * math.sqrt(2.0)))
        print(f'lever arm {axis} floor sigma: {1e3 * sd:.2f} mm; a perfect method: MAE {1e3 * sd * math.sqrt(2 / math.pi):.2f} mm, '
              f'all {runs} runs within 5 mm with probability {p5 ** runs:.3f}')
    if a_tilt > 0:
        for label, n in ((f'{frames_used} frames', frames_used), (f'every pose ({len(p)})', len(p))):
            sd = a_tilt / math.sqrt(n)
            print(f'roll / pitch floor with {label}: sigma {sd:.5f} deg, MAE {sd * math.sqrt(2 / math.pi):.5f} deg '
                  f'(white attitude noise {a_tilt} deg per pose)')


if __name__ == '__main__':
    main()
