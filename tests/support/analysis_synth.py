"""Small synthetic campaign stores for analysis tests: a real Store, hand-written RunRecords,
optional hand-written MCAP traces and flat worlds (no simulation)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from navstress.campaign.plan import run_id
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import Store
from navstress.run.record import RunRecord
from navstress.run.trace import TOPIC_MAP, TOPIC_PERCEIVED, TOPIC_TRUTH, TraceWriter

TREE = "obstacles.obstruction.tree"
DEF = "ground.deformation"


def spec_dict(*, trees: list[int] = [0, 4, 8], defs: list[float] = [0.5], maps: int = 2, runs: int = 2,
              faults: list[str | None] = [None]) -> dict[str, Any]:
    exps: list[dict[str, Any]] = [{"name": "trees", "sweep": {TREE: {"values": list(trees)}}}]
    if defs:
        exps.append({"name": "smooth", "overrides": {"ground": {"subdivisions": 2}},
                     "sweep": {DEF: {"values": list(defs)}}, "faults": [None]})
    return {"name": "synth", "seed": 3, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5}, "experiments": exps,
            "maps_per_config": maps, "runs_per_map": runs, "faults": list(faults), "timeout_s": 100.0}


def make_store(root: Path, **kw: Any) -> Store:
    d = spec_dict(**kw)
    return Store.create(root, parse_campaign(d), yaml.safe_dump(d))


def record(exp: str, key: str, m: int, r: int, outcome: str = "success", *, fault: str | None = None,
           duration: float = 10.0, tort: float = 0.1, goal: float = 1.0, collisions: int = 0,
           trace: str | None = None, params: dict[str, Any] | None = None) -> RunRecord:
    name, val = key.split("=")
    cfg = params if params is not None else {(TREE if name == "tree" else DEF): (float(val) if "." in val else int(val))}
    return RunRecord(run_id=run_id(exp, key, m, r, "reference-v1", fault), experiment=exp, config=cfg, map_index=m,
                     run_index=r, map_seed=100 + m, run_seed=200 + r, navigator="reference-v1", fault=fault,
                     outcome=outcome, reason="synthetic", duration_s=duration, wall_s=1.0, goal_distance_m=goal,
                     path_length_m=10.0, tortuousness=tort, collisions=collisions,
                     first_collision_s=1.0 if collisions else None, errors=[], trace=trace)


def write_trace(path: Path, xy_t: np.ndarray, *, perceived_offset: float = 0.3, grid: bool = True) -> str:
    """A trace whose truth poses are ``xy_t`` rows (t, x, y); perceived = truth shifted in x."""
    rows = np.zeros((len(xy_t), 7))
    rows[:, :3] = xy_t
    with TraceWriter(path) as w:
        w.poses(TOPIC_TRUTH, rows)
        per = rows.copy()
        per[:, 1] += perceived_offset
        w.poses(TOPIC_PERCEIVED, per)
        if grid:
            g = np.full((40, 40), np.nan, np.float32)
            g[:20, :] = 0.1
            w.grid(TOPIC_MAP, float(xy_t[-1, 0]), g, (0.0, 0.0), 0.5)
    return str(path)


def line(t_end: float, x0: float, y0: float, x1: float, y1: float, dt: float = 0.5) -> np.ndarray:
    t = np.arange(0.0, t_end + 1e-9, dt)
    f = t / t_end if t_end > 0 else np.zeros_like(t)
    return np.column_stack([t, x0 + f * (x1 - x0), y0 + f * (y1 - y0)])


def save_flat_worlds(store: Store, trees_per_map: int = 0) -> None:
    """A flat 20 m world with a mission (and optionally a tree) in every planned map dir."""
    from navstress.world.spec import WorldSpec
    from navstress.world.world import Obstacle, World

    spec = WorldSpec(size_m=(20.0, 20.0), cell_m=0.5)
    for mj in store.plan().maps:
        obs = tuple(Obstacle("tree", 6.0 + i, 12.0, 0.0, (1.0, 1.0, 3.0)) for i in range(trees_per_map))
        World.flat(spec, seed=mj.map_seed, obstacles=obs).save(mj.world_dir)


NAN = math.nan
