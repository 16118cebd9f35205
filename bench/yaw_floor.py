#!/usr/bin/env python3
"""The yaw error no method can avoid when the INS position drifts (issue 17, item 1).

For a level car, a map rotated by d about the vertical is the same map as the extrinsic yaw
turned by d with the trajectory rotated by d about the vertical: the LiDAR data cannot tell them
apart. Only the prior on the INS error can: correcting a drift d(t) by c(t) = d(t) + d z x p(t)
costs int |c'(t)|^2 / q^2 dt under a random-walk prior of intensity q (m/sqrt(s) per axis). The
best estimate therefore misses the yaw by delta = -int d'(t).(z x v(t)) dt / int |v|^2 dt, a
zero-mean Gaussian with sigma = q / sqrt(int |v(t)|^2 dt) on any drive, whatever the method.
A heading random walk of intensity h adds its drive mean, sigma h sqrt(T / 3).

  python3 bench/yaw_floor.py POSES [q_m_per_sqrt_s=0.005] [runs=10] [bound_deg=0.01] [h_deg_per_sqrt_s=0]

POSES: an OpenCalib pose file (name = yyyy-mm-dd-hh-mm-ss-mmm, then the 3x4 T_world_ins row-major)
or a TUM file (t x y z qx qy qz qw).
"""
import math
import sys
from datetime import datetime


def read_positions(path):
    out = []
    for line in open(path):
        f = line.split()
        if len(f) == 13:  # OpenCalib
            t = datetime.strptime(f[0][:19], '%Y-%m-%d-%H-%M-%S').timestamp() + int(f[0][20:]) / 1000.0
            out.append((t, float(f[4]), float(f[8])))
        elif len(f) == 8 and not f[0].startswith('#'):  # TUM
            out.append((float(f[0]), float(f[1]), float(f[2])))
    return out


def main():
    path = sys.argv[1]
    q = float(sys.argv[2]) if len(sys.argv) > 2 else 0.005
    runs = int(sys.argv[3]) if len(sys.argv) > 3 else 10
    bound = float(sys.argv[4]) if len(sys.argv) > 4 else 0.01
    h = float(sys.argv[5]) if len(sys.argv) > 5 else 0.0
    p = read_positions(path)
    v2dt = 0.0
    for (t0, x0, y0), (t1, x1, y1) in zip(p, p[1:]):
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


if __name__ == '__main__':
    main()
