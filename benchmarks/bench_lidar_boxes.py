"""The lidar's box pass: all-in-one ``scan_kernel`` (boxes inside) vs terrain-only scan + ``box_pass``.

World: flat 100 m x 100 m, 0.4 m cells, 6 % trees (600 boxes), ``generate(..., seed=1)``; 50
sensor poses along the mission diagonal (as ``bench_lidar.py``), 32 x 360 at 70 m. The terrain
kernel is the one of git revision ``--baseline`` (default a4d5a13, the last with boxes inside
``scan_kernel``), loaded from git, so that the comparison isolates the box pass from later
terrain work. Timed, alternating pass by pass (process CPU time per scan, best of the passes):

* old: baseline ``scan_kernel`` with the boxes (the path before ``box_pass``);
* new: baseline ``scan_kernel`` without boxes (no min-range filter), then ``_raybox.box_pass``;
* terrain: baseline ``scan_kernel`` without boxes alone (old - terrain, new - terrain = box pass);
* scan: today's ``Lidar.scan`` (noise on), for reference.

Ranges of old and new are checked bit-identical on every pose. One core: run it pinned.

    taskset -c 1 .venv/bin/python benchmarks/bench_lidar_boxes.py [--quick] [--baseline REV]
"""

from __future__ import annotations

import argparse
import math
import platform
import time
from collections.abc import Callable

import numpy as np
from bench_lidar import load_baseline, poses

from navstress.sim import _raybox
from navstress.sim.lidar import Lidar, LidarConfig, build_scene
from navstress.world.generate import generate
from navstress.world.spec import WorldSpec

NO_BOXES = np.zeros((0, 9))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="fewer poses and repeats")
    ap.add_argument("--baseline", default="a4d5a13", help="git revision of the all-in-one scan_kernel")
    a = ap.parse_args()
    n, rep = (10, 5) if a.quick else (50, 15)
    base = load_baseline(a.baseline)
    w = generate(WorldSpec.model_validate({"obstacles": {"obstruction": {"tree": 6}}}), seed=1)
    sc = build_scene(w)
    ps = poses(w, n)
    cfg = LidarConfig()
    lidar = Lidar(sc, cfg)
    trig = (lidar._cos_el, lidar._sin_el, lidar._cos_az, lidar._sin_az)
    out = np.empty((cfg.channels, cfg.azimuth_steps))
    mx, mn = float(cfg.max_range_m), float(cfg.min_range_m)

    def terrain(o: np.ndarray, r: np.ndarray) -> np.ndarray:
        base.scan_kernel(sc.heights, sc.cell_m, sc.mip, sc.mipf, sc.mip_offsets, sc.mip_widths, sc.grad_max,
                         NO_BOXES, o, r, *trig, mx, -math.inf, True, out)
        return out

    def old(o: np.ndarray, r: np.ndarray) -> np.ndarray:
        base.scan_kernel(sc.heights, sc.cell_m, sc.mip, sc.mipf, sc.mip_offsets, sc.mip_widths, sc.grad_max,
                         sc.boxes, o, r, *trig, mx, mn, True, out)
        return out

    def new(o: np.ndarray, r: np.ndarray) -> np.ndarray:
        terrain(o, r)
        _raybox.box_pass(sc.boxes, lidar._beams, lidar._params, o, r, out)
        return out

    rng = np.random.default_rng(0)

    def scan(o: np.ndarray, r: np.ndarray) -> np.ndarray:
        return lidar.scan(o, r, rng)

    for o, r in ps:
        ref = old(o, r).copy()
        assert np.array_equal(new(o, r), ref), "box_pass differs from the all-in-one kernel"
    fns: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
        "old": old, "new": new, "terrain": terrain, "scan": scan}
    best = dict.fromkeys(fns, math.inf)
    for _ in range(rep):
        for name, f in fns.items():
            t0 = time.process_time()
            for o, r in ps:
                f(o, r)
            best[name] = min(best[name], (time.process_time() - t0) / len(ps))
    ms = {k: v * 1e3 for k, v in best.items()}
    box_old, box_new = ms["old"] - ms["terrain"], ms["new"] - ms["terrain"]
    print(f"# box pass, flat 6% trees ({len(w.obstacles)} boxes), 32x360, {n} poses, best of {rep}, "
          f"CPU time, 1 core ({platform.processor() or platform.machine()}); baseline kernel {a.baseline}")
    print(f"all-in-one (old) {ms['old']:.3f} ms/scan | terrain + box_pass (new) {ms['new']:.3f} ms/scan | "
          f"ratio {ms['old'] / ms['new']:.2f}x   (ranges bit-identical on {n} poses)")
    print(f"terrain only {ms['terrain']:.3f} ms -> box pass old {box_old:.3f} ms, new {box_new:.3f} ms, "
          f"ratio {box_old / box_new:.2f}x")
    print(f"Lidar.scan today (noise on): {ms['scan']:.3f} ms/scan")


if __name__ == "__main__":
    main()
