"""Lidar ray caster: brute force, MuJoCo mj_ray, analytic scenes, noise and errors."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from navstress.errors import NavstressError, SpecError
from navstress.sim import _raybox
from navstress.sim._raycast import Box, Ray, _ray_box, new_scan_params
from navstress.sim.lidar import Lidar, LidarConfig, LidarScene, build_scene, cast_rays
from navstress.world.generate import generate
from navstress.world.spec import WorldSpec
from navstress.world.world import Obstacle, Terrain, World
from tests.oracles.scan import scan_kernel

# ---------------------------------------------------------------------------------------------
# helpers: random scenes, brute force (every triangle), MuJoCo model of the same scene
# ---------------------------------------------------------------------------------------------


def random_scene(g: np.random.Generator, max_boxes: int = 4) -> LidarScene:
    rows, cols = int(g.integers(2, 9)), int(g.integers(2, 9))
    cell = float(g.uniform(0.3, 1.5))
    h = g.uniform(-1.0, 2.0, (rows, cols)) * g.choice([0.0, 0.3, 1.0])
    W, H = (cols - 1) * cell, (rows - 1) * cell
    boxes = []
    for _ in range(int(g.integers(0, max_boxes + 1))):
        zb = float(g.uniform(h.min() - 0.5, h.max()))
        boxes.append([g.uniform(-0.5, W + 0.5), g.uniform(-0.5, H + 0.5), g.uniform(-np.pi, np.pi),
                      g.uniform(0.1, 1.5), g.uniform(0.1, 1.5), zb, zb + g.uniform(0.2, 3.0)])
    return LidarScene(h.astype(np.float32), cell, np.array(boxes).reshape(-1, 7))


def random_rays(g: np.random.Generator, sc: LidarScene, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Origins above the ground inside the map, or outside the map; random directions."""
    W, H = sc.size_m
    hmin, hmax = float(sc.heights.min()), float(sc.heights.max())
    t = Terrain(sc.heights, sc.cell_m)
    o = np.empty((n, 3))
    for k in range(n):
        if g.uniform() < 0.7:
            x, y = g.uniform(0, W), g.uniform(0, H)
            o[k] = (x, y, t.height_at(x, y) + g.uniform(0.05, 3.0))
        else:
            ang = g.uniform(0, 2 * np.pi)
            r = g.uniform(0.6, 1.5) * math.hypot(W, H)
            o[k] = (W / 2 + r * math.cos(ang), H / 2 + r * math.sin(ang), g.uniform(hmin, hmax + 3.0))
    d = g.normal(0, 1, (n, 3))
    d[:, 2] -= g.uniform(0, 1.5, n)
    outside = (o[:, 0] < 0) | (o[:, 0] > W) | (o[:, 1] < 0) | (o[:, 1] > H)
    aim = np.array([W / 2, H / 2, hmin])[None, :] + g.normal(0, 1.0, (n, 3)) - o
    d[outside] = aim[outside]
    return o, d / np.linalg.norm(d, axis=1)[:, None]


def scene_triangles(sc: LidarScene, wall_depth: float = 1e4) -> np.ndarray:
    """Every triangle of the scene, (T, 3, 3): terrain top, side walls (deep), box faces."""
    h = sc.heights.astype(np.float64)
    rows, cols = h.shape
    c = sc.cell_m
    tris = []
    P = lambda i, j: (j * c, i * c, h[i, j])  # noqa: E731
    for i in range(rows - 1):
        for j in range(cols - 1):
            tris.append([P(i, j), P(i, j + 1), P(i + 1, j + 1)])
            tris.append([P(i, j), P(i + 1, j), P(i + 1, j + 1)])
    edges = [[(0, j) for j in range(cols)], [(rows - 1, j) for j in range(cols)],
             [(i, 0) for i in range(rows)], [(i, cols - 1) for i in range(rows)]]
    for e in edges:
        for a, b in zip(e[:-1], e[1:]):
            p0, p1 = P(*a), P(*b)
            q0, q1 = (p0[0], p0[1], -wall_depth), (p1[0], p1[1], -wall_depth)
            tris += [[p0, p1, q1], [p0, q1, q0]]
    for x, y, yaw, hx, hy, zb, zt in sc.boxes[:, :7]:
        cs, sn = math.cos(yaw), math.sin(yaw)
        corner = {(sx, sy, sz): (x + cs * sx * hx - sn * sy * hy, y + sn * sx * hx + cs * sy * hy,
                                 zt if sz > 0 else zb)
                  for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)}
        for axis in range(3):
            for side in (-1, 1):
                quad = []
                for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                    k = [a, b]
                    k.insert(axis, side)
                    quad.append(corner[tuple(k)])
                tris += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
    return np.array(tris, dtype=np.float64)


def brute_force(sc: LidarScene, origins: np.ndarray, dirs: np.ndarray, max_range: float) -> np.ndarray:
    """Moller-Trumbore against every triangle, two-sided: nearest t in [0, max_range]."""
    T = scene_triangles(sc)
    v0, e1, e2 = T[:, 0], T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
    out = np.full(len(origins), np.inf)
    for k, (o, d) in enumerate(zip(origins, dirs)):
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-15
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o - v0
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        tol = 1e-12
        hit = ok & (u >= -tol) & (v >= -tol) & (u + v <= 1 + tol) & (t >= 0) & (t <= max_range)
        if hit.any():
            out[k] = t[hit].min()
    return out


def mujoco_model(sc: LidarScene) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """An MJCF of the scene: the heights as an hfield (normalised to [0, 1] by hand), boxes as geoms."""
    h = sc.heights.astype(np.float64)
    rows, cols = h.shape
    W, H = sc.size_m
    hmin, hmax = float(h.min()), float(h.max())
    ztop = max(hmax - hmin, 1e-6)
    geoms = "".join(
        f'<geom type="box" size="{hx!r} {hy!r} {(zt - zb) / 2!r}" pos="{x!r} {y!r} {(zb + zt) / 2!r}" '
        f'euler="0 0 {yaw!r}"/>' for x, y, yaw, hx, hy, zb, zt in sc.boxes[:, :7].tolist())
    xml = (f'<mujoco><compiler angle="radian"/><asset><hfield name="t" nrow="{rows}" ncol="{cols}" '
           f'size="{W / 2!r} {H / 2!r} {ztop!r} 1000"/></asset><worldbody>'
           f'<geom type="hfield" hfield="t" pos="{W / 2!r} {H / 2!r} {hmin!r}"/>{geoms}</worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    m.hfield_data[:] = ((h - hmin) / ztop).ravel()  # row 0 is -y, as heights[0]
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    return m, d


def mj_cast(m: mujoco.MjModel, d: mujoco.MjData, origins: np.ndarray, dirs: np.ndarray,
            max_range: float) -> np.ndarray:
    out = np.full(len(origins), np.inf)
    gid = np.array([-1], dtype=np.int32)
    for k, (o, v) in enumerate(zip(origins, dirs)):
        t = mujoco.mj_ray(m, d, o, v, None, 1, -1, gid)
        if 0 <= t <= max_range:
            out[k] = t
    return out


def same(a: np.ndarray, b: np.ndarray, tol: float) -> np.ndarray:
    """Both miss, or both hit within tol * (1 + |b|) metres (a hit never matches a miss: with b
    infinite, |a - b| <= tol * inf would hold for any finite a)."""
    with np.errstate(invalid="ignore"):
        both = np.isfinite(a) & np.isfinite(b)
        return (np.isinf(a) & np.isinf(b)) | (both & (np.abs(a - b) <= tol * (1 + np.abs(b))))


# ---------------------------------------------------------------------------------------------
# cross-checks on random scenes
# ---------------------------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_cast_rays_matches_brute_force(seed: int) -> None:
    g = np.random.default_rng(seed)
    sc = random_scene(g)
    o, d = random_rays(g, sc, 30)
    a = cast_rays(sc, o, d, 50.0)
    b = brute_force(sc, o, d, 50.0)
    assert same(a, b, 1e-6).all(), (np.flatnonzero(~same(a, b, 1e-6)), a, b)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_cast_rays_matches_mujoco_mj_ray(seed: int) -> None:
    g = np.random.default_rng(seed)
    sc = random_scene(g)
    o, d = random_rays(g, sc, 30)
    a = cast_rays(sc, o, d, 50.0)
    m, dd = mujoco_model(sc)
    c = mj_cast(m, dd, o, d, 50.0)
    # MuJoCo's elevations are float32 of (h - hmin) / relief: ~1e-7 relative height error
    assert same(a, c, 1e-4).all(), (np.flatnonzero(~same(a, c, 1e-4)), a, c)


def rot_zyx(yaw: float, pitch: float, roll: float) -> np.ndarray:
    cy, sy, cp, sp, cr, sr = (math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch),
                              math.cos(roll), math.sin(roll))
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz @ ry @ rx


def scan_vs_per_ray(sc: LidarScene, cfg: LidarConfig, origin: np.ndarray, rot: np.ndarray) -> None:
    """The plane-marched scan equals casting every ray on its own (and brute force on a sample)."""
    r = Lidar(sc, cfg).ranges(origin, rot).astype(np.float64)
    dirs = (cfg.directions().reshape(-1, 3) @ rot.T)
    ref = cast_rays(sc, np.broadcast_to(origin, dirs.shape), dirs, cfg.max_range_m).reshape(r.shape)
    ref[ref < cfg.min_range_m] = np.inf
    ok = same(r, ref, 1e-6)
    assert ok.all(), (np.argwhere(~ok)[:5], r[~ok][:5], ref[~ok][:5])
    slow = Lidar(sc, cfg, plane_march=False).ranges(origin, rot).astype(np.float64)
    assert same(slow, ref, 1e-6).all()


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.05, 0.3, 0.8, 1.2]))
@example(seed=33388, tilt=0.8)  # lowest channel pointing behind the plane's horizontal (fixed)
def test_scan_plane_march_equals_per_ray(seed: int, tilt: float) -> None:
    g = np.random.default_rng(seed)
    rows, cols = int(g.integers(10, 40)), int(g.integers(10, 40))
    cell = float(g.uniform(0.3, 1.0))
    relief = float(g.choice([0.0, 0.2, 1.0, 3.0]))
    h = relief * g.uniform(-1, 1, (rows, cols)).cumsum(0).cumsum(1) / max(rows, cols)
    sc0 = LidarScene(h.astype(np.float32), cell, np.zeros((0, 7)))
    W, H = sc0.size_m
    nb = int(g.integers(0, 30))
    zs = [Terrain(sc0.heights, cell).height_at(float(x), float(y))
          for x, y in zip(g.uniform(0, W, nb), g.uniform(0, H, nb))]
    boxes = np.array([[g.uniform(0, W), g.uniform(0, H), g.uniform(-3, 3), g.uniform(0.2, 2), g.uniform(0.2, 2),
                       z - g.uniform(0, 0.3) * (g.uniform() < 0.7) + g.uniform(0, 0.5) * (g.uniform() < 0.2),
                       z + g.uniform(0.5, 6)] for z in zs]).reshape(-1, 7)
    sc = LidarScene(sc0.heights, cell, boxes)
    x, y = g.uniform(0.1 * W, 0.9 * W), g.uniform(0.1 * H, 0.9 * H)
    origin = np.array([x, y, Terrain(sc.heights, cell).height_at(x, y) + g.uniform(0.2, 2.0)])
    rot = rot_zyx(g.uniform(-np.pi, np.pi), tilt * g.uniform(-1, 1), tilt * g.uniform(-1, 1))
    cfg = LidarConfig(azimuth_steps=int(g.integers(8, 90)), max_range_m=float(g.uniform(5, 40)))
    scan_vs_per_ray(sc, cfg, origin, rot)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-0.5, 3.0), st.sampled_from([0.0, 0.3, 1.0]))
def test_scan_near_the_highest_point_equals_per_ray(seed: int, above: float, tilt: float) -> None:
    """Marches start where a descending ray comes down to the highest terrain point and end where
    a rising ray climbs above it: with the sensor just under or above that point (rays grazing a
    peak or a flat top at the highest height), the scan still equals casting every ray on its own."""
    g = np.random.default_rng(seed)
    rows, cols = int(g.integers(10, 40)), int(g.integers(10, 40))
    cell = float(g.uniform(0.3, 1.0))
    h = 3.0 * g.uniform(-1, 1, (rows, cols)).cumsum(0).cumsum(1) / max(rows, cols)
    i, j = int(g.integers(0, rows - 3)), int(g.integers(0, cols - 3))
    h[i:i + int(g.integers(1, 4)), j:j + int(g.integers(1, 4))] = h.max() + float(g.uniform(0.0, 2.0))  # the top
    sc = LidarScene(h.astype(np.float32), cell, np.zeros((0, 7)))
    W, H = sc.size_m
    x, y = g.uniform(0.1 * W, 0.9 * W), g.uniform(0.1 * H, 0.9 * H)
    z = max(float(sc.heights.max()) + above, Terrain(sc.heights, cell).height_at(x, y) + 0.05)
    rot = rot_zyx(g.uniform(-np.pi, np.pi), tilt * g.uniform(-1, 1), tilt * g.uniform(-1, 1))
    cfg = LidarConfig(azimuth_steps=int(g.integers(8, 90)), max_range_m=float(g.uniform(5, 60)))
    scan_vs_per_ray(sc, cfg, np.array([x, y, z]), rot)


_HILLY: list[World] = []


def _hilly_world() -> World:
    """A 40 m s=4 d=2 world with trees and buildings (generated once)."""
    if not _HILLY:
        spec = WorldSpec.model_validate({"size_m": [40.0, 40.0], "ground": {"subdivisions": 4, "deformation": 2.0},
                                         "obstacles": {"obstruction": {"tree": 6, "building": 4}}})
        _HILLY.append(generate(spec, seed=5))
    return _HILLY[0]


def test_scan_on_generated_hilly_world_equals_per_ray() -> None:
    spec = WorldSpec.model_validate({"size_m": [40.0, 40.0], "ground": {"subdivisions": 4, "deformation": 2.0},
                                     "obstacles": {"obstruction": {"tree": 6, "building": 4}}})
    w = generate(spec, seed=5)
    sc = build_scene(w)
    g = np.random.default_rng(0)
    for _ in range(4):
        x, y = g.uniform(5, 35, 2)
        origin = np.array([x, y, w.terrain.height_at(x, y) + 0.9])
        rot = rot_zyx(g.uniform(-3, 3), g.uniform(-0.25, 0.25), g.uniform(-0.25, 0.25))
        scan_vs_per_ray(sc, LidarConfig(azimuth_steps=120), origin, rot)


def test_scan_at_default_fidelity_equals_per_ray() -> None:
    """The benchmark setting (100 m map, 0.4 m cells, trees on s=4 d=2 ground, 32 x 360 scan,
    sensor tilted to the ground) against casting every ray on its own."""
    spec = WorldSpec.model_validate({"ground": {"subdivisions": 4, "deformation": 2.0},
                                     "obstacles": {"obstruction": {"tree": 6}}})
    w = generate(spec, seed=1)
    sc = build_scene(w)
    for x, y, yaw, pitch, roll in [(30.0, 40.0, 0.8, 0.12, -0.07), (70.0, 55.0, -2.5, -0.2, 0.15)]:
        origin = np.array([x, y, w.terrain.height_at(x, y) + 0.9])
        scan_vs_per_ray(sc, LidarConfig(), origin, rot_zyx(yaw, pitch, roll))


def test_float32_mipmap_is_exact() -> None:
    """The scan's float32 mipmap holds exactly the float64 one's values (max/min of float32)."""
    g = np.random.default_rng(4)
    sc = LidarScene((g.normal(0, 3, (37, 23)) * 1.37).astype(np.float32), 0.4, np.zeros((0, 7)))
    assert sc.mipf.dtype == np.float32 and sc.mipf.shape == sc.mip.T.shape
    assert np.array_equal(sc.mipf.astype(np.float64), sc.mip.T)


def test_scan_matches_mujoco_multiray_on_generated_world() -> None:
    """A whole (coarse) scan on a hilly world with trees and buildings against mj_multiRay."""
    spec = WorldSpec.model_validate({"size_m": [30.0, 30.0], "ground": {"subdivisions": 3, "deformation": 1.5},
                                     "obstacles": {"obstruction": {"tree": 8, "building": 8}}})
    w = generate(spec, seed=11)
    sc = build_scene(w)
    m, d = mujoco_model(sc)
    x, y = 12.0, 17.0
    origin = np.array([x, y, w.terrain.height_at(x, y) + 0.9])
    rot = rot_zyx(0.7, 0.08, -0.05)
    cfg = LidarConfig(azimuth_steps=90, max_range_m=30.0)
    r = Lidar(sc, cfg).ranges(origin, rot).astype(np.float64).ravel()
    vec = (cfg.directions().reshape(-1, 3) @ rot.T).ravel()
    n = vec.size // 3
    dist, gid = np.empty(n), np.empty(n, np.int32)
    # pitfalls: normal=None must be passed; cutoff does not cap the reported distance
    mujoco.mj_multiRay(m, d, origin, vec, None, 1, -1, gid, dist, None, n, cfg.max_range_m)
    ref = np.where((dist >= cfg.min_range_m) & (dist <= cfg.max_range_m), dist, np.inf)
    ok = same(r, ref, 1e-4)
    assert ok.all(), (np.flatnonzero(~ok)[:5], r[~ok][:5], ref[~ok][:5])
    assert np.isfinite(r).sum() > n // 2 and len(w.obstacles) > 5


# ---------------------------------------------------------------------------------------------
# MuJoCo's triangulation is the one Terrain.height_at uses
# ---------------------------------------------------------------------------------------------


def test_height_at_matches_mujoco_hfield() -> None:
    g = np.random.default_rng(7)
    sc = LidarScene(g.uniform(0, 2, (5, 6)).astype(np.float32), 0.7, np.zeros((0, 7)))
    m, d = mujoco_model(sc)
    t = Terrain(sc.heights, sc.cell_m)
    W, H = sc.size_m
    pts = np.column_stack([g.uniform(0, W, 300), g.uniform(0, H, 300), np.full(300, 10.0)])
    down = np.tile([0.0, 0.0, -1.0], (300, 1))
    z_mj = 10.0 - mj_cast(m, d, pts, down, 50.0)
    z_ours = 10.0 - cast_rays(sc, pts, down, 50.0)
    z_t = np.array([t.height_at(x, y) for x, y, _ in pts])
    assert np.allclose(z_mj, z_t, atol=1e-5) and np.allclose(z_ours, z_t, atol=1e-9)


# ---------------------------------------------------------------------------------------------
# analytic scenes
# ---------------------------------------------------------------------------------------------

CFG = LidarConfig()


def flat_scene(size: float = 100.0, cell: float = 0.4, boxes: list[list[float]] | None = None,
               slope: float = 0.0) -> LidarScene:
    n = int(round(size / cell)) + 1
    xs = np.arange(n) * cell
    h = np.tile(slope * xs, (n, 1))
    return LidarScene(h.astype(np.float32), cell, np.array(boxes or []).reshape(-1, 7))


def test_flat_ground_ranges_are_h_over_sin() -> None:
    lidar = Lidar(flat_scene())
    hgt = 1.3
    r = lidar.ranges(np.array([50.0, 50.0, hgt]), rot_zyx(0.4, 0, 0))
    el = CFG.elevations_rad
    for k in range(CFG.channels):
        expect = hgt / math.sin(-el[k]) if el[k] < 0 else np.inf
        if expect > CFG.max_range_m or (el[k] < 0 and 50.0 < expect * math.cos(el[k])):
            continue  # beyond range or off the map on some azimuths: checked by the test below
        assert np.allclose(r[k], expect, rtol=1e-5), (k, r[k][:3], expect)
    assert np.isinf(r[el >= 0]).all()


def test_rays_leaving_the_map_miss() -> None:
    lidar = Lidar(flat_scene(size=20.0))
    r = lidar.ranges(np.array([10.0, 10.0, 1.0]), np.eye(3))
    k = int(np.argmax(CFG.elevations_rad > -math.atan(1.0 / 10.0)))  # first channel reaching past 10 m
    assert np.isinf(r[k:, 0]).all() and np.isfinite(r[:k, 0]).all()


def test_wall_at_known_distance() -> None:
    # a big box whose near face is the plane x = 60, sensor at x = 50 facing +x
    lidar = Lidar(flat_scene(boxes=[[70.0, 50.0, 0.0, 10.0, 40.0, -1.0, 30.0]]))
    hgt = 2.0
    r = lidar.ranges(np.array([50.0, 50.0, hgt]), np.eye(3))
    el = CFG.elevations_rad
    for k in range(CFG.channels):
        ground = hgt / math.sin(-el[k]) if el[k] < 0 else np.inf
        wall = 10.0 / math.cos(el[k])
        assert math.isclose(r[k, 0], min(ground, wall), rel_tol=1e-6)
        # azimuth 30 degrees: the face is 10 / cos(30 deg) away horizontally
        a30 = 30
        wall30 = 10.0 / math.cos(math.radians(30)) / math.cos(el[k])
        assert math.isclose(r[k, a30], min(ground, wall30), rel_tol=1e-6)


def test_constant_slope_analytic() -> None:
    slope = 0.1  # ground z = 0.1 x
    sc = flat_scene(slope=slope)
    lidar = Lidar(sc)
    x0, hgt = 50.0, 1.5
    origin = np.array([x0, 50.0, slope * x0 + hgt])
    r = lidar.ranges(origin, np.eye(3))
    el = CFG.elevations_rad
    for k in range(CFG.channels):
        # azimuth 0 (uphill): hgt + t sin(el) = slope t cos(el)  ->  t = hgt / (slope cos - sin)
        den = slope * math.cos(el[k]) - math.sin(el[k])
        t = hgt / den if den > 0 else np.inf
        t = t if (t <= CFG.max_range_m and x0 + t * math.cos(el[k]) <= 100.0) else np.inf
        assert (np.isinf(t) and np.isinf(r[k, 0])) or math.isclose(r[k, 0], t, rel_tol=1e-5), (k, r[k, 0], t)
        # azimuth 180 (downhill): den = -slope cos - sin
        den = -slope * math.cos(el[k]) - math.sin(el[k])
        t = hgt / den if den > 0 else np.inf
        t = t if (t <= CFG.max_range_m and x0 - t * math.cos(el[k]) >= 0.0) else np.inf
        assert (np.isinf(t) and np.isinf(r[k, 180])) or math.isclose(r[k, 180], t, rel_tol=1e-5)


def test_scan_points_in_sensor_frame_and_no_hit_omitted() -> None:
    lidar = Lidar(flat_scene(), LidarConfig(range_noise_std_m=0.0))
    rot = rot_zyx(1.0, 0.1, -0.05)
    origin = np.array([50.0, 50.0, 1.2])
    pts = lidar.scan(origin, rot)
    r = lidar.ranges(origin, rot)
    assert pts.dtype == np.float32 and pts.shape == (int(np.isfinite(r).sum()), 3)
    world = pts.astype(np.float64) @ rot.T + origin
    assert np.allclose(world[:, 2], 0.0, atol=1e-4)  # every return lies on the flat ground
    assert np.allclose(np.linalg.norm(pts, axis=1), r[np.isfinite(r)], rtol=1e-6)


def test_min_range_drops_close_returns() -> None:
    lidar = Lidar(flat_scene(), LidarConfig(min_range_m=3.0))
    r = lidar.ranges(np.array([50.0, 50.0, 1.0]), np.eye(3))
    el = CFG.elevations_rad
    close = (el < 0) & (1.0 / np.sin(-np.minimum(el, -1e-9)) < 3.0)
    assert close.any() and np.isinf(r[close]).all() and np.isfinite(r[~close & (el < -0.05)]).all()


def test_build_scene_from_world_obstacles() -> None:
    spec = WorldSpec(size_m=(30.0, 30.0))
    ob = Obstacle(kind="tree", x=20.0, y=15.0, yaw=0.3, size=(1.0, 2.0, 5.0), z=0.5)
    sc = build_scene(World.flat(spec, obstacles=(ob,)))
    assert sc.heights.dtype == np.float32 and sc.cell_m == spec.cell_m
    assert np.allclose(sc.boxes[:, :7], [[20.0, 15.0, 0.3, 0.5, 1.0, 0.5, 5.5]])
    # a horizontal ray at z=3 from x=10 through the box centre enters its rotated +-x face
    t = cast_rays(sc, np.array([[10.0, 15.0, 3.0]]), np.array([[1.0, 0.0, 0.0]]), 70.0)[0]
    assert math.isclose(t, 10.0 - min(0.5 / math.cos(0.3), 1.0 / math.sin(0.3)), rel_tol=1e-12)
    # above the box top (z = 5.5) it misses; below its base (z = 0.5) is under the ground plane
    assert np.isinf(cast_rays(sc, np.array([[10.0, 15.0, 5.6]]), np.array([[1.0, 0.0, 0.0]]), 70.0)[0])


# ---------------------------------------------------------------------------------------------
# noise: from the rng passed only; reproducible
# ---------------------------------------------------------------------------------------------


def test_noise_same_seed_identical_different_seed_differs() -> None:
    lidar = Lidar(flat_scene(boxes=[[60.0, 50.0, 0.2, 1.0, 1.0, 0.0, 5.0]]))
    o, rot = np.array([50.0, 50.0, 1.0]), rot_zyx(0.1, 0.02, 0.0)
    a = lidar.scan(o, rot, np.random.default_rng(3))
    b = lidar.scan(o, rot, np.random.default_rng(3))
    c = lidar.scan(o, rot, np.random.default_rng(4))
    clean = lidar.scan(o, rot)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.array_equal(clean, lidar.scan(o, rot))
    dn = np.linalg.norm(a, axis=1) - np.linalg.norm(clean, axis=1)
    assert abs(dn.std() - 0.02) < 0.002 and abs(dn.mean()) < 0.002
    # noise along the ray: directions unchanged
    ua = a / np.linalg.norm(a, axis=1)[:, None]
    uc = clean / np.linalg.norm(clean, axis=1)[:, None]
    assert np.allclose(ua, uc, atol=1e-5)


def test_scan_uses_no_global_random_state() -> None:
    lidar = Lidar(flat_scene())
    o = np.array([50.0, 50.0, 1.0])
    state = np.random.get_state()
    lidar.scan(o, np.eye(3), np.random.default_rng(1))
    assert np.array_equal(np.random.get_state()[1], state[1])


# ---------------------------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("kw", "field"), [
    ({"channels": 0}, "lidar.channels"), ({"channels": 2.5}, "lidar.channels"),
    ({"azimuth_steps": -1}, "lidar.azimuth_steps"), ({"min_elevation_deg": -95.0}, "lidar.min_elevation_deg"),
    ({"max_elevation_deg": -40.0}, "lidar.max_elevation_deg"), ({"rate_hz": 0.0}, "lidar.rate_hz"),
    ({"max_range_m": 0.2}, "lidar.max_range_m"), ({"min_range_m": -1.0}, "lidar.min_range_m"),
    ({"range_noise_std_m": -0.1}, "lidar.range_noise_std_m"), ({"max_range_m": float("nan")}, "lidar.max_range_m"),
])
def test_bad_config_names_the_field(kw: dict[str, float], field: str) -> None:
    with pytest.raises(SpecError, match=f"^{field}=") as e:
        LidarConfig(**kw)  # type: ignore[arg-type]
    assert isinstance(e.value, NavstressError) and "expected" in str(e.value)


def test_bad_pose_and_rays_raise_clear_errors() -> None:
    lidar = Lidar(flat_scene(size=10.0))
    with pytest.raises(SpecError, match="^rotation="):
        lidar.scan(np.array([5.0, 5.0, 1.0]), np.eye(3) * 2)
    with pytest.raises(SpecError, match="^origin="):
        lidar.ranges(np.array([5.0, 5.0]), np.eye(3))
    with pytest.raises(SpecError, match="^rays="):
        cast_rays(lidar.scene, np.zeros((1, 3)), np.zeros((1, 3)), 10.0)
    with pytest.raises(SpecError, match="^scene.cell_m="):
        LidarScene(np.zeros((3, 3), np.float32), 0.0, np.zeros((0, 7)))
    with pytest.raises(SpecError, match="^scene.heights="):
        LidarScene(np.zeros((1, 3), np.float32), 0.4, np.zeros((0, 7)))


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4), st.integers(0, 2**32 - 1), st.booleans())
def test_scan_from_a_body_pose_equals_scan_from_its_sensor_pose(q: list[float], seed: int, identity: bool) -> None:
    """scan_body (the simulation's one-call path) builds the rotation as MuJoCo's mju_quat2Mat
    (to the last bit but FMA rounding), places the sensor at qpos[:3] + R @ mount, and returns
    the same points (same noise draws) as scan() from that pose."""
    qv = np.array([1.0, 0.0, 0.0, 0.0]) if identity or np.linalg.norm(q) < 1e-3 else np.array(q) / np.linalg.norm(q)
    sc = build_scene(_hilly_world())
    g = np.random.default_rng(seed)
    x, y = g.uniform(5.0, 35.0, 2)
    qpos = np.concatenate([[x, y, _hilly_world().terrain.height_at(x, y) + g.uniform(0.3, 1.5)], qv, g.uniform(-1, 1, 3)])
    mount = np.array([0.2, -0.05, 0.6])
    lid = Lidar(sc, LidarConfig(azimuth_steps=90))
    pts = lid.scan_body(qpos, mount, np.random.default_rng(seed))
    ref_rot = np.empty(9)
    mujoco.mju_quat2Mat(ref_rot, qpos[3:7])
    assert np.allclose(lid._rot.ravel(), ref_rot, rtol=0, atol=1e-15)
    assert np.allclose(lid._origin, qpos[:3] + ref_rot.reshape(3, 3) @ mount, rtol=0, atol=1e-12)
    again = Lidar(sc, LidarConfig(azimuth_steps=90)).scan(lid._origin.copy(), lid._rot.copy(), np.random.default_rng(seed))
    assert pts.shape == again.shape and np.array_equal(pts, again)


def test_scan_from_a_bad_body_pose_names_qpos() -> None:
    lidar = Lidar(flat_scene(size=10.0))
    good = np.array([5.0, 5.0, 1.0, 1.0, 0.0, 0.0, 0.0])
    for bad in (good * np.array([1, 1, 1, 2, 1, 1, 1]), np.where(np.arange(7) == 0, np.nan, good), good[:5],
                good.astype(np.float32), [5.0, 5.0, 1.0]):
        with pytest.raises(SpecError, match="^qpos="):
            lidar.scan_body(bad, np.zeros(3))


@pytest.mark.parametrize("rot", [rot_zyx(0.3, 1.4, 0.0), rot_zyx(-2.0, 0.2, math.pi), rot_zyx(1.0, -1.2, 0.7)])
def test_scan_extreme_orientations_equal_per_ray(rot: np.ndarray) -> None:
    """Steep pitch or upside down: no plane-march or ordering shortcut may drop a hit."""
    g = np.random.default_rng(2)
    h = 0.5 * g.uniform(-1, 1, (30, 30)).cumsum(0).cumsum(1) / 30
    boxes = np.array([[g.uniform(1, 11), g.uniform(1, 11), g.uniform(-3, 3), 0.5, 0.7, -2.0, 4.0]
                      for _ in range(25)])
    sc = LidarScene(h.astype(np.float32), 0.4, boxes)
    origin = np.array([6.0, 6.0, Terrain(sc.heights, 0.4).height_at(6.0, 6.0) + 1.5])
    scan_vs_per_ray(sc, LidarConfig(azimuth_steps=72, max_range_m=20.0), origin, rot)


def test_scan_from_outside_the_map_sees_the_side_walls() -> None:
    """A sensor off the map edge, below the edge profile: rays hit the hfield's side wall."""
    h = np.full((20, 20), 2.0, np.float32)
    sc = LidarScene(h, 0.5, np.zeros((0, 7)))
    origin = np.array([-3.0, 4.75, 1.8])  # 3 m west of the x=0 edge, 0.2 m below the plateau
    cfg = LidarConfig(azimuth_steps=36, max_range_m=20.0)
    scan_vs_per_ray(sc, cfg, origin, np.eye(3))
    r = Lidar(sc, cfg).ranges(origin, np.eye(3))
    el = cfg.elevations_rad
    below = np.tan(el) * 3.0 < 0.2  # reaches x=0 under z=2: the wall at 3 / cos(el)
    assert np.allclose(r[below, 0], 3.0 / np.cos(el[below]), rtol=1e-6)
    assert (~below).sum() >= 3 and np.isinf(r[~below, 0]).all()  # rising over the plateau


# ---------------------------------------------------------------------------------------------
# the box pass (_raybox.box_pass after a terrain-only scan): bit-identical to the all-in-one
# scan_kernel and to the minimum over every box of the scalar ray-box test
# ---------------------------------------------------------------------------------------------


def _params(cfg: LidarConfig, plane_march: bool, min_range: float | None = None) -> np.ndarray:
    return new_scan_params(max_range=cfg.max_range_m, min_range=cfg.min_range_m if min_range is None else min_range,
                           plane_march=int(plane_march), walk=0)


def terrain_then_boxes(sc: LidarScene, cfg: LidarConfig, origin: np.ndarray, rot: np.ndarray,
                       plane_march: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(terrain-only ranges before any filter, terrain + box_pass result)."""
    lidar = Lidar(sc, cfg, plane_march=plane_march)
    terr = np.empty((cfg.channels, cfg.azimuth_steps))
    scan_kernel(sc.grid, lidar._beams, _params(cfg, plane_march, -math.inf), np.zeros((0, 9)), origin, rot, terr)
    out = terr.copy()
    _raybox.box_pass(sc.boxes, lidar._beams, _params(cfg, plane_march), origin, rot, out)
    return terr, out


def all_in_one(sc: LidarScene, cfg: LidarConfig, origin: np.ndarray, rot: np.ndarray,
               plane_march: bool = True) -> np.ndarray:
    """scan_kernel with the boxes (the path before box_pass)."""
    lidar = Lidar(sc, cfg)
    out = np.empty((cfg.channels, cfg.azimuth_steps))
    scan_kernel(sc.grid, lidar._beams, _params(cfg, plane_march), sc.boxes, origin, rot, out)
    return out


def nearest_box(sc: LidarScene, cfg: LidarConfig, origin: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """The nearest box per ray (inf: none hit), by brute force with the kernel's own direction
    arithmetic and the scalar _ray_box (run as Python: IEEE double, same operations). It does
    not depend on the terrain pass: computed once for both of them."""
    ray_box = _ray_box.py_func
    el, az = cfg.elevations_rad, cfg.azimuths_rad
    ce, se, ca, sa = np.cos(el), np.sin(el), np.cos(az), np.sin(az)
    ox, oy, oz = (float(v) for v in origin)
    uwx, uwy, uwz = float(rot[0, 2]), float(rot[1, 2]), float(rot[2, 2])
    boxes = [Box(b[0], b[1], b[7], b[8], b[3], b[4], b[5], b[6]) for b in sc.boxes.tolist()]
    out = np.full((cfg.channels, cfg.azimuth_steps), math.inf)
    for a in range(cfg.azimuth_steps):
        awx = float(rot[0, 0]) * float(ca[a]) + float(rot[0, 1]) * float(sa[a])
        awy = float(rot[1, 0]) * float(ca[a]) + float(rot[1, 1]) * float(sa[a])
        awz = float(rot[2, 0]) * float(ca[a]) + float(rot[2, 1]) * float(sa[a])
        for k in range(cfg.channels):
            c, s = float(ce[k]), float(se[k])
            rx, ry, rz = c * awx + s * uwx, c * awy + s * uwy, c * awz + s * uwz
            best = math.inf
            for b in boxes:
                best = min(best, ray_box(b, Ray(ox, oy, oz, rx, ry, rz)))
            out[k, a] = best
    return out


def boxes_brute_force(sc: LidarScene, cfg: LidarConfig, origin: np.ndarray, rot: np.ndarray,
                      terr: np.ndarray, nearest: np.ndarray | None = None) -> np.ndarray:
    """min(terrain, every box) per ray (``nearest_box``, given or computed here), then the range
    filter."""
    if nearest is None:
        nearest = nearest_box(sc, cfg, origin, rot)
    out = terr.copy()
    for k in range(cfg.channels):
        for a in range(cfg.azimuth_steps):
            best = min(float(out[k, a]), float(nearest[k, a]))
            out[k, a] = best if cfg.min_range_m <= best <= cfg.max_range_m else math.inf
    return out


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 1e-3, 0.1, 0.5, 1.2, 3.0]),
       st.sampled_from(["random", "inside", "straddle", "wide"]))
@example(seed=1, tilt=0.0, kind="inside")
def test_box_pass_equals_all_in_one_and_brute_force(seed: int, tilt: float, kind: str) -> None:
    """Random boxes (yawed, tall, below and above the sensor), tilted or upside-down sensors, a
    sensor inside a box, boxes straddling the min/max range, buildings wider than the range,
    a rotation off orthonormal by rounding: bit-identical ranges."""
    g = np.random.default_rng(seed)
    n = int(g.integers(8, 30))
    cell = float(g.uniform(0.3, 1.0))
    relief = float(g.choice([0.0, 0.5, 2.0]))
    h = (relief * g.uniform(-1, 1, (n, n)).cumsum(0).cumsum(1) / n).astype(np.float32)
    W = (n - 1) * cell
    t = Terrain(h, cell)
    x, y = g.uniform(0.2 * W, 0.8 * W, 2)
    origin = np.array([x, y, t.height_at(x, y) + g.uniform(0.2, 2.0)])
    lo = float(g.uniform(-60, 5))
    cfg = LidarConfig(channels=int(g.integers(1, 24)), min_elevation_deg=lo, max_elevation_deg=lo + float(g.uniform(1, 80)),
                      azimuth_steps=int(g.integers(1, 60)), max_range_m=float(g.uniform(4, 30)),
                      min_range_m=float(g.choice([0.0, 0.3, 1.5])))
    nb = int(g.integers(0, 25))
    boxes = []
    for _ in range(nb):
        zb = float(g.uniform(origin[2] - 4, origin[2] + 1))
        hx, hy = g.uniform(0.05, 1.5, 2)
        if kind == "straddle":  # centre near the min or max range
            r = float(g.choice([cfg.min_range_m, cfg.max_range_m])) + g.uniform(-1, 1)
            ang = g.uniform(-np.pi, np.pi)
            bx, by = x + r * math.cos(ang), y + r * math.sin(ang)
        else:
            bx, by = g.uniform(-0.2 * W, 1.2 * W, 2)
        if kind == "wide":
            hx, hy = g.uniform(0.5, 2.0 * W, 2)
        boxes.append([bx, by, g.uniform(-4, 4), hx, hy, zb, zb + g.uniform(0.1, 8)])
    if kind == "inside":  # the sensor inside a box: rays hit its exit faces
        boxes.append([x + g.uniform(-0.3, 0.3), y + g.uniform(-0.3, 0.3), g.uniform(-4, 4), g.uniform(0.4, 1.5),
                      g.uniform(0.4, 1.5), origin[2] - g.uniform(0.1, 2), origin[2] + g.uniform(0.1, 2)])
    sc = LidarScene(h, cell, np.array(boxes).reshape(-1, 7))
    rot = rot_zyx(g.uniform(-np.pi, np.pi), tilt * g.uniform(-1, 1), tilt * g.uniform(-1, 1))
    if g.uniform() < 0.3:
        rot = rot + g.uniform(-3e-7, 3e-7, (3, 3))  # still accepted (rotation error <= 1e-6)
    nearest = nearest_box(sc, cfg, origin, rot)  # the boxes' brute force, the same for both terrain passes
    for plane in (True, False):
        terr, new = terrain_then_boxes(sc, cfg, origin, rot, plane)
        old = all_in_one(sc, cfg, origin, rot, plane)
        assert np.array_equal(new, old), (np.argwhere(new != old)[:5], new[new != old][:5], old[new != old][:5])
        assert np.array_equal(Lidar(sc, cfg, plane_march=plane)._ranges(origin, rot), new)
        ref = boxes_brute_force(sc, cfg, origin, rot, terr, nearest)
        assert np.array_equal(new, ref), (np.argwhere(new != ref)[:5], new[new != ref][:5], ref[new != ref][:5])


def test_box_pass_equals_all_in_one_on_generated_worlds() -> None:
    """Trees and buildings on flat and hilly generated worlds, default 32 x 360 scans."""
    for ground in ({}, {"subdivisions": 4, "deformation": 2.0}):
        spec = WorldSpec.model_validate({"size_m": [60.0, 60.0], "ground": ground,
                                         "obstacles": {"obstruction": {"tree": 8, "building": 6}}})
        w = generate(spec, seed=3)
        sc = build_scene(w)
        g = np.random.default_rng(1)
        cfg = LidarConfig()
        lidar = Lidar(sc, cfg)
        hits = 0
        for _ in range(6):
            x, y = g.uniform(5, 55, 2)
            origin = np.array([x, y, w.terrain.height_at(x, y) + 0.9])
            rot = rot_zyx(g.uniform(-3, 3), g.uniform(-0.2, 0.2), g.uniform(-0.2, 0.2))
            new = lidar._ranges(origin, rot).copy()
            assert np.array_equal(new, all_in_one(sc, cfg, origin, rot))
            terr, _ = terrain_then_boxes(sc, cfg, origin, rot)
            hits += int(np.sum(new < np.where(terr >= cfg.min_range_m, terr, np.inf)))
        assert hits > 1000  # the boxes were seen (rays shortened by them)
