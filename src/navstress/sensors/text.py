"""Sensor entries as a person types them on the command line (``--sensor``, ``--sensor-add``)::

    NAME=KIND[:PROFILE][,KEY=VALUE...]

``KEY`` is one of the kind's parameters (``max_range_m=30``), ``mount`` (the name of one of the
robot's mounts, or ``X:Y:Z`` in meters) or ``rpy`` (``R:P:Y`` in radians, with an ``X:Y:Z``
mount). Or the path of a YAML/JSON file holding a list of sensor entries (as ``sensors:`` in a
spec), or a mapping with that list under ``sensors``. The entries are the mappings a spec's
``sensors:`` list holds, read by :func:`navstress.sensors.sensor_from_mapping` (the same
configuration a campaign would use).

    >>> entries_from_text("front_laser=lidar2d:ust10,max_range_m=30,mount=0.12:0:0.3", where="--sensor")
    [{'name': 'front_laser', 'kind': 'lidar2d', 'profile': 'ust10', 'max_range_m': 30, 'mount': {'xyz': [0.12, 0.0, 0.3]}}]
    >>> entries_from_text("front_laser", where="--sensor")
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: --sensor='front_laser' is invalid: expected NAME=KIND[:PROFILE][,KEY=VALUE...] (e.g. front_laser=lidar2d:ust10,max_range_m=30) or a YAML/JSON file of sensor entries; see docs/sensors.md
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from navstress import specfile
from navstress.errors import SpecError

SYNTAX = "NAME=KIND[:PROFILE][,KEY=VALUE...] (e.g. front_laser=lidar2d:ust10,max_range_m=30)"
FILE_SUFFIXES = (".yaml", ".yml", ".json")
_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


def _value(text: str) -> Any:
    """A value as typed: an integer, a number, true/false, else the text."""
    t = text.strip()
    if re.fullmatch(r"[+-]?\d+", t):
        return int(t)
    if _NUMBER.match(t):
        return float(t)
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    return t


def _triple(text: str, where: str, what: str) -> list[float]:
    parts = text.split(":")
    try:
        out = [float(p) for p in parts]
    except ValueError:
        out = []
    if len(out) != 3 or not all(math.isfinite(v) for v in out):
        raise SpecError(where, text, f"{what} as three numbers X:Y:Z")
    return out


def entry_from_text(text: str, *, where: str) -> dict[str, Any]:
    """The sensor entry (a mapping) one ``NAME=KIND[:PROFILE][,KEY=VALUE...]`` stands for;
    SpecError naming ``where`` when it is not of that form."""
    head, _, rest = text.partition(",")
    name, eq, kind = head.partition("=")
    if not eq or not name.strip() or not kind.strip():
        raise SpecError(where, text, SYNTAX + " or a YAML/JSON file of sensor entries", "see docs/sensors.md")
    kind_name, _, profile = kind.strip().partition(":")
    entry: dict[str, Any] = {"name": name.strip(), "kind": kind_name.strip()}
    if profile.strip():
        entry["profile"] = profile.strip()
    xyz: list[float] | None = None
    rpy: list[float] | None = None
    mount_name: str | None = None
    for item in rest.split(",") if rest else []:
        key, eq, value = item.partition("=")
        key = key.strip()
        if not eq or not key:
            raise SpecError(where, text, SYNTAX + f" (the part {item!r} is not KEY=VALUE)")
        if key in entry or (key == "mount" and (xyz is not None or mount_name is not None)) or (key == "rpy" and rpy):
            raise SpecError(f"{where}.{key}", value, "each key once")
        if key == "mount":
            if ":" in value:
                xyz = _triple(value, f"{where}.mount", "a mount position (m)")
            else:
                mount_name = value.strip()
        elif key == "rpy":
            rpy = _triple(value, f"{where}.rpy", "a mount's roll, pitch and yaw (rad)")
        elif key in ("name", "kind", "profile", "params"):
            raise SpecError(f"{where}.{key}", value, f"{key} given once, in NAME=KIND[:PROFILE]")
        else:
            entry[key] = _value(value)
    if rpy is not None and xyz is None:
        raise SpecError(f"{where}.rpy", rpy, "rpy only with a mount position (mount=X:Y:Z)",
                        "give mount=X:Y:Z too, or a robot mount that has the rotation")
    if xyz is not None:
        entry["mount"] = {"xyz": xyz, **({"rpy": rpy} if rpy is not None else {})}
    elif mount_name is not None:
        entry["mount"] = mount_name
    return entry


def entries_from_text(text: str, *, where: str) -> list[Any]:
    """The entries of one ``--sensor`` value: one entry typed inline, or every entry of a file
    (a list, or a mapping holding the list under ``sensors``)."""
    if not isinstance(text, str) or not text.strip():
        raise SpecError(where, text, SYNTAX + " or a YAML/JSON file of sensor entries")
    looks_like_file = "=" not in text and (text.lower().endswith(FILE_SUFFIXES) or Path(text).is_file())
    if not looks_like_file:
        return [entry_from_text(text, where=where)]
    p = Path(text)
    if not p.is_file():
        raise SpecError(where, text, "a YAML/JSON file of sensor entries that exists", "check the path")
    data = specfile.load_file(p, field=where)
    if isinstance(data, Mapping) and set(data) == {"sensors"}:
        data = data["sensors"]
    if not isinstance(data, list) or not data:
        raise SpecError(where, text, "a file holding a non-empty list of sensor entries (each a mapping with "
                        "name and kind), or a mapping with that list under sensors", "see docs/sensors.md")
    return list(data)


def entries_from_flags(values: list[str] | None, *, flag: str) -> list[Any] | None:
    """Every entry of a repeatable flag's values, in order (None when the flag is not given)."""
    if not values:
        return None
    out: list[Any] = []
    for v in values:
        out.extend(entries_from_text(v, where=flag))
    return out
