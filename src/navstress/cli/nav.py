"""``navstress nav list|faults|check`` (the ``nav`` group)."""

from __future__ import annotations

import warnings
from typing import Annotated, Any

import typer

from navstress._console import console
from navstress.cli._common import (MAX_WALL_S, NAV_CONFIG_HELP, RobotOpt, SensorAddOpt, SensorOpt, load_navigator_config,
                                   load_robot_flags, number)
from navstress.errors import NavstressError, SpecError
from navstress.isolate import Worker
from navstress.nav.check import check_in_worker, format_report
from navstress.nav.faults import list_faults
from navstress.nav.registry import builds_to_validate, list_navigators, validate_config, validate_each

app = typer.Typer(rich_markup_mode=None)
nav_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None,
                      help="Navigators under test: list them, list faults, check conformance.")
app.add_typer(nav_app, name="nav")


@nav_app.command("list")
def nav_list() -> None:
    """List the registered navigators (built-in and third-party entry points)."""
    con = console()
    for spec in list_navigators():
        con.print(f"  {spec.id:<24} {spec.target_text}")


@nav_app.command("faults")
def nav_faults() -> None:
    """List the faults that --fault can inject."""
    con = console()
    for f in list_faults():
        con.print(f"  {f.name:<18} {f.description}")


@nav_app.command("check")
def nav_check(
    name: Annotated[str, typer.Argument(metavar="NAME", help="Registered navigator name, e.g. reference-v1.")],
    navigator_config: Annotated[str | None, typer.Option(metavar="FILE|TEXT", help=NAV_CONFIG_HELP)] = None,
    wall_limit: Annotated[str, typer.Option(metavar="S", help=(
        "Wall-clock limit of each check in real seconds, > 0: a navigator that hangs fails the check "
        "it hangs in. Default 300.")) ] = "300",
    robot: RobotOpt = None,
    sensor: SensorOpt = None,
    sensor_add: SensorAddOpt = None,
) -> None:
    """Run the conformance checks on a navigator (in a worker process); exit 1 if any check fails.

    With --robot, the navigator is told that robot (its footprint, limits and sensor mounts) and
    the synthetic scans come from its lidar mount; --sensor / --sensor-add give it another suite (the
    navigator gets synthetic readings of every sensor kind it carries)."""
    wall_v = number("--wall-limit", wall_limit, f"a duration in seconds in (0, {MAX_WALL_S:g}]")
    if not 0 < wall_v <= MAX_WALL_S:
        raise SpecError("--wall-limit", wall_limit, f"a duration in seconds in (0, {MAX_WALL_S:g}]")
    robot_v = load_robot_flags(robot, sensor, sensor_add)
    cfg = load_navigator_config(navigator_config)
    with Worker(wall_v) as worker:
        # the same up-front check as `campaign run` (one line, exit 2); a navigator built to
        # validate its config is built in the worker (one that exits or hangs there fails `builds`)
        if builds_to_validate(name):
            status, value = worker.call(validate_each, [(name, cfg, "navigator-config")])
            if status == "raised" and isinstance(value, NavstressError):
                raise value
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                validate_config(name, cfg)
        extra: dict[str, Any] = {"robot": robot_v} if robot is not None or sensor or sensor_add else {}
        report = check_in_worker(name, cfg or None, worker=worker, **extra)
    console().print(format_report(report))
    if not report.passed:
        raise typer.Exit(1)
