"""Ray sensors' cost per simulated second: the default 3-D lidar against depth cameras.

World: the DESIGN benchmark world, flat 100 m x 100 m, 0.4 m cells, 6 % trees (600 boxes),
``generate(..., seed=1)`` (as ``bench_loop.py``). Body poses: ``--poses`` along the mission's
diagonal, the base 0.4 m above the ground, yawed toward the goal (quaternion as MuJoCo's qpos).
Sensors, each from its body-pose entry (the simulation's path), noise on:

* ``lidar3d``: the default lidar (32 x 360, 70 m, 10 Hz) on the RMP 400's lidar mount,
  ``Lidar.scan_body`` with its noise generator;
* ``lidar2d proxy``: a 1-channel, 1440-step ``LidarConfig`` (the UST-10's 0.25 degree spacing, but
  over 360 degrees: the 270-degree field is cast by the simulation's lidar2d, not by ``Lidar``),
  30 m, at the UST-10's 40 Hz;
* ``depth WxH``: :class:`navstress.sim.depth.DepthCamera` with the ``d435`` profile (87 degrees,
  10 m) at 160 x 120, 424 x 240 and 640 x 480, 15 Hz, mounted level at the front (0.35, 0, 0.6),
  ``render`` with a noise generator (the profile has no dropouts).

Timed: process CPU time per call, the sensors alternating pose by pose within a round (so that
load changes hit all of them), best round of ``--rounds``; cost per simulated second = per-call
time x rate. Prints the ratio depth / lidar3d (issue 36's target: 160 x 120 below 1.0). One core:
run it pinned.

    taskset -c 1 .venv/bin/python benchmarks/bench_sensors.py [--rounds 7] [--poses 40]
"""

from __future__ import annotations

import argparse
import math
import platform
import time
from collections.abc import Callable

import numpy as np

from navstress.sensors import Mount
from navstress.sensors.kinds.depth import DepthParams
from navstress.sim.depth import DepthCamera
from navstress.sim.lidar import Lidar, LidarConfig, build_scene
from navstress.world.generate import generate
from navstress.world.spec import parse_spec
from navstress.world.world import World

LIDAR_MOUNT = np.array([0.35, 0.0, 0.75])  # the RMP 400's lidar mount
CAMERA_MOUNT = Mount(xyz=(0.35, 0.0, 0.6))


def body_poses(world: World, n: int) -> list[np.ndarray]:
    """qpos[:7] along the mission's diagonal: 0.4 m above the ground, yawed toward the goal."""
    (sx, sy, _), (gx, gy) = world.mission.start, world.mission.goal
    yaw = math.atan2(gy - sy, gx - sx)
    out = []
    for s in np.linspace(0.02, 0.98, n):
        x, y = sx + s * (gx - sx), sy + s * (gy - sy)
        out.append(np.array([x, y, world.terrain.height_at(x, y) + 0.4, math.cos(yaw / 2), 0.0, 0.0,
                             math.sin(yaw / 2)]))
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--poses", type=int, default=40)
    a = ap.parse_args()
    w = generate(parse_spec({"size_m": [100, 100], "obstacles": {"obstruction": {"tree": 6}}}), 1)
    sc = build_scene(w)
    qs = body_poses(w, a.poses)
    lidar = Lidar(sc, LidarConfig())
    lidar_gen = np.random.default_rng(1)
    l2d = Lidar(sc, LidarConfig(channels=1, min_elevation_deg=0.0, max_elevation_deg=0.0, azimuth_steps=1440,
                                rate_hz=40.0, max_range_m=30.0, min_range_m=0.06, range_noise_std_m=0.04))
    l2d_gen = np.random.default_rng(2)
    sensors: dict[str, tuple[float, Callable[[np.ndarray], object]]] = {
        "lidar3d 32x360 @ 10 Hz": (10.0, lambda q: lidar.scan_body(q, LIDAR_MOUNT, lidar_gen)),
        "lidar2d proxy 1x1440 @ 40 Hz": (40.0, lambda q: l2d.scan_body(q, LIDAR_MOUNT, l2d_gen)),
    }
    valid: dict[str, float] = {}
    for wd, ht in ((160, 120), (424, 240), (640, 480)):
        cam = DepthCamera(sc, DepthParams(width=wd, height=ht))
        gen = np.random.default_rng(3)
        name = f"depth {wd}x{ht} @ 15 Hz"
        sensors[name] = (15.0, lambda q, cam=cam, gen=gen: cam.render(q, CAMERA_MOUNT, gen, None))
        valid[name] = float(np.mean([np.isfinite(cam.depths(q, CAMERA_MOUNT)).mean() for q in qs]))
    for _, f in sensors.values():  # compile / warm up
        f(qs[0])
    best = {k: math.inf for k in sensors}
    for _ in range(a.rounds):
        tot = dict.fromkeys(sensors, 0.0)
        for q in qs:
            for k, (_, f) in sensors.items():
                c0 = time.process_time()
                f(q)
                tot[k] += time.process_time() - c0
        for k in sensors:
            best[k] = min(best[k], tot[k] / len(qs))
    print(f"# bench_sensors: flat 100 m, 6 % trees (seed 1), {a.poses} body poses, best of {a.rounds} rounds, "
          f"process CPU time; {platform.processor() or platform.machine()}")
    lid = best["lidar3d 32x360 @ 10 Hz"] * 10.0
    print(f"{'sensor':32s} {'ms/call':>8s} {'ms per sim s':>13s} {'/ lidar3d':>10s}")
    for k, (rate, _) in sensors.items():
        per_s = best[k] * rate
        extra = f"   ({valid[k]:.0%} of the pixels valid)" if k in valid else ""
        print(f"{k:32s} {best[k] * 1e3:8.3f} {per_s * 1e3:13.2f} {per_s / lid:10.2f}{extra}")


if __name__ == "__main__":
    main()
