"""Lidar range noise: numpy ``standard_normal(n, float32)`` + ``points_from_ranges`` (old) vs the
ziggurat on raw words fused with the points (``_noise.noisy_points``, new), same run.

Ranges: one 32 x 360 scan of the flat 6 % trees world (``generate(..., seed=1)``) from its
centre, ~n finite returns. Process CPU time per scan, best of the passes, old and new alternating.

    taskset -c 1 .venv/bin/python benchmarks/bench_noise.py [--quick]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from navstress.sim import _noise, _raycast
from navstress.sim.lidar import Lidar, build_scene
from navstress.world.generate import generate
from navstress.world.spec import WorldSpec


def best(f: Callable[[], object], rep: int) -> float:
    t = time.process_time()
    for _ in range(rep):
        f()
    return (time.process_time() - t) / rep * 1e6


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    passes, rep = (3, 300) if a.quick else (15, 2000)
    w = generate(WorldSpec.model_validate({"obstacles": {"obstruction": {"tree": 6}}}), seed=1)
    lidar = Lidar(build_scene(w))
    sx, sy = w.spec.size_m
    r = lidar._ranges(np.array([sx / 2, sy / 2, 1.5]), np.eye(3)).copy()
    n = _raycast.count_finite(r)
    std = lidar.config.range_noise_std_m
    rng = np.random.default_rng(1)
    pts = np.empty((n, 3), np.float32)

    def old() -> None:
        noise = rng.standard_normal(n, dtype=np.float32)
        _raycast.points_from_ranges(r, lidar._dirs, noise, std, pts)

    def new() -> None:
        m, s = (n + 1) // 2, _noise.default_spare(n)
        words = rng.bit_generator.random_raw(m + s)
        k = _noise.noisy_points(r, lidar._dirs, words[:m], words[m:], 0, std, pts)
        while k < n:
            k = _noise.noisy_points(r, lidar._dirs, words[:m], rng.bit_generator.random_raw(s), k, std, pts)

    def points() -> None:
        _raycast.points_from_ranges(r, lidar._dirs, np.empty(0, np.float32), 0.0, pts)

    for f in (old, new, points):
        f()
    o, nw, p = [], [], []
    for _ in range(passes):
        o.append(best(old, rep))
        nw.append(best(new, rep))
        p.append(best(points, rep))
    bo, bn, bp = min(o), min(nw), min(p)
    print(f"returns per scan: {n}")
    print(f"old  standard_normal(float32) + points: {bo:7.1f} us/scan (noise ~{bo - bp:.1f} us)")
    print(f"new  ziggurat on raw words, fused:      {bn:7.1f} us/scan (noise ~{bn - bp:.1f} us)")
    print(f"points without noise:                   {bp:7.1f} us/scan")
    print(f"ratio old/new: {bo / bn:.2f}x (noise alone: {(bo - bp) / (bn - bp):.2f}x)")


if __name__ == "__main__":
    main()
