#!/usr/bin/env python3
"""CPU time per pipeline step from a perf profile with call stacks.

Build with frame pointers, profile a run, attribute each sample to the first step found on its
stack (repeatability, report, init, screening, mask, stage 1, stage 2, stage 3, decoding):

  cmake -S . -B build-prof -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS="-fno-omit-frame-pointer -g1"
  cmake --build build-prof --target insalign
  perf record -F 499 --call-graph fp -o perf.data build-prof/src/insalign calibrate ... --out OUT
  perf script -i perf.data -F tid,time,ip,sym > perf.stacks
  python3 bench/perf_steps.py perf.stacks 499 [STEP]   # STEP: that step's hottest leaf functions

Samples whose stack is cut at a TBB worker boundary count as "other".
"""
import collections
import re
import sys

STEPS = [  # outermost first: a step called inside another (stage 1 in the segments) goes to the outer
    ('repeatability', r'run_repeatability|calibrate_segment'),
    ('report', r'report_data|report_map|draw_report_images|draw_map|write_report|io::render|encode_png|write_png'),
    ('init', r'initialise_extrinsic|register_pairs|coarse_yaw|level_lidar|score_candidate'),
    ('screen', r'lidar_checks|screen_with_lidar|motion_check|map_residual_check|check_pair|align_to_map'),
    ('mask', r'find_moving_points|frame_evidence|count_evidence|ground_heights|MovingPoints'),
    ('stage1', r'calibrate_rough|build_round_problem|add_window|solve_round'),
    ('stage2', r'refine_joint|refine_checked|gauss_newton|build_normal_equations|scan_time_offset'),
    ('stage3', r'correct_z'),
    ('decode', r'FrameStore::reduced|read_pcd|lzf_decompress|read_binary_compressed'),
]


def samples(path):
    stack = None
    for line in open(path, errors='replace'):
        if not line.strip():
            if stack is not None:
                yield stack
            stack = None
        elif re.match(r'\s*\d+\s+[\d.]+:', line):
            stack = []
        elif stack is not None:
            parts = line.strip().split(None, 1)
            stack.append(parts[1] if len(parts) > 1 else '')
    if stack is not None:
        yield stack


def step_of(stack):
    for name, rx in STEPS:
        if any(re.search(rx, sym) for sym in stack):
            return name
    return 'other'


def main():
    path, hz = sys.argv[1], float(sys.argv[2]) if len(sys.argv) > 2 else 499.0
    only = sys.argv[3] if len(sys.argv) > 3 else None
    per_step, leaves = collections.Counter(), collections.Counter()
    for stack in samples(path):
        step = step_of(stack)
        per_step[step] += 1
        if step == only:
            leaves[(stack[0] if stack else '?')[:100]] += 1
    total = sum(per_step.values()) or 1
    for step, n in per_step.most_common():
        print(f'{step:14s} {n:7d} samples {100 * n / total:5.1f}%  {n / hz:6.2f} s CPU')
    for sym, n in leaves.most_common(20):
        print(f'  {n:6d} {sym}')


if __name__ == '__main__':
    main()
