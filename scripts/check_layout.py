#!/usr/bin/env python3
"""Checks the core crate's layout: no import circle between its modules, no oversized file.

The modules of `crates/vadop/src` form a pipeline, each stage importing only the stages and the
vocabulary below it. This reads every `crate::`, `super::` and `self::` path of every source file
(in `use` lines and in code), resolves it to the module it names, and fails when:

- two top-level modules (a file, or a folder counted as one) reach each other through imports;
- two files of one folder reach each other (a folder's `mod.rs` may re-export its children's
  items; its children may use what it defines);
- a source file outside `tests/` is longer than `MAX_LINES`, its `#[cfg(test)]` module aside.

Usage: `scripts/check_layout.py [--graph]` from anywhere; `--graph` prints the import graph of
the top-level modules in dependency order (each module after everything it imports).
"""

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORE = ROOT / "crates" / "vadop" / "src"
# About 800 lines: a file a reader can hold in mind. Tests and benches are exempt.
MAX_LINES = 820
SIZE_CHECKED = [ROOT / "crates" / name / "src" for name in ("vadop", "vadop-cli", "vadop-py", "vadop-bench", "vadop-mpi")]


def module_of(path: Path) -> tuple:
    """The module path of a source file: `world/rigid.rs` -> ("world", "rigid")."""
    parts = list(path.relative_to(CORE).with_suffix("").parts)
    if parts[-1] in ("mod", "lib"):
        parts.pop()
    return tuple(parts)


def strip_comments_and_strings(text: str) -> str:
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r'r#*"(?:.|\n)*?"#*', '""', text)
    return re.sub(r'"(?:\\.|[^"\\])*"', '""', text)


def strip_test_modules(text: str) -> str:
    """Drops `#[cfg(test)] mod tests { ... }`: unit tests may reach anything."""
    out, i = [], 0
    for m in re.finditer(r"#\[cfg\(test\)\]\s*mod\s+\w+\s*\{", text):
        if m.start() < i:
            continue
        out.append(text[i : m.start()])
        depth, j = 1, m.end()
        while depth and j < len(text):
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        i = j
    out.append(text[i:])
    return "".join(out)


def expand_use(tree: str) -> list:
    """`a::{b, c::{d, e}}` -> [["a","b"], ["a","c","d"], ["a","c","e"]] (names only)."""
    tree = re.sub(r"\s+", "", tree)
    tree = re.sub(r"\bas\w+", "", tree.replace("as", " as ")).replace(" ", "")

    def parse(s: str, prefix: list) -> list:
        paths, depth, start = [], 0, 0
        parts = []
        for k, ch in enumerate(s):
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
            elif ch == "," and depth == 0:
                parts.append(s[start:k])
                start = k + 1
        parts.append(s[start:])
        for part in filter(None, parts):
            brace = part.find("{")
            if brace >= 0:
                head = [p for p in part[:brace].split("::") if p]
                paths += parse(part[brace + 1 : part.rfind("}")], prefix + head)
            else:
                paths.append(prefix + [p for p in part.split("::") if p])
        return paths

    return parse(tree, [])


def referenced_paths(text: str) -> list:
    """Every module path a file names, from its `use` items and from paths in its code."""
    paths = []
    for m in re.finditer(r"\buse\s+([^;]+);", text):
        paths += expand_use(m.group(1))
    code = re.sub(r"\buse\s+[^;]+;", "", text)
    paths += [p.split("::") for p in re.findall(r"\b(?:crate|super|self)(?:::\w+)+", code)]
    return paths


def resolve(path: list, here: tuple, modules: set, is_mod_file: bool):
    """The module a path names, as the longest known module prefix, or None (extern crates)."""
    if not path:
        return None
    if path[0] == "crate":
        base, rest = (), path[1:]
    elif path[0] in ("self", "super"):
        base = here if is_mod_file else here[:-1]
        rest = path
        while rest and rest[0] in ("self", "super"):
            if rest[0] == "super":
                base = base[:-1]
            rest = rest[1:]
    else:
        return None
    best = base if base in modules else None
    for k in range(1, len(rest) + 1):
        if base + tuple(rest[:k]) in modules:
            best = base + tuple(rest[:k])
    return best


def cycles(graph: dict) -> list:
    """Strongly connected components with more than one node (Tarjan)."""
    index, low, stack, on, found, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def main() -> int:
    files = sorted(CORE.rglob("*.rs"))
    modules = {module_of(f) for f in files}
    top_graph, folder_graphs = {}, {}
    for f in files:
        here = module_of(f)
        if not here:
            continue  # lib.rs re-exports; it is the crate's front, not a stage
        text = strip_test_modules(strip_comments_and_strings(f.read_text()))
        is_mod_file = f.name == "mod.rs"
        top_graph.setdefault(here[0], set())
        for path in referenced_paths(text):
            target = resolve(path, here, modules, is_mod_file)
            if target is None or not target:
                continue
            if target[0] != here[0]:
                top_graph[here[0]].add(target[0])
            elif len(here) > 1 and len(target) > 1 and not is_mod_file:
                # Siblings inside one folder (a child using its folder's mod.rs is fine).
                folder = here[:-1]
                if target[:-1] == folder and target != here:
                    folder_graphs.setdefault(folder, {}).setdefault(here, set()).add(target)

    failures = []
    for component in cycles(top_graph):
        failures.append("import circle between modules: " + " <-> ".join(component))
        for a in component:
            into = sorted(b for b in top_graph[a] if b in component)
            failures.append(f"    {a} imports {', '.join(into)}")
    for folder, graph in sorted(folder_graphs.items()):
        for component in cycles(graph):
            names = ["::".join(c) for c in component]
            failures.append(f"import circle inside {'/'.join(folder)}/: " + " <-> ".join(names))
    for src in SIZE_CHECKED:
        for f in sorted(src.rglob("*.rs")):
            # Unit tests beside the code do not count: the limit is on what a reader must hold.
            lines = strip_test_modules(f.read_text()).count("\n")
            if lines > MAX_LINES:
                failures.append(f"{f.relative_to(ROOT)}: {lines} lines besides its unit tests (at most {MAX_LINES}): split it by concept")

    if "--graph" in sys.argv:
        done, order = set(), []

        def place(v, trail=()):
            if v in done or v in trail:
                return
            for w in sorted(top_graph.get(v, ())):
                place(w, trail + (v,))
            done.add(v)
            order.append(v)

        for v in sorted(top_graph):
            place(v)
        for v in order:
            print(f"{v:18} <- {', '.join(sorted(top_graph[v])) or '(nothing)'}")
    for line in failures:
        print(line, file=sys.stderr)
    if failures:
        return 1
    print(f"layout: {len(modules) - 1} modules, no import circle, no file over {MAX_LINES} lines", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
