"""Paths shared by the navigator plug-in tests."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "straightline_nav"
EXAMPLE_SRC = EXAMPLE / "src"
MISBEHAVING = Path(__file__).resolve().parent / "navigators" / "misbehaving_nav.py"
STDIO = EXAMPLE_SRC / "navstress_example_straightline" / "stdio_nav.py"
