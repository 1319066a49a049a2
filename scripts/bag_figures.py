#!/usr/bin/env python3
"""Builds shared sequences from their TUM folders and from the same recordings written as bags
of each kind (ROS 1, MCAP zstd and lz4, a ROS 2 sqlite3 folder), with no camera.yaml for the
bags, and prints the difference: ATE (RMSE against the sequence's groundtruth.txt), map voxels
and peak memory (the process's maximum resident set).

    scripts/bag_figures.py ../shared/data/tum_fr3_teddy_200 ../shared/data/bonn_crowd_a \\
        --stillmap build/apps/stillmap --bags-dir /tmp/bags -- --models ../shared/models

The bags are written by ../shared/tools/make-bags (the ecosystem's own writers) into --bags-dir,
and reused when already there. Extra build options follow `--`. Only the Python standard
library is used.
"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

# name: make-bags options
KINDS = {
    "ros1 tum rgb8+32FC1": ["--format", "bag", "--style", "tum", "--colour", "raw", "--depth", "m32"],
    "ros1 lz4 jpeg+16UC1": ["--format", "bag", "--style", "realsense", "--colour", "jpeg",
                            "--depth", "mm16", "--compression", "lz4"],
    "mcap zstd": ["--format", "mcap", "--style", "realsense", "--colour", "jpeg", "--depth", "mm16",
                  "--compression", "zstd"],
    "mcap lz4": ["--format", "mcap", "--style", "realsense", "--colour", "jpeg", "--depth", "mm16",
                 "--compression", "lz4"],
    "sqlite3 compressedDepth": ["--format", "db3", "--style", "realsense", "--colour", "jpeg",
                                "--depth", "compressed"],
}
SUFFIX = {"bag": ".bag", "mcap": ".mcap", "db3": "_db3"}


def bag_path(bags_dir, sequence, kind):
    options = KINDS[kind]
    name = sequence.name + "." + kind.replace(" ", "_").replace("+", "_")
    return bags_dir / (name + SUFFIX[options[options.index("--format") + 1]])


def build(stillmap, source, output, extra):
    command = [stillmap, "build", str(source), "-o", str(output), "--quiet"] + extra
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    stderr = process.stderr.read().decode(errors="replace")
    process.stderr.close()
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"bag_figures: {' '.join(command)} failed: {stderr.strip()}")
    report = json.loads((output / "report.json").read_text())
    return {
        "ate_mm": 1000.0 * report["trajectory_error"]["ate_m"]["rmse"],
        "voxels": report["map"]["voxels"],
        "peak_mib": usage.ru_maxrss / 1024.0,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sequences", nargs="+", type=Path)
    parser.add_argument("--stillmap", default="build/apps/stillmap")
    parser.add_argument("--make-bags", default="../shared/tools/make-bags")
    parser.add_argument("--bags-dir", type=Path, default=Path("/tmp/stillmap_bags"))
    parser.add_argument("--out-dir", type=Path, default=Path("/tmp/stillmap_bag_builds"))
    parser.add_argument("--kinds", nargs="*", default=list(KINDS), choices=list(KINDS))
    argv = sys.argv[1:]
    split = argv.index("--") if "--" in argv else len(argv)
    args = parser.parse_args(argv[:split])
    extra = argv[split + 1:]
    args.bags_dir.mkdir(parents=True, exist_ok=True)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    print("| sequence | input | ATE | voxels | peak memory |")
    print("|---|---|---|---|---|")
    for sequence in args.sequences:
        folder = build(args.stillmap, sequence, args.out_dir / (sequence.name + ".folder"), extra)
        print(f"| {sequence.name} | TUM folder | {folder['ate_mm']:.2f} mm | {folder['voxels']} | "
              f"{folder['peak_mib']:.0f} MiB |", flush=True)
        truth = ["--groundtruth", str(sequence / "groundtruth.txt")]
        for kind in args.kinds:
            bag = bag_path(args.bags_dir, sequence, kind)
            if not bag.exists():
                subprocess.run([args.make_bags, str(sequence), str(bag)] + KINDS[kind],
                               check=True, stdout=subprocess.DEVNULL)
            out = build(args.stillmap, bag, args.out_dir / (bag.name + ".out"), extra + truth)
            print(f"| {sequence.name} | {kind} | {out['ate_mm']:.2f} mm "
                  f"({out['ate_mm'] - folder['ate_mm']:+.2f}) | {out['voxels']} "
                  f"({100.0 * (out['voxels'] / folder['voxels'] - 1.0):+.2f} %) | "
                  f"{out['peak_mib']:.0f} MiB ({out['peak_mib'] - folder['peak_mib']:+.0f}) |",
                  flush=True)


if __name__ == "__main__":
    main()
