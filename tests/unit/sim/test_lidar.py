"""Lidar ray caster: brute force, MuJoCo mj_ray, analytic scenes, noise and errors."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.errors import NavstressError, SpecError
from navstress.sim.lidar import Lidar, LidarConfig, LidarScene, build_scene, cast_rays
from navstress.world.spec import WorldSpec
from navstress.world.world import Obstacle, Terrain, World

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
            d = np.array([W / 2, H / 2, hmin]) - o[k] + g.normal(0, 1.0, 3)
            o[k] += 0.0 * d
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
    for x, y, yaw, hx, hy, zb, zt in sc.boxes:
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
        f'euler="0 0 {yaw!r}"/>' for x, y, yaw, hx, hy, zb, zt in sc.boxes.tolist())
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
    return (np.isinf(a) & np.isinf(b)) | (np.abs(a - b) <= tol * (1 + np.abs(b)))


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
    assert same(a, b, 1e-7).all(), (np.flatnonzero(~same(a, b, 1e-7)), a, b)


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
