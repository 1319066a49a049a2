#!/usr/bin/env python3
"""Fails when a module includes the public header of a module it may not depend on. The arrows
(the same in the README's "For developers", CMakeLists.txt and each module's README) point
downwards only: io at the bottom; tracking's three parts (tracker, detectors, masking -> detectors)
and mapping on io; synth on io; viewer on mapping; pipeline on all of these but synth; apps on
pipeline, synth and viewer. Usage: module_arrows.py ROOT."""
import pathlib
import re
import sys

FOLDERS = {
    "io": "io", "mapping": "mapping", "synth": "synth", "viewer": "viewer",
    "pipeline": "pipeline", "apps": "apps", "tracking/tracker": "tracker",
    "tracking/detectors": "detectors", "tracking/masking": "masking",
}
ALLOWED = {
    "io": set(),
    "tracker": {"io"},
    "detectors": {"io"},
    "masking": {"io", "detectors"},
    "mapping": {"io"},
    "synth": {"io"},
    "viewer": {"io", "mapping"},
    "pipeline": {"io", "tracker", "detectors", "masking", "mapping", "viewer"},
    "apps": {"io", "pipeline", "synth", "viewer"},
}
INCLUDE = re.compile(r'#include "(stillmap/[^"]+)"')


def main():
    root = pathlib.Path(sys.argv[1])
    owner = {}
    for folder, module in FOLDERS.items():
        for header in (root / folder).glob("include/stillmap/*/*.h"):
            owner[str(header.relative_to(root / folder / "include"))] = module
    wrong = []
    for folder, module in FOLDERS.items():
        for path in sorted((root / folder).rglob("*")):
            if path.suffix not in (".h", ".cpp"):
                continue
            for line_number, line in enumerate(path.read_text().splitlines(), 1):
                match = INCLUDE.search(line)
                if not match:
                    continue
                target = owner.get(match.group(1))
                if target is None:
                    wrong.append(f"{path}:{line_number}: {match.group(1)} is no module's header")
                elif target != module and target not in ALLOWED[module]:
                    wrong.append(f"{path}:{line_number}: {module} may not include {target} "
                                 f"({match.group(1)})")
    for line in wrong:
        print(line)
    print(f"{len(FOLDERS)} modules; {len(wrong)} includes against the arrows")
    return 1 if wrong else 0


if __name__ == "__main__":
    sys.exit(main())
