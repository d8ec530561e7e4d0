"""DESIGN invariant 1: the reference stack imports nothing from navstress.sim or navstress.world."""

from __future__ import annotations

import ast
from pathlib import Path

import navstress.nav.reference as ref

ALLOWED = {"navstress.nav.api", "navstress.robot", "navstress.errors", "navstress.seeding",
           "navstress._jit",  # numba's cache directory, imported by every compiled module (no world data)
           "navstress._records",  # the maker of a kernel's named record (numpy only, no world data)
           "navstress._models", "navstress.specfile"}  # the config's strict model and bounded file reader


def test_reference_stack_sees_no_ground_truth() -> None:
    files = sorted(Path(ref.__file__).parent.glob("*.py"))
    assert len(files) >= 7
    for f in files:
        for node in ast.walk(ast.parse(f.read_text())):
            mods = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            for m in mods:
                if m.startswith("navstress"):
                    assert m in ALLOWED or m.startswith("navstress.nav.reference"), f"{f.name} imports {m}"
