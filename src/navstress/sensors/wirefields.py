"""What the kinds' line-protocol encoders share (``to_wire`` / ``from_wire`` of each module under
:mod:`navstress.sensors.kinds`; the protocol is :mod:`navstress.nav.wire`, version 2): reading
numbers, triples and names out of a decoded JSON object, with a :class:`ValueError` that says
which field is wrong (the protocol turns it into its own error)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from navstress.sensors.base import decode_array, encode_array


def num(d: Any, key: str, *, finite: bool = True) -> float:
    """``d[key]`` as a float (a JSON number, not a bool); ValueError otherwise."""
    if not isinstance(d, dict):
        raise ValueError(f"a reading is an object, got {type(d).__name__}")
    v = d.get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"field {key!r} is {v!r:.40}, not a number")
    f = float(v)
    if finite and not math.isfinite(f):
        raise ValueError(f"field {key!r} is not finite")
    return f


def vec3(d: Any, key: str) -> tuple[float, float, float]:
    """``d[key]`` as three finite floats."""
    v = d.get(key) if isinstance(d, dict) else None
    if not isinstance(v, list) or len(v) != 3:
        raise ValueError(f"field {key!r} is {v!r:.60}, not a list of 3 numbers")
    x, y, z = (num({"v": e}, "v") for e in v)
    return x, y, z


def text(d: Any, key: str) -> str:
    """``d[key]`` as a string."""
    v = d.get(key) if isinstance(d, dict) else None
    if not isinstance(v, str):
        raise ValueError(f"field {key!r} is {v!r:.40}, not a string")
    return v


def array(d: Any, key: str, *, ndim: int, last: int | None = None) -> np.ndarray:
    """``d[key]``, an :func:`~navstress.sensors.base.encode_array` of float32 with ``ndim``
    dimensions (and ``last`` columns), as a float32 array of the native byte order."""
    if not isinstance(d, dict) or key not in d:
        raise ValueError(f"field {key!r} is missing")
    a = decode_array(d[key], dtype="<f4")
    if a.ndim != ndim or (last is not None and a.shape[-1] != last):
        raise ValueError(f"field {key!r} has shape {list(a.shape)}, expected {ndim} dimensions"
                         + (f" with {last} columns" if last is not None else ""))
    return a.astype(np.float32)


def f32(a: np.ndarray) -> dict[str, Any]:
    """A float32 array for the wire."""
    return encode_array(np.asarray(a, dtype=np.float32))


def pose_fields(r: Any) -> dict[str, Any]:
    """The fields every ray sensor's reading has: ``t``, ``mount``, ``rpy``, ``sensor``."""
    return {"t": float(r.t), "mount": [float(v) for v in r.mount], "rpy": [float(v) for v in r.rpy],
            "sensor": str(r.sensor)}
