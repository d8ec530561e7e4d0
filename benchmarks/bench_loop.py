"""Full mission loop speed at the default fidelity, one core.

The simulated-time / wall-time ratio of ``run_mission`` (MuJoCo simulation + lidar 32 x 360 at
10 Hz + reference-v1 at 10 Hz) on the DESIGN benchmark worlds (100 m x 100 m, the paper's
mission; flat with 6 % trees, the same with 20 movers (16 crossing pedestrians, 2 intercepting
walkers, 2 vehicles: default fidelity), and s=4 d=2; fixed seeds), for ``--seconds`` of simulated time;
in the same run, the baseline: the simulation alone driven by a scripted controller; and a
breakdown from timers wrapped around the hot calls (physics+sensors = Simulation.advance minus
the lidar; lidar = Lidar.scan_body, the scan the simulation makes; map integration = TerrainMap.integrate; planning =
ArcPlanner.evaluate; the rest of the navigator = step minus those two; movers = the movers'
controller runs, Simulation._step_movers, inside physics+sensors), with the mean cost per
call of map integration (per scan) and planning (per 10 Hz cycle).

``--robots`` runs the same for other robot profiles (default: the paper's ``rmp400`` alone, whose
section names are unchanged for ``side_by_side.py``; another profile's sections start with its
name in brackets).

    taskset -c 1 .venv/bin/python benchmarks/bench_loop.py [--seconds 60] [--repeat 3]
    taskset -c 1 .venv/bin/python benchmarks/bench_loop.py --robots husky,jackal,turtlebot4,f1tenth

``--laser2d`` adds the configuration "jackal + one ust10 lidar2d" (a UST-10LX-class planar scanner,
270 degrees, 1081 beams, 40 Hz, named ``front_laser``) on the flat world with 6 % trees, driven by
``--navigator`` (default ``reference-2d-v1`` when it is registered, else ``reference-v1``, which
sees no 3-D scans then): its full loop (the median of ``--repeat`` runs, timers on) and the parts of
the last run per simulated second: physics+sensors (``Simulation.advance`` minus the casts), the
scanner's casts (``Lidar2dCaster.cast``: fan, noise, reading), the navigator's ``step``, the rest.

    taskset -c 1 .venv/bin/python benchmarks/bench_loop.py --robots none --laser2d
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

from navstress.nav.api import Command
from navstress.nav.reference.navigator import ReferenceNavigator
from navstress.nav.reference.planner import ArcPlanner
from navstress.nav.reference.terrain_map import TerrainMap
from navstress.robot import RobotSpec, profile
from navstress.run.mission import run_mission
from navstress.sim import Simulation
from navstress.sim.lidar import Lidar
from navstress.world.generate import generate
from navstress.world.spec import parse_spec

#: The movers world: the trees world with 20 movers (runs end at a collision, as every mission).
MOVERS_WORLD: dict[str, Any] = {
    "size_m": [100, 100], "obstacles": {"obstruction": {"tree": 6}},
    "movers": {"types": {"walker": {"shape": "disc", "length_m": 0.5, "width_m": 0.5, "height_m": 1.8,
                                    "speed_min_m_s": 0.5, "speed_max_m_s": 1.5}},
               "count": {"pedestrian": 16, "walker": 2, "vehicle": 2},
               "behaviour": {"pedestrian": {"pause_max_s": 2.0}, "walker": {"kind": "intercept", "ttc_s": 3.0}}}}

TIMES: dict[str, float] = defaultdict(float)
CPU: dict[str, float] = {}
CALLS: dict[str, int] = defaultdict(int)


def timed(cls: type, name: str, key: str) -> Callable[[], None]:
    """Wrap ``cls.name`` with a wall-clock accumulator under ``key``; returns the undo."""
    orig = getattr(cls, name)

    def wrapper(*a: Any, **k: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return orig(*a, **k)
        finally:
            TIMES[key] += time.perf_counter() - t0
            CALLS[key] += 1

    setattr(cls, name, wrapper)
    return lambda: setattr(cls, name, orig)


def scripted(sim: Simulation, seconds: float) -> float:
    """Drive a scripted course (straight, gentle turns) for ``seconds``; returns the wall time
    (the process CPU time in ``CPU["baseline"]``)."""
    c0 = time.process_time()
    t0 = time.perf_counter()
    while sim.t < seconds and sim.stopped is None:
        sim.observe()
        k = int(sim.t // 10.0) % 4
        sim.command(Command(0.8, 0.0 if k in (0, 2) else (0.3 if k == 1 else -0.3)))
        sim.advance(0.1)
    CPU["baseline"] = time.process_time() - c0
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--repeat", type=int, default=3,
                    help="runs of the full loop per world (wall time on a shared or virtual machine varies "
                         "by +-5-10 %%: the median and the range are printed)")
    ap.add_argument("--robots", default="rmp400", help="comma-separated robot profiles ('none': none)")
    ap.add_argument("--laser2d", action="store_true", help="also: jackal + one ust10 lidar2d")
    ap.add_argument("--navigator", default=None, help="the navigator of --laser2d (default: reference-2d-v1 "
                    "when registered, else reference-v1)")
    args = ap.parse_args()
    for name in args.robots.split(","):
        if name.strip() != "none":
            bench_robot(profile(name.strip()), args.seconds, args.repeat)
    if args.laser2d:
        bench_laser2d(args.seconds, args.repeat, args.navigator)


def bench_laser2d(seconds: float, repeat: int, navigator: str | None) -> None:
    """The full loop of a Jackal with one UST-10LX-class scanner on the flat world with 6 % trees."""
    from navstress.nav.registry import list_navigators, make_navigator
    from navstress.robot.files import with_sensors
    from navstress.sim.rays import Lidar2dCaster

    if navigator is None:
        names = {f"{s.base}-v{s.version}" for s in list_navigators()}
        navigator = "reference-2d-v1" if "reference-2d-v1" in names else "reference-v1"
    robot = with_sensors(profile("jackal"), sensors=[{"name": "front_laser", "kind": "lidar2d", "profile": "ust10"}])
    world = generate(parse_spec({"size_m": [100, 100], "obstacles": {"obstruction": {"tree": 6}}}), 1, robot=robot)
    run_mission(world, make_navigator(navigator), run_seed=0, timeout_s=20.0, robot=robot)  # warm-up (compiles)
    ratios, cpu = [], []
    for i in range(max(1, repeat)):
        TIMES.clear()
        CALLS.clear()
        nav = make_navigator(navigator)
        undo = [timed(Lidar2dCaster, "cast", "laser"), timed(Simulation, "advance", "sim"),
                timed(type(nav), "step", "nav")]
        t0, c0 = time.perf_counter(), time.process_time()
        r = run_mission(world, nav, run_seed=3, timeout_s=seconds, robot=robot)
        wall = time.perf_counter() - t0
        for u in undo:
            u()
        ratios.append(r.duration_s / wall)
        cpu.append(r.duration_s / (time.process_time() - c0))
    print(f"== [jackal + ust10 lidar2d, {navigator}] flat, 6% trees (seed 1): {r.duration_s:.0f} s simulated, "
          f"outcome {r.classification.outcome.value} ({r.classification.reason})")
    print(f"  full loop, {len(ratios)} runs: median {statistics.median(ratios):6.1f} x real time "
          f"(min {min(ratios):.1f}, max {max(ratios):.1f}); CPU time: median {statistics.median(cpu):6.1f} x")
    print(f"  lidar2d casts: {1e3 * TIMES['laser'] / max(1, CALLS['laser']):.3f} ms/scan ({CALLS['laser']} scans, "
          f"{100 * TIMES['laser'] / wall:.1f} % of the last run's wall time)")
    parts = {"physics+sensors (advance minus the casts)": TIMES["sim"] - TIMES["laser"], "lidar2d casts": TIMES["laser"],
             f"navigator ({navigator} step)": TIMES["nav"]}
    parts["loop/other"] = wall - sum(parts.values())
    print(f"  the last run, per simulated second ({wall:.2f} s wall for {r.duration_s:.0f} s):")
    for k, v in parts.items():
        print(f"    {k:44s} {1e3 * v / r.duration_s:7.3f} ms  {100 * v / wall:5.1f} %")
    print(f"  per call: navigator step {1e3 * TIMES['nav'] / max(1, CALLS['nav']):.3f} ms ({CALLS['nav']} steps)")


def bench_robot(robot: RobotSpec, seconds: float, repeat: int) -> None:
    """The three worlds with ``robot``."""
    tag = "" if robot.name == "rmp400" else f"[{robot.name}] "
    worlds = {
        "flat, 6% trees (seed 1)": generate(parse_spec({"size_m": [100, 100], "obstacles": {"obstruction": {"tree": 6}}}), 1),
        "flat, 6% trees, 20 movers (seed 1)": generate(parse_spec(MOVERS_WORLD), 1),
        "s=4 d=2 (seed 1)": generate(parse_spec({"size_m": [100, 100], "ground": {"subdivisions": 4, "deformation": 2.0}}), 1),
    }
    # warm up the numba caches outside the timing
    # (20 s: past the scan manoeuvre, so the planning kernels are loaded too)
    run_mission(worlds["s=4 d=2 (seed 1)"], ReferenceNavigator(), run_seed=0, timeout_s=20.0, robot=robot)
    run_mission(worlds["flat, 6% trees, 20 movers (seed 1)"], ReferenceNavigator(), run_seed=0, timeout_s=5.0,
                robot=robot)
    for name, world in worlds.items():
        sim = Simulation(world, robot, seed=3)
        base_wall = scripted(sim, seconds)
        base_ratio = sim.t / base_wall
        TIMES.clear()
        CALLS.clear()
        undo = [timed(Simulation, "advance", "sim"), timed(Lidar, "scan_body", "lidar"),
                timed(ReferenceNavigator, "step", "nav"), timed(TerrainMap, "integrate", "map"),
                timed(ArcPlanner, "evaluate", "plan"), timed(Simulation, "_step_movers", "movers")]
        t0 = time.perf_counter()
        r = run_mission(world, ReferenceNavigator(), run_seed=3, timeout_s=seconds, robot=robot)
        wall = time.perf_counter() - t0
        for u in undo:
            u()
        # the same run again without the timers (same seed: the same work), for the spread
        ratios, cpu_ratios = [r.duration_s / wall], []
        for _ in range(max(0, repeat - 1)):
            t1, c1 = time.perf_counter(), time.process_time()
            r2 = run_mission(world, ReferenceNavigator(), run_seed=3, timeout_s=seconds, robot=robot)
            cpu_ratios.append(r2.duration_s / (time.process_time() - c1))
            ratios.append(r2.duration_s / (time.perf_counter() - t1))
        print(f"== {tag}{name}: {r.duration_s:.0f} s simulated, outcome {r.classification.outcome.value} "
              f"({r.classification.reason})")
        print(f"  full loop      : {r.duration_s / wall:6.1f} x real time  ({wall:.2f} s wall, with the timers below)")
        if len(ratios) > 1:
            print(f"  full loop, {len(ratios)} runs: median {statistics.median(ratios):6.1f} x real time "
                  f"(min {min(ratios):.1f}, max {max(ratios):.1f})")
        if cpu_ratios:  # CPU time: steadier than wall time on a loaded machine
            print(f"  full loop, CPU time: median {statistics.median(cpu_ratios):6.1f} x real time "
                  f"(min {min(cpu_ratios):.1f}, max {max(cpu_ratios):.1f})")
        print(f"  baseline (sim + lidar, scripted): {base_ratio:6.1f} x real time "
              f"({sim.t / CPU['baseline']:.1f} x in CPU time)")
        parts = {"physics+sensors": TIMES["sim"] - TIMES["lidar"], "lidar": TIMES["lidar"],
                 "map integration": TIMES["map"], "planning (P3D)": TIMES["plan"],
                 "navigator other (POM, fill, election)": TIMES["nav"] - TIMES["map"] - TIMES["plan"]}
        parts["loop/other"] = wall - sum(parts.values())
        if CALLS["movers"]:
            parts["  of physics+sensors: movers' controller"] = TIMES["movers"]
        for k, v in parts.items():
            print(f"    {k:40s} {v:7.3f} s  {100 * v / wall:5.1f} %")
        print(f"  per call: map integration {1e3 * TIMES['map'] / max(1, CALLS['map']):.3f} ms/scan "
              f"({CALLS['map']} scans), planning {1e3 * TIMES['plan'] / max(1, CALLS['plan']):.3f} ms/cycle "
              f"({CALLS['plan']} cycles), navigator step {1e3 * TIMES['nav'] / max(1, CALLS['nav']):.3f} ms"
              + (f", movers' controller {1e6 * TIMES['movers'] / CALLS['movers']:.1f} us/run ({CALLS['movers']} runs)"
                 if CALLS["movers"] else ""))


if __name__ == "__main__":
    main()
