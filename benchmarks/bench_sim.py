"""Simulation speed at the default fidelity, one core.

Prints physics steps per second, lidar rays per second, and the simulated-time / wall-time
ratio of driving a fixed 3-minute scripted course (straight, turn, straight, ...) on the DESIGN
benchmark worlds (100 m x 100 m: flat with 6 % trees, and s=4 d=2), with the default sensor
set-up (lidar 32 x 360 at 10 Hz, odometry 50 Hz, IMU 50 Hz, pose 10 Hz, observer 10 Hz) and
the same without lidar. In-run baselines of the physics + sensors figure: every obstacle static in
MuJoCo (``obstacle_pool=0``, the model before the obstacle pool) and, for comparison, the optional
analytic wheel contacts. Also the lidar at 32 x 1024. Real-time factors are given against wall
time and against the process CPU time (the latter is steadier on a shared machine).

Per-advance overhead: the CPU time of one 10 Hz control cycle (``command``, ``advance(0.1)``,
``observe``) without the lidar, and the part of it spent outside the compiled step loop
(``_step.run_steps``: the physics) -- the Python around the physics. Measured for the current
``Simulation`` and for the one of git revision ``--baseline`` (its ``simulation``, ``_step``,
``sensors``, ``observer`` and ``model`` loaded as a temporary package) in alternating blocks on
the same world and commands, one core.

    .venv/bin/python benchmarks/bench_sim.py [--seconds 180] [--baseline REV]
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import importlib
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from navstress.nav.api import Command
from navstress.sim import SimConfig, Simulation
from navstress.sim import _step as cur_step
from navstress.sim import native
from navstress.sim.lidar import Lidar, LidarConfig, build_scene
from navstress.world.generate import generate
from navstress.world.spec import WorldSpec


def course(t: float) -> Command:
    """A fixed scripted course: 20 s straight, 5 s turning left, 20 s straight, 5 s turning right, ..."""
    phase = t % 50.0
    if phase < 20.0 or 25.0 <= phase < 45.0:
        return Command(1.0, 0.0)
    return Command(0.5, 0.3 if phase < 25.0 else -0.3)


def drive(world, cfg: SimConfig, seconds: float) -> tuple[float, float, int, float]:  # type: ignore[no-untyped-def]
    """(wall seconds, simulated seconds, physics steps, CPU seconds) of the scripted course at
    10 Hz control."""
    sim = Simulation(world, config=cfg, seed=1, start=(20.0, 20.0, math.pi / 4))
    sim.advance(0.1)  # warm up (numba, caches)
    t0, c0 = time.perf_counter(), time.process_time()
    ts = sim.t
    while sim.t - ts < seconds - 1e-9 and sim.stopped is None:
        sim.command(course(sim.t - ts))
        sim.advance(0.1)
        sim.observe()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return wall, sim.t - ts, int(round((sim.t - ts) / cfg.timestep_s)), cpu


REPO = Path(__file__).resolve().parents[1]
SIM_MODULES = ("model", "_step", "sensors", "observer", "simulation")


def load_baseline(rev: str) -> dict[str, ModuleType]:
    """``navstress.sim``'s simulation modules of git revision ``rev`` as a temporary package (its
    own imports rewritten to it; the lidar and config stay current; kept in the temp dir so that
    numba's cache survives between runs)."""
    srcs = {m: subprocess.run(["git", "show", f"{rev}:src/navstress/sim/{m}.py"], cwd=REPO, capture_output=True,
                              text=True, check=True).stdout for m in SIM_MODULES}
    digest = hashlib.sha1("".join(srcs.values()).encode()).hexdigest()[:12]
    pkg = f"navsim_base_{digest}"
    root = Path(tempfile.gettempdir()) / f"navstress_bench_sim_{digest}"
    (root / pkg).mkdir(parents=True, exist_ok=True)
    for m, src in {**srcs, "__init__": ""}.items():
        text = src
        for n in SIM_MODULES:
            text = text.replace(f"navstress.sim.{n} ", f"{pkg}.{n} ").replace(f"navstress.sim.{n}\n", f"{pkg}.{n}\n")
        text = text.replace("from navstress.sim import _step", f"from {pkg} import _step")
        p = root / pkg / f"{m}.py"
        if not p.exists() or p.read_text() != text:
            p.write_text(text)
    if str(root) not in sys.path:
        sys.path.insert(0, str(root))
    return {m: importlib.import_module(f"{pkg}.{m}") for m in ("_step", "simulation")}


class _Timed:
    """Wraps a module's ``run_steps`` and sums the CPU time spent in it."""

    def __init__(self, mod: ModuleType) -> None:
        self.mod, self.inner, self.ns = mod, mod.run_steps, 0

    def __call__(self, *a: Any) -> int:
        c = time.process_time_ns()
        r = self.inner(*a)
        self.ns += time.process_time_ns() - c
        return int(r)


def _cycle_us(sim: Simulation, cycles: int) -> float:
    """CPU microseconds per 10 Hz cycle of the scripted course, over ``cycles`` cycles."""
    c0 = time.process_time_ns()
    for _ in range(cycles):
        sim.command(course(sim.t))
        sim.advance(0.1)
        sim.observe()
    return (time.process_time_ns() - c0) / cycles / 1e3


def overhead(world, baseline: dict[str, ModuleType], seconds: float,  # type: ignore[no-untyped-def]
             block: float = 5.0) -> dict[str, tuple[float, float]]:
    """{"baseline"/"current": (CPU us per 10 Hz cycle, of which outside run_steps)}, no lidar: the
    medians over alternating blocks of ``block`` simulated seconds (``run_steps`` timed by a wrapper
    in a separate pass of each block, so that the totals carry no wrapper cost)."""
    cfg = SimConfig(lidar_enabled=False)
    kinds = {"baseline": (baseline["simulation"].Simulation, baseline["_step"]),
             "current": (Simulation, cur_step)}
    sims = {n: c(world, config=cfg, seed=1, start=(20.0, 20.0, math.pi / 4)) for n, (c, _) in kinds.items()}
    timed = {n: c(world, config=cfg, seed=1, start=(20.0, 20.0, math.pi / 4)) for n, (c, _) in kinds.items()}
    for s in (*sims.values(), *timed.values()):
        s.advance(0.1)
    res: dict[str, tuple[list[float], list[float]]] = {n: ([], []) for n in kinds}
    cycles = int(round(block / 0.1))
    for _ in range(max(2, int(seconds / block))):
        for n, (_, mod) in kinds.items():
            total = _cycle_us(sims[n], cycles)
            w = _Timed(mod)
            setattr(mod, "run_steps", w)
            try:
                total_w = _cycle_us(timed[n], cycles)
            finally:
                setattr(mod, "run_steps", w.inner)
            res[n][0].append(total)
            res[n][1].append(total_w - w.ns / cycles / 1e3)
    return {n: (statistics.median(a), statistics.median(b)) for n, (a, b) in res.items()}


def lidar_rate(world, lcfg: LidarConfig, n: int = 30) -> float:  # type: ignore[no-untyped-def]
    lidar = Lidar(build_scene(world), lcfg)
    rot = np.eye(3)
    gen = np.random.default_rng(0)
    lidar.scan(np.array([50.0, 50.0, 2.0]), rot, gen)
    t0 = time.perf_counter()
    for k in range(n):
        o = np.array([20.0 + 2.0 * k, 20.0 + 2.0 * k, world.terrain.height_at(20 + 2 * k, 20 + 2 * k) + 1.0])
        lidar.scan(o, rot, gen)
    return n * lcfg.channels * lcfg.azimuth_steps / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=180.0, help="simulated seconds of the course")
    ap.add_argument("--baseline", default="4dc2429", help="git revision of the baseline simulation (overhead rows)")
    a = ap.parse_args()
    try:  # one core, as the figures are quoted
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    worlds = {
        "trees6%": generate(WorldSpec.model_validate({"obstacles": {"obstruction": {"tree": 6}}}), 1),
        "s4d2": generate(WorldSpec.model_validate({"ground": {"subdivisions": 4, "deformation": 2.0}}), 1),
    }
    print(f"bench_sim: {a.seconds:g} s scripted course, timestep {SimConfig().timestep_s * 1e3:g} ms, one core; "
          f"native terrain walk {native.status()}")
    base = load_baseline(a.baseline)
    for name, w in worlds.items():
        oh = overhead(w, base, min(a.seconds, 60.0))
        (b_tot, b_py), (c_tot, c_py) = oh["baseline"], oh["current"]
        print(f"[{name}] per 10 Hz cycle, no lidar (CPU us): baseline {a.baseline}: {b_tot:6.1f} total, "
              f"{b_py:5.1f} outside run_steps; current: {c_tot:6.1f} total, {c_py:5.1f} outside run_steps "
              f"({b_py / max(c_py, 1e-9):.2f}x less)")
        rows = {"physics+sensors, no lidar": SimConfig(lidar_enabled=False),
                "  baseline: all obstacles static": SimConfig(lidar_enabled=False, obstacle_pool=0),
                "  option: analytic wheel contacts": SimConfig(lidar_enabled=False, analytic_wheel_contacts=True)}
        for label, cfg in rows.items():
            wall, simt, steps, cpu = drive(w, cfg, a.seconds)
            print(f"[{name}] {label:34s}: {steps / wall:7.0f} steps/s  {simt / wall:6.1f}x real time "
                  f"(CPU time: {simt / cpu:6.1f}x)")
        wall0, sim0, _, cpu0 = drive(w, SimConfig(lidar_enabled=False), a.seconds)
        wall1, sim1, _, cpu1 = drive(w, SimConfig(), a.seconds)
        wide = SimConfig(lidar=dataclasses.replace(LidarConfig(), azimuth_steps=1024))
        wall2, sim2, _, cpu2 = drive(w, wide, min(a.seconds, 60.0))
        print(f"[{name}] physics+sensors+lidar 32x360 : {sim1 / wall1:6.1f}x real time (CPU time: {sim1 / cpu1:6.1f}x; "
              f"lidar costs {100 * (1 - cpu0 / cpu1 * sim1 / sim0):.0f}% of the run)")
        print(f"[{name}] physics+sensors+lidar 32x1024: {sim2 / wall2:6.1f}x real time (CPU time: {sim2 / cpu2:6.1f}x)")
        print(f"[{name}] lidar alone 32x360: {lidar_rate(w, LidarConfig()) / 1e6:6.2f} M rays/s; "
              f"32x1024: {lidar_rate(w, dataclasses.replace(LidarConfig(), azimuth_steps=1024)) / 1e6:6.2f} M rays/s")


if __name__ == "__main__":
    main()
