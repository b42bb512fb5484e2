#!/usr/bin/env python3
"""Import cycles between sibling modules of each crate (DEVELOPERS.md: no two modules of a crate
import each other, directly or through others).

Every `crate::…`, `super::…` and `self::…` path in a crate's source (use declarations, braces
expanded, and paths written inline) is resolved to the module that defines it, following
`pub use` re-exports. An edge from module A to module B counts between the two children of
their deepest common ancestor that contain them: `run::driver` using `run::recorder` is an edge
driver → recorder under `run`; `report::context` using `run::RunOutput` is an edge report → run
at the crate root. A child using its own ancestor (`super::X` defined in the parent's `mod.rs`)
is not a sibling edge (`-v` lists those). Unit-test modules (`#[cfg(test)] mod tests`) are left
out: a test may use its module's siblings.

Usage: tools/module_cycles.py [crate-dir …]   (default: estimator sim scenarios)
Exit status 1 when a cycle is found. Prints each cycle with one reference per edge.
"""

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def module_of(src: Path, f: Path):
    """The module path of source file `f` under `src` (a tuple), or None for binaries."""
    rel = f.relative_to(src)
    parts = list(rel.parts)
    if parts[0] == "bin":
        return None
    if parts == ["lib.rs"]:
        return ()
    name = parts[-1][:-3]
    if name == "mod":
        return tuple(parts[:-1])
    return tuple(parts[:-1] + [name])


def strip_comments(text: str) -> str:
    # Unit tests (`#[cfg(test)] mod tests` at the end of a file) may use their module's
    # siblings: they are not part of the module graph.
    cut = re.search(r"#\[cfg\(test\)\]\s*mod \w+\s*\{", text)
    if cut:
        text = text[: cut.start()]
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    # String literals could hold `crate::`: blank them.
    return re.sub(r'"(?:[^"\\]|\\.)*"', '""', text)


def expand(tree: str):
    """`a::{b, c::{d, e}}` → ['a::b', 'a::c::d', 'a::c::e']."""
    tree = tree.strip()
    i = tree.find("{")
    if i < 0:
        return [tree.split(" as ")[0].strip()]
    prefix = tree[:i]
    body = tree[i + 1 : tree.rfind("}")]
    parts, depth, cur = [], 0, ""
    for ch in body:
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        depth += ch == "{"
        depth -= ch == "}"
        cur += ch
    parts.append(cur)
    out = []
    for p in parts:
        if p.strip():
            out += [prefix + q for q in expand(p)]
    return out


USE = re.compile(r"\b(pub(?:\([^)]*\))?\s+)?use\s+([^;]+);")
INLINE = re.compile(r"(?<![\w:])((?:crate|super|self)(?:::\w+)+)")


def absolute(path: str, module: tuple, is_mod_file: bool):
    """`path` (crate::/super::/self::…) as components from the crate root; None if external."""
    parts = [p for p in path.split("::") if p]
    if not parts:
        return None
    if parts[0] == "crate":
        return parts[1:]
    base = list(module)
    if parts[0] in ("self", "super"):
        while parts and parts[0] in ("self", "super"):
            if parts[0] == "super":
                base = base[:-1]
            parts = parts[1:]
        return base + parts
    return None


def main():
    crates = sys.argv[1:] or ["estimator", "sim", "scenarios"]
    found = False
    for crate in crates:
        src = ROOT / crate / "src"
        files = {}
        for f in sorted(src.rglob("*.rs")):
            m = module_of(src, f)
            if m is not None:
                files[m] = strip_comments(f.read_text())
        modules = set(files)
        # Re-exports: module → name → absolute target path.
        reexports = {}
        uses = {}
        for m, text in files.items():
            for vis, tree in USE.findall(text):
                for p in expand(" ".join(tree.split())):
                    a = absolute(p, m, True)
                    if a is None:
                        # `pub use child::X` inside a module: relative to it.
                        first = p.split("::")[0]
                        if m + (first,) in modules:
                            a = list(m) + p.split("::")
                        else:
                            continue
                    uses.setdefault(m, []).append(a)
                    if vis:
                        reexports.setdefault(m, {})[a[-1]] = a
            for p in INLINE.findall(text):
                a = absolute(p, m, True)
                if a is not None:
                    uses.setdefault(m, []).append(a)

        def resolve(path, depth=0):
            k = 0
            while k < len(path) and tuple(path[: k + 1]) in modules:
                k += 1
            mod = tuple(path[:k])
            rest = path[k:]
            if rest and depth < 8:
                target = reexports.get(mod, {}).get(rest[0])
                if target is not None and target != path:
                    return resolve(target + rest[1:], depth + 1)
            return mod

        # Sibling edges per parent, with one example reference each.
        edges = {}
        ancestors = []
        for m, refs in uses.items():
            for r in refs:
                t = resolve(r)
                if t == m:
                    continue
                k = 0
                while k < min(len(m), len(t)) and m[k] == t[k]:
                    k += 1
                if k == len(t):
                    ancestors.append((m, t, "::".join(r)))
                    continue
                if k == len(m):
                    continue  # a module using its own descendant
                parent, a, b = m[:k], m[k], t[k]
                edges.setdefault(parent, {}).setdefault(a, {}).setdefault(
                    b, ("::".join(m), "::".join(r))
                )
        for parent, graph in sorted(edges.items()):
            for comp in sccs(graph):
                if len(comp) < 2:
                    continue
                found = True
                where = "::".join((crate,) + parent)
                print(f"cycle in {where}: {' ↔ '.join(sorted(comp))}")
                for a in sorted(comp):
                    for b, (f, r) in sorted(graph.get(a, {}).items()):
                        if b in comp:
                            print(f"    {a} → {b}   ({f} uses {r})")
        if "-v" in sys.argv:
            for m, t, r in sorted(set(ancestors)):
                print(f"  {crate}::{'::'.join(m)} leans on ancestor {'::'.join(t) or 'crate root'} ({r})")
    if not found:
        print("no cycles between sibling modules")
    return 1 if found else 0


def sccs(graph):
    """Tarjan's strongly connected components."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]
    nodes = set(graph) | {b for v in graph.values() for b in v}

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, {}):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            out.append(comp)

    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return out


if __name__ == "__main__":
    sys.exit(main())
