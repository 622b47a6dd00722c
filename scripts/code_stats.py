#!/usr/bin/env python3
"""Lines per module and the longest functions of the project's C++ sources.

Usage: scripts/code_stats.py [--top N] [ROOT]

A module is a top-level folder (detectors/ and its sub-folders counted as one, with the
sub-folders listed under it). Function lengths come from Universal Ctags' `end:` field (lambdas
inside a function count towards it). Tests, benches and fuzzers are listed but not ranked.
"""
import argparse
import collections
import os
import subprocess
import sys

SOURCE_EXT = (".h", ".cc", ".cpp")
SKIP = {"build", "build_fuzz", "build_sanitize", ".git", "third_party"}
NOT_RANKED = {"tests", "bench", "fuzz"}


def sources(root):
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if d not in SKIP and not d.startswith("build"))
        for f in sorted(filenames):
            if f.endswith(SOURCE_EXT):
                yield os.path.relpath(os.path.join(dirpath, f), root)


def count_lines(path):
    with open(path, encoding="utf-8", errors="replace") as f:
        return sum(1 for _ in f)


def functions(root, files):
    """(length, name, file, line) of every function definition ctags finds."""
    out = subprocess.run(
        ["ctags", "--c++-kinds=f", "--fields=+ne", "--extras=-F", "-o", "-"] + list(files),
        cwd=root, capture_output=True, text=True, check=True).stdout
    result = []
    for row in out.splitlines():
        parts = row.split("\t")
        fields = dict(p.split(":", 1) for p in parts[3:] if ":" in p)
        if "line" not in fields or "end" not in fields or parts[0].startswith("__anon"):
            continue
        scope = fields.get("class") or fields.get("struct") or ""
        name = (scope.split("::")[-1] + "::" if scope else "") + parts[0]
        line, end = int(fields["line"]), int(fields["end"])
        result.append((end - line + 1, name, parts[1], line))
    return result


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("root", nargs="?", default=os.path.join(os.path.dirname(__file__), ".."))
    ap.add_argument("--top", type=int, default=5)
    args = ap.parse_args()
    root = os.path.abspath(args.root)
    files = list(sources(root))
    per_module = collections.Counter()
    per_sub = collections.Counter()
    for f in files:
        parts = f.split(os.sep)
        module = parts[0] if len(parts) > 1 else "."
        n = count_lines(os.path.join(root, f))
        per_module[module] += n
        if len(parts) > 2:
            per_sub[os.path.join(parts[0], parts[1])] += n
    total = sum(n for m, n in per_module.items() if m not in NOT_RANKED)
    print("lines per module (library sources; %d in all):" % total)
    for m, n in sorted(per_module.items(), key=lambda x: -x[1]):
        share = "" if m in NOT_RANKED else " %4.1f%%" % (100.0 * n / total)
        print("  %-12s %6d%s" % (m + "/", n, share))
        for s, k in sorted(per_sub.items()):
            if s.startswith(m + os.sep) and m not in NOT_RANKED:
                print("    %-22s %6d" % (s + "/", k))
    ranked = [f for f in files if f.split(os.sep)[0] not in NOT_RANKED]
    longest = sorted(functions(root, ranked), reverse=True)[:args.top]
    print("longest functions (library sources):")
    for n, name, f, line in longest:
        print("  %4d  %s  (%s:%d)" % (n, name, f, line))
    return 0


if __name__ == "__main__":
    sys.exit(main())
