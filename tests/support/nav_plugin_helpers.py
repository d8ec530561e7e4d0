"""Paths shared by the navigator plug-in tests (imported by name: tests/ has no packages)."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = ROOT / "examples" / "straightline_nav"
EXAMPLE_SRC = EXAMPLE / "src"
MISBEHAVING = Path(__file__).resolve().parent / "misbehaving_nav.py"
STDIO = EXAMPLE_SRC / "navstress_example_straightline" / "stdio_nav.py"
