"""The movers' controller (``navstress.sim.movers.step``): wall time per call for 20 movers.

World: the default 100 m map with 6 % trees (``seed=1``) and 20 movers: 8 crossing pedestrians,
4 patrolling ones, 6 intercepting walkers (a pedestrian-sized type) and 2 still-then-move ones.
The robot drives the paper's diagonal from (5, 5) at 1 m/s, so the intercepting movers engage.
One call = the Python wrapper (the run generator's draws included) + the compiled kernel, at a
10 Hz control period; process CPU time per call, best of the passes (the machine may be shared).
The target: well under 50 us per call.

    taskset -c 1 .venv/bin/python benchmarks/bench_movers.py [--quick]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from navstress.sim.movers import initial_state, make_plan, step
from navstress.world.generate import generate
from navstress.world.spec import parse_spec

SPEC = {
    "obstacles": {"obstruction": {"tree": 6}},
    "movers": {
        "types": {"patroller": {"shape": "disc", "length_m": 0.5, "width_m": 0.5, "height_m": 1.8,
                                "speed_min_m_s": 0.5, "speed_max_m_s": 1.5},
                  "walker": {"shape": "disc", "length_m": 0.5, "width_m": 0.5, "height_m": 1.8,
                             "speed_min_m_s": 0.5, "speed_max_m_s": 1.5},
                  "child": {"shape": "disc", "length_m": 0.4, "width_m": 0.4, "height_m": 1.2,
                            "speed_min_m_s": 1.0, "speed_max_m_s": 2.0}},
        "count": {"pedestrian": 8, "patroller": 4, "walker": 6, "child": 2},
        "behaviour": {"patroller": {"kind": "patrol"}, "walker": {"kind": "intercept"},
                      "child": {"kind": "still-then-move"}},
    },
}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    passes, steps = (3, 2000) if a.quick else (7, 10000)
    world = generate(parse_spec(SPEC), seed=1)
    plan = make_plan(world)
    dt = 0.1
    heading = math.atan2(90.0, 90.0)
    vel = (math.cos(heading), math.sin(heading))
    step(plan, initial_state(plan), dt, (5.0, 5.0, heading), vel, np.random.default_rng(0))  # compile
    best = math.inf
    for _ in range(passes):
        state = initial_state(plan)
        gen = np.random.default_rng(1)
        poses = [(5.0 + vel[0] * k * dt, 5.0 + vel[1] * k * dt, heading) for k in range(steps)]
        t = time.process_time()
        for k in range(steps):
            step(plan, state, dt, poses[k], vel, gen)
        best = min(best, (time.process_time() - t) / steps * 1e6)
    print(f"movers: {plan.n}, static obstacles: {len(world.obstacles)}, calls per pass: {steps}")
    print(f"step: {best:.1f} us per call (best of {passes} passes; target well under 50 us)")


if __name__ == "__main__":
    main()
