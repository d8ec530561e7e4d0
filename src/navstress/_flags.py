"""Parsing of numeric command-line flags into values, or a SpecError naming the flag."""

from __future__ import annotations

import math

from navstress.errors import SpecError


def number(flag: str, raw: str, expected: str) -> float:
    """A finite float from ``raw`` (SpecError naming ``flag`` otherwise)."""
    try:
        v = float(raw)
    except ValueError:
        raise SpecError(flag, raw, expected) from None
    if math.isnan(v) or math.isinf(v):
        raise SpecError(flag, raw, expected)
    return v


def integer(flag: str, raw: str, expected: str) -> int:
    """An int from ``raw`` (SpecError naming ``flag`` otherwise)."""
    try:
        return int(raw)
    except ValueError:
        raise SpecError(flag, raw, expected) from None


def bounded_int(flag: str, raw: str, lo: int, hi: int) -> int:
    """An int in ``[lo, hi]`` from ``raw`` (SpecError naming ``flag`` otherwise)."""
    expected = f"an integer in [{lo}, {hi}]"
    v = integer(flag, raw, expected)
    if not lo <= v <= hi:
        raise SpecError(flag, raw, expected)
    return v
