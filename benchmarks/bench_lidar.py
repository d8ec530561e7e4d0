"""Lidar speed at default fidelity: ms per scan and rays/s, plane marching vs per-ray baselines.

Worlds: (a) flat 100 m x 100 m, 0.4 m cells, 6 % trees; (b) subdivide s=4, d=2 (no obstacles),
both from ``navstress.world.generate`` with fixed seeds. Sensor poses: 50 poses along the paper
mission's diagonal, 0.9 m above the ground, tilted to the local terrain normal. One core.

    .venv/bin/python benchmarks/bench_lidar.py [--quick]
"""

from __future__ import annotations

import argparse
import math
import platform
import time

import numpy as np

from navstress.sim.lidar import Lidar, LidarConfig, LidarScene, build_scene, cast_rays
from navstress.world.generate import generate
from navstress.world.spec import WorldSpec
from navstress.world.world import World

MOUNT_M = 0.9


def poses(world: World, n: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Sensor poses along the mission line, yaw toward the goal, tilted to the terrain normal."""
    (sx, sy, _), (gx, gy) = world.mission.start, world.mission.goal
    yaw = math.atan2(gy - sy, gx - sx)
    t = world.terrain
    out = []
    for s in np.linspace(0.0, 1.0, n):
        x, y = sx + s * (gx - sx), sy + s * (gy - sy)
        e = 0.3
        nx = -(t.height_at(x + e, y) - t.height_at(x - e, y)) / (2 * e)
        ny = -(t.height_at(x, y + e) - t.height_at(x, y - e)) / (2 * e)
        z = np.array([nx, ny, 1.0]) / math.sqrt(nx * nx + ny * ny + 1.0)
        f = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        f -= z * (f @ z)
        f /= np.linalg.norm(f)
        rot = np.column_stack([f, np.cross(z, f), z])
        out.append((np.array([x, y, t.height_at(x, y)]) + MOUNT_M * z, rot))
    return out


def time_scans(lidar: Lidar, ps: list[tuple[np.ndarray, np.ndarray]], repeat: int) -> float:
    """Best-of-``repeat`` mean seconds per scan over the poses."""
    rng = np.random.default_rng(0)
    lidar.scan(*ps[0], rng)  # compile / warm
    best = math.inf
    for _ in range(repeat):
        t0 = time.process_time()
        for o, r in ps:
            lidar.scan(o, r, rng)
        best = min(best, (time.process_time() - t0) / len(ps))
    return best


def time_naive(scene: LidarScene, cfg: LidarConfig, ps: list[tuple[np.ndarray, np.ndarray]]) -> float:
    """Per-ray baseline: ``cast_rays`` (terrain march from the sensor, every box tested)."""
    dirs = cfg.directions().reshape(-1, 3)
    cast_rays(scene, ps[0][0][None, :], dirs[:1], cfg.max_range_m)
    t0 = time.process_time()
    for o, r in ps:
        cast_rays(scene, np.broadcast_to(o, dirs.shape), dirs @ r.T, cfg.max_range_m)
    return (time.process_time() - t0) / len(ps)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="fewer poses and repeats")
    a = ap.parse_args()
    n, rep = (10, 2) if a.quick else (50, 5)
    worlds = {
        "flat, 6% trees": generate(WorldSpec.model_validate({"obstacles": {"obstruction": {"tree": 6}}}), seed=1),
        "s=4 d=2": generate(WorldSpec.model_validate({"ground": {"subdivisions": 4, "deformation": 2.0}}), seed=1),
    }
    print(f"# lidar benchmark  ({platform.processor() or platform.machine()}, numba, 1 core, "
          f"{n} poses, best of {rep})")
    print(f"{'world':16s} {'rays':>10s} {'ms/scan':>8s} {'Mrays/s':>8s} | {'per-ray ms':>10s} {'x':>5s}"
          f" | {'naive ms':>9s} {'x':>5s}")
    for name, w in worlds.items():
        scene = build_scene(w)
        ps = poses(w, n)
        for az in (360, 1024):
            cfg = LidarConfig(azimuth_steps=az)
            nr = cfg.channels * az
            fast = time_scans(Lidar(scene, cfg), ps, rep)
            per_ray = time_scans(Lidar(scene, cfg, plane_march=False), ps, max(1, rep // 2))
            naive = time_naive(scene, cfg, ps[: max(3, n // 5)])
            print(f"{name:16s} {f'32x{az}':>10s} {fast * 1e3:8.3f} {nr / fast / 1e6:8.1f} | "
                  f"{per_ray * 1e3:10.3f} {per_ray / fast:5.1f} | {naive * 1e3:9.2f} {naive / fast:5.1f}")
        print(f"  ({len(w.obstacles)} boxes, grid {w.terrain.heights.shape}, "
              f"relief {float(np.ptp(w.terrain.heights)):.2f} m, max slope {scene.grad_max:.2f})")


if __name__ == "__main__":
    main()
