#!/usr/bin/env python3
"""The link table of the project's libraries, read from the CMakeLists.txt files, and its checks.

    python3 scripts/link_table.py                        print the table (docs/design.md's format)
    python3 scripts/link_table.py --check docs/design.md check the CMake files, the includes and
                                                         the docs' "Link dependencies" block
    python3 scripts/link_table.py --write docs/design.md replace that block by the printed table

The CMake files are read from the top-level CMakeLists.txt down its add_subdirectory() calls, in
order: that order is the layer order (a library is defined after every library it links). Each
library's files are its folder's .h and .cc files (a sub-folder with a library of its own is that
library's); an executable's are its sources and the project headers outside any library folder
they include (tests' and apps' helpers), followed to the end.

--check fails (exit 1, one line per problem) where
  - a library links a project library defined later (a back-edge, which any cycle has),
  - a library's files include a project library's header and it does not link that library
    itself, or it links a project library none of its files includes (every link is stated
    where it is used: declared links == included libraries),
  - an executable's files include a header of a project library it does not link, directly or
    through the libraries it links,
  - the docs' block differs from the printed table (each differing edge named).
Python 3 standard library only.
"""

import argparse
import os
import re
import sys

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir))
PREFIX = "omnistereo_"
BLOCK_INTRO = "Link dependencies"

# Third-party link items as the docs name them; others are shown as written.
THIRD_PARTY = {
    "Eigen3::Eigen": "Eigen",
    "yaml-cpp": "yaml-cpp",
    "${OpenCV_LIBS}": "OpenCV",
    "NLopt::nlopt_cxx": "NLopt",
    "Ceres::ceres": "Ceres",
    "apriltag": "libapriltag",
    "opencv_aruco": "opencv_aruco",
    "ZLIB::ZLIB": "zlib",
    "${LIBDEFLATE_LIBRARY}": "libdeflate",
    "PkgConfig::CAIRO": "cairo",
    "gflags": "gflags",
    "glog::glog": "glog",
    "benchmark::benchmark": "Google Benchmark",
    "GTest::gtest": "GoogleTest",
    "GTest::gtest_main": "GoogleTest",
}
KEYWORDS = {"PUBLIC", "PRIVATE", "INTERFACE", "STATIC", "SHARED", "OBJECT", "MODULE",
            "EXCLUDE_FROM_ALL", "LINK_PUBLIC", "LINK_PRIVATE"}
# Executables that appear in the table (after the libraries): their folders.
TABLE_EXECUTABLE_FOLDERS = ("python", "apps")

INCLUDE_RE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


class Target:
    def __init__(self, name, kind, folder, order):
        self.name = name
        self.kind = kind          # "library" or "executable"
        self.folder = folder      # relative to ROOT, "" for the top level
        self.order = order
        self.sources = []         # relative to ROOT
        self.links = []           # link items in order, as written
        self.module = False       # pybind11_add_module

    def label(self):
        if self.kind == "library":
            return self.name
        return "%s (%s/)" % (self.name, self.folder)


def cmake_commands(text):
    """(command, [arguments]) of a CMake file, comments removed, quotes kept as one argument."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == "#":
            j = text.find("\n", i)
            i = n if j < 0 else j
            continue
        m = re.match(r"[A-Za-z_][A-Za-z0-9_]*", text[i:])
        if not m:
            i += 1
            continue
        name = m.group(0)
        j = i + len(name)
        while j < n and text[j] in " \t":
            j += 1
        if j >= n or text[j] != "(":
            i = j
            continue
        depth, k, args, cur, in_quote = 1, j + 1, [], "", False
        while k < n and depth > 0:
            ch = text[k]
            if in_quote:
                cur += ch
                if ch == '"' and text[k - 1] != "\\":
                    in_quote = False
            elif ch == '"':
                in_quote = True
                cur += ch
            elif ch == "#":
                e = text.find("\n", k)
                k = n if e < 0 else e
                continue
            elif ch == "(":
                depth += 1
                cur += ch
            elif ch == ")":
                depth -= 1
                if depth > 0:
                    cur += ch
            elif ch in " \t\r\n":
                if cur:
                    args.append(cur)
                cur = ""
            else:
                cur += ch
            k += 1
        if cur:
            args.append(cur)
        out.append((name.lower(), args))
        i = k
    return out


def read_cmake():
    """Targets by name, in the order CMake defines them."""
    targets = {}
    order = [0]

    def new(name, kind, folder):
        t = Target(name, kind, folder, order[0])
        order[0] += 1
        targets[name] = t
        return t

    def sources_of(folder, args):
        out = []
        for a in args:
            if a in KEYWORDS or "$" in a:
                continue
            out.append(os.path.normpath(os.path.join(folder, a)))
        return out

    def visit(folder):
        path = os.path.join(ROOT, folder, "CMakeLists.txt")
        with open(path) as f:
            commands = cmake_commands(f.read())
        for cmd, args in commands:
            if not args:
                continue
            if cmd == "add_subdirectory":
                visit(os.path.normpath(os.path.join(folder, args[0])))
            elif cmd == "add_library":
                new(args[0], "library", folder).sources += sources_of(folder, args[1:])
            elif cmd in ("add_executable", "omni_test", "pybind11_add_module"):
                if args[0].startswith("${"):
                    continue  # a function's body (tests/: omni_test's add_executable(${name} ...))
                t = new(args[0], "executable", folder)
                t.sources += sources_of(folder, args[1:])
                t.module = cmd == "pybind11_add_module"
            elif cmd == "target_sources" and args[0] in targets:
                targets[args[0]].sources += sources_of(folder, args[1:])
            elif cmd == "target_link_libraries" and args[0] in targets:
                targets[args[0]].links += [a for a in args[1:] if a not in KEYWORDS]

    visit("")
    return targets


def includes_of(path):
    try:
        with open(os.path.join(ROOT, path), errors="replace") as f:
            text = f.read()
    except OSError:
        return []
    return [inc for inc in INCLUDE_RE.findall(text) if os.path.isfile(os.path.join(ROOT, inc))]


class Project:
    def __init__(self):
        self.targets = read_cmake()
        self.libraries = sorted((t for t in self.targets.values() if t.kind == "library"),
                                key=lambda t: t.order)
        self.by_folder = {t.folder: t for t in self.libraries}

    def library_of(self, path):
        """The library whose folder holds `path` (deepest library folder), or None."""
        d = os.path.dirname(path)
        while True:
            if d in self.by_folder:
                return self.by_folder[d]
            if not d:
                return None
            d = os.path.dirname(d)

    def project_links(self, t):
        return [self.targets[l] for l in t.links
                if l in self.targets and self.targets[l].kind == "library"]

    def third_party(self, t):
        out = []
        if t.module:
            out += ["pybind11", "Python 3"]
        for l in t.links:
            if l in self.targets:
                continue
            name = THIRD_PARTY.get(l, l)
            if name not in out:
                out.append(name)
        return out

    def closure(self, t):
        seen, stack = set(), [t]
        while stack:
            for dep in self.project_links(stack.pop()):
                if dep.name not in seen:
                    seen.add(dep.name)
                    stack.append(dep)
        return seen

    def files_of(self, t):
        """The files whose includes count for t."""
        if t.kind == "library":
            full = os.path.join(ROOT, t.folder)
            files = [os.path.join(t.folder, f) for f in sorted(os.listdir(full))
                     if f.endswith((".h", ".cc", ".cpp", ".hpp"))]
            return sorted(set(files) | set(t.sources))
        files, stack = [], list(t.sources)
        while stack:
            f = stack.pop()
            if f in files:
                continue
            files.append(f)
            for inc in includes_of(f):
                if self.library_of(inc) is None:
                    stack.append(inc)
        return sorted(files)

    def included_libraries(self, t):
        """{library name: [(file, header), ...]} of the project libraries t's files include."""
        out = {}
        for f in self.files_of(t):
            for inc in includes_of(f):
                lib = self.library_of(inc)
                if lib is not None and lib.name != t.name:
                    out.setdefault(lib.name, []).append((f, inc))
        return out

    def short(self, name):
        return name[len(PREFIX):] if name.startswith(PREFIX) else name

    def table_targets(self):
        exes = [t for t in self.targets.values()
                if t.kind == "executable" and t.folder in TABLE_EXECUTABLE_FOLDERS]
        return self.libraries + sorted(exes, key=lambda t: t.order)

    def table(self):
        rows = []
        for t in self.table_targets():
            deps = [self.short(d.name) for d in sorted(self.project_links(t), key=lambda d: d.order)]
            deps = list(dict.fromkeys(deps))
            rows.append((t.label(), ("<- " + ", ".join(deps)) if deps else "",
                         "[" + ", ".join(self.third_party(t)) + "]" if self.third_party(t) else ""))
        # Names in one column; the third-party libraries in another where the links leave room.
        w0 = max(len(r[0]) for r in rows) + 1
        w1 = 40
        return [(r[0].ljust(w0) + (r[1].ljust(w1) if len(r[1]) < w1 else r[1] + "  ") + r[2]).rstrip()
                for r in rows]

    def problems(self):
        out = []
        for t in self.libraries:
            for dep in self.project_links(t):
                if dep.order >= t.order:
                    out.append("back-edge: %s (%s/) links %s (%s/), which is defined after it "
                               "(layer order: the add_subdirectory order of the CMake files)"
                               % (t.name, t.folder, dep.name, dep.folder))
            linked = {d.name for d in self.project_links(t)}
            included = self.included_libraries(t)
            for lib, where in sorted(included.items()):
                if lib not in linked:
                    f, inc = where[0]
                    out.append("missing link: %s includes %s (%s) in %s but %s/CMakeLists.txt "
                               "does not link it" % (t.name, inc, lib, f, t.folder))
            for lib in sorted(linked - set(included)):
                out.append("unused link: %s links %s but none of %s/'s files includes its "
                           "headers" % (t.name, lib, t.folder))
        for t in sorted(self.targets.values(), key=lambda t: t.order):
            if t.kind != "executable":
                continue
            reach = self.closure(t)
            for lib, where in sorted(self.included_libraries(t).items()):
                if lib not in reach:
                    f, inc = where[0]
                    out.append("missing link: %s (%s/) includes %s (%s) in %s but links it "
                               "neither directly nor through its libraries" % (t.name, t.folder, inc,
                                                                             lib, f))
        return out


def docs_block(path):
    """(lines of the file, index of the block's first line, index after its last) or None."""
    with open(path) as f:
        lines = f.read().split("\n")
    for i, line in enumerate(lines):
        if line.startswith(BLOCK_INTRO):
            for j in range(i + 1, len(lines)):
                if lines[j].startswith("```"):
                    for k in range(j + 1, len(lines)):
                        if lines[k].startswith("```"):
                            return lines, j + 1, k
                    return None
            return None
    return None


def parse_row(line):
    """(name, [deps], [third-party]) of a table line."""
    m = re.match(r"^(\S+(?: \([^)]*\))?)\s*(?:<-\s*([^\[]*?))?\s*(?:\[(.*)\])?\s*$", line)
    if not m:
        return line.strip(), [], []
    deps = [d.strip() for d in (m.group(2) or "").split(",") if d.strip()]
    third = [d.strip() for d in (m.group(3) or "").split(",") if d.strip()]
    return m.group(1), deps, third


def compare(docs_lines, table_lines, docs_path):
    out = []
    docs = {parse_row(l)[0]: parse_row(l) for l in docs_lines if l.strip()}
    cmake = {parse_row(l)[0]: parse_row(l) for l in table_lines}
    for name, (_, deps, third) in cmake.items():
        if name not in docs:
            out.append("%s: no line for %s (CMake: %s)" % (docs_path, name,
                                                          ", ".join(deps) or "no project library"))
            continue
        _, ddeps, dthird = docs[name]
        for d in deps:
            if d not in ddeps:
                out.append("%s: edge %s <- %s missing (the CMake files link it)" % (docs_path, name, d))
        for d in ddeps:
            if d not in deps:
                out.append("%s: edge %s <- %s not in the CMake files" % (docs_path, name, d))
        if sorted(third) != sorted(dthird):
            out.append("%s: %s's third-party libraries [%s], the CMake files' [%s]"
                       % (docs_path, name, ", ".join(dthird), ", ".join(third)))
    for name in docs:
        if name not in cmake:
            out.append("%s: line for %s, not a library of the CMake files" % (docs_path, name))
    if not out and [l.rstrip() for l in docs_lines if l.strip()] != table_lines:
        out.append("%s: the block's layout or order differs from the printed table "
                   "(scripts/link_table.py --write %s)" % (docs_path, docs_path))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--check", metavar="DOCS", help="check the CMake files, includes and DOCS")
    group.add_argument("--write", metavar="DOCS", help="replace DOCS' link block by the table")
    args = parser.parse_args()
    project = Project()
    table = project.table()
    if args.write:
        found = docs_block(args.write)
        if found is None:
            sys.exit("%s: no '%s' code block" % (args.write, BLOCK_INTRO))
        lines, begin, end = found
        with open(args.write, "w") as f:
            f.write("\n".join(lines[:begin] + table + lines[end:]))
        return 0
    if not args.check:
        print("\n".join(table))
        return 0
    problems = project.problems()
    found = docs_block(args.check)
    if found is None:
        problems.append("%s: no '%s' code block" % (args.check, BLOCK_INTRO))
    else:
        lines, begin, end = found
        problems += compare(lines[begin:end], table, args.check)
    for p in problems:
        print(p)
    if problems:
        print("%d problem(s); the table from the CMake files:" % len(problems))
        print("\n".join(table))
        return 1
    print("link table: %d libraries, layer order and includes consistent with the CMake files "
          "and %s" % (len(project.libraries), args.check))
    return 0


if __name__ == "__main__":
    sys.exit(main())
