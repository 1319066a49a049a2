#!/usr/bin/env python3
"""Times two stillmap binaries on one sequence, alternating runs (A, B, A, B, ...), so that the
machine's drift hits both alike: whole-process wall time, CPU time (user + sys) and peak memory
of each run, and the medians.

    scripts/side_by_side.py OLD/stillmap NEW/stillmap ../shared/data/bonn_crowd_a --runs 3

Extra build options follow `--`: scripts/side_by_side.py A B SEQ -- --detector none
Run it on a quiet machine. Only the Python standard library is used.
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def run_once(binary, sequence, output, extra):
    command = [binary, "build", sequence, "-o", output, "--quiet"] + extra
    start = time.monotonic()
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.monotonic() - start
    stderr = process.stderr.read().decode(errors="replace")
    process.stderr.close()
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"side_by_side: {' '.join(command)} failed: {stderr.strip()}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", help="first stillmap binary (e.g. the older build)")
    parser.add_argument("b", help="second stillmap binary")
    parser.add_argument("sequence")
    parser.add_argument("--runs", type=int, default=3, help="runs of each binary")
    argv = sys.argv[1:]
    split = argv.index("--") if "--" in argv else len(argv)
    args = parser.parse_args(argv[:split])
    extra = argv[split + 1:]
    work = tempfile.mkdtemp(prefix="side_by_side_")
    results = {"a": [], "b": []}
    try:
        for i in range(args.runs):
            for key in ("a", "b"):
                binary = getattr(args, key)
                output = os.path.join(work, f"{key}{i}")
                wall, cpu, peak = run_once(binary, args.sequence, output, extra)
                results[key].append((wall, cpu, peak))
                print(f"{key} run {i + 1}: wall {wall:.2f} s, cpu {cpu:.2f} s, peak {peak:.0f} MiB",
                      flush=True)
                shutil.rmtree(output, ignore_errors=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    medians = {}
    for key, rows in results.items():
        medians[key] = [statistics.median(column) for column in zip(*rows)]
        wall, cpu, peak = medians[key]
        print(f"{key} median: wall {wall:.2f} s, cpu {cpu:.2f} s, peak {peak:.0f} MiB "
              f"({getattr(args, key)})")
    (wall_a, cpu_a, _), (wall_b, cpu_b, _) = medians["a"], medians["b"]
    print(f"b / a: wall {wall_b / wall_a:.3f}, cpu {cpu_b / cpu_a:.3f}")


if __name__ == "__main__":
    main()
