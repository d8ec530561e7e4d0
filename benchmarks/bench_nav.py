"""Reference navigator cost per call, replayed on recorded observations, against a git baseline.

Records the observations of a real mission (``run_mission`` with reference-v1, ``--seconds`` of
simulated time, run seed 3) on each DESIGN benchmark world (100 m x 100 m, the paper's mission;
flat with 6 % trees, and s=4 d=2; seed 1), then replays them through the navigator of git
revision ``--baseline`` (``src/navstress/nav/reference/*.py`` of that revision, loaded as a
temporary package) and through the current one, alternating passes, process CPU time, pinned to
one core. Per pass:

* ``step``: a whole replay (reset outside the timing), CPU time per ``step`` call;
* ``integrate``: every recorded scan integrated into a fresh map with the pose the navigator
  used (per scan); ``integrate (cold)``: the same with the caches flushed before each scan (the
  mission loop runs the physics and the lidar between two scans);
* ``evaluate``: ``ArcPlanner.evaluate`` at every recorded navigation cycle, on the final map
  (per cycle).

Best of the passes, and the ratio baseline / current. Outputs are checked bit-identical: the
commands and statuses of the replay, the perceived trajectory, the map statistics and fine layer,
and the planner's node costs.

    .venv/bin/python benchmarks/bench_nav.py [--seconds 30] [--passes 5] [--baseline REV]
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

import navstress.nav.reference.navigator as cur_navigator
import navstress.nav.reference.pose as cur_pose
import navstress.nav.reference.terrain_map as cur_terrain_map
from navstress.nav.api import Command, NavMission, Observation, Status
from navstress.robot import RobotSpec
from navstress.run.mission import run_mission
from navstress.seeding import derive_seed
from navstress.world.generate import generate
from navstress.world.spec import parse_spec
from navstress.world.world import World

REPO = Path(__file__).resolve().parents[1]
MODULES = ("config", "pose", "terrain_map", "planner", "navigator", "global_planner", "__init__")
RUN_SEED = 3


def load_baseline(rev: str) -> dict[str, ModuleType]:
    """``navstress.nav.reference`` of git revision ``rev`` as a temporary package (its own
    imports rewritten to it; kept in the temp dir so that numba's cache survives between runs)."""
    srcs = {m: subprocess.run(["git", "show", f"{rev}:src/navstress/nav/reference/{m}.py"], cwd=REPO,
                              capture_output=True, text=True, check=True).stdout for m in MODULES}
    digest = hashlib.sha1("".join(srcs.values()).encode()).hexdigest()[:12]
    pkg = f"navref_base_{digest}"
    root = Path(tempfile.gettempdir()) / f"navstress_bench_nav_{digest}"
    (root / pkg).mkdir(parents=True, exist_ok=True)
    for m, src in srcs.items():
        p = root / pkg / f"{m}.py"
        text = src.replace("navstress.nav.reference.", f"{pkg}.")
        if not p.exists() or p.read_text() != text:
            p.write_text(text)
    if str(root) not in sys.path:
        sys.path.insert(0, str(root))
    return {m: importlib.import_module(f"{pkg}.{m}") for m in ("pose", "terrain_map", "navigator")}


class Recorder:
    """A reference-v1 that keeps every observation it is given."""

    def __init__(self) -> None:
        self.inner = cur_navigator.ReferenceNavigator()
        self.config = self.inner.config
        self.observations: list[Observation] = []

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self.mission, self.robot, self.seed = mission, robot, seed
        self.inner.reset(mission, robot, seed=seed)

    def step(self, obs: Observation) -> Command | Status:
        self.observations.append(obs)
        return self.inner.step(obs)

    def close(self) -> None:
        self.inner.close()


@dataclass
class Recording:
    """One mission's observations and what the replay needs around them."""

    name: str
    mission: NavMission
    robot: RobotSpec
    seed: int
    observations: list[Observation]


def record(name: str, world: World, seconds: float) -> Recording:
    rec = Recorder()
    run_mission(world, rec, run_seed=RUN_SEED, timeout_s=seconds)
    return Recording(name, rec.mission, rec.robot, rec.seed, rec.observations)


@dataclass
class Replay:
    """What one replay produced (for the identity check) and its inputs for the part passes."""

    outputs: list[Command | Status]
    trajectory: np.ndarray
    stats: np.ndarray
    fine: np.ndarray
    scans: list[tuple[np.ndarray, tuple[float, float, float], tuple[float, ...]]]  # points, mount, pose row
    cycles: list[tuple[float, float, float, int]]  # x, y, yaw, spin of every evaluate call
    nav: Any


def replay(navmod: ModuleType, rec: Recording, *, collect: bool) -> tuple[float, int, Replay | None]:
    """Step a fresh navigator through ``rec``; (CPU seconds, steps, details when ``collect``)."""
    nav = navmod.ReferenceNavigator()
    nav.reset(rec.mission, rec.robot, seed=rec.seed)
    scans: list[tuple[np.ndarray, tuple[float, float, float], tuple[float, ...]]] = []
    cycles: list[tuple[float, float, float, int]] = []
    if collect:  # spy on the map and the planner (outside any timing)
        integ, evaluate = nav.terrain.integrate, nav.planner.evaluate

        def spy_integrate(points: np.ndarray, mount: tuple[float, float, float], pose: Any) -> int:
            scans.append((points, mount, pose.as_row()))
            return int(integ(points, mount, pose))

        def spy_evaluate(terrain: Any, x: float, y: float, yaw: float, spin: int) -> Any:
            cycles.append((x, y, yaw, spin))
            return evaluate(terrain, x, y, yaw, spin)

        nav.terrain.integrate = spy_integrate
        nav.planner.evaluate = spy_evaluate
    outputs: list[Command | Status] = []
    step = nav.step
    obs = rec.observations
    t0 = time.process_time()
    for o in obs:
        outputs.append(step(o))
    cpu = time.process_time() - t0
    if not collect:
        return cpu, len(obs), None
    del nav.terrain.integrate, nav.planner.evaluate  # the spies go (the passes below reuse nav)
    return cpu, len(obs), Replay(outputs, nav.perceived_trajectory(), nav.terrain.stats.copy(),
                                 nav.terrain.fine.copy(), scans, cycles, nav)


_EVICT = np.zeros(8_000_000)  # 64 MB, twice the L3 cache


def integrate_pass(tmmod: ModuleType, posemod: ModuleType, nav: Any, scans: list[Any],
                   cold: bool = False) -> tuple[float, np.ndarray, np.ndarray]:
    """Integrate every scan into a fresh map shaped as ``nav``'s; (CPU s, stats, fine). With
    ``cold``, the caches are flushed before each scan (outside the timing), as in the mission
    loop where the physics and the lidar run between two scans."""
    t = nav.terrain
    m = tmmod.TerrainMap(t.origin, t.shape, t.cell_m, t.step_m, t.max_range_m, t.sub)
    work = [(p, mount, posemod.Pose(*row)) for p, mount, row in scans]
    integ = m.integrate
    t0 = time.process_time()
    cpu = 0.0
    for p, mount, pose in work:
        if cold:
            _EVICT[::8] += 1.0
        t0 = time.process_time()
        integ(p, mount, pose)
        cpu += time.process_time() - t0
    return cpu, m.stats, m.fine


def evaluate_pass(nav: Any, cycles: list[tuple[float, float, float, int]]) -> tuple[float, list[np.ndarray]]:
    """``evaluate`` at every recorded cycle pose on ``nav``'s final map; (CPU s, node costs)."""
    ev = nav.planner.evaluate
    terrain = nav.terrain
    out = []
    t0 = time.process_time()
    for x, y, yaw, spin in cycles:
        out.append(ev(terrain, x, y, yaw, spin).node_cost)
    return time.process_time() - t0, out


def same(a: Any, b: Any) -> bool:
    """Bit-identical (NaN equal to NaN)."""
    if isinstance(a, np.ndarray):
        return a.shape == b.shape and a.dtype == b.dtype and bool(np.array_equal(a, b, equal_nan=True))
    if isinstance(a, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return bool(a == b)


def outputs_equal(a: list[Any], b: list[Any]) -> bool:
    return len(a) == len(b) and all(type(x).__name__ == type(y).__name__ and repr(x) == repr(y) for x, y in zip(a, b))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--passes", type=int, default=5)
    ap.add_argument("--baseline", default="4dc2429", help="git revision of the baseline navigator")
    args = ap.parse_args()
    if hasattr(os, "sched_setaffinity") and len(os.sched_getaffinity(0)) > 1:
        os.sched_setaffinity(0, {max(os.sched_getaffinity(0))})
    base = load_baseline(args.baseline)
    stacks = {"baseline": base, "current": {"pose": cur_pose, "terrain_map": cur_terrain_map,
                                            "navigator": cur_navigator}}
    worlds = {
        "flat, 6% trees (seed 1)": generate(parse_spec({"size_m": [100, 100], "obstacles": {"obstruction": {"tree": 6}}}), 1),
        "s=4 d=2 (seed 1)": generate(parse_spec({"size_m": [100, 100], "ground": {"subdivisions": 4, "deformation": 2.0}}), 1),
    }
    assert derive_seed(RUN_SEED, "navigator") == derive_seed(RUN_SEED, "navigator")
    print(f"baseline {args.baseline} vs working tree; {args.passes} alternating passes, CPU time, best")
    for name, world in worlds.items():
        rec = record(name, world, args.seconds)
        n_obs = len(rec.observations)
        details = {k: replay(s["navigator"], rec, collect=True)[2] for k, s in stacks.items()}
        b, c = details["baseline"], details["current"]
        assert b is not None and c is not None
        checks = {"outputs": outputs_equal(b.outputs, c.outputs), "trajectory": same(b.trajectory, c.trajectory),
                  "map stats": same(b.stats, c.stats), "fine layer": same(b.fine, c.fine),
                  "scans/cycles": len(b.scans) == len(c.scans) and b.cycles == c.cycles}
        best: dict[tuple[str, str], float] = {}
        costs: dict[str, list[np.ndarray]] = {}
        maps: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        for _ in range(args.passes):
            for k, s in stacks.items():
                d = details[k]
                assert d is not None
                cpu, n, _r = replay(s["navigator"], rec, collect=False)
                best[(k, "step")] = min(best.get((k, "step"), np.inf), cpu / n)
                cpu, st, fi = integrate_pass(s["terrain_map"], s["pose"], d.nav, c.scans)
                best[(k, "integrate")] = min(best.get((k, "integrate"), np.inf), cpu / max(1, len(c.scans)))
                maps[k] = (st, fi)
                cpu, _st, _fi = integrate_pass(s["terrain_map"], s["pose"], d.nav, c.scans, cold=True)
                best[(k, "integrate (cold)")] = min(best.get((k, "integrate (cold)"), np.inf), cpu / max(1, len(c.scans)))
                cpu, nc = evaluate_pass(d.nav, c.cycles)
                best[(k, "evaluate")] = min(best.get((k, "evaluate"), np.inf), cpu / max(1, len(c.cycles)))
                costs[k] = nc
        checks["integrate pass maps"] = same(maps["baseline"][0], maps["current"][0]) and same(
            maps["baseline"][1], maps["current"][1])
        checks["evaluate pass costs"] = same(costs["baseline"], costs["current"])
        npts = sum(len(p) for p, _m, _r in c.scans) / max(1, len(c.scans))
        print(f"== {name}: {n_obs} steps ({rec.observations[-1].t:.1f} s simulated), {len(c.scans)} scans "
              f"(~{npts:.0f} points), {len(c.cycles)} planning cycles")
        for part, unit in (("step", "step"), ("integrate", "scan"), ("integrate (cold)", "scan"), ("evaluate", "cycle")):
            bb, cc = best[("baseline", part)], best[("current", part)]
            print(f"  {part:16s} baseline {1e3 * bb:7.4f} ms/{unit:5s}  current {1e3 * cc:7.4f} ms/{unit:5s}  "
                  f"ratio {bb / cc:5.2f}x")
        steps_per_s = n_obs / max(rec.observations[-1].t, 1e-9)
        print(f"  navigator per simulated second: baseline {1e3 * best[('baseline', 'step')] * steps_per_s:.3f} ms, "
              f"current {1e3 * best[('current', 'step')] * steps_per_s:.3f} ms")
        print("  bit-identical: " + ", ".join(f"{k} {'yes' if v else 'NO'}" for k, v in checks.items()))


if __name__ == "__main__":
    main()
