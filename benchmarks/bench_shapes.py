"""Cost of obstacle shapes: the full loop on a world of 2,000 cylinders and one of 500 wall segments
against the same worlds in boxes, one core.

Worlds (100 m x 100 m, flat, fixed seed, the mission (5, 50) -> (95, 50), nothing within 4 m of
either end):

- ``cylinders``: 2,000 upright cylinders (diameter 0.3-0.9 m, height 1.5-4 m); its box twin puts a
  box of the same size (side = the diameter, same height and yaw) at each cylinder's place;
- ``walls``: 500 wall segments (long thin boxes: 2-8 m x 0.2 m x 2.5 m, any heading); its box twin
  puts a square box of the same footprint area and height at each segment's centre (the same
  obstruction, in compact boxes: what a wall costs over a tree-like box).

For each world and twin: the full loop (``run_mission``: MuJoCo simulation with the obstacle pool +
the RMP 400's lidar 32 x 360 at 10 Hz + reference-v1 at 10 Hz, as ``bench_loop.py``) for
``--seconds`` of simulated time, ``--repeat`` runs, the median simulated/wall ratio and CPU ratio;
the scripted baseline (simulation + lidar on a fixed course, the same work in both twins up to the
geometry); and the lidar's mean cost per scan. ``--laser2d`` runs the same with the Jackal, one
UST-10-class ``lidar2d`` and ``reference-2d-v1`` (the BARN configuration).

    taskset -c 1 .venv/bin/python benchmarks/bench_shapes.py [--seconds 60] [--repeat 3] [--laser2d]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from typing import Any

import numpy as np

from navstress.nav.api import Command
from navstress.robot import RobotSpec, profile
from navstress.run.mission import run_mission
from navstress.sim import Simulation
from navstress.sim.lidar import Lidar
from navstress.sim.rays import Lidar2dCaster
from navstress.world.spec import WorldSpec
from navstress.world.world import Mission, Obstacle, World

SIZE = 100.0
START, GOAL = (5.0, 50.0, 0.0), (95.0, 50.0)
CLEAR_M = 4.0  # nothing this close to the start or the goal


def _clear(o: Obstacle) -> bool:
    """Whether the obstacle's footprint stays CLEAR_M from the start and the goal."""
    for px, py in (START[:2], GOAL):
        c, s = math.cos(o.yaw), math.sin(o.yaw)
        lx, ly = c * (px - o.x) + s * (py - o.y), -s * (px - o.x) + c * (py - o.y)
        if o.is_cylinder:
            gap = math.hypot(px - o.x, py - o.y) - o.size[0] / 2
        else:
            gap = math.hypot(max(abs(lx) - o.size[0] / 2, 0.0), max(abs(ly) - o.size[1] / 2, 0.0))
        if gap < CLEAR_M:
            return False
    return True


def _world(obstacles: list[Obstacle]) -> World:
    spec = WorldSpec(size_m=(SIZE, SIZE))
    return World.flat(spec, seed=1, obstacles=tuple(obstacles), mission=Mission(START, GOAL, CLEAR_M))


def cylinder_worlds(n: int = 2000, seed: int = 1) -> tuple[World, World]:
    """(n cylinders, their box twin)."""
    g = np.random.default_rng(seed)
    cyl: list[Obstacle] = []
    while len(cyl) < n:
        d, h = float(g.uniform(0.3, 0.9)), float(g.uniform(1.5, 4.0))
        o = Obstacle("tree", float(g.uniform(1, SIZE - 1)), float(g.uniform(1, SIZE - 1)), float(g.uniform(-3, 3)),
                     (d, d, h), shape="cylinder")
        if _clear(o):
            cyl.append(o)
    boxes = [Obstacle(o.kind, o.x, o.y, o.yaw, o.size, o.z) for o in cyl]
    return _world(cyl), _world(boxes)


def wall_worlds(n: int = 500, seed: int = 2) -> tuple[World, World]:
    """(n wall segments, their twin of square boxes of the same footprint areas)."""
    g = np.random.default_rng(seed)
    walls: list[Obstacle] = []
    while len(walls) < n:
        ln = float(g.uniform(2.0, 8.0))
        o = Obstacle("wall", float(g.uniform(4, SIZE - 4)), float(g.uniform(4, SIZE - 4)),
                     float(g.uniform(-math.pi, math.pi)), (ln, 0.2, 2.5))
        if _clear(o):
            walls.append(o)
    boxes = [Obstacle("rock", o.x, o.y, o.yaw, (math.sqrt(o.area), math.sqrt(o.area), o.size[2])) for o in walls]
    return _world(walls), _world(boxes)


def scripted(sim: Simulation, seconds: float) -> float:
    """Drive a fixed course (straight, gentle turns) for ``seconds``; the simulated/CPU ratio."""
    c0 = time.process_time()
    while sim.t < seconds and sim.stopped is None:
        sim.observe()
        k = int(sim.t // 10.0) % 4
        sim.command(Command(0.8, 0.0 if k in (0, 2) else (0.3 if k == 1 else -0.3)))
        sim.advance(0.1)
    return sim.t / (time.process_time() - c0)


def _timed(cls: type, name: str, acc: dict[str, float]) -> Any:
    orig = getattr(cls, name)

    def wrapper(*a: Any, **k: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return orig(*a, **k)
        finally:
            acc["t"] += time.perf_counter() - t0
            acc["n"] += 1

    setattr(cls, name, wrapper)
    return lambda: setattr(cls, name, orig)


def loop(world: World, robot: RobotSpec, navigator: str, seconds: float, repeat: int) -> dict[str, float]:
    """The full loop's figures on ``world``."""
    from navstress.nav.registry import make_navigator

    wall_r, cpu_r, dur = [], [], 0.0
    for _ in range(max(1, repeat)):
        t0, c0 = time.perf_counter(), time.process_time()
        r = run_mission(world, make_navigator(navigator), run_seed=3, timeout_s=seconds, robot=robot)
        wall_r.append(r.duration_s / (time.perf_counter() - t0))
        cpu_r.append(r.duration_s / (time.process_time() - c0))
        dur = r.duration_s
        outcome = f"{r.classification.outcome.value} ({r.classification.reason})"
    acc = {"t": 0.0, "n": 0.0}
    undo = _timed(Lidar2dCaster if robot.name == "jackal" else Lidar, "cast" if robot.name == "jackal" else "scan_body",
                  acc)
    try:
        sim = Simulation(world, robot, seed=3)
        base = scripted(sim, seconds)
    finally:
        undo()
    return {"wall": statistics.median(wall_r), "wall_min": min(wall_r), "wall_max": max(wall_r),
            "cpu": statistics.median(cpu_r), "sim_s": dur, "baseline_cpu": base,
            "scan_ms": 1e3 * acc["t"] / max(1.0, acc["n"]), "outcome": outcome}  # type: ignore[dict-item]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--laser2d", action="store_true", help="also: jackal + one ust10 lidar2d + reference-2d-v1")
    args = ap.parse_args()
    configs: list[tuple[str, RobotSpec, str]] = [("rmp400 + lidar3d, reference-v1", profile("rmp400"), "reference-v1")]
    if args.laser2d:
        from navstress.robot.files import with_sensors

        jackal = with_sensors(profile("jackal"), sensors=[{"name": "front_laser", "kind": "lidar2d", "profile": "ust10"}])
        configs.append(("jackal + ust10 lidar2d, reference-2d-v1", jackal, "reference-2d-v1"))
    pairs = {"2,000 cylinders": cylinder_worlds(), "500 wall segments": wall_worlds()}
    for label, robot, nav in configs:
        run_mission(pairs["2,000 cylinders"][0], __import__("navstress.nav.registry", fromlist=["x"]).make_navigator(nav),
                    run_seed=0, timeout_s=5.0, robot=robot)  # warm-up (numba caches)
        print(f"#### {label}, {args.seconds:.0f} s simulated, {args.repeat} runs each")
        for name, (shaped, boxed) in pairs.items():
            a = loop(shaped, robot, nav, args.seconds, args.repeat)
            b = loop(boxed, robot, nav, args.seconds, args.repeat)
            print(f"== {name} vs the same world in boxes")
            for tag, f in ((name, a), ("boxes", b)):
                print(f"  {tag:18s} full loop {f['wall']:6.1f} x real time (min {f['wall_min']:.1f}, max "
                      f"{f['wall_max']:.1f}), CPU {f['cpu']:6.1f} x; {f['sim_s']:.0f} s, {f['outcome']}; "
                      f"scripted sim+sensor {f['baseline_cpu']:6.1f} x CPU; scan {f['scan_ms']:.3f} ms")
            print(f"  cost of the shapes: full loop CPU {100 * (b['cpu'] / a['cpu'] - 1):+.1f} %, wall "
                  f"{100 * (b['wall'] / a['wall'] - 1):+.1f} %, scripted {100 * (b['baseline_cpu'] / a['baseline_cpu'] - 1):+.1f} %"
                  f" (positive: the shapes are slower)")


if __name__ == "__main__":
    main()
