"""``navstress run``: several runs of one navigator on one world, each in a worker process."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.progress import BarColumn, TextColumn, TimeRemainingColumn
from rich.table import Table

from navstress._bar import Bar
from navstress._console import console
from navstress._json import pretty as dumps
from navstress.campaign.store import OUTCOMES
from navstress.cli._common import (MAX_RUNS, MAX_SEED, MAX_TIMEOUT_S, MAX_WALL_S, NAV_CONFIG_HELP, LidarOpt,
                                   LiveHostOpt, LiveOpt, LivePortOpt, LiveWaitOpt, NavigatorViewOpt, RobotOpt, SensorAddOpt,
                                   SensorOpt, SpeedOpt, bounded_int, live_banner, live_settings, load_navigator_config,
                                   load_robot_flags,
                                   number)
from navstress.errors import SpecError, WorldFileError
from navstress.nav.registry import NavigatorNote, build_and_close, resolve
from navstress._tables import NOMINAL
from navstress.run.robot import check_stable
from navstress.world.generate import check_robot_fits
from navstress.run.batch import batch_picture, check_buildable, default_wall_limit_s, plan_batch, record_dict, run_batch
from navstress.world.world import World

app = typer.Typer(rich_markup_mode=None)


@app.command("run")
def run_cmd(
    world_dir: Annotated[Path, typer.Argument(metavar="WORLD_DIR", help="A world directory (navstress world generate).")],
    *,
    output: Annotated[Path, typer.Option("--output", "-o", metavar="OUT", help=(
        "Folder for the traces (run-NNN.mcap), records (runs.jsonl) and trajectories.png; must be new or empty."))],
    navigator: Annotated[str, typer.Option(metavar="NAME", help=(
        "Navigator under test, by registered name (see `navstress nav list`).")) ] = "reference-v1",
    navigator_config: Annotated[str | None, typer.Option(metavar="FILE|TEXT", help=NAV_CONFIG_HELP)] = None,
    fault: Annotated[str | None, typer.Option(metavar="NAME", help=(
        "Inject a named fault into the navigator (see `navstress nav faults`)."))] = None,
    robot: RobotOpt = None,
    sensor: SensorOpt = None,
    sensor_add: SensorAddOpt = None,
    runs: Annotated[str, typer.Option(metavar="N", help="Number of runs (each with its own run seed), in [1, 10000]. Default 1.")] = "1",
    seed: Annotated[str, typer.Option(metavar="N", help="Root seed of the run seeds, an integer in [0, 2**63-1]. Default 0.")] = "0",
    timeout: Annotated[str, typer.Option(metavar="S", help="Simulated-time limit of a run in seconds, in (0, 86400]. Default 400.")] = "400",
    goal_tolerance: Annotated[str, typer.Option(metavar="M", help="Success radius around the goal in meters, > 0. Default 2.")] = "2",
    lidar: LidarOpt = False,
    navigator_view: NavigatorViewOpt = False,
    live: LiveOpt = False,
    live_host: LiveHostOpt = "127.0.0.1",
    live_port: LivePortOpt = "8765",
    live_wait: LiveWaitOpt = "30",
    speed: SpeedOpt = "1",
    wall_limit: Annotated[str | None, typer.Option(metavar="S", help=(
        "Wall-clock limit of one run in real seconds, > 0 (a navigator that hangs is killed and its run "
        "recorded as Fail-Other). Default: timeout * 2 + 120.")) ] = None,
    as_json: Annotated[bool, typer.Option("--json", help=(
        "Print the result as one JSON object on stdout (counts by outcome, every record, the paths written) "
        "instead of the table; the progress goes to stderr.")) ] = False,
) -> None:
    """Run the navigator on a world's mission, classify each run, write traces and a picture.

    Exit 0 when every run is recorded, whatever its outcome: a failing run is a result, not an
    error (`navstress gate` turns results into pass or fail); 2 on bad input."""
    n = bounded_int("--runs", runs, 1, MAX_RUNS)
    seed_v = bounded_int("--seed", seed, 0, MAX_SEED)
    timeout_v = number("--timeout", timeout, f"a duration in seconds in (0, {MAX_TIMEOUT_S:g}]")
    if not 0 < timeout_v <= MAX_TIMEOUT_S:
        raise SpecError("--timeout", timeout, f"a duration in seconds in (0, {MAX_TIMEOUT_S:g}]")
    tol = number("--goal-tolerance", goal_tolerance, "a distance in meters > 0")
    if tol <= 0:
        raise SpecError("--goal-tolerance", goal_tolerance, "a distance in meters > 0")
    wall_v = None
    if wall_limit is not None:
        wall_v = number("--wall-limit", wall_limit, f"a duration in seconds in (0, {MAX_WALL_S:g}]")
        if not 0 < wall_v <= MAX_WALL_S:
            raise SpecError("--wall-limit", wall_limit, f"a duration in seconds in (0, {MAX_WALL_S:g}]")
    settings = live_settings(live_host, live_port, live_wait, speed) if live else None
    if settings is not None and wall_v is None:  # paced to the wall clock, after waiting for a client
        wall_v = default_wall_limit_s(timeout_v / settings.speed) + settings.wait_s
    robot_v = load_robot_flags(robot, sensor, sensor_add)
    world = World.load(world_dir)  # a clear error for a non-world, before anything is written
    world_seed = world.seed
    check_robot_fits(world.mission.free_radius_m, robot_v, "--robot")
    check_stable(robot_v)  # a robot the simulation cannot hold stable: refused before any run
    cfg = load_navigator_config(navigator_config)
    # built in a worker process: a navigator that exits, crashes or hangs there is the runs' to classify
    check_buildable(build_and_close, navigator, fault, cfg,
                    wall_limit_s=wall_v if wall_v is not None else default_wall_limit_s(timeout_v))
    _, note = resolve(navigator)  # an unversioned name's note, said once here (the runs are quiet)
    if note:
        warnings.warn(note, NavigatorNote, stacklevel=1)
    if output.exists() and (not output.is_dir() or any(output.iterdir())):
        raise WorldFileError(f"--output={str(output)!r} is invalid: expected a new or empty folder; "
                             "choose another path or remove it")
    created = not output.exists()
    con = console(stderr=as_json)
    counts: dict[str, int] = {}
    try:
        tasks = plan_batch(world_dir, output, navigator=navigator, navigator_config=cfg, fault=fault, runs=n,
                           seed=seed_v, timeout_s=timeout_v, goal_tolerance_m=tol, record_lidar=lidar,
                           record_navigator=navigator_view or live, map_seed=world_seed, robot=robot_v)
        if settings is not None:
            con.print(live_banner(settings))
        with Bar(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                      TimeRemainingColumn(), TextColumn("{task.fields[counts]}"), console=con) as prog:
            bar = prog.add_task("runs", total=n, counts="")

            def done(rec: Any) -> None:
                counts[rec.outcome] = counts.get(rec.outcome, 0) + 1
                prog.update(bar, advance=1, counts="  ".join(f"{k}={v}" for k, v in sorted(counts.items())))

            records = run_batch(tasks, output, done, wall_limit_s=wall_v, live=settings)
    except BaseException:
        if created and not counts:  # nothing recorded: leave nothing behind
            shutil.rmtree(output, ignore_errors=True)
        raise
    pic = batch_picture(world_dir, records, output / "trajectories.png",
                        f"{navigator}{' + ' + fault if fault else ''}: {n} run(s) on {world_dir.name}")
    if as_json:
        typer.echo(dumps({"world": str(world_dir), "navigator": navigator, "fault": fault or NOMINAL,
                          "robot": {"name": robot_v.name, "digest": robot_v.digest}, "runs": len(records),
                          "counts": {o: sum(r.outcome == o for r in records) for o in OUTCOMES},
                          "output": str(output), "records_file": str(output / "runs.jsonl"), "picture": str(pic),
                          "records": [record_dict(r) for r in records]}))
        return
    table = Table(title=f"{navigator}{' + ' + fault if fault else ''} on {world_dir}"
                        + (f" (robot {robot_v.name})" if robot is not None or sensor or sensor_add else ""))
    for col in ("run", "outcome", "sim s", "wall s", "goal m", "path m", "reason"):
        table.add_column(col)
    for r in records:
        table.add_row(r.run_id, r.outcome, f"{r.duration_s:.1f}", f"{r.wall_s:.1f}", f"{r.goal_distance_m:.2f}",
                      f"{r.path_length_m:.1f}", r.reason)
    con.print(table)
    con.print(f"traces and records in {output}/, picture: {pic}")
