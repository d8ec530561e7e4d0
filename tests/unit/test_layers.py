"""The layer map of docs/design.md ("Layers"), checked on the static import graph of src/: every
module parsed with ast, every import counted (module level, function level, and TYPE_CHECKING
ones for the layer rule; TYPE_CHECKING ones are left out of the cycle check, as Python never
runs them). ``from package import name`` counts as an import of the submodule that the
package's ``__init__`` re-exports ``name`` from."""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src"

#: Layer of each part, lowest first: a module may import its own layer and the layers below.
LAYERS: dict[str, int] = {
    # base: no navstress imports beyond this layer
    "navstress": 0, "navstress.errors": 0, "navstress.seeding": 0, "navstress.specfile": 0,
    "navstress._console": 0, "navstress._files": 0, "navstress._flags": 0, "navstress._jit": 0,
    "navstress._paths": 0, "navstress._tables": 0, "navstress.sequential": 0, "navstress._json": 0,
    "navstress._percent": 0, "navstress._models": 0, "navstress._bar": 0,
    "navstress.robot": 1, "navstress.sensors": 1,
    # the navigator side and the world side, side by side (neither imports the other)
    "navstress.nav": 2, "navstress.isolate": 2, "navstress.world": 2,
    "navstress.sim": 3,
    "navstress.run": 4,
    "navstress.campaign": 5,
    "navstress.analysis": 6,
    # the search: candidates over the campaign store, its objectives may use the analysis
    "navstress.search": 7,
    "navstress.cli": 8, "navstress._facade": 8,
}

#: Parts a part never imports even when the layer order would allow it.
FORBIDDEN: dict[str, tuple[str, ...]] = {
    "navstress.nav": ("navstress.sim", "navstress.world"),  # DESIGN invariant 1: no ground truth
    "navstress.isolate": ("navstress.sim", "navstress.world"),
    "navstress.world": ("navstress.nav", "navstress.isolate"),
}

#: A package's lazy facade (``__getattr__``) may name a higher layer: ``navstress.run_mission``.
FACADES = {("navstress", "navstress._facade")}



@dataclass(frozen=True)
class Edge:
    src: str
    dst: str
    line: int
    type_only: bool


def _modules() -> dict[str, Path]:
    out = {}
    for p in (SRC / "navstress").rglob("*.py"):
        parts = list(p.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


MODULES = _modules()


def _is_package(name: str) -> bool:
    return MODULES[name].name == "__init__.py"


def _reexports(package: str) -> dict[str, str]:
    """name -> module for ``from module import name`` at the top of a package's ``__init__``."""
    out = {}
    for node in ast.parse(MODULES[package].read_text(encoding="utf-8")).body:
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 and node.module in MODULES:
            for a in node.names:
                out[a.asname or a.name] = node.module
    return out


def _type_checking_lines(tree: ast.Module) -> set[int]:
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for sub in node.body:
                for n in ast.walk(sub):
                    if hasattr(n, "lineno"):
                        lines.add(n.lineno)
    return lines


def _edges(name: str) -> list[Edge]:
    tree = ast.parse(MODULES[name].read_text(encoding="utf-8"))
    type_only = _type_checking_lines(tree)
    out: list[Edge] = []
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if _is_package(name) else name.split(".")[:-1]
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            for a in node.names:
                full = f"{mod}.{a.name}"
                if full in MODULES:
                    targets.append(full)
                elif mod in MODULES and _is_package(mod):
                    targets.append(_reexports(mod).get(a.name, mod))
                else:
                    targets.append(mod)
        for t in targets:
            while t and t not in MODULES and "." in t:  # `import a.b.c` of a name inside a module
                t = t.rsplit(".", 1)[0]
            if t in MODULES and t != name:
                out.append(Edge(name, t, node.lineno, node.lineno in type_only))
    return out


EDGES = [e for m in sorted(MODULES) for e in _edges(m)]


def _part(module: str) -> str:
    best = ""
    for part in LAYERS:
        if (module == part or module.startswith(part + ".")) and len(part) > len(best):
            best = part
    assert best, f"{module} is in no layer of the map: add it to LAYERS and docs/design.md"
    return best


def test_every_module_is_on_the_map() -> None:
    for m in MODULES:
        _part(m)


def test_the_graph_is_not_empty() -> None:
    assert len(EDGES) > 300 and any(e.src == "navstress.run.mission" for e in EDGES)


@pytest.mark.parametrize("part", sorted(LAYERS))
def test_no_import_reaches_up_a_layer(part: str) -> None:
    bad = []
    for e in EDGES:
        if _part(e.src) != part or (e.src, e.dst) in FACADES:
            continue
        dst = _part(e.dst)
        if LAYERS[dst] > LAYERS[part] or any(dst == f or dst.startswith(f + ".") for f in FORBIDDEN.get(part, ())):
            bad.append(f"{e.src}:{e.line} imports {e.dst}{' (TYPE_CHECKING)' if e.type_only else ''}")
    assert not bad, "\n".join(bad)


def _runtime_graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for e in EDGES:
        if not e.type_only:
            graph[e.src].add(e.dst)
    return graph


def _cycles(graph: dict[str, set[str]] | None = None) -> list[frozenset[str]]:
    """Strongly connected components of more than one module (Tarjan), runtime imports only."""
    graph = _runtime_graph() if graph is None else graph
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[frozenset[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
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
            if len(comp) > 1:
                out.append(frozenset(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle() -> None:
    cycles = [sorted(c) for c in _cycles()]
    assert not cycles, cycles


def test_the_cycle_check_finds_cycles() -> None:
    g = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": {"f"}, "f": {"e"}, "g": set()}
    assert sorted(sorted(c) for c in _cycles(g)) == [["a", "b", "c"], ["e", "f"]]
