"""Measure the effective-track multiplier of this simulator's skid steer over a family of geometries.

For each wheels-per-side count and wheelbase/track ratio, a base (the ``--base`` profile's mass,
wheels and limits, its wheelbase changed) turns in closed loop (the firmware's gyro PI makes the
body turn at the commanded rate, whatever the multiplier) in place and at half its top speed, at
half its top turn rate; the multiplier is the wheels' speed difference over (track x the true
yaw rate), averaged over 1 s of steady turning. These figures are
``navstress.sim.drives.skid_steer.MEASURED`` (docs/simulation.md, "Drive types").

    PYTHONPATH=src .venv/bin/python benchmarks/skid_calibration.py --base husky   # 10 ms
    PYTHONPATH=src .venv/bin/python benchmarks/skid_calibration.py --base jackal  # 5 ms
"""

from __future__ import annotations

import argparse

import numpy as np

from navstress.nav.api import Command
from navstress.robot import RobotSpec, profile
from navstress.sim import SimConfig, Simulation
from navstress.sim.drives import skid_steer
from navstress.world.spec import WorldSpec
from navstress.world.world import World


def measure(world: World, r: RobotSpec, v: float, w: float) -> tuple[float, float, float]:
    """(true yaw rate, multiplier, time step) of ``r`` commanded (v, w) for 3 s, then 1 s measured."""
    sim = Simulation(world, r, SimConfig(lidar_enabled=False, noise=False, jitter=False), seed=0,
                     start=(20.0, 20.0, 0.0))
    sim.command(Command(v, w))
    sim.advance(3.0)
    ws, dv = [], []
    side = np.array([wh.side for wh in sim.drive.wheels])
    for _ in range(50):
        sim.advance(0.02)
        q = sim.data.qvel
        sp = q[sim.rm.wheel_dofs] * r.wheel_radius_m
        dv.append(sp[side < 0].mean() - sp[side > 0].mean())
        ws.append(q[5])
    return float(np.mean(ws)), float(np.mean(dv) / (r.track_m * np.mean(ws))), sim.config.timestep_s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="husky")
    args = ap.parse_args()
    world = World.flat(WorldSpec(size_m=(40.0, 40.0)))
    base = profile(args.base)
    for n in (2, 3, 4):
        row = []
        for ratio in skid_steer.MEASURED_RATIOS:
            r = RobotSpec(**{**base.model_dump(), "wheelbase_m": ratio * base.track_m, "wheels_per_side": n,
                             "name": "calibration", "track_multiplier": None})
            r = RobotSpec(**{**r.model_dump(), "track_multiplier": skid_steer.coulomb_multiplier(r)})
            ms = []
            for v in (0.0, 0.5 * base.max_speed_mps):
                wt, m, dt = measure(world, r, v, 0.5 * base.max_yaw_rate_rps)
                ms.append(m)
                print(f"dt {dt} n {n} wheelbase/track {ratio}: v {v} w {wt:.3f} multiplier {m:.3f}", flush=True)
            row.append(round(float(np.mean(ms)), 3))
        print(f"MEASURED[{dt}][{n}] = {tuple(row)}", flush=True)


if __name__ == "__main__":
    main()
