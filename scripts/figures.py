#!/usr/bin/env python3
"""Current figures: builds every sequence we have with the defaults and prints one table.

The real sequences of ../shared/data (or $STILLMAP_DATA): tum_fr3_teddy_200 (static) and
bonn_crowd_a (three people); the synthetic scenarios of `stillmap synth` (300 frames, seed 1,
rendered once into --synth-dir). Each is built once with the defaults (plus the build arguments
given after `--`). The background bundle adjustment races tracking, so ATE varies by a few
tenths of a millimetre from run to run; scripts/robustness_suite.py repeats runs for that.

Per sequence, from OUT/report.json: frames tracked, ATE RMSE, RPE over 1 s, mean masked share,
mask precision / recall, ghost share and completeness (synthetic: they need the truth), grid
agreement with the static truth and occupied cells with no static truth within a cell,
frames per second of the whole build, peak memory.

  scripts/figures.py [--synth-dir DIR] [--out-dir DIR] [--stillmap PATH] [-- build arguments]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

REAL = ["tum_fr3_teddy_200", "bonn_crowd_a"]
SYNTHETIC = ["static", "walking_xyz", "walking_static", "walking_rpy", "walking_halfsphere",
             "carried_object", "sitting"]


def data_dir():
    if os.environ.get("STILLMAP_DATA"):
        return os.environ["STILLMAP_DATA"]
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data")


def run(command):
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed: {result.stderr.strip()}")


def render(stillmap, scenario, synth_dir):
    sequence = os.path.join(synth_dir, scenario)
    if not os.path.exists(os.path.join(sequence, "synth.json")):
        run([stillmap, "synth", sequence, "--scenario", scenario, "--frames", "300", "--seed", "1"])
    return sequence


def figures(stillmap, sequence, out, extra):
    run([stillmap, "build", sequence, "-o", out, "--quiet"] + extra)
    with open(os.path.join(out, "report.json")) as report_file:
        report = json.load(report_file)
    error = report.get("trajectory_error", {})
    masks = report.get("mask_quality", {})
    quality = report.get("map_quality", {})
    grid = report.get("grid_quality", {})
    frames = report["frames"]
    return {
        "tracked": f"{frames['tracked']} / {frames['pairs_used']}",
        "ate": error.get("ate_m", {}).get("rmse"),
        "rpe_t": error.get("rpe_translation_m", {}).get("rmse"),
        "rpe_r": error.get("rpe_rotation_deg", {}).get("rmse"),
        "masked": report.get("dynamic_share"),
        "precision": masks.get("precision"),
        "recall": masks.get("recall"),
        "ghosts": quality.get("ghost_share"),
        "completeness": quality.get("completeness"),
        "agreement": grid.get("agreement"),
        "false_occupied": grid.get("occupied_without_static_truth"),
        "fps": report["timing"]["frames_per_second"],
        "memory": report["timing"]["peak_memory_mib"],
    }


def cell(value, scale=1.0, digits=1, suffix=""):
    return "-" if value is None else f"{value * scale:.{digits}f}{suffix}"


def mask_scores(name, f):
    if f["precision"] is None:
        return "-"
    if name == "synthetic static":
        return "(nothing moves)"
    return f"{f['precision']:.3f} / {f['recall']:.3f}"


def row(name, f):
    return " | ".join([
        name, f["tracked"], cell(f["ate"], 1e3, 1), cell(f["rpe_t"], 1e3, 1),
        cell(f["rpe_r"], 1, 2), cell(f["masked"], 100, 1, " %"),
        mask_scores(name, f),
        cell(f["ghosts"], 100, 2, " %"), cell(f["completeness"], 100, 1, " %"),
        "-" if f["agreement"] is None else f"{f['agreement']:.3f} / {f['false_occupied']}",
        cell(f["fps"], 1, 1), cell(f["memory"], 1, 0)])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--synth-dir", default=os.path.join(tempfile.gettempdir(), "stillmap_synth"))
    parser.add_argument("--out-dir", default=None, help="keep the builds here (default: a temp dir)")
    parser.add_argument("--stillmap", default=os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "build", "apps", "stillmap"))
    parser.add_argument("extra", nargs="*", help="build arguments (after --)")
    args = parser.parse_args()
    sequences = [(name, os.path.join(data_dir(), name)) for name in REAL]
    missing = [path for _, path in sequences if not os.path.isdir(path)]
    for path in missing:
        print(f"skipping {path}: not found (set STILLMAP_DATA)", file=sys.stderr)
    sequences = [(n, p) for n, p in sequences if p not in missing]
    sequences += [(f"synthetic {s}", render(args.stillmap, s, args.synth_dir)) for s in SYNTHETIC]
    print("| sequence | tracked | ATE RMSE mm | RPE mm, deg (1 s) | masked | mask precision / "
          "recall | ghosts | completeness | grid agreement / false occupied | frames/s | peak MiB |")
    print("|" + " --- |" * 11)
    with tempfile.TemporaryDirectory() as scratch:
        for name, sequence in sequences:
            out = os.path.join(args.out_dir or scratch, name.replace(" ", "_"))
            f = figures(args.stillmap, sequence, out, args.extra)
            line = row(name, f).split(" | ")
            line[3] = f"{line[3]}, {line[4]}"
            del line[4]
            print("| " + " | ".join(line) + " |", flush=True)


if __name__ == "__main__":
    main()
