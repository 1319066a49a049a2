#!/usr/bin/env python3
"""Fails when a configuration key ("tracking.place_tables") is typed by hand in a string literal
of the modules' sources: messages, checks and help texts take the key from the option registry
(io/option_names.h: OptionKey). The registry itself (the structs' VisitFields, pipeline/config.h,
and the former names in pipeline/src/config.cpp) is where keys are written; a line marked
"// file format" documents a key inside a file format that must not change. Usage:
option_names.py ROOT STILLMAP (the binary, whose `build --help` lists every key)."""
import argparse
import pathlib
import re
import subprocess
import sys

MODULES = ["apps", "io", "mapping", "pipeline", "synth", "tracking", "viewer"]
STRING = re.compile(r'"(?:[^"\\\n]|\\.)*"')
COMMENT = re.compile(r"//[^\n]*")


def literals(text):
    """The string literals of C++ source outside comments (comments name keys freely)."""
    for line_number, line in enumerate(text.splitlines(), 1):
        code = line
        # Drop a trailing comment that is not inside a string.
        out, in_string, i = [], False, 0
        while i < len(code):
            if code[i] == '"' and (i == 0 or code[i - 1] != "\\"):
                in_string = not in_string
            if not in_string and code.startswith("//", i):
                break
            out.append(code[i])
            i += 1
        for match in STRING.finditer("".join(out)):
            yield line_number, match.group(0)


def in_registry(path, text, line_number):
    """VisitFields bodies and the former-names table are the registry."""
    lines = text.splitlines()
    for back in range(line_number - 1, max(-1, line_number - 60), -1):
        line = lines[back]
        if "VisitFields(" in line or "kFormer" in line:
            return True
        if re.match(r"^(\S.*\)\s*(const)?\s*\{|\};)\s*$", line):
            return False
    return False


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root")
    parser.add_argument("stillmap")
    args = parser.parse_args()
    help_text = subprocess.run([args.stillmap, "build", "--help"], capture_output=True, text=True,
                               check=True).stdout
    keys = re.findall(r"^  ([a-z_]+\.[a-z0-9_]+) = ", help_text, re.M)
    if len(keys) < 100:
        print(f"only {len(keys)} keys in `{args.stillmap} build --help`")
        return 1
    pattern = re.compile(r"(?<![\w])(?<!\w\.)(" + "|".join(re.escape(k) for k in keys) + r")(?![\w])")
    found = []
    root = pathlib.Path(args.root)
    for module in MODULES:
        for path in sorted((root / module).rglob("*")):
            if path.suffix not in (".h", ".cpp"):
                continue
            text = path.read_text(errors="replace")
            lines = text.splitlines()
            for line_number, literal in literals(text):
                if "// file format" in lines[line_number - 1]:
                    continue
                for match in pattern.finditer(literal):
                    if not in_registry(path, text, line_number):
                        found.append(f"{path.relative_to(root)}:{line_number}: {match.group(1)}")
    for line in found:
        print(line)
    print(f"{len(keys)} keys; {len(found)} typed by hand outside the registry")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
