"""A strict JSON parser for tests: ``NaN``, ``Infinity`` and ``-Infinity`` (which Python's
``json`` reads, but which are not JSON) raise instead of parsing."""

from __future__ import annotations

import json
from typing import Any


def _refuse(word: str) -> Any:
    raise ValueError(f"{word} is not JSON")


def strict_loads(text: str) -> Any:
    """``json.loads(text)``, refusing the non-standard constants."""
    return json.loads(text, parse_constant=_refuse)


def strict_lines(text: str) -> list[Any]:
    """Every non-empty line of a JSON Lines text, each parsed strictly."""
    return [strict_loads(ln) for ln in text.splitlines() if ln.strip()]
