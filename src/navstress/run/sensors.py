"""The sensors of a run as every entry point configures them: a spec's ``sensors:`` /
``sensors_add:`` (:func:`apply_sensors`), the command line's ``--sensor`` / ``--sensor-add``
(:func:`apply_sensor_flags`), a sweep's or a search's ``sensors.<name>.<param>`` paths
(:func:`apply_sensor_values`); and the one check of a resolved suite against the simulation
(:func:`check_suite`: every rate at most the step rate, no ``sim.lidar`` beside a listed suite),
made when a spec is loaded or a command's flags are read, before anything is written or run.

    >>> from navstress.robot import profile
    >>> r = apply_sensor_values(profile("jackal"), {"sensors.lidar.max_range_m": 30})
    >>> r.sensors[0].params["max_range_m"]
    30.0
    >>> apply_sensor_values(profile("jackal"), {"sensors.lidar.max_rnge_m": 30})
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: sensors.lidar.max_rnge_m=30 is invalid: expected a lidar3d parameter (or kind, profile): rate_hz, channels, min_elevation_deg, max_elevation_deg, azimuth_steps, max_range_m, min_range_m, range_noise_std_m, dropout_prob; did you mean max_range_m?
"""

from __future__ import annotations

import dataclasses
import difflib
import typing
from collections.abc import Callable, Mapping
from typing import Any

from navstress._models import unoptional
from navstress.errors import SpecError
from navstress.robot import RobotSpec
from navstress.robot.files import with_sensors
from navstress.sensors import Sensor, default_suite, kind, sensor_from_mapping
from navstress.sensors.text import entries_from_flags
from navstress.sim.config import SimConfig
from navstress.sim.drives import drive_model
from navstress.sim.lidar import LidarConfig

#: The first part of a sweepable sensor path: ``sensors.<name>.<param>``.
PREFIX = "sensors"
#: What a sensor path may end in besides the kind's parameters.
ENTRY_FIELDS = ("kind", "profile")


def is_sensor_path(path: str) -> bool:
    """Whether ``path`` addresses a sensor (``sensors.<name>.<param>``), not the world."""
    return path.split(".", 1)[0] == PREFIX


def apply_sensors(robot: RobotSpec, *, sensors: Any = None, sensors_add: Any = None, where: str = "") -> RobotSpec:
    """``robot`` with a spec's ``sensors:`` and ``sensors_add:`` (:func:`navstress.robot.files.with_sensors`)."""
    return with_sensors(robot, sensors=sensors, sensors_add=sensors_add, where=where)


def apply_sensor_flags(robot: RobotSpec, sensor: list[str] | None, sensor_add: list[str] | None) -> RobotSpec:
    """``robot`` with ``--sensor`` (its suite, replacing the robot's) and ``--sensor-add`` (added to
    it): the configuration a campaign's ``sensors:`` / ``sensors_add:`` would give; every error one
    line naming the flag (``--sensor[0].kind=...``)."""
    entries = entries_from_flags(sensor, flag="--sensor")
    added = entries_from_flags(sensor_add, flag="--sensor-add")
    try:
        return with_sensors(robot, sensors=entries, sensors_add=added)
    except SpecError as err:
        field = err.field
        for ours, flag in (("sensors_add", "--sensor-add"), ("sensors", "--sensor")):
            if field.startswith(ours):
                field = flag + field[len(ours):]
                break
        raise SpecError(field, err.value, err.expected, err.fix) from None


def suite_of(robot: RobotSpec) -> tuple[Sensor, ...]:
    """The robot's sensors: its own suite, or its default one."""
    return robot.sensors if robot.sensors is not None else default_suite(robot.mounts)


def _sensor_error(where: str, name: str, suite: tuple[Sensor, ...], robot: RobotSpec) -> SpecError:
    names = [s.name for s in suite]
    close = difflib.get_close_matches(name, names, n=1, cutoff=0.5)
    return SpecError(where, name, f"the name of a sensor of the robot {robot.name!r}: " + ", ".join(names),
                     f"did you mean {close[0]}?" if close else "add it with sensors: or sensors_add:")


def sensor_path_kind(robot: RobotSpec, path: str, *, where: str, value: Any = None) -> str:
    """What ``path`` (``sensors.<name>.<param>``) sets on ``robot``: "int", "float", "bool" or
    "str" (``kind``, ``profile``); SpecError naming ``where`` for an unknown sensor or parameter."""
    parts = path.split(".")
    if len(parts) != 3 or parts[0] != PREFIX:
        raise SpecError(where, path, "a sensor path sensors.<name>.<param> (e.g. sensors.front_laser.max_range_m)")
    suite = suite_of(robot)
    s = next((x for x in suite if x.name == parts[1]), None)
    if s is None:
        raise _sensor_error(where, parts[1], suite, robot)
    if parts[2] in ENTRY_FIELDS:
        return "str"
    fields = kind(s.kind).params.model_fields
    f = fields.get(parts[2])
    if f is None:
        close = difflib.get_close_matches(parts[2], [*fields, *ENTRY_FIELDS], n=1, cutoff=0.6)
        raise SpecError(where, path if value is None else value,
                        f"a {s.kind} parameter (or kind, profile): " + ", ".join(fields),
                        f"did you mean {close[0]}?" if close else None)
    ann = unoptional(f.annotation)
    return {int: "int", float: "float", bool: "bool"}.get(typing.cast(type, ann), "str")


def apply_sensor_values(robot: RobotSpec, values: Mapping[str, Any], *, where: str = "") -> RobotSpec:
    """``robot`` with each ``sensors.<name>.<param>`` of ``values`` set (other paths ignored): a
    sensor's ``kind`` starts it again from that kind's default profile, its ``profile`` from that
    profile's figures (the entry's own overrides dropped), then its parameters are set. Errors name
    ``where`` + the path (``experiments[0].sweep.sensors.front_laser.max_range_m``)."""
    by_name: dict[str, dict[str, Any]] = {}
    for path, v in values.items():
        if is_sensor_path(path):
            sensor_path_kind(robot, path, where=f"{where}{path}", value=v)
            by_name.setdefault(path.split(".")[1], {})[path.split(".")[2]] = v
    if not by_name:
        return robot
    suite = list(suite_of(robot))
    for i, s in enumerate(suite):
        changes = by_name.get(s.name)
        if changes is None:
            continue
        entry: dict[str, Any] = {"name": s.name, "kind": changes.get("kind", s.kind), "mount": s.mount}
        if "kind" in changes:
            pass  # the new kind's default profile
        elif "profile" in changes:
            entry["profile"] = changes["profile"]
        else:
            entry["profile"] = s.profile
            entry["params"] = dict(s.params)
        entry.update({k: v for k, v in changes.items() if k not in ENTRY_FIELDS})
        at = f"{where}{PREFIX}.{s.name}"
        try:
            suite[i] = sensor_from_mapping(entry, where=at, mounts=robot.mounts)
        except SpecError as err:
            field = err.field.replace(f"{at}.params.", f"{at}.")
            raise SpecError(field, err.value, err.expected, err.fix) from None
    return with_sensors(robot, sensors=suite, where=where)


def check_suite(robot: RobotSpec, sim: Any = None, *,
                field_of: Callable[[Sensor], str] | None = None) -> None:
    """The robot's sensors as the simulation will run them: every rate at most the step rate
    (the effective time step: the spec's ``sim.timestep_s``, or smaller when the robot's drive
    needs it) and no ``sim.lidar`` beside a suite the robot lists. ``sim``: a SimConfig or a
    spec's ``sim:`` mapping. SpecError naming ``field_of(sensor)`` (default
    ``sensors.<name>.rate_hz``)."""
    if robot.sensors is None:
        return  # the default suite: sim.lidar's figures, checked with sim: (check_runnable)
    cfg = sim if isinstance(sim, SimConfig) else SimConfig.from_mapping(dict(sim or {}))
    if cfg.lidar != LidarConfig():
        raise SpecError("sim.lidar", dataclasses.asdict(cfg.lidar), "no sim.lidar with a robot that lists its sensors",
                        "set the lidar's figures in its entry of sensors: (docs/sensors.md)")
    dt = min(cfg.timestep_s, drive_model(robot).timestep_s)
    for s in robot.sensors:
        rate = float(s.params.get("rate_hz", 0.0))
        if rate * dt > 1.0 + 1e-9:
            field = field_of(s) if field_of is not None else f"{PREFIX}.{s.name}.rate_hz"
            raise SpecError(field, rate, f"at most the simulation's step rate, {1.0 / dt:g} Hz (time step {dt:g} s)",
                            "lower the sensor's rate or the sim's timestep_s")
