"""Importing navstress, its plug-in contract or its CLI does no work: no numba, no MuJoCo, no
compiler, no hashing of the sources (checked in fresh interpreters, not timed; the times are
benchmarks/bench_import.py's)."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src" / "navstress"

#: Modules a fresh interpreter must not hold after the import (heavy, or doing work when imported).
HEAVY = ("numba", "llvmlite", "mujoco", "navstress._jit", "navstress.sim.native", "matplotlib", "scipy")

_PROBE = """
import json, os, sys
opened = []
def hook(event, args):
    if event == "open" and isinstance(args[0], (str, bytes)):
        opened.append(os.fsdecode(args[0]))
sys.addaudithook(hook)
import {module}
print(json.dumps({{"heavy": [m for m in {heavy!r} if m in sys.modules],
                  "modules": sorted(m for m in sys.modules if m.startswith("navstress")),
                  "opened": opened}}))
"""


def _probe(module: str, heavy: tuple[str, ...] = HEAVY) -> dict[str, list[str]]:
    """In a fresh interpreter, ``import module``: which of ``heavy`` it pulled, the navstress modules
    it holds, the files it opened."""
    code = _PROBE.format(module=module, heavy=heavy)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out: dict[str, list[str]] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


@pytest.mark.parametrize("module", ["navstress", "navstress.nav.api", "navstress.nav", "navstress.errors",
                                    "navstress.robot", "navstress.cli"])
def test_import_pulls_no_heavy_module(module: str) -> None:
    got = _probe(module)
    assert got["heavy"] == [], f"import {module} pulled {got['heavy']}"


@pytest.mark.parametrize("module", ["navstress", "navstress.nav.api"])
def test_import_reads_no_source_file_it_does_not_import(module: str) -> None:
    """Hashing the source tree (numba's cache directory) reads every file; an import reads only
    the files of the modules it imports."""
    got = _probe(module)
    imported = set(got["modules"])
    read = set()
    for path in got["opened"]:
        p = Path(path)
        if p.suffix in (".py", ".c") and SRC in p.resolve().parents:
            rel = p.resolve().relative_to(SRC.parent).with_suffix("")
            parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
            read.add(".".join(parts))
    assert read <= imported, f"import {module} read {sorted(read - imported)}"


def _njit_cached(tree: ast.Module) -> bool:
    for node in ast.walk(tree):
        if isinstance(node, ast.keyword) and node.arg == "cache" and isinstance(node.value, ast.Constant) \
                and node.value.value is True:
            return True
    return False


def _imports_jit_first(tree: ast.Module) -> bool:
    """``import navstress._jit`` at module level, before the first decorated definition."""
    for node in tree.body:
        if isinstance(node, ast.Import) and any(a.name == "navstress._jit" for a in node.names):
            return True
        if isinstance(node, ast.ImportFrom) and node.module == "navstress" and \
                any(a.name == "_jit" for a in node.names):
            return True
        if isinstance(node, (ast.FunctionDef, ast.ClassDef, ast.Assign)) and \
                any(True for _ in getattr(node, "decorator_list", [])):
            return False
    return False


COMPILED = sorted(p for p in SRC.rglob("*.py") if _njit_cached(ast.parse(p.read_text(encoding="utf-8"))))


def test_compiled_modules_exist() -> None:
    assert len(COMPILED) >= 5, COMPILED


@pytest.mark.parametrize("path", COMPILED, ids=lambda p: str(p.relative_to(SRC)))
def test_every_cached_kernel_module_sets_the_numba_cache_first(path: Path) -> None:
    """numba reads its cache directory when ``@njit(cache=True)`` runs: every module that caches
    compiled code imports navstress._jit before its first decorator."""
    assert _imports_jit_first(ast.parse(path.read_text(encoding="utf-8"))), \
        f"{path.relative_to(SRC)}: add `import navstress._jit` before the first @njit(cache=True)"


def test_help_imports_no_command_module() -> None:
    """``navstress --help`` lists every command from the mount table, importing none of them."""
    code = ("import sys; from navstress.cli import main; sys.argv = ['navstress', '--help']\n"
            "try:\n    main()\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.startswith('navstress.cli.') or m in "
            f"{HEAVY!r}))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().splitlines()[-1] == "[]", proc.stdout


#: What a module's own commands never use, so importing it must not import them: the search's
#: algorithm libraries (pyribs, pymoo: 1-3 s) and scipy's image, graph and rotation modules (0.3-0.5 s).
NOT_NEEDED = {
    "navstress.cli.analysis": ("ribs", "pymoo"),  # report, analyze: read a search's files, run no algorithm
    "navstress.campaign.work": ("ribs", "pymoo", "scipy.ndimage", "scipy.sparse", "scipy.spatial"),
    "navstress.cli.run": ("ribs", "pymoo", "scipy.ndimage", "scipy.sparse", "scipy.spatial"),
}


@pytest.mark.parametrize("module", sorted(NOT_NEEDED))
def test_commands_do_not_import_what_they_never_use(module: str) -> None:
    got = _probe(module, NOT_NEEDED[module])
    assert got["heavy"] == [], f"import {module} pulled {got['heavy']}"
