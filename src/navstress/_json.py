"""The JSON text navstress writes: strict JSON (RFC 8259) that any parser reads.

Python's ``json`` writes a non-finite float as the bare words ``NaN``, ``Infinity`` and
``-Infinity``, which are not JSON: ``jq``, JavaScript's ``JSON.parse`` and most other parsers
refuse the whole document. Every JSON writer of the package goes through :func:`dumps`, which
writes such a value as ``null`` (a missing number: a goal distance that is unknown, a rate of
no runs) and then serialises with ``allow_nan=False``, so a value it did not clean is an error
here, never invalid JSON in a file. A test checks that no other writer calls ``json.dumps`` or
``json.dump`` without ``allow_nan=False``.

    >>> dumps({"goal_distance_m": float("nan"), "rates": (0.5, float("inf"))})
    '{"goal_distance_m": null, "rates": [0.5, null]}'
"""

from __future__ import annotations

import json
import math
from typing import Any

__all__ = ["dumps", "finite", "pretty"]


def finite(obj: Any) -> Any:
    """``obj`` with every non-finite float (in dicts, lists and tuples, at any depth) replaced
    by None; tuples become lists, as JSON has only arrays."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite(v) for v in obj]
    return obj


def dumps(obj: Any, **kw: Any) -> str:
    """``json.dumps(obj, **kw)`` with non-finite floats written as ``null`` (strict JSON)."""
    return json.dumps(finite(obj), allow_nan=False, **kw)


def pretty(obj: Any) -> str:
    """Indented strict JSON (NaN/inf written as null; keys as text): what commands print."""
    def keys(x: Any) -> Any:
        if isinstance(x, dict):
            return {str(k): keys(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [keys(v) for v in x]
        return x
    return dumps(keys(obj), indent=2, sort_keys=False)
