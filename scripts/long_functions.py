#!/usr/bin/env python3
"""List C++ function bodies longer than a limit (default 120 lines) outside tests.

usage: scripts/long_functions.py [--limit N] [DIR ...]   (default DIRS: runtime plugins tools)

A function is a definition whose body opens with '{' at the end of a line that starts at the
namespace's indentation (column 0, the house style: no indentation inside namespaces) and
closes with '}' at column 0. Lambdas and class bodies are counted with their enclosing
function. Exit status 1 when any is longer than the limit, so a CI step can use it.
"""
import argparse
import os
import re
import sys

SIGNATURE_END = re.compile(r"\)\s*(const)?\s*(noexcept)?\s*(override)?\s*(->\s*[\w:<>,\s*&]+)?\s*\{\s*$")
NOT_A_FUNCTION = re.compile(r"^(namespace|class|struct|enum|union|extern|template\s*<[^>]*>\s*(class|struct))\b")


def functions(path):
    """Yields (name line, first line number, body length in lines) of column-0 definitions."""
    with open(path, encoding="utf-8", errors="replace") as f:
        lines = f.read().split("\n")
    i = 0
    while i < len(lines):
        line = lines[i]
        if line and not line[0].isspace() and not line.startswith(("//", "#", "}")) and not NOT_A_FUNCTION.match(line):
            # The signature may span lines: join until the line ending in '{' (at most 8 lines).
            j, text = i, line
            while not SIGNATURE_END.search(text) and j + 1 < len(lines) and j - i < 8 and not text.rstrip().endswith(";"):
                j += 1
                text += " " + lines[j].strip()
            is_type = re.match(r"^template\s*<.*>\s*(class|struct|union)\b", text)
            if SIGNATURE_END.search(text) and "(" in text and "=" not in text.split("(")[0] and not is_type:
                k = j + 1
                while k < len(lines) and not lines[k].startswith("}"):
                    k += 1
                yield line.strip(), i + 1, k - j - 1
                i = k + 1
                continue
        i += 1


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--limit", type=int, default=120)
    parser.add_argument("dirs", nargs="*", default=["runtime", "plugins", "tools"])
    args = parser.parse_args()
    long = []
    for top in args.dirs:
        for root, _, files in os.walk(top):
            if "/tests" in root or root.startswith("tests"):
                continue
            for name in sorted(files):
                if name.endswith((".cpp", ".hpp", ".cc", ".h")):
                    path = os.path.join(root, name)
                    for signature, line, length in functions(path):
                        if length > args.limit:
                            long.append((length, path, line, signature))
    for length, path, line, signature in sorted(long, reverse=True):
        print(f"{path}:{line}: {length} lines: {signature[:100]}")
    print(f"{len(long)} function(s) over {args.limit} lines", file=sys.stderr)
    return 1 if long else 0


if __name__ == "__main__":
    sys.exit(main())
