#!/usr/bin/env python3
"""Joins two TUM-layout sequences into one recording of two different places: the first played
as it is, then the second re-timed to follow it (its first frame one frame interval after the
first's last), as a camera carried from one place to the other with nothing seen in between.

    scripts/two_places.py ../shared/data/bonn_crowd_a ../shared/data/tum_fr3_teddy_200 /tmp/two
    build/apps/stillmap build /tmp/two -o out_two

The new folder holds rgb.txt and depth.txt (the first's frames, then the second's under the new
timestamps), camera.yaml (the first's: one camera file, as a recording has), groundtruth.txt (the
first's only: the second place's poses are in a world of their own) and links first_rgb,
first_depth, second_rgb and second_depth to the original image folders (nothing is copied). Only
the Python standard library is used.
"""

import argparse
import os
import shutil
import sys


def read_list(path):
    """(timestamp, file) for each non-comment line of a TUM image list."""
    entries = []
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            fields = line.split()
            try:
                entries.append((float(fields[0]), fields[1]))
            except (ValueError, IndexError):
                sys.exit(f"two_places: {path}:{number}: expected 'timestamp file', got '{line}'")
    if not entries:
        sys.exit(f"two_places: {path}: no entries")
    return entries


def link(target, name):
    if os.path.lexists(name):
        os.remove(name)
    os.symlink(os.path.abspath(target), name)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first", help="the sequence played first")
    parser.add_argument("second", help="the sequence played after it, re-timed")
    parser.add_argument("out", help="new folder for the joined sequence")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    first_rgb = read_list(os.path.join(args.first, "rgb.txt"))
    first_depth = read_list(os.path.join(args.first, "depth.txt"))
    second_rgb = read_list(os.path.join(args.second, "rgb.txt"))
    second_depth = read_list(os.path.join(args.second, "depth.txt"))
    step = (first_rgb[-1][0] - first_rgb[0][0]) / max(1, len(first_rgb) - 1)
    # The second's clock moved so that its first frame follows the first's last by one step.
    second_start = min(second_rgb[0][0], second_depth[0][0])
    shift = max(first_rgb[-1][0], first_depth[-1][0]) + step - second_start
    for kind, first, second in (("rgb", first_rgb, second_rgb),
                                ("depth", first_depth, second_depth)):
        link(os.path.join(args.first, kind), os.path.join(args.out, "first_" + kind))
        link(os.path.join(args.second, kind), os.path.join(args.out, "second_" + kind))
        with open(os.path.join(args.out, kind + ".txt"), "w", encoding="utf-8") as out:
            out.write(f"# {kind}: {args.first}, then {args.second} re-timed by {shift:+.6f} s\n")
            out.write("# timestamp filename\n")
            for t, name in first:
                out.write(f"{t:.6f} first_{name}\n")
            for t, name in second:
                out.write(f"{t + shift:.6f} second_{name}\n")
    shutil.copyfile(os.path.join(args.first, "camera.yaml"), os.path.join(args.out, "camera.yaml"))
    shutil.copyfile(os.path.join(args.first, "groundtruth.txt"),
                    os.path.join(args.out, "groundtruth.txt"))
    print(f"{args.out}: {len(first_rgb)} + {len(second_rgb)} frames, the second place from "
          f"{second_start + shift:.3f} s")


if __name__ == "__main__":
    main()
