#!/usr/bin/env python3
"""Times two stillmap binaries on one sequence, alternating runs (A, B, A, B, ...), so that the
machine's drift hits both alike: whole-process wall time, CPU time (user + sys) and peak memory
of each run, and the medians.

    scripts/side_by_side.py OLD/stillmap NEW/stillmap ../shared/data/bonn_crowd_a --runs 3

Extra build options follow `--`: scripts/side_by_side.py A B SEQ -- --detector none
Run it on a quiet machine. Only the Python standard library is used.

With --together, each run of A starts at the same moment as a run of B and both share the
machine: their wall times are not those of a run alone then, but their CPU times are compared
under the same conditions. On a virtual machine whose speed drifts by 10-15 % from one minute to
the next, the same binary measured this way twice differed by 0.7 and 1.8 % in CPU
(bonn_crowd_a), where alternating runs differed by up to 25 %.
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def start_run(binary, sequence, output, extra):
    command = [binary, "build", sequence, "-o", output, "--quiet"] + extra
    stderr = open(output + ".stderr", "w+b")  # a file, not a pipe: nothing blocks the run
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=stderr)
    return command, process, stderr, time.monotonic()


def finish_runs(started):
    """Waits for the runs `started` (key -> start_run's result), each collected as it ends: per
    key, its wall time, CPU time (user + sys) and peak memory [MiB]."""
    by_pid = {run[1].pid: key for key, run in started.items()}
    rows = {}
    while by_pid:
        pid, status, usage = os.wait4(-1, 0)
        if pid not in by_pid:
            continue
        key = by_pid.pop(pid)
        command, process, stderr, start = started[key]
        process.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
        wall = time.monotonic() - start
        stderr.seek(0)
        message = stderr.read().decode(errors="replace").strip()
        stderr.close()
        if process.returncode != 0:
            for other in by_pid:  # the run started with it would go on writing
                started[by_pid[other]][1].kill()
            sys.exit(f"side_by_side: {' '.join(command)} failed: {message}")
        rows[key] = (wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0)
    return rows


def report(key, i, row):
    wall, cpu, peak = row
    print(f"{key} run {i + 1}: wall {wall:.2f} s, cpu {cpu:.2f} s, peak {peak:.0f} MiB", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", help="first stillmap binary (e.g. the older build)")
    parser.add_argument("b", help="second stillmap binary")
    parser.add_argument("sequence")
    parser.add_argument("--runs", type=int, default=3, help="runs of each binary")
    parser.add_argument("--together", action="store_true",
                        help="start each run of A with one of B, for their CPU times only")
    argv = sys.argv[1:]
    split = argv.index("--") if "--" in argv else len(argv)
    args = parser.parse_args(argv[:split])
    extra = argv[split + 1:]
    work = tempfile.mkdtemp(prefix="side_by_side_")
    results = {"a": [], "b": []}
    try:
        for i in range(args.runs):
            keys = ("a", "b")
            outputs = {key: os.path.join(work, f"{key}{i}") for key in keys}

            def start(key):
                return start_run(getattr(args, key), args.sequence, outputs[key], extra)

            if args.together:
                rows = finish_runs({key: start(key) for key in keys})
            else:
                rows = {key: finish_runs({key: start(key)})[key] for key in keys}
            for key in keys:
                results[key].append(rows[key])
                report(key, i, rows[key])
                shutil.rmtree(outputs[key], ignore_errors=True)  # the maps are large
    finally:
        shutil.rmtree(work, ignore_errors=True)
    medians = {}
    for key, rows in results.items():
        medians[key] = [statistics.median(column) for column in zip(*rows)]
        wall, cpu, peak = medians[key]
        print(f"{key} median: wall {wall:.2f} s, cpu {cpu:.2f} s, peak {peak:.0f} MiB "
              f"({getattr(args, key)})")
    (wall_a, cpu_a, _), (wall_b, cpu_b, _) = medians["a"], medians["b"]
    if args.together:
        ratios = [b[1] / a[1] for a, b in zip(results["a"], results["b"])]
        print(f"b / a: cpu {cpu_b / cpu_a:.3f} (per pair: "
              f"{', '.join(f'{r:.3f}' for r in ratios)}); wall not compared (shared machine)")
    else:
        print(f"b / a: wall {wall_b / wall_a:.3f}, cpu {cpu_b / cpu_a:.3f}")


if __name__ == "__main__":
    main()
