#!/usr/bin/env python3
"""Turns a TUM-layout sequence into a revisit test: the frames played forward, then backward,
then forward ... (--passes N), with timestamps that go on increasing at the sequence's own frame
intervals, and each replayed frame's ground truth (the original pose at the original frame's time,
interpolated) at its new timestamp.

    scripts/revisit_replay.py ../shared/data/tum_fr3_teddy_200 /tmp/teddy_x4 --passes 4
    build/apps/stillmap build /tmp/teddy_x4 -o out_teddy_x4

The new folder holds rgb.txt, depth.txt, groundtruth.txt and camera.yaml, and links named rgb and
depth to the original image folders (nothing is copied). A pass turns at the last frame, which is
not repeated (forward 0..n-1, backward n-2..0, ...). Only the Python standard library is used.
"""

import argparse
import bisect
import math
import os
import shutil
import sys


def read_list(path):
    """(timestamp, rest of the line) for each non-comment line of a TUM list."""
    entries = []
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            fields = line.split()
            try:
                entries.append((float(fields[0]), fields[1:]))
            except (ValueError, IndexError):
                sys.exit(f"revisit_replay: {path}:{number}: expected 'timestamp ...', got '{line}'")
    if not entries:
        sys.exit(f"revisit_replay: {path}: no entries")
    return entries


def slerp(q0, q1, t):
    dot = sum(a * b for a, b in zip(q0, q1))
    if dot < 0.0:
        q1, dot = [-c for c in q1], -dot
    if dot > 0.9995:
        q = [a + t * (b - a) for a, b in zip(q0, q1)]
    else:
        theta = math.acos(dot)
        s0 = math.sin((1.0 - t) * theta) / math.sin(theta)
        s1 = math.sin(t * theta) / math.sin(theta)
        q = [s0 * a + s1 * b for a, b in zip(q0, q1)]
    norm = math.sqrt(sum(c * c for c in q))
    return [c / norm for c in q]


def pose_at(truth, times, t, max_gap):
    """The ground-truth pose at time t (interpolated between the two poses around it), or None
    when t is outside the ground truth or the poses around it are more than max_gap apart."""
    i = bisect.bisect_left(times, t)
    if i < len(times) and abs(times[i] - t) < 1e-9:
        return truth[i][1]
    if i == 0 or i == len(times):
        return None
    (t0, p0), (t1, p1) = truth[i - 1], truth[i]
    if t1 - t0 > max_gap:
        return None
    a = (t - t0) / (t1 - t0)
    position = [x0 + a * (x1 - x0) for x0, x1 in zip(p0[:3], p1[:3])]
    return position + slerp(p0[3:], p1[3:], a)


def passes_of(count, passes):
    """Each pass as (frame indices, direction): forward, backward, ... turning at the ends
    without repeating a frame."""
    out = [(list(range(count)), 1)]
    for p in range(1, passes):
        out.append((list(range(count - 2, -1, -1)), -1) if p % 2 else (list(range(1, count)), 1))
    return out


def pass_offsets(times, plan):
    """For each pass the offset a of its time map t -> a + direction * t: the clock goes on at
    the sequence's own frame intervals, reflected at each turn."""
    offsets = [0.0]
    for (previous, direction), (frames, _) in zip(plan, plan[1:]):
        turn = times[previous[-1]]
        turned_at = offsets[-1] + direction * turn  # new time of the turning frame
        # Reflection about the turning frame: the next frame comes one interval later.
        offsets.append(turned_at + direction * turn)
    return offsets


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sequence", help="TUM-layout folder (rgb.txt, depth.txt, ...)")
    parser.add_argument("output", help="new folder for the replay (must not exist)")
    parser.add_argument("--passes", type=int, default=2, help="passes, 2 = there and back")
    parser.add_argument("--first", type=int, default=0, help="first frame of rgb.txt used")
    parser.add_argument("--count", type=int, default=0, help="frames used (0: all from --first)")
    parser.add_argument("--max-truth-gap", type=float, default=0.1,
                        help="no ground truth where its poses are farther apart [s]")
    args = parser.parse_args()
    if args.passes < 1:
        sys.exit("revisit_replay: --passes must be at least 1")
    source = os.path.abspath(args.sequence)
    if os.path.exists(args.output):
        sys.exit(f"revisit_replay: {args.output} exists; give a new folder")

    rgb = read_list(os.path.join(source, "rgb.txt"))
    depth = read_list(os.path.join(source, "depth.txt"))
    last = len(rgb) if args.count <= 0 else min(len(rgb), args.first + args.count)
    rgb = rgb[args.first:last]
    if len(rgb) < 2:
        sys.exit("revisit_replay: fewer than 2 frames selected")
    depth_times = [t for t, _ in depth]
    truth_path = os.path.join(source, "groundtruth.txt")
    truth = []
    if os.path.exists(truth_path):
        truth = [(t, [float(v) for v in rest[:7]]) for t, rest in read_list(truth_path)]
        truth.sort()
    truth_times = [t for t, _ in truth]

    rgb_times = [t for t, _ in rgb]
    plan = passes_of(len(rgb), args.passes)
    offsets = pass_offsets(rgb_times, plan)
    # Each depth image goes with the colour frame nearest in time, as the build pairs them.
    depth_of_frame = {i: [] for i in range(len(rgb))}
    for k, t in enumerate(depth_times):
        i = bisect.bisect_left(rgb_times, t)
        near = [j for j in (i - 1, i) if 0 <= j < len(rgb)]
        j = min(near, key=lambda j: abs(rgb_times[j] - t))
        if abs(rgb_times[j] - t) <= 0.02:  # the build pairs within 0.02 s
            depth_of_frame[j].append(k)

    os.makedirs(args.output)
    for name in ("rgb", "depth"):
        if os.path.isdir(os.path.join(source, name)):
            os.symlink(os.path.join(source, name), os.path.join(args.output, name))
    for name in ("camera.yaml",):
        if os.path.exists(os.path.join(source, name)):
            shutil.copyfile(os.path.join(source, name), os.path.join(args.output, name))

    header = f"# replay of {source}, {args.passes} passes (scripts/revisit_replay.py)\n"
    frames = 0
    with open(os.path.join(args.output, "rgb.txt"), "w", encoding="utf-8") as out_rgb, \
            open(os.path.join(args.output, "depth.txt"), "w", encoding="utf-8") as out_depth, \
            open(os.path.join(args.output, "groundtruth.txt"), "w", encoding="utf-8") as out_gt:
        for f in (out_rgb, out_depth, out_gt):
            f.write(header)
        out_gt.write("# timestamp tx ty tz qx qy qz qw (the original frame's pose)\n")
        for (indices, direction), offset in zip(plan, offsets):
            for i in indices:
                time, rest = rgb[i]
                new_time = offset + direction * time
                out_rgb.write(f"{new_time:.6f} {rest[0]}\n")
                frames += 1
                for k in sorted(depth_of_frame[i], key=lambda k: direction * depth_times[k]):
                    out_depth.write(f"{offset + direction * depth_times[k]:.6f} {depth[k][1][0]}\n")
                pose = pose_at(truth, truth_times, time, args.max_truth_gap) if truth else None
                if pose is not None:
                    out_gt.write(f"{new_time:.6f} " + " ".join(f"{v:.7f}" for v in pose) + "\n")
    print(f"revisit_replay: {frames} frames ({args.passes} passes of {len(rgb)}) in "
          f"{args.output}")


if __name__ == "__main__":
    main()
