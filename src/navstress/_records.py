"""Named records for compiled kernels: one-row numpy structured arrays whose every field is named.

A kernel's constants travel as one record (``p[0].field`` inside numba) rather than a long list of
positional values (docs/design.md, "Named state"). :func:`full_record` makes one and refuses a
field missing or unknown, so that adding a field to a record's dtype makes every place that builds
it say so.

    >>> import numpy as np
    >>> GRID = np.dtype([("cell", np.float64), ("sub", np.int64)], align=True)
    >>> full_record(GRID, "GRID", {"cell": 0.4, "sub": 4})["sub"]
    array([4])
    >>> full_record(GRID, "GRID", {"cell": 0.4, "subs": 4})
    Traceback (most recent call last):
    ...
    TypeError: GRID fields missing: ['sub'], unknown: ['subs']
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["full_record"]


def full_record(dtype: np.dtype[Any], what: str, values: Mapping[str, Any]) -> np.ndarray:
    """A one-record array of ``dtype`` holding ``values``; TypeError (naming the record ``what``)
    unless they give every field of ``dtype`` and nothing else."""
    fields = frozenset(dtype.names or ())
    if values.keys() != fields:
        raise TypeError(f"{what} fields missing: {sorted(fields - set(values))}, "
                        f"unknown: {sorted(set(values) - fields)}")
    p = np.zeros(1, dtype)
    for name, v in values.items():
        p[name] = v
    return p
