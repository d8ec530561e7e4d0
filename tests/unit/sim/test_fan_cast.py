"""The ``lidar2d`` fan's fast path (``Lidar.fan_ranges`` / ``_raybox.fan_scan_ranges``: only the
fan's own beams cast, each box's and disc's azimuth interval mapped onto the circle) against the two
plain paths, over families of random scenes (rough and flat terrain, boxes, discs) and poses (level,
tilted, pitched mounts, inside or near obstacles, outside the map):

- bit for bit the first columns of the full-circle scan (``Lidar.mounted_ranges``, every column
  cast, the path before the fan had its own);
- the per-ray path (``_raybox.rays_ranges``: every box and disc tested, the terrain marched from the
  sensor by ``march_terrain``) along the same directions: box and disc hits bit for bit, terrain hits
  within 1e-9 m (the two terrain marches round differently, docs/simulation.md), the same returns.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from navstress.sensors.registry import sensor_from_mapping
from navstress.sim import _raybox
from navstress.sim.lidar import LidarScene
from navstress.sim.rays import Lidar2dCaster, circle_steps
from tests.oracles import lidar2d as o2

CELL = 0.5
N = 41  # vertices per side: a 20 m map

#: fans whose beams are the first columns of a whole circle: (fov_deg, beams)
FANS = [(270.0, 1081), (270.0, 811), (360.0, 400), (90.0, 91), (180.0, 181), (20.0, 21), (360.0, 1), (359.0, 360)]


def _scene(gen: np.random.Generator, rough: bool) -> tuple[LidarScene, np.ndarray]:
    if rough:
        x = np.linspace(0, 1, N)
        h = sum(gen.uniform(-0.4, 0.4) * np.sin(2 * math.pi * (gen.uniform(0.5, 3) * x[None, :] + gen.uniform(0, 3)
                                                                  * x[:, None] + gen.uniform(0, 6)))
                for _ in range(3))
        h = np.asarray(h + gen.normal(0.0, 0.03, (N, N)), dtype=np.float32)
    else:
        h = np.full((N, N), gen.uniform(-1.0, 1.0), np.float32)
    nb = int(gen.integers(0, 40))
    boxes = np.column_stack([gen.uniform(2, 18, nb), gen.uniform(2, 18, nb), gen.uniform(-math.pi, math.pi, nb),
                             gen.uniform(0.05, 1.5, nb), gen.uniform(0.05, 1.5, nb), gen.uniform(-1.5, 0.5, nb),
                             gen.uniform(0.6, 2.5, nb)])
    nd = int(gen.integers(0, 6))
    discs = np.column_stack([gen.uniform(3, 17, nd), gen.uniform(3, 17, nd), gen.uniform(0.1, 0.8, nd),
                             gen.uniform(-1.0, 0.3, nd), gen.uniform(0.5, 2.0, nd)])
    return LidarScene(h, CELL, boxes), discs


def _caster(scene: LidarScene, fov: float, beams: int, rpy: tuple[float, float, float], max_range: float,
            min_range: float) -> Lidar2dCaster:
    s = sensor_from_mapping({"name": "f", "kind": "lidar2d", "fov_deg": fov, "beams": beams, "max_range_m": max_range,
                             "min_range_m": min_range, "mount": {"xyz": [0.1, -0.05, 0.3], "rpy": list(rpy)}},
                            where="sensors[0]", mounts={})
    c = Lidar2dCaster(s, 1, scene)
    assert c.lidar is not None, (fov, beams)
    return c


def _pose(gen: np.random.Generator, scene: LidarScene) -> np.ndarray:
    x, y = gen.uniform(-2, 22, 2) if gen.random() < 0.15 else gen.uniform(1, 19, 2)  # sometimes off the map
    ground = float(scene.heights[min(max(int(round(y / CELL)), 0), N - 1), min(max(int(round(x / CELL)), 0), N - 1)])
    tilt = 0.0 if gen.random() < 0.3 else 0.25
    return o2.qpos(float(x), float(y), ground + gen.uniform(-0.2, 1.0), gen.uniform(-tilt, tilt),
                   gen.uniform(-tilt, tilt), gen.uniform(-math.pi, math.pi))


def _per_ray(c: Lidar2dCaster, discs: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """The per-ray path along the directions the fan cast (from the pose it computed)."""
    assert c.lidar is not None
    origin, rot = c.lidar.last_pose
    a = 2.0 * np.pi * np.arange(c.lidar.config.azimuth_steps)[: c.beams] / c.lidar.config.azimuth_steps
    ca, sa = np.cos(a), np.sin(a)
    dirs = np.ascontiguousarray(np.stack([rot[i, 0] * ca + rot[i, 1] * sa for i in range(3)], axis=1))
    out = np.empty(c.beams)
    _raybox.rays_ranges(c.scene.grid, boxes, discs, origin.copy(), dirs, c.max_range, c.min_range, out)
    return out


@pytest.mark.parametrize("seed", range(12))
def test_the_fan_equals_the_full_circle_and_the_per_ray_path(seed: int) -> None:
    gen = np.random.default_rng(seed)
    scene, discs = _scene(gen, rough=seed % 3 != 0)
    checked = 0
    for fov, beams in FANS:
        rpy = (0.0, 0.0, 0.0) if gen.random() < 0.5 else (gen.uniform(-0.3, 0.3), gen.uniform(-0.4, 0.4),
                                                           gen.uniform(-3.0, 3.0))
        c = _caster(scene, fov, beams, rpy, float(gen.uniform(3.0, 25.0)), float(gen.uniform(0.0, 0.5)))
        assert c.lidar is not None
        for _ in range(3):
            q = _pose(gen, scene)
            d = discs if gen.random() < 0.7 else None
            fast = c.ranges(q, d)
            # the full circle's first columns, bit for bit
            c.lidar.mounted_ranges(q, c.mount_v, c.fan_rot, discs=d)
            assert np.array_equal(fast, c.lidar.last_ranges[0, :beams]), (fov, beams)
            slow = _per_ray(c, np.zeros((0, 5)) if d is None else d, scene.boxes)
            assert np.array_equal(np.isfinite(fast), np.isfinite(slow)), (fov, beams, np.flatnonzero(
                np.isfinite(fast) != np.isfinite(slow)))
            ok = np.isfinite(fast)
            assert np.all(np.abs(fast[ok] - slow[ok]) <= 1e-9 * (1.0 + slow[ok])), (fov, beams)
            checked += int(ok.sum())
    assert checked > 500  # the scenes do return


def test_obstacles_on_every_side_of_a_narrow_fan() -> None:
    """Boxes and discs all around (wrapping past +-180 degrees, behind the fan, straddling its
    edges): the fan sees exactly the per-ray path's hits and nothing of what lies outside it."""
    gen = np.random.default_rng(99)
    h = np.zeros((N, N), np.float32)
    ang = np.linspace(-math.pi, math.pi, 48, endpoint=False)
    boxes = np.column_stack([10 + 3 * np.cos(ang), 10 + 3 * np.sin(ang), ang, np.full(48, 0.15), np.full(48, 0.15),
                             np.full(48, -1.0), np.full(48, 2.0)])
    discs = np.column_stack([10 + 5 * np.cos(ang + 0.05), 10 + 5 * np.sin(ang + 0.05), np.full(48, 0.2),
                             np.full(48, -1.0), np.full(48, 2.0)])
    scene = LidarScene(h, CELL, boxes)
    for fov, beams in [(20.0, 21), (90.0, 91), (270.0, 1081)]:
        for yaw in np.linspace(-math.pi, math.pi, 9):
            c = _caster(scene, fov, beams, (0.0, 0.0, float(gen.uniform(-0.1, 0.1))), 8.0, 0.05)
            q = o2.qpos(10.0, 10.0, 0.3, 0.0, 0.0, float(yaw))
            fast = c.ranges(q, discs)
            slow = _per_ray(c, discs, scene.boxes)
            assert np.array_equal(fast, slow), (fov, yaw)  # boxes and discs only: bit for bit
            assert np.isfinite(fast).sum() > beams // 3


@pytest.mark.parametrize("fov,beams", FANS)
def test_fans_are_the_first_columns_of_a_whole_circle(fov: float, beams: int) -> None:
    c = _caster(LidarScene(np.zeros((N, N), np.float32), CELL, np.zeros((0, 7))), fov, beams, (0, 0, 0), 10.0, 0.1)
    assert c.lidar is not None
    assert circle_steps(c.angle_increment, c.beams) == c.lidar.config.azimuth_steps >= beams


@pytest.mark.parametrize("ground", [0.0, -0.7, 1.3])
def test_a_fan_pitched_about_the_angle_where_it_would_reach_the_ground(ground: float) -> None:
    """The terrain is skipped only when no ray can come down to its highest point within range
    (``_raybox.above_terrain``): pitches just above and below the critical one (the farthest ray
    just reaching the ground at max range), on flat and rough ground, give the full circle's
    ranges bit for bit and the per-ray path's."""
    gen = np.random.default_rng(int(abs(ground) * 10) + 5)
    flat = np.full((N, N), ground, np.float32)
    rough = flat + np.asarray(gen.uniform(-0.2, 0.0, (N, N)), np.float32)
    rough[20, 20] = ground  # the highest point is the flat ground's height
    skipped = {True: 0, False: 0}
    for h in (flat, rough):
        scene = LidarScene(h, CELL, np.zeros((0, 7)))
        max_range, z = 6.0, ground + 0.5
        c = _caster(scene, 270.0, 1081, (0.0, 0.0, 0.0), max_range, 0.05)
        assert c.lidar is not None
        a = 2.0 * np.pi * np.arange(1440)[:1081] / 1440

        def lowest(pitch: float) -> float:  # how far above the ground the lowest ray is at max range
            assert c.lidar is not None
            c.ranges(o2.qpos(10.0, 10.0, z - 0.3, 0.0, pitch, 0.4))
            o, rot = c.lidar.last_pose
            return float(o[2] + max_range * np.min(rot[2, 0] * np.cos(a) + rot[2, 1] * np.sin(a)) - ground)

        lo, hi = 0.0, 0.5  # the critical pitch, by bisection
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if lowest(mid) > 0.0 else (lo, mid)
        crit = lo
        for dp in (-1e-3, -1e-6, -1e-9, 0.0, 1e-9, 1e-6, 1e-3, 0.05):
            c = _caster(scene, 270.0, 1081, (0.0, 0.0, 0.0), max_range, 0.05)
            assert c.lidar is not None
            q = o2.qpos(10.0, 10.0, z - 0.3, 0.0, crit + dp, 0.4)
            fast = c.ranges(q)
            origin, rot = c.lidar.last_pose
            b = c.lidar._fans[1081]
            beams = _raybox.Beams(*b[7:11])  # (the grid's 7 fields, then the beams')
            skipped[bool(_raybox.above_terrain(scene.grid, beams, c.lidar._params, origin, rot))] += 1
            c.lidar.mounted_ranges(q, c.mount_v, c.fan_rot)
            assert np.array_equal(fast, c.lidar.last_ranges[0, :1081]), dp
            slow = _per_ray(c, np.zeros((0, 5)), scene.boxes)
            assert np.array_equal(np.isfinite(fast), np.isfinite(slow)), dp
            ok = np.isfinite(fast)
            assert np.all(np.abs(fast[ok] - slow[ok]) <= 1e-9 * (1.0 + slow[ok])), dp
    assert skipped[True] >= 4 and skipped[False] >= 4, skipped


@pytest.mark.parametrize("seed", range(4))
def test_the_noisy_cast_is_numpys_arithmetic_bit_for_bit(seed: int) -> None:
    """``Lidar2dCaster.cast`` (one kernel: ``_raybox.noisy_ranges32``) against the numpy of
    before: ``r[hit] += std * z``, the range filter, ``astype(float32)``, dropouts, from a copy of
    the same generators; fans on both paths (whole-circle steps and ray by ray)."""
    gen = np.random.default_rng(seed)
    scene, discs = _scene(gen, rough=True)
    for fov, beams in [(270.0, 1081), (270.0, 1001), (360.0, 400)]:
        std = float(gen.choice([0.0, 0.01, 0.3]))
        s = sensor_from_mapping({"name": "f", "kind": "lidar2d", "fov_deg": fov, "beams": beams, "max_range_m": 8.0,
                                 "min_range_m": 0.2, "range_noise_std_m": std, "dropout_prob": 0.1,
                                 "mount": {"xyz": [0.1, -0.05, 0.3], "rpy": [0.0, 0.05, 0.0]}},
                                where="sensors[0]", mounts={})
        c = Lidar2dCaster(s, seed, scene)
        for _ in range(3):
            q = _pose(gen, scene)
            noise, drop = copy.deepcopy(c.noise_gen), copy.deepcopy(c.dropout_gen)
            r = c.ranges(q, discs)
            got = c.cast(q, 1.0, True, discs, None).ranges
            if std > 0:
                hit = np.isfinite(r)
                r[hit] += std * noise.standard_normal(int(hit.sum()))
                r[(r < 0.2) | (r > 8.0)] = np.inf
            assert drop is not None
            r[drop.random(beams) < 0.1] = np.inf
            assert got.dtype == np.float32 and np.array_equal(got, r.astype(np.float32)), (fov, beams, std)
            assert np.array_equal(c.cast(q, 1.0, False, discs, None).ranges, c.ranges(q, discs).astype(np.float32))
