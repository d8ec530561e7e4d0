"""The sensor kinds (every module of :mod:`navstress.sensors.kinds`) and the one reader of a
sensor entry as a user writes it::

    sensors:
      - {name: front_laser, kind: lidar2d, profile: ust10, mount: {xyz: [0.12, 0, 0.3], rpy: [0, 0, 0]}}
      - {name: cam, kind: depth, profile: d435, max_range_m: 6}

An entry is ``name``, ``kind``, an optional ``profile`` (the kind's default profile when left out),
an optional ``mount`` (``{xyz, rpy}``, or the name of one of the robot's mounts; left out: the
robot's mount of the sensor's name, else its ``lidar`` mount), and any of the kind's parameters,
which override the profile's. A whole sensor as navstress writes it (``params:`` holding every
parameter) reads back as itself.
"""

from __future__ import annotations

import difflib
import importlib
import pkgutil
from collections.abc import Mapping, Sequence
from functools import cache
from typing import Any

from pydantic import ValidationError

from navstress._models import parse, spec_error
from navstress.errors import SpecError
from navstress.sensors import kinds as _kinds_pkg
from pydantic import BaseModel, Field, model_validator

from navstress._models import SPEC_CONFIG
from navstress.sensors.base import MAX_RAY_SENSORS, NAME_PATTERN, RESERVED_NAMES, Mount, SensorKind

ENTRY_KEYS = ("name", "kind", "profile", "mount", "params")


@cache
def kinds() -> dict[str, SensorKind]:
    """Every sensor kind by name, from the modules of :mod:`navstress.sensors.kinds`."""
    out: dict[str, SensorKind] = {}
    for info in sorted(pkgutil.iter_modules(_kinds_pkg.__path__), key=lambda i: i.name):
        mod = importlib.import_module(f"{_kinds_pkg.__name__}.{info.name}")
        k = getattr(mod, "KIND", None)
        if isinstance(k, SensorKind):
            out[k.name] = k
    return out


def user_kinds() -> dict[str, SensorKind]:
    """The kinds a suite may list (the built-in odometry, IMU and pose are always there)."""
    return {n: k for n, k in kinds().items() if k.caster != "builtin"}


def kind(name: Any, *, where: str = "sensor.kind") -> SensorKind:
    """The kind called ``name``; a SpecError with a "did you mean" otherwise."""
    ks = user_kinds()
    if isinstance(name, str) and name in ks:
        return ks[name]
    if isinstance(name, str) and name in kinds():
        raise SpecError(where, name, "a sensor kind a robot may add: " + ", ".join(ks),
                        f"the {name} sensor is built in: set its figures in sim:")
    close = difflib.get_close_matches(str(name), list(ks), n=1, cutoff=0.5)
    raise SpecError(where, name, "a sensor kind: " + ", ".join(ks), f"did you mean {close[0]}?" if close else None)



class Sensor(BaseModel):
    """One sensor the robot carries: its ``name`` (unique on the robot; the frame ``<name>`` in
    traces and readings under that name), its ``kind`` and the ``profile`` its parameters started
    from, its ``mount`` and its full parameter set ``params`` (the kind's parameter model as a
    mapping: the profile's figures with the user's overrides)."""

    model_config = SPEC_CONFIG
    name: str = Field(pattern=NAME_PATTERN.pattern)
    kind: str
    profile: str | None = None
    mount: Mount
    params: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _check(self) -> "Sensor":
        self.config()  # a known kind, parameters valid for it (a description read back)
        return self

    def config(self) -> Any:
        """The parameters as the kind's model (validated)."""
        return kind(self.kind, where="kind").params.model_validate(self.params)


def _mount(value: Any, mounts: Mapping[str, Mount], name: str, where: str) -> Mount:
    if value is None:
        m = mounts.get(name) or mounts.get("lidar")
        if m is None:
            raise SpecError(f"{where}.mount", None, "a mount {xyz: [x, y, z], rpy: [r, p, y]} (the robot has no "
                            f"mount named {name} or lidar)")
        return m
    if isinstance(value, str):
        if value in mounts:
            return mounts[value]
        close = difflib.get_close_matches(value, list(mounts), n=1, cutoff=0.5)
        raise SpecError(f"{where}.mount", value, "a mapping {xyz, rpy} or one of the robot's mounts: "
                        + (", ".join(mounts) or "(none)"), f"did you mean {close[0]}?" if close else None)
    if isinstance(value, Mount):
        return value
    return parse(Mount, value, prefix=f"{where}.mount")


def sensor_from_mapping(data: Any, *, where: str, mounts: Mapping[str, Mount]) -> Sensor:
    """The :class:`Sensor` an entry describes (see the module's text); SpecError naming
    ``where.<field>`` for anything wrong."""
    if isinstance(data, Sensor):
        return data
    if not isinstance(data, Mapping):
        raise SpecError(where, data, "a sensor: a mapping with name, kind, and optionally profile, mount and "
                        "the kind's parameters", "see docs/sensors.md")
    for key in ("name", "kind"):
        if key not in data:
            raise SpecError(f"{where}.{key}", None, "a sensor's " + ("name (unique on the robot)" if key == "name"
                                                                     else "kind: " + ", ".join(user_kinds())))
    name = data["name"]
    if not isinstance(name, str) or not NAME_PATTERN.match(name):
        raise SpecError(f"{where}.name", name, "a name of lowercase letters, digits and _ (at most 32, a letter "
                        "first)")
    if name in RESERVED_NAMES:
        raise SpecError(f"{where}.name", name, "a name other than " + ", ".join(RESERVED_NAMES)
                        + " (the built-in sensors' names)")
    k = kind(data["kind"], where=f"{where}.kind")
    prof = data.get("profile", k.default_profile)
    if prof is None:
        prof = k.default_profile
    if not isinstance(prof, str) or prof not in k.profiles:
        close = difflib.get_close_matches(str(prof), list(k.profiles), n=1, cutoff=0.5)
        raise SpecError(f"{where}.profile", prof, f"a {k.name} profile: " + ", ".join(k.profiles),
                        f"did you mean {close[0]}?" if close else None)
    fields = list(k.params.model_fields)
    params: dict[str, Any] = dict(k.profiles[prof])
    given = data.get("params")
    if given is not None:
        if not isinstance(given, Mapping):
            raise SpecError(f"{where}.params", given, f"a mapping of {k.name} parameters: " + ", ".join(fields))
        params.update(given)
    for key, value in data.items():
        if key in ENTRY_KEYS:
            continue
        if not isinstance(key, str) or key not in fields:
            close = difflib.get_close_matches(str(key), fields + list(ENTRY_KEYS), n=1, cutoff=0.6)
            raise SpecError(f"{where}.{key}", value, f"a {k.name} parameter: " + ", ".join(fields),
                            f"did you mean {close[0]}?" if close else None)
        params[key] = value
    try:
        cfg = k.params.model_validate(params)
    except ValidationError as err:
        raise spec_error(err, params, model=k.params, prefix=where) from None
    except SpecError as err:  # a cross-field check of the kind's model
        raise SpecError(f"{where}.{err.field}", err.value, err.expected, err.fix) from None
    if k.check is not None:
        k.check(cfg, where)
    mount = _mount(data.get("mount"), mounts, name, where)
    return Sensor(name=name, kind=k.name, profile=prof, mount=mount, params=cfg.model_dump(mode="json"))


def suite_from_list(items: Any, *, where: str, mounts: Mapping[str, Mount],
                    base: Sequence[Sensor] = ()) -> tuple[Sensor, ...]:
    """``base`` followed by the sensors of the list ``items`` (``where[i]`` in errors); names must
    be unique over the whole suite, at most :data:`MAX_RAY_SENSORS` sensors."""
    if isinstance(items, (str, bytes)) or not isinstance(items, Sequence):
        raise SpecError(where, items, "a list of sensors (each a mapping with name and kind)", "see docs/sensors.md")
    out = list(base)
    for i, item in enumerate(items):
        s = sensor_from_mapping(item, where=f"{where}[{i}]", mounts=mounts)
        if any(o.name == s.name for o in out):
            raise SpecError(f"{where}[{i}].name", s.name, "a name no other sensor of the robot has",
                            "name each sensor once")
        out.append(s)
    if len(out) > MAX_RAY_SENSORS:
        raise SpecError(where, f"{len(out)} sensors", f"at most {MAX_RAY_SENSORS} sensors on one robot")
    return tuple(out)


def check_rates(sensors: Sequence[Sensor], timestep_s: float, *, where: str = "sensors") -> None:
    """Every sensor's rate at most the simulation's step rate (1 / ``timestep_s``)."""
    for i, s in enumerate(sensors):
        rate = float(s.params.get("rate_hz", 0.0))
        if rate * timestep_s > 1.0 + 1e-9:
            raise SpecError(f"{where}[{i}].rate_hz", rate, f"at most the simulation's step rate, "
                            f"{1.0 / timestep_s:g} Hz (time step {timestep_s:g} s)",
                            "lower the sensor's rate or the sim's timestep_s")


def default_suite(mounts: Mapping[str, Mount]) -> tuple[Sensor, ...]:
    """A robot's default suite (``RobotSpec.sensors`` None): the paper's 32-channel lidar, named
    ``lidar``, on the robot's ``lidar`` mount (the default mount when it has none)."""
    m = mounts.get("lidar") or Mount(xyz=(0.35, 0.0, 0.75))
    k = kinds()["lidar3d"]
    return (Sensor(name="lidar", kind="lidar3d", profile=k.default_profile, mount=m,
                   params=k.params().model_dump(mode="json")),)
