"""Several runs of one navigator on one world (``navstress run``).

Each run gets its own run seed ``derive_seed(seed, "run", i)`` and its own trace; records are
appended to ``OUT/runs.jsonl`` as each run finishes (flushed and fsync'd: nothing is lost if
the batch is interrupted), and ``OUT/trajectories.png`` shows all runs over the world. Every
record carries the world's own seed as ``map_seed`` (DESIGN invariant 2).

The runs execute in a worker process (:mod:`navstress.isolate`) with a wall-clock limit per
run (default ``timeout_s * 2 + 120`` s, as in campaigns): a navigator that exits, crashes its
process or hangs costs its own run, recorded as Fail-Other with the reason and no trace left
behind, and the batch goes on in a fresh worker.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from navstress import _files, _json
from navstress._tables import NOMINAL, config_key_of
from navstress.errors import NavstressError, SpecError
from navstress.isolate import Worker
from navstress.run.live import execute_live
from navstress.run.mission import execute
from navstress.run.record import RunRecord, RunTask, without_source
from navstress.run.robot import task_robot
from navstress.run.trace import TOPIC_PERCEIVED, read_movers, read_poses, read_robot
from navstress.seeding import derive_seed
from navstress.world.world import World

#: Default wall-clock limit of one run: ``timeout_s * WALL_FACTOR + WALL_SLACK_S`` real seconds.
WALL_FACTOR = 2.0
WALL_SLACK_S = 120.0


#: Modules a run's worker imports before it takes runs (outside the wall-clock limit).
PRELOAD = ("navstress.run.mission", "navstress.sim.simulation", "navstress.nav.reference")


def default_wall_limit_s(timeout_s: float) -> float:
    """The wall-clock limit of a run of ``timeout_s`` simulated seconds when none is given."""
    return timeout_s * WALL_FACTOR + WALL_SLACK_S


def plan_batch(world_dir: Path, out: Path, *, navigator: str, navigator_config: dict[str, Any], fault: str | None,
               runs: int, seed: int, timeout_s: float, goal_tolerance_m: float,
               record_lidar: bool = False, record_navigator: bool = False,
               map_seed: int | None = None, robot: Any = None) -> list[RunTask]:
    """The tasks of ``runs`` runs on ``world_dir``; ``map_seed``: the world's seed (read from
    the world when not given); ``robot``: the simulated robot (a RobotSpec, a profile name or a
    robot file; default the paper's rmp400)."""
    if map_seed is None:
        map_seed = World.load(world_dir).seed
    planned = task_robot(robot)
    return [RunTask(run_id=f"run-{i:03d}", world_dir=str(world_dir), run_seed=derive_seed(seed, "run", i),
                    trace_path=str(out / f"run-{i:03d}.mcap"), navigator=navigator,
                    navigator_config=navigator_config, fault=fault, timeout_s=timeout_s,
                    goal_tolerance_m=goal_tolerance_m, run_index=i, experiment="single",
                    record_lidar=record_lidar, record_navigator=record_navigator, map_seed=int(map_seed),
                    robot=planned)
            for i in range(runs)]


def failure_record(task: RunTask, reason: str, wall_s: float = 0.0) -> RunRecord:
    """A Fail-Other record for a run that produced no result of its own (its process died, it
    exceeded the wall-clock limit, it raised out of the run loop); used by `navstress run` and
    by the campaign executors."""
    return RunRecord(
        run_id=task.run_id, experiment=task.experiment, config=dict(task.config), map_index=task.map_index,
        run_index=task.run_index, map_seed=task.map_seed, run_seed=task.run_seed, navigator=task.navigator,
        fault=task.fault, outcome="fail-other", reason=reason, duration_s=0.0, wall_s=wall_s,
        goal_distance_m=math.nan, path_length_m=0.0, tortuousness=0.0, collisions=0, first_collision_s=None,
        errors=[reason], trace=None, **_robot_columns(task))


def _robot_columns(task: RunTask) -> dict[str, str]:
    """The record's robot and robot_digest for ``task`` (a robot description that no longer
    validates: its name as planned, no digest; a campaign store fills both in from its plan)."""
    try:
        robot = task.robot_spec()
    except SpecError:
        return {"robot": str((task.robot or {}).get("name", "unknown")), "robot_digest": ""}
    return {"robot": robot.name, "robot_digest": robot.digest}


def drop_partial_trace(task: RunTask) -> None:
    """Remove the partial trace a killed run left behind (TraceWriter's ``.NAME.partial``)."""
    p = Path(task.trace_path)
    try:
        p.with_name(f".{p.name}.partial").unlink(missing_ok=True)
    except OSError:  # its folder is gone or not a folder: there is no partial trace either
        pass


def _first_line(text: str) -> str:
    lines = text.splitlines()
    return lines[0] if lines else ""


def run_isolated(task: RunTask, worker: Worker, live: Any = None) -> RunRecord:
    """``execute(task)`` in ``worker`` (``execute_live(task, live)`` with
    :class:`~navstress.run.live.LiveSettings`); whatever goes wrong with the navigator (its process
    died, it hung, something raised out of the run) becomes a Fail-Other record. An OSError
    (full disk, permissions) or a NavstressError is navstress's own failure: raised here."""
    t0 = time.perf_counter()
    try:
        if live is None:
            status, value = worker.call(execute, task)
        else:
            status, value = worker.call(execute_live, task, live)
    except BaseException:  # Ctrl-C: stop the worker, leave nothing partial
        worker.close(now=True)
        drop_partial_trace(task)
        raise
    wall = time.perf_counter() - t0
    if status == "ok":
        rec: RunRecord = value
        return rec
    drop_partial_trace(task)
    if status == "raised" and isinstance(value, (OSError, NavstressError)):
        # navstress's own machinery failed (a full disk, an unreadable world), not the navigator
        # (execute() classifies whatever the navigator raises): stop with that error, record nothing
        raise value
    if status == "raised":
        why = f"run raised {type(value).__name__}: {_first_line(str(value))}".rstrip(": ")
    elif status == "died":
        why = f"the navigator killed its run's process ({value})"
    else:
        why = f"run exceeded wall-clock limit ({value:g} s); its process was killed"
    return failure_record(task, why, wall)


def check_buildable(fn: Callable[..., None], *args: Any, wall_limit_s: float = 120.0) -> None:
    """``fn(*args)`` (a check that builds the navigator) in a worker process: a
    :class:`~navstress.errors.NavstressError` it raises is raised here (bad input); a
    navigator that exits, crashes or hangs while being built is left to the runs to classify."""
    with Worker(wall_limit_s) as worker:
        status, value = worker.call(fn, *args)
    if status == "raised" and isinstance(value, NavstressError):
        raise value


def record_line(rec: RunRecord) -> str:
    """One line of ``runs.jsonl``: the record as strict JSON (an unknown number is ``null``), its
    keys spelled as in every table (navstress._tables.KEYS): ``config`` the configuration key,
    ``params`` the world's parameters, ``fault`` ``"nominal"`` for the nominal stack."""
    return _json.dumps(record_dict(rec), sort_keys=True) + "\n"


def record_dict(rec: RunRecord) -> dict[str, Any]:
    """A run's record as ``runs.jsonl`` and ``navstress run --json`` write it (see :func:`record_line`)."""
    d = without_source(asdict(rec))
    d["params"] = d["config"]
    d["config"] = config_key_of(rec.run_id, rec.experiment, rec.config)
    d["fault"] = rec.fault or NOMINAL
    return d


def run_batch(tasks: list[RunTask], out: Path, on_done: Callable[[RunRecord], None] | None = None, *,
              wall_limit_s: float | None = None, live: Any = None) -> list[RunRecord]:
    """Run ``tasks`` one after the other in a worker process, appending each record to
    ``out/runs.jsonl``. ``wall_limit_s``: per-run wall-clock limit (default
    :func:`default_wall_limit_s` of each task's timeout). ``live``: a
    :class:`~navstress.run.live.LiveSettings` to show each run in Foxglove as it goes."""
    out.mkdir(parents=True, exist_ok=True)
    records: list[RunRecord] = []
    limit = wall_limit_s if wall_limit_s is not None else max(
        (default_wall_limit_s(t.timeout_s) for t in tasks), default=WALL_SLACK_S)
    with Worker(limit, preload=PRELOAD) as worker, _files.open_nofollow(out / "runs.jsonl", "a", encoding="utf-8") as f:
        for task in tasks:
            rec = run_isolated(task, worker, live)
            f.write(record_line(rec))
            f.flush()
            os.fsync(f.fileno())
            records.append(rec)
            if on_done:
                on_done(rec)
    return records


def batch_picture(world_dir: Path, records: list[RunRecord], path: Path, title: str) -> Path:
    from navstress.run.figures import RunTrack, trajectories_png  # local: matplotlib, 0.7 s, not for workers

    world = World.load(world_dir)
    tracks = []
    for r in records:
        if r.trace is None:
            continue
        truth = read_poses(r.trace)
        perceived = read_poses(r.trace, TOPIC_PERCEIVED) if len(records) == 1 else None
        col = None
        if r.first_collision_s is not None and len(truth):
            k = int(np.argmin(np.abs(truth[:, 0] - r.first_collision_s)))
            col = (float(truth[k, 1]), float(truth[k, 2]))
        movers = read_movers(r.trace) if world.movers else None
        ring = read_robot(r.trace).footprint_points()  # the robot's true shape, where the run ended
        tracks.append(RunTrack(r.run_id, r.outcome, truth, perceived, col, movers, r.first_collision_s, ring))
    return trajectories_png(world, tracks, path, title=title, perceived=len(records) == 1)
