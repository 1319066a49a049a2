#!/usr/bin/env python3
"""Robustness suite (issue 17): stillmap on clips nobody tuned for.

Each sequence is built whole and, when it is long enough, as overlapping clips
(--clip-frames frames starting every --clip-step frames). Default builds are not repeatable (the
background bundle adjustment races tracking), so every clip is built --runs times and its worst
run counts. Per clip: ATE RMSE and max [mm], frames lost / relocalized, new local maps, mean masked
share, frames per second; then the worst clip and the median over clips.

Then the synthetic scenarios of `stillmap synth` (crowd_start, lens_pass, stop_and_go, and
busy_office, which holds the three at once; 300
frames, seed 1, rendered once into --synth-dir): ATE, ghost share, mask precision and recall, and
the mask recall over the frames in which a person stands still, worst run of --runs.

  scripts/robustness_suite.py [--sequence DIR]... [--runs 3] [--no-synthetic]
                              [--synth-dir DIR] [-- extra build arguments]

Without --sequence: ../shared/data/bonn_crowd_a (or $STILLMAP_DATA/bonn_crowd_a).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile


def frame_count(sequence):
    with open(os.path.join(sequence, "rgb.txt")) as listing:
        return sum(1 for line in listing if line.strip() and not line.startswith("#"))


def build(stillmap, sequence, first, frames, extra, out):
    command = [stillmap, "build", sequence, "-o", out, "--quiet"]
    if frames:
        command += ["--set", f"sequence.first_frame={first}", "--set", f"sequence.max_frames={frames}"]
    command += extra
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed: {result.stderr.strip()}")
    with open(os.path.join(out, "report.json")) as report_file:
        report = json.load(report_file)
    ate = report.get("trajectory_error", {}).get("ate_m")
    if ate is None:
        raise RuntimeError(f"{sequence}: no ATE in report.json (is there a groundtruth.txt?)")
    tracking = report["tracking"]
    quality = report.get("map_quality", {})
    masks = report.get("mask_quality", {})
    still = masks.get("while_still", {})
    return {
        "precision": masks.get("precision"),
        "recall": masks.get("recall"),
        "ghost_share": quality.get("ghost_share"),
        "still_recall": still.get("recall"),
        "ate_rmse_mm": 1000.0 * ate["rmse"],
        "ate_max_mm": 1000.0 * ate["max"],
        "lost": tracking["lost"],
        "relocalized": tracking["relocalized"],
        "new_maps": tracking["new_maps"],
        "masked_share": report["masking"].get("mean_masked_share", 0.0),
        "fps": report["timing"]["frames_per_second"],
    }


def clips(sequence, clip_frames, clip_step):
    total = frame_count(sequence)
    yield ("whole", 0, 0)
    if total <= clip_frames:
        return
    for first in range(0, total - clip_frames + 1, clip_step):
        yield (f"{first}+{clip_frames}", first, clip_frames)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    data = os.environ.get("STILLMAP_DATA", os.path.join(root, "..", "shared", "data"))
    parser.add_argument("--stillmap", default=os.path.join(root, "build", "apps", "stillmap"))
    parser.add_argument("--sequence", action="append", help="sequence folder (repeatable)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--clip-frames", type=int, default=300)
    parser.add_argument("--clip-step", type=int, default=50)
    parser.add_argument("--no-synthetic", action="store_true", help="skip the synthetic scenarios")
    parser.add_argument("--synth-dir", default=os.path.join(tempfile.gettempdir(), "stillmap_suite_synth"),
                        help="where the synthetic scenarios are rendered (once)")
    parser.add_argument("extra", nargs="*", help="further build arguments, after --")
    args = parser.parse_args()
    sequences = args.sequence or [os.path.join(data, "bonn_crowd_a")]
    for sequence in sequences:
        if not os.path.isfile(os.path.join(sequence, "rgb.txt")):
            sys.exit(f"robustness_suite: {sequence}: not a sequence folder (set STILLMAP_DATA or "
                     "pass --sequence)")

    header = (f"{'sequence':<22}{'clip':>10}{'ATE mm':>9}{'max mm':>9}{'lost':>6}{'reloc':>6}"
              f"{'maps':>6}{'masked':>8}{'fps':>7}   (worst of {args.runs} runs)")
    print(header)
    worst_clips = []
    with tempfile.TemporaryDirectory() as scratch:
        for sequence in sequences:
            name = os.path.basename(os.path.normpath(sequence))
            for label, first, frames in clips(sequence, args.clip_frames, args.clip_step):
                runs = [build(args.stillmap, sequence, first, frames, args.extra,
                              os.path.join(scratch, f"run{i}")) for i in range(args.runs)]
                worst = max(runs, key=lambda run: run["ate_rmse_mm"])
                worst["ate_max_mm"] = max(run["ate_max_mm"] for run in runs)
                print(f"{name:<22}{label:>10}{worst['ate_rmse_mm']:>9.1f}{worst['ate_max_mm']:>9.1f}"
                      f"{worst['lost']:>6}{worst['relocalized']:>6}{worst['new_maps']:>6}"
                      f"{100 * worst['masked_share']:>7.1f}%{worst['fps']:>7.1f}", flush=True)
                if label != "whole":
                    worst_clips.append((worst["ate_rmse_mm"], worst["ate_max_mm"], name, label))
        if not args.no_synthetic:
            synthetic(args, scratch)
    if worst_clips:
        rmse, peak, name, label = max(worst_clips)
        print(f"worst clip: {name} {label}: {rmse:.1f} mm RMSE ({peak:.1f} mm max); "
              f"median over {len(worst_clips)} clips: "
              f"{statistics.median(c[0] for c in worst_clips):.1f} mm; "
              f"largest error in any clip: {max(c[1] for c in worst_clips):.1f} mm")


def synthetic(args, scratch):
    print(f"{'scenario':<22}{'ATE mm':>9}{'max mm':>9}{'ghosts':>9}{'precision':>11}{'recall':>8}"
          f"{'still recall':>14}   (worst of {args.runs} runs)")
    for scenario in ("crowd_start", "lens_pass", "stop_and_go", "busy_office"):
        sequence = os.path.join(args.synth_dir, scenario)
        if not os.path.isfile(os.path.join(sequence, "synth.json")):
            subprocess.run([args.stillmap, "synth", sequence, "--scenario", scenario, "--frames",
                            "300", "--seed", "1"], check=True, capture_output=True)
        runs = [build(args.stillmap, sequence, 0, 0, args.extra, os.path.join(scratch, f"s{i}"))
                for i in range(args.runs)]
        worst = lambda key, pick: pick(run[key] for run in runs if run[key] is not None)
        still = worst("still_recall", min) if scenario in ("stop_and_go", "busy_office") else None
        print(f"{scenario:<22}{worst('ate_rmse_mm', max):>9.1f}{worst('ate_max_mm', max):>9.1f}"
              f"{100 * worst('ghost_share', max):>8.2f}%"
              f"{worst('precision', min):>11.3f}{worst('recall', min):>8.3f}"
              f"{'' if still is None else f'{still:.3f}':>14}", flush=True)


if __name__ == "__main__":
    main()
