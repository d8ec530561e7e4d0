"""Several runs of one navigator on one world (``navstress run``).

Each run gets its own run seed ``derive_seed(seed, "run", i)`` and its own trace; records are
appended to ``OUT/runs.jsonl`` as each run finishes (flushed and fsync'd: nothing is lost if
the batch is interrupted), and ``OUT/trajectories.png`` shows all runs over the world.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from navstress.run.mission import execute
from navstress.run.record import RunRecord, RunTask
from navstress.seeding import derive_seed


def plan_batch(world_dir: Path, out: Path, *, navigator: str, navigator_config: dict[str, Any], fault: str | None,
               runs: int, seed: int, timeout_s: float, goal_tolerance_m: float,
               record_lidar: bool = False) -> list[RunTask]:
    return [RunTask(run_id=f"run-{i:03d}", world_dir=str(world_dir), run_seed=derive_seed(seed, "run", i),
                    trace_path=str(out / f"run-{i:03d}.mcap"), navigator=navigator,
                    navigator_config=navigator_config, fault=fault, timeout_s=timeout_s,
                    goal_tolerance_m=goal_tolerance_m, run_index=i, experiment="single",
                    record_lidar=record_lidar)
            for i in range(runs)]


def run_batch(tasks: list[RunTask], out: Path, on_done: Callable[[RunRecord], None] | None = None) -> list[RunRecord]:
    out.mkdir(parents=True, exist_ok=True)
    records: list[RunRecord] = []
    with open(out / "runs.jsonl", "a", encoding="utf-8") as f:
        for task in tasks:
            rec = execute(task)
            f.write(json.dumps(asdict(rec), sort_keys=True) + "\n")
            f.flush()
            os.fsync(f.fileno())
            records.append(rec)
            if on_done:
                on_done(rec)
    return records


def batch_picture(world_dir: Path, records: list[RunRecord], path: Path, title: str) -> Path:
    from navstress.analysis.figures import RunTrack, trajectories_png
    from navstress.run.trace import TOPIC_PERCEIVED, read_poses
    from navstress.world.world import World

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
        tracks.append(RunTrack(r.run_id, r.outcome, truth, perceived, col))
    return trajectories_png(world, tracks, path, title=title, perceived=len(records) == 1)
