"""The robot of a run: what a user names (a profile, a robot file, a mapping, a RobotSpec)
resolved once (:func:`robot_of`), checked for the simulation (:func:`check_stable`), planned
into a :class:`~navstress.run.record.RunTask` as data (:func:`task_robot`) and read back from a
trace for a replay (:func:`with_recorded_robot`).

A trace carries its robot as MCAP metadata ``navstress.robot`` (``name``, ``digest``,
``description``: the RobotSpec as canonical JSON); a trace written before robots were recorded
has none and reads as the paper's ``rmp400`` (:func:`navstress.run.trace.read_robot`).

    >>> robot_of("jackal").name, robot_of(None).name
    ('jackal', 'rmp400')
    >>> task_robot(None) is None, task_robot("rmp400") is None, RunTask("r", "w", 0, "t", robot=task_robot("jackal")).robot_spec().name
    (True, True, 'jackal')
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from navstress.errors import SpecError
from navstress.robot import PROFILES, RobotSpec, resolve_robot
from navstress.run.record import RunTask
from navstress.sim.validation import require_stable


def robot_of(ref: Any, field: str | None = None) -> RobotSpec:
    """The RobotSpec ``ref`` names: None (``rmp400``), a RobotSpec, a profile name, a robot file
    path or a mapping (:func:`navstress.robot.resolve_robot`). ``field``: the name a
    :class:`SpecError` gives the value instead of ``robot`` (``--robot`` on the command line)."""
    if isinstance(ref, Path):
        ref = str(ref)
    try:
        if isinstance(ref, str) and ref.lstrip().startswith("{"):  # a whole description (a RunTask's robot)
            try:
                return RobotSpec.model_validate_json(ref)
            except ValueError as err:  # (pydantic's ValidationError is a ValueError)
                why = " ".join(str(err).split())[:200]
                raise SpecError("robot", ref[:60] + "...", f"a robot description as JSON ({why})") from None
        return resolve_robot(dict(ref) if isinstance(ref, Mapping) else ref)
    except SpecError as err:
        if field is None:
            raise
        name = field + err.field[len("robot"):] if err.field.startswith("robot") else f"{field}: {err.field}"
        raise SpecError(name, err.value, err.expected, err.fix) from None


def description(robot: RobotSpec) -> str:
    """The robot as canonical JSON: :meth:`RobotSpec.description`."""
    return robot.description()


def task_robot(ref: Any) -> dict[str, Any] | None:
    """What a :class:`RunTask` carries of the robot ``ref``: None for the paper's robot (the
    default: a task of it keeps its JSON, and its store, as before robots), else the whole
    description as a JSON mapping (:func:`description`'s), so that a replay simulates the same
    robot even after a profile or a robot file changed (:meth:`RunTask.robot_spec` reads it)."""
    robot = robot_of(ref)
    return None if robot == PROFILES["rmp400"] else dict(json.loads(description(robot)))


def with_recorded_robot(task: RunTask, trace: str | Path) -> RunTask:
    """``task`` with the robot recorded in ``trace`` (its run's trace) when the task names none:
    what ``replay`` simulates (the record's robot, never today's default). A trace without a
    robot (written before robots were recorded) is the paper's rmp400."""
    from navstress.run.trace import read_robot  # local: the trace module loads the MCAP and protobuf stack

    if task.robot is not None:
        return task
    return replace(task, robot=task_robot(read_robot(trace)))


def check_stable(robot: RobotSpec, config: Any = None) -> None:
    """Refuse (one-line error) a robot the simulation cannot hold stable on flat ground at its own
    top speed: :func:`navstress.sim.validation.require_stable` (cached per robot and
    configuration), called before every run."""
    require_stable(robot, config)
