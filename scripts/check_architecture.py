#!/usr/bin/python3
"""The rules of docs/architecture.md, checked on the tree (a ctest test runs this).

- Below app/, no folder includes the simulator: `#include "sim/..."` only in sim/, app/, tests/, bench/
  (python/, the Python module, is beside app/: it reads stores and never includes the simulator).
- storage/ is four rooms (video, index, writer, tools): video/ includes no other room, index/ only
  video/, writer/ and tools/ only index/ and video/. No SQL statement outside storage/index/ (tests
  and bench aside). The offline readers include nothing from storage/writer/.
- The offline readers (storage, calib, protocol, report, export, dataset, replay, python) include nothing
  from capture/, the drivers: what a frame's bytes mean is codec/'s.
- The include graph between folders has no cycle and is at most 7 levels deep.
- No function of the product is longer than 120 lines; app/ holds at most 2,000 lines, no file over 300.
- No module below app/ reads the environment (settings and test faults come down as values).

- With `--graphviz FILE` (CMake's `--graphviz` output): the offline libraries (report, export, replay,
  protocol, dataset, python, storage's index, video and tools, the calibration commands) link neither the
  recording, the store's live writer, the drivers, the simulator, Aravis nor libusb; the readers (report,
  export, replay, protocol, the calibration commands) link only the index and video rooms of storage;
  only the app, tests and benchmarks link the simulator.

`--graph` prints the folder graph (what docs/architecture.md draws) and each folder's depth.
"""
import os
import re
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
PRODUCT = ["core", "codec", "capture", "sync", "lighting", "calib", "storage", "session", "protocol", "console", "report", "export",
           "dataset", "replay", "sim", "app", "python"]
NOT_PRODUCT = {"tests", "bench", "build", "scripts", "docs", "rig-configs", ".git"}
MAX_DEPTH = 7
OFFLINE_FOLDERS = ["storage", "lighting", "calib", "protocol", "report", "export", "dataset", "replay", "python"]
MAX_FUNCTION_LINES = 120
# app/ wires: each command a thin parse-and-call over a library function (docs/architecture.md).
MAX_APP_LINES = 2000
MAX_APP_FILE_LINES = 300
# storage/'s rooms, and the rooms each may include (docs/architecture.md, "storage/").
STORAGE_ROOMS = {"video": set(), "index": {"video"}, "writer": {"index", "video"}, "tools": {"index", "video"}}
SQL_ROOM = "storage/index"
INCLUDE = re.compile(r'^\s*#\s*include\s+"([a-z_]+)/[^"]+"', re.M)
# A statement of SQL: a string literal that starts with a statement keyword and names a table.
SQL = re.compile(r'"\s*(SELECT\s|INSERT\s+INTO|UPDATE\s+\w+\s+SET|DELETE\s+FROM|CREATE\s+(TABLE|INDEX)|'
                 r'PRAGMA\s+\w+|ALTER\s+TABLE|DROP\s+TABLE|BEGIN\b|COMMIT\b)')


def app_size_problems():
    """app/ stays wiring: its sources at most MAX_APP_LINES lines, none over MAX_APP_FILE_LINES."""
    problems, total = [], 0
    for path in sorted(sources("app")):
        lines = read(path).count("\n")
        total += lines
        if lines > MAX_APP_FILE_LINES:
            problems.append(f"{os.path.relpath(path, ROOT)}: {lines} lines (an app/ file holds at most "
                            f"{MAX_APP_FILE_LINES}: move the work into a library)")
    if total > MAX_APP_LINES:
        problems.append(f"app/: {total} lines of sources (at most {MAX_APP_LINES}: app/ wires, libraries work)")
    return problems


def sources(folder):
    for dirpath, _, files in os.walk(os.path.join(ROOT, folder)):
        for f in files:
            if f.endswith((".cpp", ".h")):
                yield os.path.join(dirpath, f)


def read(path):
    with open(path, encoding="utf-8", errors="replace") as f:
        return f.read()


def folder_graph():
    graph = {f: set() for f in PRODUCT if os.path.isdir(os.path.join(ROOT, f))}
    for folder in graph:
        for path in sources(folder):
            for dep in INCLUDE.findall(read(path)):
                if dep != folder and dep in graph:
                    graph[folder].add(dep)
    return graph


def depths(graph):
    """Levels of each folder (a folder that includes nothing of ours is level 1); None on a cycle."""
    memo, visiting = {}, set()

    def level(f):
        if f in memo:
            return memo[f]
        if f in visiting:
            raise ValueError(f)
        visiting.add(f)
        memo[f] = 1 + max((level(d) for d in graph[f]), default=0)
        visiting.discard(f)
        return memo[f]

    try:
        return {f: level(f) for f in graph}
    except ValueError as cycle:
        return {"cycle": str(cycle)}


def storage_room_problems():
    """storage/'s files are in its rooms, and each room includes only the rooms below it."""
    problems = []
    for path in sources("storage"):
        rel = os.path.relpath(path, ROOT)
        parts = rel.split(os.sep)
        room = parts[1] if len(parts) > 2 else None
        if room not in STORAGE_ROOMS:
            problems.append(f"{rel}: outside storage/'s rooms ({', '.join(STORAGE_ROOMS)})")
            continue
        for other in re.findall(r'^\s*#\s*include\s+"storage/([a-z_]+)/', read(path), re.M):
            if other != room and other not in STORAGE_ROOMS[room]:
                problems.append(f"{rel}: storage/{room}/ includes storage/{other}/ (it may include "
                                f"{', '.join(sorted(STORAGE_ROOMS[room])) or 'no other room'})")
    return problems


def strip_comments_and_strings(text):
    """The text with comments, string and character literals blanked (newlines kept), in one pass."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            end = text.find(")" + m.group(1) + '"', i) if m else -1
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append('""' + "\n" * text.count("\n", i, j))
            i = j
        elif c == "'" and i > 0 and text[i - 1].isalnum():  # a digit separator: 200'000
            out.append(c)
            i += 1
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + c)
            i = j + 1 if j < n and text[j] == c else j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def long_functions(path):
    """(name, lines) of every function body longer than the limit: a brace block opened after a ')' (and
    qualifiers) at namespace or class level."""
    text = strip_comments_and_strings(read(path))
    found, depth, stack = [], 0, []
    i = 0
    while i < len(text):
        c = text[i]
        if c == "{":
            head = text[max(0, i - 300):i]
            is_function = re.search(r"\)\s*(const|noexcept|override|final|mutable|->\s*[\w:<>,\s*&]+|\s)*$", head) \
                and not re.search(r"\b(if|for|while|switch|catch)\s*\(.*\)\s*$", head.split("\n")[-1]) \
                and not re.search(r"(=|return|\(|,)\s*\[[^\]]*\]\s*\([^)]*\)\s*(mutable\s*)?(->\s*[\w:<>]+\s*)?$", head)
            inside_function = any(s[0] for s in stack)
            name = ""
            if is_function and not inside_function:
                m = re.search(r"([\w:~]+)\s*\([^()]*(\([^()]*\)[^()]*)*\)[^)]*$", head)
                name = m.group(1) if m else "?"
            stack.append((bool(is_function and not inside_function), text.count("\n", 0, i), name))
            depth += 1
        elif c == "}" and stack:
            is_function, start, name = stack.pop()
            depth -= 1
            if is_function:
                lines = text.count("\n", 0, i) - start + 1
                if lines > MAX_FUNCTION_LINES:
                    found.append((name, lines, start + 1))
        i += 1
    return found


OFFLINE = ["pvcap_python", "pvcap_storage_index", "pvcap_storage_video", "pvcap_storage_tools", "pvcap_protocol", "pvcap_report", "pvcap_export", "pvcap_dataset", "pvcap_replay", "pvcap_calib_session",
           "pvcap_codec"]
NOT_OFFLINE = ["pvcap_session", "pvcap_storage_writer", "pvcap_console", "pvcap_capture", "pvcap_sim", "PkgConfig::ARAVIS",
               "PkgConfig::LIBUSB", "PkgConfig::UMOCKDEV"]
MAY_LINK_SIM = {"pvcap_sim", "pvcap_sim_pictures", "pvcap_app_lib", "pvcap"}
# What reads a finished session links of storage/ its index and video only (not the tools that rewrite one).
READERS = ["pvcap_report", "pvcap_export", "pvcap_replay", "pvcap_protocol", "pvcap_calib_session"]


def link_graph(dot_file):
    """target -> the targets it links, from CMake's --graphviz output."""
    names, edges = {}, {}
    with open(dot_file) as f:
        for line in f:
            m = re.match(r'\s*"(node\d+)" \[ label = "([^"]+)"', line)
            if m:
                names[m.group(1)] = m.group(2)
            m = re.match(r'\s*"(node\d+)" -> "(node\d+)"', line)
            if m:
                edges.setdefault(m.group(1), set()).add(m.group(2))
    return {names[a]: {names[b] for b in bs} for a, bs in edges.items() if a in names}


def links_transitively(graph, target):
    seen, todo = set(), [target]
    while todo:
        for d in graph.get(todo.pop(), ()):
            if d not in seen:
                seen.add(d)
                todo.append(d)
    return seen


def check_links(dot_file, problems):
    graph = link_graph(dot_file)
    for target in OFFLINE:
        if target not in graph and not any(target in v for v in graph.values()):
            problems.append(f"{target}: not in {dot_file}")
            continue
        bad = sorted(links_transitively(graph, target) & set(NOT_OFFLINE))
        if bad:
            problems.append(f"{target} (an offline library) links {', '.join(bad)}")
    for target in READERS:
        if "pvcap_storage_tools" in links_transitively(graph, target):
            problems.append(f"{target} (a reader) links pvcap_storage_tools (readers link storage's index and video)")
    for target in graph:
        if target in MAY_LINK_SIM or target.endswith("_tests") or target.endswith("_bench") or \
                target.startswith("fuzz") or target in ("make_store_seeds", "extract_sensel_seeds", "make_export_fixture"):
            continue
        if {"pvcap_sim", "pvcap_sim_pictures"} & links_transitively(graph, target):
            problems.append(f"{target} links the simulator (only app/, tests/ and bench/ may)")


def main():
    problems = []
    if "--graphviz" in sys.argv:
        check_links(sys.argv[sys.argv.index("--graphviz") + 1], problems)
    for folder in PRODUCT:
        if folder in ("sim", "app"):
            continue
        for path in sources(folder):
            if re.search(r'#\s*include\s+"sim/', read(path)):
                problems.append(f"{os.path.relpath(path, ROOT)}: includes the simulator (only sim/, app/, tests/ and "
                                f"bench/ may)")
    for folder in PRODUCT:
        if folder in ("app", "sim"):
            continue
        for path in sources(folder):
            if re.search(r"\bgetenv\s*\(", strip_comments_and_strings(read(path))):
                problems.append(f"{os.path.relpath(path, ROOT)}: reads the environment (settings come from app/ as "
                                f"values)")
    for folder in PRODUCT:
        for path in sources(folder):
            rel = os.path.relpath(path, ROOT)
            if rel.startswith(SQL_ROOM + "/"):
                continue
            for n, line in enumerate(read(path).split("\n"), 1):
                if SQL.search(line):
                    problems.append(f"{rel}:{n}: an SQL statement outside {SQL_ROOM}/")
    problems += storage_room_problems()
    problems += app_size_problems()
    for folder in OFFLINE_FOLDERS:
        for path in sources(folder):
            if re.search(r'#\s*include\s+"capture/', read(path)):
                problems.append(f"{os.path.relpath(path, ROOT)}: an offline reader includes the drivers (capture/); "
                                f"what a frame's bytes mean is in codec/")
            if folder != "storage" and re.search(r'#\s*include\s+"storage/writer/', read(path)):
                problems.append(f"{os.path.relpath(path, ROOT)}: an offline reader includes the live writer "
                                f"(storage/writer/)")
    graph = folder_graph()
    d = depths(graph)
    if "cycle" in d:
        problems.append(f"the include graph between folders has a cycle through {d['cycle']}/")
    else:
        for f, level in d.items():
            if level > MAX_DEPTH:
                problems.append(f"{f}/ is {level} levels deep (at most {MAX_DEPTH})")
    for folder in PRODUCT:
        for path in sources(folder):
            for name, lines, line in long_functions(path):
                problems.append(f"{os.path.relpath(path, ROOT)}:{line}: {name} is {lines} lines (at most "
                                f"{MAX_FUNCTION_LINES})")
    if "--graph" in sys.argv:
        for f in sorted(graph, key=lambda f: (d.get(f, 0), f)):
            print(f"{f:9} level {d.get(f, '?')}: {', '.join(sorted(graph[f])) or '-'}")
    for p in problems:
        print(p)
    if problems:
        print(f"{len(problems)} problem{'s' if len(problems) != 1 else ''} with the architecture's rules "
              f"(docs/architecture.md)")
        return 1
    print("architecture: no simulator below app/, storage/ in its rooms, no SQL outside storage/index/, no driver "
          "or live writer in an offline reader, "
          f"no folder cycle, app/ within {MAX_APP_LINES} lines (no file over {MAX_APP_FILE_LINES}), at most "
          f"{max(d.values())} levels, no function over {MAX_FUNCTION_LINES} lines")
    return 0


if __name__ == "__main__":
    sys.exit(main())
