#!/usr/bin/env python3
"""Fails when a source file of the project is longer than a screen allows (STYLE.md: small files
with one job): every .cpp, .h, .py, .sh and CMake file under ROOT (build folders and .git left
out) must hold at most MAX lines.

usage: file_lengths.py ROOT [--max LINES]
"""
import argparse
import os
import sys

EXTENSIONS = (".cpp", ".h", ".py", ".sh", ".cmake")


def sources(root):
    for folder, subfolders, files in os.walk(root):
        subfolders[:] = sorted(d for d in subfolders
                               if not d.startswith(("build", ".")) and d != "node_modules")
        for name in sorted(files):
            if name.endswith(EXTENSIONS) or name == "CMakeLists.txt":
                yield os.path.join(folder, name)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("root")
    parser.add_argument("--max", type=int, default=500)
    args = parser.parse_args()
    long_files = []
    count = 0
    for path in sources(args.root):
        count += 1
        with open(path, "rb") as f:
            lines = f.read().count(b"\n")
        if lines > args.max:
            long_files.append((lines, os.path.relpath(path, args.root)))
    for lines, path in sorted(long_files, reverse=True):
        print(f"{path}: {lines} lines, more than {args.max}: split it by what its parts do")
    print(f"{count} files read, {len(long_files)} over {args.max} lines")
    return 1 if long_files else 0


if __name__ == "__main__":
    sys.exit(main())
