"""The sensor registry (the foundation) over families of inputs: every kind's every profile is a
valid sensor; any valid overrides give a sensor whose dump reads back as itself (through the
model, through a spec entry and through a robot); the ``--sensor`` text gives the same sensor as
the spec entry it stands for; every reading round-trips through the line protocol's encoders."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from pydantic.fields import FieldInfo

from navstress.errors import SpecError
from navstress.robot import profile
from navstress.robot.files import with_sensors
from navstress.sensors import Mount, Sensor, kinds, sensor_from_mapping, user_kinds
from navstress.sensors.text import entry_from_text

MOUNTS = {"lidar": Mount(xyz=(0.1, 0.0, 0.3))}
USER = sorted(user_kinds())


def _bounds(info: FieldInfo) -> dict[str, float]:
    out: dict[str, float] = {}
    for m in info.metadata:
        for attr in ("gt", "ge", "lt", "le"):
            v = getattr(m, attr, None)
            if v is not None:
                out[attr] = float(v)
    return out


def _value(info: FieldInfo, ann: Any) -> st.SearchStrategy[Any]:
    b = _bounds(info)
    if ann is int or ann == int:
        lo = int(b.get("ge", b.get("gt", 0) + 1))
        hi = int(b.get("le", b.get("lt", 10**6) - 1))
        return st.integers(lo, min(hi, lo + 2000))
    lo = b.get("ge", b.get("gt", 0.0))
    hi = b.get("le", b.get("lt", 1e4))
    return st.floats(lo, hi, exclude_min="gt" in b, exclude_max="lt" in b, allow_nan=False, allow_infinity=False)


@st.composite
def overrides(draw: st.DrawFn, kind_name: str) -> dict[str, Any]:
    k = kinds()[kind_name]
    out: dict[str, Any] = {}
    for name, info in k.params.model_fields.items():
        ann = info.annotation
        if ann not in (int, float) or not draw(st.booleans()):
            continue
        out[name] = draw(_value(info, ann))
    return out


@pytest.mark.parametrize("kind_name", sorted(kinds()))
def test_every_profile_is_a_valid_sensor(kind_name: str) -> None:
    k = kinds()[kind_name]
    assert k.default_profile in k.profiles
    for prof, figures in k.profiles.items():
        cfg = k.params.model_validate(figures)
        if k.caster == "builtin":
            continue
        s = sensor_from_mapping({"name": "s", "kind": kind_name, "profile": prof}, where="s", mounts=MOUNTS)
        assert s.params == cfg.model_dump(mode="json") and s.profile == prof
        assert all(figures[f] == s.params[f] for f in figures)  # the profile's figures, as written
        assert k.to_wire is not None and k.from_wire is not None, f"{kind_name} has no line-protocol encoder"


@pytest.mark.parametrize("kind_name", USER)
@settings(max_examples=40, deadline=None)
@given(data=st.data())
def test_valid_overrides_round_trip(kind_name: str, data: st.DataObject) -> None:
    over = data.draw(overrides(kind_name))
    entry = {"name": "front", "kind": kind_name, **over}
    try:
        s = sensor_from_mapping(entry, where="sensors[0]", mounts=MOUNTS)
    except SpecError as err:  # only a cross-field rule may refuse values inside every bound
        assert err.field.startswith("sensors[0].") and ("max_" in err.field or "elevation" in err.field), str(err)
        assume(False)
        return
    for f, v in over.items():
        assert s.params[f] == v
    dumped = s.model_dump(mode="json")
    assert Sensor.model_validate(dumped) == s  # a description read back
    assert sensor_from_mapping(dumped, where="s", mounts={}) == s  # as navstress writes it: params:
    # on a robot, and that robot's description read back
    robot = with_sensors(profile("jackal"), sensors=[entry])
    assert robot.sensors == (s.model_copy(update={"mount": robot.mounts["lidar"]}),)
    assert type(robot).model_validate_json(robot.model_dump_json()) == robot
    # the command line's text for the same entry gives the same sensor
    text = f"front={kind_name}," + ",".join(f"{k}={v!r}" for k, v in over.items())
    assert sensor_from_mapping(entry_from_text(text.rstrip(","), where="--sensor"), where="s", mounts=MOUNTS) == s


def _reading(kind_name: str, rng: np.random.Generator, n: int) -> Any:
    k = kinds()[kind_name]
    common = {"t": float(rng.uniform(0, 100)), "mount": (0.1, -0.2, 0.3), "rpy": (0.0, 0.1, -0.2), "sensor": "x"}
    if kind_name == "lidar3d":
        return k.reading(points=rng.normal(size=(n, 3)).astype(np.float32), **common)
    if kind_name == "lidar2d":
        r = rng.uniform(0.1, 10, size=n).astype(np.float32)
        r[rng.random(n) < 0.3] = np.inf
        return k.reading(ranges=r, angle_min=-2.0, angle_increment=0.01, range_min=0.06, range_max=10.0, **common)
    if kind_name == "depth":
        d = rng.uniform(0.1, 10, size=(max(n // 4, 1), 4)).astype(np.float32)
        d[rng.random(d.shape) < 0.3] = np.inf
        return k.reading(depth=d, fx=100.0, fy=100.0, cx=2.0, cy=1.5, **common)
    if kind_name == "odometry":
        return k.reading(*(float(v) for v in rng.normal(size=6)))
    if kind_name == "imu":
        return k.reading(1.0, 0.1, 0.2, 0.3, (0.0, -1.0, 2.5))
    return k.reading(*(float(v) for v in rng.normal(size=7)))


def _same(a: Any, b: Any) -> bool:
    for f in a.__dataclass_fields__:
        x, y = getattr(a, f), getattr(b, f)
        if isinstance(x, np.ndarray):
            if x.shape != y.shape or x.dtype != y.dtype or not np.array_equal(x, y):
                return False
        elif tuple(x) != tuple(y) if isinstance(x, tuple) else x != y:
            return False
    return True


@pytest.mark.parametrize("kind_name", sorted(kinds()))
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 300))
def test_every_reading_round_trips_through_the_line_protocol(kind_name: str, seed: int, n: int) -> None:
    k = kinds()[kind_name]
    r = _reading(kind_name, np.random.default_rng(seed), n)
    d = k.to_wire(r)  # type: ignore[misc]
    import json
    back = k.from_wire(json.loads(json.dumps(d, allow_nan=False)))  # type: ignore[misc]
    assert _same(r, back)


@pytest.mark.parametrize("kind_name", ["lidar2d", "lidar3d", "depth"])
@pytest.mark.parametrize("damage", ["no-field", "bad-dtype", "bad-shape", "not-base64", "short-data", "nan-t"])
def test_bad_wire_readings_are_value_errors(kind_name: str, damage: str) -> None:
    k = kinds()[kind_name]
    d = k.to_wire(_reading(kind_name, np.random.default_rng(0), 8))  # type: ignore[misc]
    key = {"lidar2d": "ranges", "lidar3d": "points", "depth": "depth"}[kind_name]
    if damage == "no-field":
        del d[key]
    elif damage == "bad-dtype":
        d[key]["dtype"] = "<f8"
    elif damage == "bad-shape":
        d[key]["shape"] = [2, 2, 2, 1] if kind_name != "lidar2d" else [4, 2]
    elif damage == "not-base64":
        d[key]["data"] = "%%%"
    elif damage == "short-data":
        d[key]["data"] = d[key]["data"][:8]
    else:
        d["t"] = math.nan
    with pytest.raises(ValueError):
        k.from_wire(d)  # type: ignore[misc]
