"""Lidar speed at default fidelity: ms per scan and rays/s, against a baseline kernel in the same run.

Worlds: (a) flat 100 m x 100 m, 0.4 m cells, 6 % trees; (b) subdivide s=4, d=2 (no obstacles),
both from ``navstress.world.generate`` with fixed seeds. Sensor poses: 50 poses along the paper
mission's diagonal, 0.9 m above the ground, tilted to the local terrain normal. One core: run it
pinned (``taskset -c 1``). Times are process CPU time per ``Lidar.scan`` (noise on), best of the
passes; the current kernel and the baseline alternate pass by pass, so load changes hit both.

Baselines: ``--baseline REV`` (default e6a6917, the kernel before the per-ray-setup work). A
revision with the separate box pass (``_raybox.py``, from 2026-11-21) is loaded whole -- its
``lidar``, ``_raycast``, ``_raybox`` and ``_noise`` as a temporary package -- and scanned through
its own ``Lidar.scan``; for an older one, ``src/navstress/sim/_raycast.py`` is loaded into a
temporary module and scanned exactly as that revision's ``Lidar.scan`` did (all-in-one
``scan_kernel``, numpy noise). Its ranges are checked equal to the current ones (1e-6);
``plane_march=False`` (per-ray march) and ``cast_rays`` (naive) are also timed.

    taskset -c 1 .venv/bin/python benchmarks/bench_lidar.py [--quick] [--baseline REV] [--no-naive]
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import inspect
import math
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np

from navstress.sim import native
from navstress.sim.lidar import Lidar, LidarConfig, LidarScene, build_scene, cast_rays
from navstress.world.generate import generate
from navstress.world.spec import WorldSpec
from navstress.world.world import World

MOUNT_M = 0.9
REPO = Path(__file__).resolve().parents[1]
Pose = tuple[np.ndarray, np.ndarray]


def poses(world: World, n: int) -> list[Pose]:
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


def load_baseline(rev: str) -> ModuleType:
    """``_raycast.py`` of git revision ``rev`` as a module (file kept in the temp dir so that
    numba's cache survives between runs)."""
    src = subprocess.run(["git", "show", f"{rev}:src/navstress/sim/_raycast.py"], cwd=REPO,
                         capture_output=True, text=True, check=True).stdout
    d = Path(tempfile.gettempdir()) / f"navstress_bench_lidar_{hashlib.sha1(src.encode()).hexdigest()[:12]}"
    d.mkdir(exist_ok=True)
    p = d / "_raycast_baseline.py"
    if not p.exists() or p.read_text() != src:
        p.write_text(src)
    spec = importlib.util.spec_from_file_location(f"_raycast_baseline_{d.name}", p)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # numba's cache re-imports the module by name
    spec.loader.exec_module(mod)
    return mod


LIDAR_MODULES = ("_raycast", "_raybox", "_noise", "lidar")
OPTIONAL_MODULES = ("native",)  # (the native walk's loader and its C file, from their revision on)
NATIVE_C = "_march_avx512.c"


def load_baseline_lidar(rev: str) -> ModuleType | None:
    """The ``lidar`` module of git revision ``rev`` with its own kernels (a temporary package whose
    imports are rewritten to it; kept in the temp dir so that numba's cache survives between
    runs), or None if that revision has no separate box pass."""
    srcs = {}
    for m in LIDAR_MODULES:
        r = subprocess.run(["git", "show", f"{rev}:src/navstress/sim/{m}.py"], cwd=REPO, capture_output=True, text=True)
        if r.returncode != 0:
            return None
        srcs[m] = r.stdout
    for m in OPTIONAL_MODULES:
        r = subprocess.run(["git", "show", f"{rev}:src/navstress/sim/{m}.py"], cwd=REPO, capture_output=True, text=True)
        if r.returncode == 0:
            srcs[m] = r.stdout
    c_src = subprocess.run(["git", "show", f"{rev}:src/navstress/sim/{NATIVE_C}"], cwd=REPO, capture_output=True,
                           text=True)
    digest = hashlib.sha1("".join(srcs.values()).encode()).hexdigest()[:12]
    pkg = f"navlidar_base_{digest}"
    root = Path(tempfile.gettempdir()) / f"navstress_bench_lidar_pkg_{digest}"
    (root / pkg).mkdir(parents=True, exist_ok=True)
    for m, src in {**srcs, "__init__": ""}.items():
        text = src.replace("from navstress.sim import ", f"from {pkg} import ")
        for n in srcs:
            text = text.replace(f"navstress.sim.{n} ", f"{pkg}.{n} ").replace(f"navstress.sim.{n}\n", f"{pkg}.{n}\n")
        p = root / pkg / f"{m}.py"
        if not p.exists() or p.read_text() != text:
            p.write_text(text)
    if c_src.returncode == 0 and not (root / pkg / NATIVE_C).exists():
        (root / pkg / NATIVE_C).write_text(c_src.stdout)
    if str(root) not in sys.path:
        sys.path.insert(0, str(root))
    return importlib.import_module(f"{pkg}.lidar")


class BaselineLidar:
    """``Lidar.scan`` as of revision e6a6917 (all-in-one ``scan_kernel``, numpy noise), on a baseline module."""

    def __init__(self, mod: ModuleType, scene: LidarScene, config: LidarConfig) -> None:
        self.mod, self.scene, self.config = mod, scene, config
        el, az = config.elevations_rad, config.azimuths_rad
        self._cos_el, self._sin_el, self._cos_az, self._sin_az = np.cos(el), np.sin(el), np.cos(az), np.sin(az)
        self._dirs = config.directions()
        self._out = np.empty((config.channels, config.azimuth_steps), np.float64)
        # revisions from 2026-11-21 on take the float32 mipmap too
        self._takes_mipf = "mipf" in inspect.signature(mod.scan_kernel.py_func).parameters

    def ranges(self, origin: np.ndarray, rotation: np.ndarray) -> np.ndarray:
        o = np.ascontiguousarray(origin, dtype=np.float64)
        r = np.ascontiguousarray(rotation, dtype=np.float64)
        assert self.mod.rotation_error(r) <= 1e-6
        s, c = self.scene, self.config
        mip = (s.mip, s.mipf) if self._takes_mipf else (s.mip,)
        self.mod.scan_kernel(s.heights, s.cell_m, *mip, s.mip_offsets, s.mip_widths, s.grad_max, s.boxes,
                             o, r, self._cos_el, self._sin_el, self._cos_az, self._sin_az,
                             float(c.max_range_m), float(c.min_range_m), True, self._out)
        return self._out

    def scan(self, origin: np.ndarray, rotation: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        r = self.ranges(origin, rotation)
        n = self.mod.count_finite(r)
        std = self.config.range_noise_std_m
        noise = rng.standard_normal(n, dtype=np.float32) if (rng is not None and std > 0) else \
            np.empty(0, np.float32)
        pts = np.empty((n, 3), np.float32)
        self.mod.points_from_ranges(r, self._dirs, noise, float(std), pts)
        return pts


ScanFn = Callable[[np.ndarray, np.ndarray, np.random.Generator], np.ndarray]


def time_pass(scan: ScanFn, ps: list[Pose]) -> float:
    rng = np.random.default_rng(0)
    t0 = time.process_time()
    for o, r in ps:
        scan(o, r, rng)
    return (time.process_time() - t0) / len(ps)


def time_alternating(fns: list[ScanFn], ps: list[Pose], repeat: int) -> list[float]:
    """Best-of-``repeat`` mean seconds per scan of each function, passes interleaved."""
    for f in fns:
        f(*ps[0], np.random.default_rng(0))  # compile / warm
    best = [math.inf] * len(fns)
    for _ in range(repeat):
        for i, f in enumerate(fns):
            best[i] = min(best[i], time_pass(f, ps))
    return best


def time_naive(scene: LidarScene, cfg: LidarConfig, ps: list[Pose]) -> float:
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
    ap.add_argument("--baseline", default="e6a6917", help="git revision of the baseline kernel")
    ap.add_argument("--no-naive", action="store_true", help="skip the per-ray and naive baselines")
    a = ap.parse_args()
    n, rep = (10, 3) if a.quick else (50, 7)
    base_cls = load_baseline_lidar(a.baseline)
    base = load_baseline(a.baseline) if base_cls is None else None
    worlds = {
        "flat, 6% trees": generate(WorldSpec.model_validate({"obstacles": {"obstruction": {"tree": 6}}}), seed=1),
        "s=4 d=2": generate(WorldSpec.model_validate({"ground": {"subdivisions": 4, "deformation": 2.0}}), seed=1),
    }
    print(f"# lidar benchmark  ({platform.processor() or platform.machine()}, numba, 1 core, "
          f"{n} poses, best of {rep}; baseline {a.baseline})")
    print(f"# native terrain walk: {native.status()}; 'numba walk' = the same scan with Lidar(simd=False)")
    print(f"{'world':16s} {'rays':>8s} {'ms/scan':>8s} {'Mrays/s':>8s} | {'baseline':>8s} {'speedup':>7s}"
          f" | {'numba walk':>8s} {'x':>7s} | {'per-ray ms':>10s} {'x':>5s} | {'naive ms':>9s} {'x':>5s}")
    for name, w in worlds.items():
        scene = build_scene(w)
        ps = poses(w, n)
        for az in (360, 1024):
            cfg = LidarConfig(azimuth_steps=az)
            nr = cfg.channels * az
            new = Lidar(scene, cfg)
            old = (BaselineLidar(base, scene, cfg) if base_cls is None
                   else base_cls.Lidar(scene, base_cls.LidarConfig(azimuth_steps=az)))
            for o, r in ps:
                a_, b_ = new.ranges(o, r), old.ranges(o, r).astype(np.float32)
                assert np.array_equal(np.isinf(a_), np.isinf(b_)) and np.allclose(
                    a_[np.isfinite(a_)], b_[np.isfinite(b_)], rtol=1e-6, atol=1e-6), "baseline disagrees"
            walk = Lidar(scene, cfg, simd=False)
            fast, slow, nb = time_alternating([new.scan, old.scan, walk.scan], ps, rep)
            line = (f"{name:16s} {f'32x{az}':>8s} {fast * 1e3:8.3f} {nr / fast / 1e6:8.1f} | "
                    f"{slow * 1e3:8.3f} {slow / fast:6.2f}x | {nb * 1e3:8.3f} {nb / fast:6.2f}x")
            if not a.no_naive:
                (per_ray,) = time_alternating([Lidar(scene, cfg, plane_march=False).scan], ps, max(1, rep // 3))
                naive = time_naive(scene, cfg, ps[: max(3, n // 5)])
                line += f" | {per_ray * 1e3:10.3f} {per_ray / fast:5.1f} | {naive * 1e3:9.2f} {naive / fast:5.1f}"
            print(line, flush=True)
        print(f"  ({len(w.obstacles)} boxes, grid {w.terrain.heights.shape}, "
              f"relief {float(np.ptp(w.terrain.heights)):.2f} m, max slope {scene.grad_max:.2f})")


if __name__ == "__main__":
    main()
