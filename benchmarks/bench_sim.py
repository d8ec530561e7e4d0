"""Simulation speed at the default fidelity, one core.

Prints physics steps per second, lidar rays per second, and the simulated-time / wall-time
ratio of driving a fixed 3-minute scripted course (straight, turn, straight, ...) on the DESIGN
benchmark worlds (100 m x 100 m: flat with 6 % trees, and s=4 d=2), with the default sensor
set-up (lidar 32 x 360 at 10 Hz, odometry 50 Hz, IMU 50 Hz, pose 10 Hz, observer 10 Hz) and
the same without lidar. In-run baselines of the physics + sensors figure: every obstacle static in
MuJoCo (``obstacle_pool=0``, the model before the obstacle pool) and, for comparison, the optional
analytic wheel contacts. Also the lidar at 32 x 1024. Real-time factors are given against wall
time and against the process CPU time (the latter is steadier on a shared machine).

    .venv/bin/python benchmarks/bench_sim.py [--seconds 180]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import time

import numpy as np

from navstress.nav.api import Command
from navstress.sim import SimConfig, Simulation
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
    a = ap.parse_args()
    try:  # one core, as the figures are quoted
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    worlds = {
        "trees6%": generate(WorldSpec.model_validate({"obstacles": {"obstruction": {"tree": 6}}}), 1),
        "s4d2": generate(WorldSpec.model_validate({"ground": {"subdivisions": 4, "deformation": 2.0}}), 1),
    }
    print(f"bench_sim: {a.seconds:g} s scripted course, timestep {SimConfig().timestep_s * 1e3:g} ms, one core")
    for name, w in worlds.items():
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
