#!/usr/bin/env python3
"""Import circles between the modules of each Rust crate and of the Python package.

    python3 scripts/import-cycles.py            # every crate under crates/ and python/selfmanip
    python3 scripts/import-cycles.py --edges    # also print every edge

A Rust module is a file under `src/` (`a/b.rs` and `a/b/mod.rs` are `a::b`); an edge
`a -> b` is a path `crate::b…` (in a `use` or in an expression) or a `super::…` that resolves
to `b`, outside `#[cfg(test)]` modules. A child module's edge to its parent module counts
as the child's own (`a::b -> a` is no cycle with `a -> a::b` when `a` only declares `b`).
A Python module is a file of the package; an edge is a relative import (`from .x import`,
`from . import x`) at any depth of the file. Prints each strongly connected component of
more than one module and exits 1 if there is one, else prints "no import circle".
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def rust_modules(src: Path) -> dict[str, Path]:
    mods = {}
    for f in sorted(src.rglob("*.rs")):
        rel = f.relative_to(src).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "mod":
            parts = parts[:-1]
        if parts in (["lib"], ["main"]):
            parts = []
        if parts and parts[0] == "bin":
            continue
        mods["::".join(parts)] = f
    return mods


def strip_tests(text: str) -> str:
    """Drops `#[cfg(test)] mod … { … }` blocks (brace-matched) and comments."""
    text = re.sub(r"//[^\n]*", "", text)
    out, i = [], 0
    for m in re.finditer(r"#\[cfg\(test\)\]\s*(pub\s+)?mod\s+\w+\s*\{", text):
        if m.start() < i:
            continue
        out.append(text[i : m.start()])
        depth, j = 1, m.end()
        while j < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        i = j
    out.append(text[i:])
    return "".join(out)


def resolve(path: list[str], mods: dict[str, Path]) -> str | None:
    """The longest module prefix of `path`."""
    for k in range(len(path), 0, -1):
        name = "::".join(path[:k])
        if name in mods:
            return name
    return None


def expand_use(body: str) -> list[list[str]]:
    """`a::{b, c::{d, e}}` -> [[a, b], [a, c, d], [a, c, e]] (names only)."""
    body = re.sub(r"\s+", "", body)

    def split_top(s: str) -> list[str]:
        parts, depth, cur = [], 0, ""
        for ch in s:
            if ch == "," and depth == 0:
                parts.append(cur)
                cur = ""
                continue
            depth += {"{": 1, "}": -1}.get(ch, 0)
            cur += ch
        if cur:
            parts.append(cur)
        return parts

    def go(s: str) -> list[list[str]]:
        if "{" in s:
            head, rest = s.split("{", 1)
            rest = rest[: rest.rfind("}")]
            prefix = [p for p in head.split("::") if p]
            return [prefix + sub for item in split_top(rest) for sub in go(item)]
        return [[p for p in re.sub(r"\bas\b.*", "", s).split("::") if p]]

    return go(body)


def rust_edges(src: Path) -> dict[str, set[str]]:
    mods = rust_modules(src)
    edges: dict[str, set[str]] = {m: set() for m in mods}
    for name, f in mods.items():
        here = name.split("::") if name else []
        # a `mod.rs`/`lib.rs` file is its own module; `super` of a file module is its parent
        text = strip_tests(f.read_text())
        paths = []
        for m in re.finditer(r"\buse\s+([^;]+);", text):
            paths += expand_use(m.group(1))
        for m in re.finditer(r"\b((?:crate|super)(?:::\w+)+)", text):
            paths.append(m.group(1).split("::"))
        for p in paths:
            if not p:
                continue
            if p[0] == "crate":
                target = resolve(p[1:], mods)
            elif p[0] == "super":
                base = here[:]
                while p and p[0] == "super":
                    base = base[:-1]
                    p = p[1:]
                target = resolve(base + p, mods) if base + p else ""
            else:
                continue
            if target is None or target == name:
                continue
            # a child naming its ancestor (or the crate root) is not an edge of the tree
            if name.startswith(target + "::") or target == "":
                continue
            edges[name].add(target)
    return edges


def python_edges(pkg: Path) -> dict[str, set[str]]:
    mods = {f.relative_to(pkg).with_suffix("").as_posix().replace("/", "."): f for f in pkg.rglob("*.py")}
    edges: dict[str, set[str]] = {m: set() for m in mods}
    for name, f in mods.items():
        for m in re.finditer(r"^\s*from\s+(\.+)([\w.]*)\s+import\s+([^\n#]+)", f.read_text(), re.M):
            dots, mod, names = m.groups()
            base = name.split(".")[: -len(dots)] if len(dots) else []
            target = ".".join(base + ([mod] if mod else []))
            if mod and target in mods:
                cands = [target]
            else:
                cands = [
                    ".".join(base + [n.strip(" ()")])
                    for n in names.replace("\\", "").split(",")
                    if n.strip(" ()")
                ]
                cands = [c.split(" as ")[0].strip() for c in cands]
            for c in cands:
                if c in mods and c != name and c != "__init__":
                    edges[name].add(c)
    return edges


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of more than one node."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10_000)
    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def main() -> int:
    show_edges = "--edges" in sys.argv
    units = [(c.name, rust_edges(c / "src")) for c in sorted((ROOT / "crates").iterdir()) if (c / "src").is_dir()]
    units.append(("python/selfmanip", python_edges(ROOT / "python" / "selfmanip")))
    found = 0
    for unit, edges in units:
        if show_edges:
            for a in sorted(edges):
                for b in sorted(edges[a]):
                    print(f"{unit}: {a or '(root)'} -> {b}")
        for comp in cycles(edges):
            found += 1
            inner = {a: sorted(b for b in edges[a] if b in comp) for a in comp}
            print(f"{unit}: circle of {len(comp)}: " + "; ".join(f"{a} -> {', '.join(bs)}" for a, bs in inner.items()))
    if not found:
        print("no import circle")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
