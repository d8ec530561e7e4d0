"""Obstacle shapes in the simulator: upright cylinders (``Obstacle.shape == "cylinder"``) and long
walls (boxes) in the MuJoCo model (static geoms, the MJCF export, the obstacle pool), every ray
caster against analytic scenes (tests/oracles: the 3-D lidar with the numba and the native walk,
the 2-D fan on both of its paths, the depth camera on both of its paths, the per-ray path), the
ray-cylinder kernel's properties, and the robot stopping where the geometry says."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from navstress.nav.api import Command
from navstress.robot import RobotSpec
from navstress.sensors import Mount
from navstress.sensors.kinds.depth import DepthParams
from navstress.sensors.registry import sensor_from_mapping
from navstress.sim import SimConfig, Simulation, _raybox, native
from navstress.sim._raycast import Ray
from navstress.sim.depth import DepthCamera
from navstress.sim.lidar import Lidar, LidarConfig, build_scene, cast_rays
from navstress.sim.model import GEOM_BOX, GEOM_CYLINDER, ObstaclePool, build_model, world_to_mjcf
from navstress.sim.rays import Lidar2dCaster
from navstress.world.world import Obstacle, World
from tests.oracles import depth as od
from tests.oracles import lidar2d as o2
from tests.oracles.lidar3d import scan_ranges
from tests.support.sim_worlds import flat

QUIET = SimConfig(noise=False, jitter=False)

#: a scene of every shape: cylinders (one raised off the ground, one tall and thin), a long
#: wall, a turned box; the sensors stand at (20, 20)
SHAPES = (
    Obstacle("tree", 24.0, 21.0, 0.7, (1.2, 1.2, 3.0), shape="cylinder"),
    Obstacle("tree", 17.0, 17.5, 0.0, (0.4, 0.4, 6.0), shape="cylinder"),
    Obstacle("rock", 21.5, 17.0, 0.0, (2.0, 2.0, 0.5), z=0.4, shape="cylinder"),
    Obstacle("wall", 20.0, 31.0, 0.0, (36.0, 0.2, 2.5)),
    Obstacle("building", 12.0, 24.0, 0.5, (3.0, 2.0, 4.0)),
)


def _oracle_scene(obstacles: tuple[Obstacle, ...]) -> dict[str, tuple[tuple[float, ...], ...]]:
    return o2.obstacle_shapes(obstacles)


def _close(got: np.ndarray, want: np.ndarray, tol: float = 1e-6) -> None:
    assert np.array_equal(np.isfinite(got), np.isfinite(want)), np.argwhere(np.isfinite(got) != np.isfinite(want))[:5]
    ok = np.isfinite(want)
    assert np.max(np.abs(got[ok] - want[ok]), initial=0.0) <= tol * (1 + np.max(want[ok], initial=0.0))


# ---------------------------------------------------------------- MuJoCo model


def test_cylinders_are_upright_cylinder_geoms_in_the_model_and_the_mjcf() -> None:
    w = flat(obstacles=SHAPES)
    for m in (mujoco.MjModel.from_xml_string(world_to_mjcf(w)), build_model(w).model):
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        for k, o in enumerate(SHAPES):
            g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f"obstacle_{k}")
            if o.is_cylinder:
                assert m.geom_type[g] == GEOM_CYLINDER
                np.testing.assert_allclose(m.geom_size[g][:2], (o.size[0] / 2, o.size[2] / 2))
                np.testing.assert_allclose(d.geom_xmat[g].reshape(3, 3), np.eye(3), atol=1e-15)  # upright
            else:
                assert m.geom_type[g] == GEOM_BOX
                np.testing.assert_allclose(m.geom_size[g], np.array(o.size) / 2)
            np.testing.assert_allclose(d.geom_xpos[g], (o.x, o.y, o.z + o.size[2] / 2))


def test_a_box_world_keeps_its_mjcf_bytes() -> None:
    """A box's geom text is what it was before shapes: type, size, pos, euler, in that order."""
    o = Obstacle("tree", 3.25, 4.5, 0.3, (1.0, 2.0, 3.0), 0.5)
    xml = world_to_mjcf(flat(obstacles=(o,)))
    assert ('<geom name="obstacle_0" type="box" size="0.5 1.0 1.5" pos="3.25 4.5 2.0" euler="0 0 0.3" '
            'group="1" contype="2" conaffinity="2" rgba="0.3 0.5 0.3 1"/>') in xml


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31))
def test_mujocos_ray_meets_the_exported_cylinders_where_the_lidar_does(seed: int) -> None:
    """mj_ray on the MJCF export (MuJoCo's own cylinder) against the lidar's per-ray path."""
    g = np.random.default_rng(seed)
    w = flat(obstacles=SHAPES)
    m = mujoco.MjModel.from_xml_string(world_to_mjcf(w))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    cyl = [o for o in SHAPES if o.is_cylinder]
    origins, dirs = [], []
    for _ in range(60):  # rays from around the map at points of the cylinders (side and caps)
        o = cyl[int(g.integers(len(cyl)))]
        a, rr = g.uniform(0, 2 * math.pi), o.size[0] / 2 * math.sqrt(g.uniform())
        p = np.array([o.x + rr * math.cos(a), o.y + rr * math.sin(a), o.z + g.uniform(0, o.size[2])])
        org = np.array([g.uniform(1, 39), g.uniform(1, 39), g.uniform(0.2, 8.0)])
        origins.append(org)
        dirs.append((p - org) / np.linalg.norm(p - org))
    got = cast_rays(build_scene(w), np.array(origins), np.array(dirs), 100.0)
    gid = np.zeros(1, np.int32)
    for org, dd, t in zip(origins, dirs, got):
        want = mujoco.mj_ray(m, d, org, dd, None, 1, -1, gid)
        assert (want < 0) == (not math.isfinite(t))
        if want >= 0:
            assert t == pytest.approx(want, abs=1e-7)


# ---------------------------------------------------------------- the obstacle pool


def _footprint_gap(o: Obstacle, x: float, y: float) -> float:
    """Distance from (x, y) to the obstacle's footprint (0 inside), from its outline: a cylinder's
    circle, a box's corner polygon (segment distances, inside by the winding of the corners)."""
    if o.is_cylinder:
        return max(math.hypot(x - o.x, y - o.y) - o.size[0] / 2, 0.0)
    c = o.corners()
    p = np.array([x, y])
    def cross(u: np.ndarray, v: np.ndarray) -> float:
        return float(u[0] * v[1] - u[1] * v[0])

    inside = all(cross(c[(k + 1) % 4] - c[k], p - c[k]) >= 0 for k in range(4))
    if inside:
        return 0.0
    best = math.inf
    for k in range(4):
        a, b = c[k], c[(k + 1) % 4]
        u = float(np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0))
        best = min(best, float(np.linalg.norm(p - (a + u * (b - a)))))
    return best


def _mixed_world(seed: int, n: int) -> tuple[list[Obstacle], np.ndarray]:
    g = np.random.default_rng(seed)
    obs = []
    for _ in range(n):
        x, y, yaw = float(g.uniform(1, 39)), float(g.uniform(1, 39)), float(g.uniform(-3, 3))
        kind = int(g.integers(3))
        if kind == 0:
            d = float(g.uniform(0.2, 3.0))
            obs.append(Obstacle("tree", x, y, yaw, (d, d, 4.0), float(g.uniform(0, 1)), shape="cylinder"))
        elif kind == 1:  # a long wall segment
            obs.append(Obstacle("wall", x, y, yaw, (float(g.uniform(5, 40)), float(g.uniform(0.1, 0.4)), 2.5)))
        else:
            obs.append(Obstacle("rock", x, y, yaw, (float(g.uniform(0.3, 3.0)), float(g.uniform(0.3, 3.0)), 2.0)))
    return obs, g.uniform(2, 38, (6, 2))


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(0, 60), margin=st.floats(0.0, 3.0))
def test_pool_holds_exactly_the_obstacles_whose_footprint_is_near(seed: int, n: int, margin: float) -> None:
    """Brute force over boxes, cylinders and long walls: after each update the filled slots hold
    exactly the obstacles whose footprint is within robot reach + margin of the robot's centre,
    each with its geom type, size, bounds and pose; an obstacle keeps its slot."""
    obs, spots = _mixed_world(seed, n)
    w = flat(obstacles=tuple(obs))
    r = RobotSpec()
    rm = build_model(w, r, start=(20.0, 20.0, 0.0), obstacle_pool=64)
    m, d = rm.model, mujoco.MjData(rm.model)
    pool = ObstaclePool(rm, w, r, margin)
    reach = math.hypot(r.length_m, r.width_m) / 2 + margin
    prev: dict[int, int] = {}
    for x, y in spots:
        d.qpos[0:2] = (x, y)
        pool.update(d)
        gaps = [_footprint_gap(o, x, y) for o in obs]
        want = {k for k, gap in enumerate(gaps) if gap <= reach - 1e-9}
        maybe = {k for k, gap in enumerate(gaps) if abs(gap - reach) <= 1e-9}  # (rounding at the edge)
        slots = {int(o): s for s, o in enumerate(pool.slot_obstacle) if o >= 0}
        assert want <= set(slots) <= want | maybe and pool.overflows == 0
        for k, s in slots.items():
            g, b = rm.slot_geoms[s], m.body_mocapid[rm.slot_bodies[s]]
            o = obs[k]
            assert rm.obstacle_of_geom[g] == k and m.geom_contype[g] != 0
            np.testing.assert_allclose(d.mocap_pos[b], (o.x, o.y, o.z + o.size[2] / 2))
            half = np.array(o.size) / 2
            if o.is_cylinder:
                assert m.geom_type[g] == GEOM_CYLINDER
                np.testing.assert_allclose(m.geom_size[g][:2], (half[0], half[2]))
                assert m.geom_rbound[g] == pytest.approx(math.hypot(half[0], half[2]))
            else:
                assert m.geom_type[g] == GEOM_BOX
                np.testing.assert_allclose(m.geom_size[g], half)
                assert m.geom_rbound[g] == pytest.approx(float(np.linalg.norm(half)))
                assert abs(d.mocap_quat[b][3] - math.sin(o.yaw / 2)) < 1e-12
            np.testing.assert_allclose(m.geom_aabb[g][3:], half)
            if k in prev:
                assert prev[k] == s
        for s in range(64):
            if pool.slot_obstacle[s] < 0:
                assert m.geom_contype[rm.slot_geoms[s]] == 0 and rm.obstacle_of_geom[rm.slot_geoms[s]] == -1
        prev = slots


def test_a_long_wall_takes_a_slot_only_where_the_robot_comes_near_it() -> None:
    """A 40 m wall: 10 m beside its middle it is far (its bounding circle, 20 m, would hold a
    slot), 1 m beside it near, and 1 m past its end near too."""
    wall = Obstacle("wall", 20.0, 20.0, 0.3, (40.0, 0.2, 2.5))
    w = flat(size=60.0, obstacles=(wall,))
    r = RobotSpec()
    rm = build_model(w, r, start=(2.0, 2.0, 0.0), obstacle_pool=4)
    d = mujoco.MjData(rm.model)
    pool = ObstaclePool(rm, w, r, 1.5)
    c, s = math.cos(0.3), math.sin(0.3)
    for along, off, near in ((0.0, 10.0, False), (0.0, 1.0, True), (15.0, -3.5, False), (20.8, 0.0, True),
                             (25.0, 0.0, False)):
        d.qpos[0:2] = (20.0 + c * along - s * off, 20.0 + s * along + c * off)
        pool.update(d)
        assert (pool.slot_obstacle[0] == 0) == near, (along, off)


def test_pool_and_static_cylinders_give_the_same_run() -> None:
    obs, _ = _mixed_world(3, 40)
    obs = [o for o in obs if min(_footprint_gap(o, x, 20.0) for x in range(3, 27)) > 4.0]  # (clear of the path)
    obs += [Obstacle("tree", 12.0 + 2.0 * k, 20.5 - 0.3 * k, 0.0, (0.8, 0.8, 5.0), shape="cylinder")
            for k in range(6)]
    runs = []
    for pool in (0, 32):
        cfg = SimConfig(lidar_enabled=False, obstacle_pool=pool, noise=False, jitter=False)
        sim = Simulation(flat(obstacles=tuple(obs)), config=cfg, seed=0, start=(5.0, 20.0, 0.0))
        for k in range(100):
            sim.command(Command(1.2, 0.2 * math.sin(k / 8)))
            sim.advance(0.1)
        runs.append((sim.observer.poses.copy(), [(e.t, e.obstacle) for e in sim.observer.collisions]))
    (pa, ea), (pb, eb) = runs
    assert ea and ea == eb and ea[0][1] >= len(obs) - 6  # it met the cylinders
    # the same motion to round-off up to the first contact (a cylinder's side against the bumper's
    # face is a line contact: MuJoCo picks its points where round-off says, so the two runs then
    # drift apart by millimetres, as two builds of one model would)
    upto = pa[:, 0] <= ea[0][0]
    assert np.abs(pa[upto] - pb[upto]).max() < 1e-6


# ---------------------------------------------------------------- physics against the geometry


@pytest.mark.parametrize("pool", [0, 32])
@pytest.mark.parametrize("offset", [0.0, 0.5, 0.8])  # (0.8: the corner meets it, 12 cm before a box would)
def test_the_robot_stops_where_it_meets_a_cylinder(pool: int, offset: float) -> None:
    """Driving straight along +x at a cylinder of radius R whose centre is ``offset`` to the side:
    the bumper (a box of half length L, half width W) meets it when its front face reaches
    cx - R (|offset| <= W) or its front corner reaches the circle (else); the first contact's
    robot x is that, to the contact's penetration and a step's travel."""
    r = RobotSpec()
    R, L, W = 0.6, r.length_m / 2, r.width_m / 2
    cx, cy = 15.0, 20.0 + offset
    cyl = Obstacle("tree", cx, cy, 0.4, (2 * R, 2 * R, 3.0), shape="cylinder")
    sim = Simulation(flat(obstacles=(cyl,)), config=SimConfig(noise=False, jitter=False, lidar_enabled=False,
                                                              obstacle_pool=pool), seed=0, start=(8.0, 20.0, 0.0))
    for _ in range(100):
        sim.command(Command(0.8, 0.0))
        sim.advance(0.1)
        if sim.observer.collisions:
            break
    ev = sim.observer.collisions
    assert ev and ev[0].obstacle == 0
    dy = abs(cy - 20.0)
    front = cx - R if dy <= W else cx - math.sqrt(R * R - (dy - W) ** 2)
    assert ev[0].x + L == pytest.approx(front, abs=0.02)
    for _ in range(30):  # pushing on: it slides or stops, never passes through
        sim.command(Command(0.8, 0.0))
        sim.advance(0.1)
        q = sim.data.qpos
        yaw = math.atan2(2 * (q[3] * q[6] + q[4] * q[5]), 1 - 2 * (q[5] ** 2 + q[6] ** 2))
        c, s = math.cos(yaw), math.sin(yaw)
        ex, ey = cx - q[0], cy - q[1]  # the cylinder's centre in the robot's frame, then to the bumper box
        lx, ly = abs(c * ex + s * ey) - L, abs(-s * ex + c * ey) - W
        gap = math.hypot(max(lx, 0.0), max(ly, 0.0)) - R if max(lx, ly) > 0 else -R
        assert gap >= -0.02, (sim.t, gap)


# ---------------------------------------------------------------- ray casters vs the analytic scene


@pytest.mark.parametrize("plane_march", [True, False])
@pytest.mark.parametrize("simd", [False, True])
@pytest.mark.parametrize("pose", [(20.0, 20.0, 1.2, np.eye(3)), (19.0, 21.0, 0.6, None)])
def test_the_3d_lidar_sees_cylinders_where_geometry_says(plane_march: bool, simd: bool, pose: tuple) -> None:  # type: ignore[type-arg]
    if simd and not native.available():
        pytest.skip(f"native walk {native.status()}")
    x, y, z, rot = pose
    if rot is None:  # turned and tilted
        rot = o2.rot_rpy(0.1, -0.15, 0.9)
    cfg = LidarConfig(channels=16, azimuth_steps=720, max_range_m=30.0, min_range_m=0.2)
    lid = Lidar(build_scene(flat(obstacles=SHAPES)), cfg, plane_march=plane_march, simd=simd)
    got = lid.ranges(np.array([x, y, z]), rot).astype(np.float64)
    d = cfg.directions().reshape(-1, 3) @ rot.T
    want = o2.ranges(np.array([x, y, z]), d, plane=(0.0, 0.0, 0.0), min_range=0.2, max_range=30.0,
                     **_oracle_scene(SHAPES)).reshape(got.shape)  # type: ignore[arg-type]
    _close(got, want, 1e-6)  # (the ranges are float32)
    # the cylinders are what the rays meet: without them the ranges differ
    hits_cyl = o2.ranges(np.array([x, y, z]), d, plane=None, min_range=0.2, max_range=30.0,
                         discs=_oracle_scene(SHAPES)["discs"]).reshape(got.shape)  # type: ignore[arg-type]
    assert np.isfinite(hits_cyl).sum() > 100


def test_the_3d_lidar_on_a_body_sees_scene_cylinders_and_disc_movers() -> None:
    """scan_body / mounted_ranges: ``discs`` None is the scene's cylinders; given, every cylinder of
    the scan (the scene's, then a mover's), against the lidar3d oracle."""
    lid = Lidar(build_scene(flat(obstacles=SHAPES)), LidarConfig(channels=8, azimuth_steps=360, max_range_m=30.0))
    q = o2.qpos(20.0, 20.0, 0.5, roll=0.05, yaw=0.4)
    sc = _oracle_scene(SHAPES)
    mover = (22.0, 22.5, 0.3, 0.0, 1.8)
    for discs in (None, np.vstack([lid.scene.discs, [mover]])):
        n = lid.mounted_ranges(q, np.array([0.2, 0.0, 0.4]), o2.rot_rpy(0.0, 0.1, 0.0), discs=discs)
        want = scan_ranges(q, (0.2, 0.0, 0.4), (0.0, 0.1, 0.0), lid.config.directions(), plane=(0.0, 0.0, 0.0),
                           boxes=sc["boxes"], discs=tuple(sc["discs"]) + ((mover,) if discs is not None else ()),
                           min_range=lid.config.min_range_m, max_range=30.0)
        _close(lid.last_ranges, want, 1e-9)
        assert n == np.isfinite(want).sum()


def _fan(beams: int) -> Lidar2dCaster:
    s = sensor_from_mapping({"name": "s", "kind": "lidar2d", "mount": {"xyz": [0.1, 0.0, 0.3], "rpy": [0, 0, 0]},
                             "beams": beams, "max_range_m": 30.0}, where="sensors[0]", mounts={})
    return Lidar2dCaster(s, 1, build_scene(flat(obstacles=SHAPES)))


@pytest.mark.parametrize("beams", [1081, 1001])  # the scan kernels' fan, the ray-by-ray path
@pytest.mark.parametrize("yaw,pitch", [(0.0, 0.0), (1.3, 0.05), (-2.0, -0.02)])
def test_the_2d_fan_sees_cylinders_where_geometry_says(beams: int, yaw: float, pitch: float) -> None:
    c = _fan(beams)
    assert (c.lidar is None) == (beams == 1001)
    q = o2.qpos(20.0, 20.0, 0.2, pitch=pitch, yaw=yaw)
    got = c.ranges(q)
    o, r = o2.sensor_pose(q, c.mount, c.rpy)
    d = o2.fan(c.angle_min, c.angle_increment, c.beams) @ r.T
    want = o2.ranges(o, d, plane=(0.0, 0.0, 0.0), min_range=c.min_range, max_range=c.max_range,
                     **_oracle_scene(SHAPES))  # type: ignore[arg-type]
    _close(got, want, 1e-9)
    only = o2.ranges(o, d, plane=None, discs=_oracle_scene(SHAPES)["discs"], min_range=c.min_range,  # type: ignore[arg-type]
                     max_range=c.max_range)
    assert np.isfinite(only).sum() > 20 and np.all(got[np.isfinite(only)] <= only[np.isfinite(only)] + 1e-9)


@pytest.mark.parametrize("fast", [True, False])
@pytest.mark.parametrize("yaw,pitch", [(0.4, 0.1), (-2.3, 0.3), (-1.0, -0.1)])
def test_the_depth_camera_sees_cylinders_where_geometry_says(fast: bool, yaw: float, pitch: float) -> None:
    p = DepthParams(width=48, height=36, max_range_m=20.0, hfov_deg=100.0)
    m = Mount(xyz=(0.2, 0.0, 0.6), rpy=(0.0, pitch, 0.0))
    q = o2.qpos(20.0, 20.0, 0.2, yaw=yaw)
    img = DepthCamera(build_scene(flat(obstacles=SHAPES)), p, fast=fast).depths(q, m)
    o, r = od.sensor_pose(q, m.xyz, m.rpy)
    d = od.world_dirs(r, od.pixel_dirs(p.width, p.height, p.hfov_deg, p.vfov_deg))
    best = od.plane_z(o, d, 0.0, (0, 40), (0, 40))
    sc = _oracle_scene(SHAPES)
    for b in sc["boxes"]:  # type: ignore[attr-defined]
        best = np.minimum(best, od.box(o, d, *b))
    cyl = np.full(best.shape, np.inf)
    for c in sc["discs"]:  # type: ignore[attr-defined]
        cyl = np.minimum(cyl, od.cylinder(o, d, *c))
    want = od.cut(np.minimum(best, cyl), p.min_range_m, p.max_range_m)
    assert np.array_equal(np.isfinite(img), np.isfinite(want))
    ok = np.isfinite(want)
    assert np.max(np.abs(img[ok] - want[ok]) / (1 + want[ok])) <= 1e-6  # (float32 depths)
    assert (np.isfinite(cyl) & (cyl <= best)).sum() > 10  # cylinders in view, in front


# ---------------------------------------------------------------- the ray-cylinder kernel


def _ray_cyl(o: np.ndarray, d: np.ndarray, c: tuple[float, float, float, float, float]) -> float:
    return float(_raybox._ray_cylinder(_raybox.Cylinder(*c), Ray(*o, *d)))


_coord = st.floats(-5.0, 5.0)


@settings(max_examples=300, deadline=None)
@given(o=st.tuples(_coord, _coord, _coord), d=st.tuples(_coord, _coord, _coord),
       c=st.tuples(_coord, _coord, st.floats(0.05, 3.0), st.floats(-2.0, 1.0), st.floats(0.0, 4.0)))
def test_ray_cylinder_hits_the_surface_first(o: tuple[float, float, float], d: tuple[float, float, float],
                                             c: tuple[float, float, float, float, float]) -> None:
    """The hit lies on the cylinder's surface (side or cap), the oracle agrees, and no point of the
    ray before it is inside the cylinder (for a ray from outside)."""
    dv = np.array(d)
    n = float(np.linalg.norm(dv))
    assume(n > 1e-3)
    dv = dv / n
    cx, cy, r, zb, h = c
    cyl = (cx, cy, r, zb, zb + h)
    ov = np.array(o)
    t = _ray_cyl(ov, dv, cyl)
    with np.errstate(over="ignore"):  # (a direction with a tiny z: a cap's t overflows to inf)
        want = o2.ray_cylinder(ov, dv, cyl)
    assert (math.isfinite(t)) == (math.isfinite(want)) or abs(min(t, 1e9) - min(want, 1e9)) < 1e-9
    if not math.isfinite(t):
        return
    assert t == pytest.approx(want, abs=1e-9) and t >= 0.0
    p = ov + t * dv
    rho = math.hypot(p[0] - cx, p[1] - cy)
    eps = 1e-7 * (1 + t)
    on_side = abs(rho - r) <= eps and zb - eps <= p[2] <= zb + h + eps
    on_cap = rho <= r + eps and (abs(p[2] - zb) <= eps or abs(p[2] - zb - h) <= eps)
    assert on_side or on_cap
    inside0 = math.hypot(ov[0] - cx, ov[1] - cy) < r and zb < ov[2] < zb + h
    if not inside0:
        for s in np.linspace(0.0, t, 50)[:-1]:
            q = ov + (s * (1 - 1e-6)) * dv
            assert not (math.hypot(q[0] - cx, q[1] - cy) < r - 1e-9 and zb + 1e-9 < q[2] < zb + h - 1e-9)


@settings(max_examples=150, deadline=None)
@given(a=st.floats(0, 2 * math.pi), z=st.floats(0.001, 0.999),
       shift=st.tuples(st.floats(-50, 50), st.floats(-50, 50)), r=st.floats(0.05, 2.0),
       el=st.floats(-1.2, 1.2), az=st.floats(0, 2 * math.pi), dist=st.floats(0.5, 30.0))
def test_ray_cylinder_is_exact_for_rays_aimed_at_known_surface_points(a: float, z: float,
                                                                      shift: tuple[float, float], r: float, el: float,
                                                                      az: float, dist: float) -> None:
    """A ray aimed at a point p of the side wall from outside, entering there: the solid is convex,
    so p is where the ray first meets it, at the distance to p; shifting ray and cylinder together
    changes nothing."""
    h = 2.0
    cx, cy = shift
    p = np.array([cx + r * math.cos(a), cy + r * math.sin(a), h * z])
    n = np.array([math.cos(a), math.sin(a), 0.0])  # the wall's outward normal there
    d_in = -np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    assume(float(np.dot(d_in, n)) < -0.05)  # coming from outside, through the wall
    org = p - dist * d_in
    rho_o = math.hypot(org[0] - cx, org[1] - cy)
    assume(rho_o > r)
    t = _ray_cyl(org, d_in, (cx, cy, r, 0.0, h))
    assert t == pytest.approx(dist, abs=1e-9 * (1 + dist + abs(cx) + abs(cy)) / 0.05)
    t0 = _ray_cyl(org - np.array([cx, cy, 0.0]), d_in, (0.0, 0.0, r, 0.0, h))
    assert t0 == pytest.approx(t, abs=1e-9 * (1 + dist + abs(cx) + abs(cy)) / 0.05)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(1, 80), roll=st.floats(-0.3, 0.3), pitch=st.floats(-0.3, 0.3),
       yaw=st.floats(-math.pi, math.pi), ground=st.booleans())
def test_the_disc_pass_culls_nothing_it_should_test(seed: int, n: int, roll: float, pitch: float, yaw: float,
                                                    ground: bool) -> None:
    """Many cylinders, near and far, around a tilted sensor, over ranges already lowered (a ground
    at some rays): the culled, near-first pass gives bit for bit the minimum over every ray
    against every cylinder."""
    g = np.random.default_rng(seed)
    lid = Lidar(build_scene(flat(size=80.0)), LidarConfig(channels=16, azimuth_steps=180, max_range_m=30.0))
    rot = o2.rot_rpy(roll, pitch, yaw)
    o = np.array([40.0, 40.0, 1.0])
    rr = g.uniform(0.05, 1.5, n)
    zb = g.uniform(-1.0, 1.5, n)
    discs = np.column_stack([o[0] + g.uniform(-35, 35, n), o[1] + g.uniform(-35, 35, n), rr, zb,
                             zb + g.uniform(0.1, 4.0, n)])
    start = np.where(g.random((16, 180)) < 0.5, g.uniform(0.5, 40.0, (16, 180)), np.inf) if ground else \
        np.full((16, 180), np.inf)
    out = start.copy()
    _raybox.disc_pass(discs, lid._beams, lid._params, o, rot, out)
    ref = start.copy()
    for k in range(16):
        for a in range(180):
            awx = rot[0, 0] * lid._cos_az[a] + rot[0, 1] * lid._sin_az[a]
            awy = rot[1, 0] * lid._cos_az[a] + rot[1, 1] * lid._sin_az[a]
            awz = rot[2, 0] * lid._cos_az[a] + rot[2, 1] * lid._sin_az[a]
            ce, se = lid._cos_el[k], lid._sin_el[k]
            ray = Ray(*o, ce * awx + se * rot[0, 2], ce * awy + se * rot[1, 2], ce * awz + se * rot[2, 2])
            for c in discs:
                ref[k, a] = min(ref[k, a], _raybox._ray_cylinder(_raybox.Cylinder(*c), ray))
    # (past max_range the pass may skip a cylinder: the box pass drops those ranges anyway)
    far = 30.0
    assert np.array_equal(np.where(ref <= far, ref, np.inf), np.where(out <= far, out, np.inf))
