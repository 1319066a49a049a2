#!/usr/bin/env python3
"""Digests of a build folder for before/after comparisons of a change that must not alter
behaviour: SHA-256 of the map, grid and trajectory files, and of report.json without its
timings, speed, memory and other run-dependent figures. Usage: output_digest.py OUT_DIR...
(a developer tool; needs python3, which the two README commands do not)."""
import hashlib
import json
import pathlib
import sys

FILES = ["trajectory.txt", "keyframes.txt", "map.ply", "map.pcd", "grid.pgm", "grid.yaml"]
# Keys whose values change from run to run on the same input: report.json keeps every timing,
# speed and memory figure under "timing"; "sequence", "command" and a session's "folder" are paths
# as given.
VOLATILE = ("timing", "sequence", "command", "folder")


def stable(value):
    if isinstance(value, dict):
        return {k: stable(v) for k, v in value.items() if not k.startswith(VOLATILE)}
    if isinstance(value, list):
        return [stable(v) for v in value]
    return value


def digest(folder):
    folder = pathlib.Path(folder)
    lines = []
    for name in FILES:
        path = folder / name
        text = hashlib.sha256(path.read_bytes()).hexdigest() if path.exists() else "absent"
        lines.append(f"{text[:16]}  {name}")
    report = stable(json.loads((folder / "report.json").read_text()))
    text = json.dumps(report, sort_keys=True).encode()
    lines.append(f"{hashlib.sha256(text).hexdigest()[:16]}  report.json (figures)")
    return lines


for folder in sys.argv[1:]:
    print(folder)
    for line in digest(folder):
        print("  " + line)
