"""The campaign package's import graph: no cycle (every import counted, function-local ones
too), the scheduling core below its executors, and imports at the top of its modules."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import navstress

SRC = Path(navstress.__file__).parent
#: Function-local imports kept on purpose: (module, imported module) -> why.
LOCAL_IMPORTS_KEPT = {("navstress.campaign.ray_executor", "ray"): "optional extra; reads its environment on import"}


def _module(path: Path) -> str:
    rel = path.relative_to(SRC.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path) -> list[tuple[str, bool]]:
    """(imported module, inside a function) for every import of ``path``; ``from a import b``
    counts as ``a.b`` when ``a.b`` is a module, else ``a``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    local: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            local |= {id(n) for n in ast.walk(node) if n is not node}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, id(node) in local) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for a in node.names:
                sub = f"{node.module}.{a.name}"
                is_mod = (SRC.parent / sub.replace(".", "/")).with_suffix(".py").is_file() or \
                    (SRC.parent / sub.replace(".", "/") / "__init__.py").is_file()
                out.append((sub if is_mod else node.module, id(node) in local))
    return out


def _graph() -> dict[str, set[str]]:
    g: dict[str, set[str]] = {}
    for p in SRC.rglob("*.py"):
        g[_module(p)] = {m for m, _ in _imports(p) if m.startswith("navstress")}
    return g


def _cycles_through(g: dict[str, set[str]], prefix: str) -> list[list[str]]:
    """Every elementary cycle found by a depth-first walk from the modules under ``prefix``."""
    found: list[list[str]] = []

    def walk(node: str, path: list[str]) -> None:
        for nxt in sorted(g.get(node, ())):
            if nxt == path[0]:
                found.append(path + [nxt])
            elif nxt not in path and nxt.startswith(prefix):
                walk(nxt, path + [nxt])

    for start in sorted(m for m in g if m.startswith(prefix)):
        walk(start, [start])
    return found


def test_campaign_has_no_import_cycle() -> None:
    g = _graph()
    assert "navstress.campaign.scheduler" in g and "navstress.campaign.executors" in g
    assert _cycles_through(g, "navstress.campaign") == []


def test_the_cycle_finder_finds_cycles() -> None:
    g = {"navstress.campaign.a": {"navstress.campaign.b"}, "navstress.campaign.b": {"navstress.campaign.a"}}
    assert _cycles_through(g, "navstress.campaign")


def test_scheduler_knows_no_executor() -> None:
    """The core imports no executor; executors import the core, not each other or the driver."""
    g = _graph()
    executors = {"navstress.campaign.local", "navstress.campaign.ray_executor", "navstress.campaign.executors"}
    for core in ("navstress.campaign.scheduler", "navstress.campaign.work"):
        assert not g[core] & executors, (core, g[core] & executors)
    assert "navstress.campaign.ray_executor" not in g["navstress.campaign.local"]
    assert "navstress.campaign.local" not in g["navstress.campaign.ray_executor"]
    assert not g["navstress.isolate"] & {m for m in g if m.startswith(("navstress.campaign", "navstress.run"))}


def test_imports_are_at_the_top() -> None:
    files = ["campaign/executors.py", "campaign/scheduler.py", "campaign/local.py", "campaign/work.py",
             "campaign/ray_executor.py", "isolate.py"]
    found = {(_module(SRC / f), m) for f in files for m, inside in _imports(SRC / f) if inside}
    assert found == set(LOCAL_IMPORTS_KEPT)


def test_one_worker_loop() -> None:
    """Campaign workers, ``navstress run`` and ``nav check`` share one worker loop and process
    handle (``navstress.isolate``): nothing else in src/ reads a worker's pipe or sets up a
    worker process."""
    pattern = re.compile(r"\.recv\(\)|die_with_parent\(|get_context\(\"spawn\"\)")
    users = sorted(str(p.relative_to(SRC)) for p in SRC.rglob("*.py") if pattern.search(p.read_text(encoding="utf-8")))
    assert users == ["isolate.py"]
    g = _graph()
    assert "navstress.isolate" in g["navstress.campaign.local"] and "navstress.isolate" in g["navstress.run.batch"]
