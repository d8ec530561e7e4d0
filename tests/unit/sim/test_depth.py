"""Depth camera (navstress.sim.depth): analytic scenes (tests/oracles/depth.py), MuJoCo's mj_ray on
a generated world, the fast path against the plain one, noise, dropouts, determinism, errors."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.errors import SpecError
from navstress.sensors import Mount
from navstress.sensors.kinds.depth import DepthParams, rays
from navstress.sim.depth import DepthCamera
from navstress.sim.lidar import LidarScene, build_scene
from navstress.sim.model import world_to_mjcf
from navstress.world.generate import generate
from navstress.world.spec import parse_spec
from tests.oracles import depth as oracle

LEVEL = np.array([1.0, 0.0, 0.0, 0.0])


def qpos(x: float, y: float, z: float, roll: float = 0.0, pitch: float = 0.0, yaw: float = 0.0) -> np.ndarray:
    """Body pose with the quaternion of Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([x, y, z, cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr,
                     cy * sp * cr + sy * cp * sr, sy * cp * cr - cy * sp * sr])


def flat_scene(z: float = 0.0, size: float = 40.0, boxes: list[list[float]] | None = None,
               cell: float = 0.5) -> LidarScene:
    n = int(round(size / cell)) + 1
    return LidarScene(np.full((n, n), z, np.float32), cell, np.array(boxes or []).reshape(-1, 7))


def expected(p: DepthParams, q: np.ndarray, mount: Mount, surfaces: list) -> np.ndarray:  # type: ignore[type-arg]
    """The oracle's image: the nearest of the surfaces (callables of origin, world dirs), cut."""
    o, r = oracle.sensor_pose(q, mount.xyz, mount.rpy)
    d = oracle.world_dirs(r, oracle.pixel_dirs(p.width, p.height, p.hfov_deg, p.vfov_deg))
    best = np.full((p.height, p.width), np.inf)
    for f in surfaces:
        best = np.minimum(best, f(o, d))
    return oracle.cut(best, p.min_range_m, p.max_range_m)


def same(a: np.ndarray, b: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return (np.isinf(a) & np.isinf(b)) | (np.abs(a - b) <= tol * (1.0 + np.abs(b)))


def check(img: np.ndarray, want: np.ndarray, tol: float = 1e-9) -> None:
    ok = same(img, want, tol)
    assert ok.all(), (np.argwhere(~ok)[:5], img[~ok][:5], want[~ok][:5])


FAST = pytest.mark.parametrize("fast", [True, False], ids=["fast", "plain"])


# ---------------------------------------------------------------------------------------------
# analytic scenes
# ---------------------------------------------------------------------------------------------


@FAST
@pytest.mark.parametrize("pitch_deg, ground, size", [(20.0, 0.0, 40.0), (35.0, 0.7, 40.0), (5.0, -0.3, 40.0),
                                                     (60.0, 0.2, 12.0), (-10.0, 0.0, 40.0)])
def test_flat_ground_pitched_down(fast: bool, pitch_deg: float, ground: float, size: float) -> None:
    """Ground rows: depth from the plane's geometry (the map's edge bounds it: size 12 m); a
    camera pitched up sees the ground only in its lower rows."""
    ground = float(np.float32(ground))  # (the terrain's heights are float32)
    p = DepthParams(width=40, height=30, max_range_m=25.0)
    cam = DepthCamera(flat_scene(ground, size), p, fast=fast)
    m = Mount(xyz=(0.3, 0.0, 0.8), rpy=(0.0, math.radians(pitch_deg), 0.0))
    q = qpos(size / 2, size / 2, ground + 0.2)
    img = cam.render(q, m, None, None)
    assert img.dtype == np.float32 and img.shape == (30, 40)
    want = expected(p, q, m, [lambda o, d: oracle.plane_z(o, d, ground, (0, size), (0, size))])
    check(img.astype(np.float64), want, 1e-6)  # (float32 image)
    check(cam.depths(q, m), want)
    assert np.isfinite(want).any()


@FAST
@pytest.mark.parametrize("yaw_deg", [0.0, 90.0, -135.0, 33.0])
def test_fronto_parallel_wall_has_constant_depth(fast: bool, yaw_deg: float) -> None:
    """A wall facing the camera at distance D along its axis: every pixel on it reads D (the depth,
    not the range along the ray), whatever the body's yaw."""
    yaw = math.radians(yaw_deg)
    c, s = math.cos(yaw), math.sin(yaw)
    dist = 4.0
    cx, cy = 20.0 + c * (dist + 0.25), 20.0 + s * (dist + 0.25)  # the wall's near face at dist
    p = DepthParams(width=32, height=24, min_range_m=0.1, max_range_m=8.0)
    cam = DepthCamera(flat_scene(-20.0, 40.0, [[cx, cy, yaw, 0.25, 30.0, -30.0, 20.0]]), p, fast=fast)
    m = Mount(xyz=(0.0, 0.0, 0.5), rpy=(0.0, 0.0, 0.0))
    img = cam.depths(qpos(20.0, 20.0, 0.5, yaw=yaw), m)
    assert np.all(np.abs(img - dist) <= 1e-9)


@FAST
def test_wall_and_ground_with_yawed_and_rolled_mounts(fast: bool) -> None:
    """A mount yawed 90 degrees sees the wall on the body's left; a rolled mount (30 degrees) sees
    the ground's horizon tilted; both as the oracle's planes and box."""
    wall = [10.0, 16.0, 0.0, 6.0, 0.2, 0.0, 2.0]
    sc = flat_scene(0.0, 30.0, [wall])
    p = DepthParams(width=48, height=36, max_range_m=12.0, vfov_deg=50.0)
    for rpy in ((0.0, 0.2, math.pi / 2), (math.radians(30), 0.25, 0.0), (-0.4, 0.1, 2.5)):
        m = Mount(xyz=(0.2, 0.1, 0.6), rpy=rpy)
        q = qpos(10.0, 12.0, 0.3, yaw=0.3)
        img = DepthCamera(sc, p, fast=fast).depths(q, m)
        want = expected(p, q, m, [lambda o, d: oracle.plane_z(o, d, 0.0, (0, 30), (0, 30)),
                                  lambda o, d: oracle.box(o, d, *wall)])
        check(img, want)


@FAST
@pytest.mark.parametrize("roll, pitch, yaw", [(0.2, 0.0, 0.0), (0.0, -0.3, 1.0), (0.15, 0.25, -2.0)])
def test_tilted_body(fast: bool, roll: float, pitch: float, yaw: float) -> None:
    boxes = [[14.0, 10.0, 0.4, 0.6, 1.2, 0.0, 1.5], [9.0, 13.0, -0.2, 0.3, 0.3, 0.0, 3.0]]
    sc = flat_scene(0.25, 24.0, boxes)
    p = DepthParams(width=40, height=30, hfov_deg=100.0, max_range_m=15.0)
    m = Mount(xyz=(0.3, 0.0, 0.5), rpy=(0.0, 0.15, 0.0))
    for yaw_k in (yaw, yaw + 1.5):
        q = qpos(10.0, 10.0, 0.6, roll, pitch, yaw_k)
        want = expected(p, q, m, [lambda o, d: oracle.plane_z(o, d, 0.25, (0, 24), (0, 24))]
                        + [lambda o, d, b=b: oracle.box(o, d, *b) for b in boxes])
        check(DepthCamera(sc, p, fast=fast).depths(q, m), want)


@FAST
def test_box_edges_pixel_exact(fast: bool) -> None:
    """Which pixels a box covers, to the pixel: boxes placed so that pixel centres pass close to
    (but not on) their silhouettes, at many yaws, sizes and heights (also across the image's
    borders and straddling the camera's plane: a box beside the camera)."""
    g = np.random.default_rng(7)
    p = DepthParams(width=64, height=48, max_range_m=20.0, min_range_m=0.0)
    m = Mount(xyz=(0.0, 0.0, 1.0), rpy=(0.0, 0.1, 0.0))
    q = qpos(15.0, 15.0, 0.0)
    boxes = []
    for _ in range(14):
        ang = g.uniform(-2.0, 2.0) if len(boxes) % 4 else g.uniform(1.2, 1.8)  # some beside the camera
        dist = g.uniform(1.0, 9.0)
        zb = g.uniform(-0.5, 1.5)
        boxes.append([15.0 + dist * math.cos(ang), 15.0 + dist * math.sin(ang), g.uniform(-3, 3),
                      g.uniform(0.05, 1.5), g.uniform(0.05, 1.5), zb, zb + g.uniform(0.05, 2.5)])
    sc = flat_scene(0.0, 30.0, boxes)
    img = DepthCamera(sc, p, fast=fast).depths(q, m)
    want = expected(p, q, m, [lambda o, d: oracle.plane_z(o, d, 0.0, (0, 30), (0, 30))]
                    + [lambda o, d, b=b: oracle.box(o, d, *b) for b in boxes])
    check(img, want)
    assert (np.isfinite(want) & (want < np.inf)).sum() > 100


@FAST
def test_discs(fast: bool) -> None:
    p = DepthParams(width=48, height=36, max_range_m=12.0)
    m = Mount(xyz=(0.2, 0.0, 0.6), rpy=(0.0, 0.2, 0.0))
    q = qpos(5.0, 5.0, 0.2, yaw=0.1)
    discs = np.array([[8.0, 5.5, 0.4, 0.0, 1.8], [7.0, 4.0, 0.25, 0.0, 0.5], [5.7, 5.0, 0.15, 0.0, 2.0],
                      [4.0, 5.0, 0.3, 0.0, 1.0], [30.0, 5.0, 0.3, 0.0, 1.0]])
    img = DepthCamera(flat_scene(0.0, 20.0), p, fast=fast).depths(q, m, discs=discs)
    want = expected(p, q, m, [lambda o, d: oracle.plane_z(o, d, 0.0, (0, 20), (0, 20))]
                    + [lambda o, d, c=c: oracle.cylinder(o, d, *c) for c in discs])
    check(img, want)
    top = expected(p, q, m, [lambda o, d: oracle.cylinder(o, d, *discs[0])])
    assert np.isfinite(top).sum() > 20  # the first disc is in view


@FAST
def test_min_and_max_cut_offs(fast: bool) -> None:
    """A surface nearer than min_range hides what is behind it (inf, not the ground behind); the
    ground beyond max_range is inf; the cut is on the depth, not on the range along the ray."""
    p = DepthParams(width=40, height=30, min_range_m=1.0, max_range_m=6.0)
    sc = flat_scene(0.0, 40.0, [[20.8, 20.0, 0.0, 0.2, 0.3, 0.0, 3.0]])  # near face at 0.6 m
    m = Mount(xyz=(0.0, 0.0, 1.0), rpy=(0.0, 0.3, 0.0))
    q = qpos(20.0, 20.0, 0.0)
    img = DepthCamera(sc, p, fast=fast).depths(q, m)
    raw = expected(DepthParams(width=40, height=30, min_range_m=0.0, max_range_m=100.0), q, m,
                   [lambda o, d: oracle.plane_z(o, d, 0.0), lambda o, d: oracle.box(o, d, 20.8, 20.0, 0.0, 0.2, 0.3,
                                                                                    0.0, 3.0)])
    near = raw < 1.0
    far = (raw > 6.0) & np.isfinite(raw)
    assert near.sum() > 10 and far.sum() > 10
    assert np.all(np.isinf(img[near])) and np.all(np.isinf(img[far]))
    check(img, oracle.cut(raw, 1.0, 6.0))
    # depth, not range: the corner pixels' range exceeds their depth
    o, r = oracle.sensor_pose(q, m.xyz, m.rpy)
    d = oracle.world_dirs(r, oracle.pixel_dirs(40, 30, p.hfov_deg))
    rng_ = raw * np.linalg.norm(d, axis=-1)
    assert np.any(np.isfinite(img) & (rng_ > 6.0))


def test_camera_inside_a_box_sees_its_exit_faces() -> None:
    """Two-sided boxes as the lidar's: a camera inside a box sees where each ray leaves it."""
    b = [10.0, 10.0, 0.3, 2.0, 1.5, -1.0, 3.0]
    p = DepthParams(width=24, height=18, min_range_m=0.0)
    m = Mount(xyz=(0.0, 0.0, 0.5))
    q = qpos(10.2, 9.9, 0.5, yaw=0.7)
    want = expected(p, q, m, [lambda o, d: oracle.box(o, d, *b)])
    for fast in (True, False):
        check(DepthCamera(flat_scene(-5.0, 20.0, [b]), p, fast=fast).depths(q, m), want)


def test_camera_exactly_on_a_box_face_plane() -> None:
    """The sensor on the plane of a box's face (x = box's near face, as with a mount at an exact
    offset): the fast path's reciprocal slab test would give 0 x inf there; it takes the plain
    test for that box, and the image equals the plain path's."""
    b = [12.0, 10.0, 0.0, 1.0, 0.5, 0.0, 1.5]  # faces at y = 9.5, 10.5; top z = 1.5
    p = DepthParams(width=33, height=25, min_range_m=0.0)  # odd: a centre column and row
    for q, m in ((qpos(8.0, 10.5, 0.5), Mount(xyz=(0.0, 0.0, 1.0))), (qpos(8.0, 9.0, 1.0), Mount(xyz=(0.0, 0.5, 0.0)))):
        imgs = [DepthCamera(flat_scene(0.0, 20.0, [b]), p, fast=f).depths(q, m).copy() for f in (True, False)]
        check(imgs[0], imgs[1], 1e-12)
        o, r = oracle.sensor_pose(q, m.xyz, m.rpy)
        d = oracle.world_dirs(r, oracle.pixel_dirs(p.width, p.height, p.hfov_deg))
        assert np.isfinite(oracle.box(o, d, *b)).sum() > 20


# ---------------------------------------------------------------------------------------------
# MuJoCo's mj_ray on a generated world; the fast path against the plain one
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", [1, 2])
def test_matches_mujoco_mj_ray_on_a_generated_world(seed: int) -> None:
    w = generate(parse_spec({"size_m": [30, 30], "ground": {"subdivisions": 3, "deformation": 1.5},
                             "obstacles": {"obstruction": {"tree": 12}}}), seed)
    sc = build_scene(w)
    assert sc.boxes.shape[0] > 0
    model = mujoco.MjModel.from_xml_string(world_to_mjcf(w))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    p = DepthParams(width=20, height=16, hfov_deg=100.0, max_range_m=30.0, min_range_m=0.05)
    g = np.random.default_rng(seed)
    gid = np.array([-1], np.int32)
    hits = 0
    for k in range(3):
        x, y = g.uniform(5, 25, 2)
        q = qpos(x, y, float(w.terrain.height_at(x, y)) + 0.3, yaw=g.uniform(-3, 3), pitch=g.uniform(-0.1, 0.1))
        m = Mount(xyz=(0.2, 0.0, 0.6), rpy=(0.0, g.uniform(0.0, 0.5), 0.0))
        img = DepthCamera(sc, p).depths(q, m)
        o, r = oracle.sensor_pose(q, m.xyz, m.rpy)
        d = oracle.world_dirs(r, oracle.pixel_dirs(p.width, p.height, p.hfov_deg))
        ref = np.full(img.shape, np.inf)
        for v in range(p.height):
            for u in range(p.width):
                n = float(np.linalg.norm(d[v, u]))
                t = mujoco.mj_ray(model, data, o, d[v, u] / n, None, 1, -1, gid)
                if t >= 0:
                    ref[v, u] = t / n
        ref = oracle.cut(ref, p.min_range_m, p.max_range_m)
        # MuJoCo's elevations are float32 of (h - hmin) / relief: ~1e-7 relative height error
        check(img, ref, 1e-4)
        hits += int(np.isfinite(ref).sum())
    assert hits > 300


def random_scene(g: np.random.Generator) -> tuple[LidarScene, np.ndarray]:
    rows, cols = int(g.integers(2, 12)), int(g.integers(2, 12))
    cell = float(g.uniform(0.3, 1.5))
    h = g.uniform(-1.0, 2.0, (rows, cols)) * g.choice([0.0, 0.0, 0.3, 1.0]) + g.uniform(-1, 1)
    W, H = (cols - 1) * cell, (rows - 1) * cell
    boxes = []
    for _ in range(int(g.integers(0, 12))):
        zb = float(g.uniform(h.min() - 0.5, h.max()))
        boxes.append([g.uniform(-0.5, W + 0.5), g.uniform(-0.5, H + 0.5), g.uniform(-np.pi, np.pi),
                      g.uniform(0.05, 1.5), g.uniform(0.05, 1.5), zb, zb + g.uniform(0.1, 3.0)])
    discs = np.array([[g.uniform(-0.5, W + 0.5), g.uniform(-0.5, H + 0.5), g.uniform(0.1, 0.8), zb, zb + 1.8]
                      for zb in g.uniform(h.min() - 0.5, h.max(), int(g.integers(0, 5)))]).reshape(-1, 5)
    return LidarScene(h.astype(np.float32), cell, np.array(boxes).reshape(-1, 7)), discs


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_fast_path_equals_plain_path(seed: int) -> None:
    """Random terrains (flat and not), boxes, discs, poses (inside and outside the map, above and
    below ground, tilted), mounts and cameras: the fast path's image is the plain path's."""
    g = np.random.default_rng(seed)
    sc, discs = random_scene(g)
    W, H = sc.size_m
    p = DepthParams(width=int(g.integers(1, 40)), height=int(g.integers(1, 30)), hfov_deg=float(g.uniform(20, 170)),
                    max_range_m=float(g.uniform(1.0, 30.0)), min_range_m=float(g.choice([0.0, 0.3])))
    x, y = g.uniform(-0.3 * W, 1.3 * W), g.uniform(-0.3 * H, 1.3 * H)
    q = qpos(x, y, float(g.uniform(sc.heights.min() - 0.5, sc.heights.max() + 2.0)), *g.uniform(-0.5, 0.5, 2),
             g.uniform(-3.2, 3.2))
    m = Mount(xyz=tuple(g.uniform(-0.3, 0.6, 3)), rpy=tuple(g.uniform(-0.8, 0.8, 3)))
    boxes = sc.boxes
    a = DepthCamera(sc, p, fast=True).depths(q, m, discs=discs, scene_boxes=boxes).copy()
    b = DepthCamera(sc, p, fast=False).depths(q, m, discs=discs, scene_boxes=boxes)
    check(a, b, 1e-12)


def test_fast_path_equals_plain_path_on_the_benchmark_world() -> None:
    """The DESIGN benchmark world (flat, 6 % trees), a few poses, a 64 x 48 camera with movers."""
    w = generate(parse_spec({"size_m": [100, 100], "obstacles": {"obstruction": {"tree": 6}}}), 1)
    sc = build_scene(w)
    p = DepthParams(width=64, height=48)
    m = Mount(xyz=(0.35, 0.0, 0.6))
    g = np.random.default_rng(3)
    for _ in range(4):
        x, y = g.uniform(10, 90, 2)
        discs = np.column_stack([x + g.uniform(-6, 6, 8), y + g.uniform(-6, 6, 8), np.full(8, 0.25), np.zeros(8),
                                 np.full(8, 1.8)])
        q = qpos(x, y, 0.4, yaw=g.uniform(-3, 3))
        a = DepthCamera(sc, p, fast=True).depths(q, m, discs=discs).copy()
        b = DepthCamera(sc, p, fast=False).depths(q, m, discs=discs)
        check(a, b, 1e-12)
        assert np.isfinite(a).mean() > 0.3


def test_scene_boxes_replace_the_scenes_boxes() -> None:
    """scene_boxes (LidarScene.boxes' 9 columns: every box at render time) is what is seen."""
    sc = flat_scene(0.0, 20.0, [[14.0, 10.0, 0.0, 0.5, 3.0, 0.0, 3.0]])
    extra = np.array([[12.0, 10.0, 0.5, 0.3, 0.3, 0.0, 2.0]])
    allb = np.concatenate([sc.boxes, np.column_stack([extra, np.cos(extra[:, 2]), np.sin(extra[:, 2])])])
    p = DepthParams(width=24, height=18)
    m = Mount(xyz=(0.0, 0.0, 0.8))
    q = qpos(10.0, 10.0, 0.0)
    cam = DepthCamera(sc, p)
    plain = cam.depths(q, m).copy()
    both = cam.depths(q, m, scene_boxes=allb)
    want = expected(p, q, m, [lambda o, d: oracle.plane_z(o, d, 0.0, (0, 20), (0, 20)),
                              lambda o, d: oracle.box(o, d, 14.0, 10.0, 0.0, 0.5, 3.0, 0.0, 3.0),
                              lambda o, d: oracle.box(o, d, *extra[0])])
    check(both, want)
    assert (both < plain).any()


# ---------------------------------------------------------------------------------------------
# noise, dropouts, determinism, errors
# ---------------------------------------------------------------------------------------------


def wall_camera(dist: float, **kw: float) -> tuple[DepthCamera, np.ndarray, Mount]:
    sc = flat_scene(-5.0, 60.0, [[30.0 + dist + 1.0, 30.0, 0.0, 1.0, 29.0, -6.0, 30.0]])
    return DepthCamera(sc, DepthParams(width=160, height=120, hfov_deg=60.0, **kw)), qpos(30.0, 30.0, 1.0), Mount(
        xyz=(0.0, 0.0, 0.0))


@pytest.mark.parametrize("dist", [1.0, 3.0])
def test_noise_std_grows_with_depth_squared(dist: float) -> None:
    std1 = 0.01
    cam, q, m = wall_camera(dist, noise_std_at_1m_m=std1)
    clean = cam.render(q, m, None, None).astype(np.float64)
    assert np.all(np.abs(clean - dist) < 1e-5)
    noisy = cam.render(q, m, np.random.default_rng(5), None).astype(np.float64)
    e = (noisy - clean).ravel()
    n = e.size
    want = std1 * dist * dist
    # the sample std of n normals is within 5 standard errors (std / sqrt(2n)) of the truth
    assert abs(e.std() - want) < 5 * want / math.sqrt(2 * n) + 1e-6 * dist, (e.std(), want)
    assert abs(e.mean()) < 5 * want / math.sqrt(n) + 1e-6 * dist


def test_dropouts_fraction_and_streams() -> None:
    cam, q, m = wall_camera(2.0, dropout_prob=0.3)
    img = cam.render(q, m, None, np.random.default_rng(9))
    lost = np.isinf(img).mean()
    n = img.size
    assert abs(lost - 0.3) < 5 * math.sqrt(0.3 * 0.7 / n)
    # None: no dropouts; dropout_prob 0: the dropout generator is not drawn
    assert np.isfinite(cam.render(q, m, None, None)).all()
    cam0, _, _ = wall_camera(2.0, dropout_prob=0.0)
    g = np.random.default_rng(9)
    before = g.bit_generator.state
    assert np.isfinite(cam0.render(q, m, None, g)).all()
    assert g.bit_generator.state == before


def test_same_generator_state_same_image() -> None:
    cam, q, m = wall_camera(2.5, dropout_prob=0.1)
    a = cam.render(q, m, np.random.default_rng(1), np.random.default_rng(2))
    b = cam.render(q, m, np.random.default_rng(1), np.random.default_rng(2))
    c = cam.render(q, m, np.random.default_rng(3), np.random.default_rng(2))
    d = cam.render(q, m, np.random.default_rng(1), np.random.default_rng(4))
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c) and np.array_equal(np.isinf(a), np.isinf(c))
    assert not np.array_equal(np.isinf(a), np.isinf(d))


def test_rays_match_the_oracles_pixel_directions() -> None:
    p = DepthParams(width=7, height=5, hfov_deg=70.0, vfov_deg=40.0)
    assert np.allclose(rays(p), oracle.pixel_dirs(7, 5, 70.0, 40.0), rtol=0, atol=1e-15)


@pytest.mark.parametrize("q", [np.array([1.0, 1.0, 1.0, 2.0, 0.0, 0.0, 0.0]), np.array([np.nan, 1, 1, 1, 0, 0, 0.0]),
                               np.array([1.0, 1.0, 1.0]), np.array([1, 1, 1, 1, 0, 0, 0])])
def test_bad_pose_is_one_line_error(q: np.ndarray) -> None:
    cam = DepthCamera(flat_scene(), DepthParams(width=4, height=3))
    with pytest.raises(SpecError) as e:
        cam.render(q, Mount(xyz=(0.0, 0.0, 0.5)), None, None)
    assert "\n" not in str(e.value)
