"""MuJoCo model of a World and a RobotSpec.

Terrain is one heightfield (``hfield``) spanning the map ``[0, size_x] x [0, size_y]``: its geom
sits at the map centre at the lowest terrain height; heights are normalised to [0, 1] by hand
and the elevation range is ``max - min`` (a small positive value on a flat world). MuJoCo
stores hfield row 0 at -y, which is World's row 0 (y = 0), so rows map one to one; the MJCF
``elevation`` attribute lists rows from +y down, so :func:`world_to_mjcf` writes them flipped.
Each cell is split along the (i, j)-(i+1, j+1) diagonal, as ``Terrain.height_at`` assumes.

Obstacles are static geoms named ``obstacle_<index>`` (geom group 1, collision bit 2: a box turned
by its yaw, or an upright cylinder for ``Obstacle.shape == "cylinder"``), or, with
``obstacle_pool=K`` (what :class:`~navstress.sim.simulation.Simulation` uses), K mocap "slot"
bodies ``obstacle_slot_<s>`` that :class:`ObstaclePool` fills with the obstacles near the robot
(a slot's geom takes the type, box or cylinder, of the obstacle it holds):
MuJoCo then computes a few geoms each step instead of every obstacle of the map. The
robot (geom group 3) is an RMP 400 class skid steer: a chassis body with a belly box that
touches the ground (bit 1), a massless bumper box of the full footprint that touches obstacles
(bit 2), and four sphere wheels (bit 1: ground only) on velocity-servo hinges.

Movers (``World.movers``) are mocap bodies ``mover_<id>`` (geom group 2, collision bit 4: they
touch only the bumper; an upright cylinder for a ``disc`` mover, a box for a ``box`` one, standing
on the ground), always present; the simulation moves them (:mod:`navstress.sim.movers`). Being
mocap bodies they push the robot and the robot does not push them. A world without movers
compiles to the same model as before.

Skid steer friction: every wheel-ground contact frame is turned so that its first tangent is
the wheel's rolling direction and the pyramidal friction limits are split between rolling and
lateral directions in proportion to the slip direction (``navstress.sim._step``): the
friction force then opposes the slip as in Coulomb's law, which isotropic soft MuJoCo contacts
do not do for a four-wheel skid steer (it barely turns). See docs/simulation.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import mujoco
import numba
import numpy as np

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.errors import SimulationError
from navstress.robot import RobotSpec
from navstress.sim.config import SimConfig
from navstress.sim.drives import MAX_WHEELS, WHEEL_MASS_FRACTION, drive_model
from navstress.world.world import Obstacle, World

TERRAIN_GROUP = 0
OBSTACLE_GROUP = 1
ROBOT_GROUP = 3
GROUND_BIT = 1
OBSTACLE_BIT = 2
MOVER_BIT = 4  # movers touch only the bumper (whose conaffinity has this bit only in worlds with movers)
MOVER_GROUP = 2
HFIELD_BASE_M = 1.0
FLAT_ELEVATION_M = 1e-3
PARK_Z_M = -1.0e4  # where unused obstacle slots wait (far below any terrain)


def _xml_float(x: float) -> str:
    """``x`` as MJCF text: the shortest repr that reads back as the same float64."""
    return repr(float(x))


def _terrain_params(world: World) -> tuple[np.ndarray, float, float]:
    """Heights normalised to [0, 1], the base height and the elevation range (meters)."""
    h = np.asarray(world.terrain.heights, dtype=np.float64)
    if h.ndim != 2 or min(h.shape) < 2 or not np.all(np.isfinite(h)):
        raise SimulationError(f"terrain heights of shape {h.shape} are not a finite 2-D grid of >= 2x2")
    lo, hi = float(h.min()), float(h.max())
    rng = hi - lo
    if rng <= FLAT_ELEVATION_M:
        return np.zeros_like(h), lo, FLAT_ELEVATION_M
    return (h - lo) / rng, lo, rng


def _world_xml(world: World, *, inline: bool, pool: int = 0) -> tuple[str, str, np.ndarray]:
    """(asset xml, worldbody xml, normalised heights); ``pool`` > 0: that many obstacle slots
    (parked, collisions off) instead of one static box per obstacle."""
    sx, sy = world.terrain.size_m
    norm, base, elev = _terrain_params(world)
    rows, cols = norm.shape
    elevation = ""
    if inline:  # MJCF lists rows from +y to -y
        elevation = ' elevation="' + " ".join(f"{v:.7g}" for v in norm[::-1].ravel()) + '"'
    asset = (f'<hfield name="terrain" nrow="{rows}" ncol="{cols}" '
             f'size="{_xml_float(sx / 2)} {_xml_float(sy / 2)} {_xml_float(elev)} {_xml_float(HFIELD_BASE_M)}"'
             f'{elevation}/>')
    body = [f'<geom name="terrain" type="hfield" hfield="terrain" '
            f'pos="{_xml_float(sx / 2)} {_xml_float(sy / 2)} {_xml_float(base)}" '
            f'group="{TERRAIN_GROUP}" contype="{GROUND_BIT}" conaffinity="{GROUND_BIT}" rgba="0.5 0.45 0.35 1"/>']
    # contype only: slots never collide with each other, only with the bumper; compiled with the
    # bit set (MuJoCo's per-body broadphase filter body_contype), switched off while parked
    for k in range(pool):
        body.append(f'<body name="obstacle_slot_{k}" mocap="true" pos="0 0 {_xml_float(PARK_Z_M - 10.0 * k)}">'
                    f'<geom name="obstacle_slot_{k}" type="box" size="0.5 0.5 0.5" group="{OBSTACLE_GROUP}" '
                    f'contype="{OBSTACLE_BIT}" conaffinity="0" rgba="0.3 0.5 0.3 1"/></body>')
    for k, o in enumerate(world.obstacles if pool == 0 else ()):
        body.append(f'<geom name="obstacle_{k}" {_obstacle_geom(o)} '
                    f'group="{OBSTACLE_GROUP}" contype="{OBSTACLE_BIT}" conaffinity="{OBSTACLE_BIT}" '
                    f'rgba="0.3 0.5 0.3 1"/>')
    return asset, "\n".join(body), norm


def _obstacle_geom(o: Obstacle) -> str:
    """An obstacle's geom type, size and pose attributes: a box turned by its yaw, or an upright
    cylinder (MJCF size = radius, half height) without a turn (its yaw has no effect)."""
    hz = o.size[2] / 2
    pos = f'pos="{_xml_float(o.x)} {_xml_float(o.y)} {_xml_float(o.z + hz)}"'
    if o.is_cylinder:
        return f'type="cylinder" size="{_xml_float(o.size[0] / 2)} {_xml_float(hz)}" {pos}'
    hx, hy = o.size[0] / 2, o.size[1] / 2
    return (f'type="box" size="{_xml_float(hx)} {_xml_float(hy)} {_xml_float(hz)}" {pos} '
            f'euler="0 0 {_xml_float(o.yaw)}"')


def world_to_mjcf(world: World) -> str:
    """The world alone (terrain + obstacles) as one self-contained MJCF document.

    >>> from navstress.world.spec import WorldSpec
    >>> w = World.flat(WorldSpec(size_m=(20.0, 20.0)))
    >>> m = mujoco.MjModel.from_xml_string(world_to_mjcf(w))
    >>> m.nhfield
    1
    """
    asset, body, _ = _world_xml(world, inline=True)
    return (f'<mujoco model="navstress-world-{world.seed}">\n<compiler angle="radian"/>\n'
            f"<asset>\n{asset}\n</asset>\n<worldbody>\n{body}\n</worldbody>\n</mujoco>\n")


def _robot_asset(robot: RobotSpec) -> str:
    """Asset xml of the robot: the bumper's prism of a polygon footprint ("" otherwise)."""
    if robot.footprint.shape != "polygon":
        return ""
    h = robot.body_height_m / 2
    pts = robot.footprint_points()
    vert = " ".join(f"{_xml_float(x)} {_xml_float(y)} {_xml_float(z)}" for z in (-h, h) for x, y in pts)
    return f'<mesh name="bumper" vertex="{vert}"/>'


def _bumper_geom(robot: RobotSpec) -> str:
    """The bumper's type and size attributes: a box, an upright cylinder or the footprint prism."""
    fp, L, W, H = robot.footprint, robot.length_m, robot.width_m, robot.body_height_m
    if fp.shape == "circle":
        assert fp.radius_m is not None
        return f'type="cylinder" size="{_xml_float(fp.radius_m)} {_xml_float(H / 2)}"'
    if fp.shape == "polygon":
        return 'type="mesh" mesh="bumper"'
    return f'type="box" size="{_xml_float(L / 2)} {_xml_float(W / 2)} {_xml_float(H / 2)}"'


def _robot_xml(robot: RobotSpec, cfg: SimConfig, pose: tuple[float, float, float, float],
               movers: bool = False) -> tuple[str, str]:
    """(worldbody xml, actuator xml) of the robot placed at (x, y, z_ground, yaw); ``movers``: the
    bumper touches movers too. The wheels, casters and steering come from the drive model
    (:mod:`navstress.sim.drives`); the polygon bumper's mesh is in :func:`_robot_asset`."""
    x, y, zg, yaw = pose
    dm = drive_model(robot)
    r = robot.wheel_radius_m
    mw = WHEEL_MASS_FRACTION * robot.mass_kg
    mc = robot.mass_kg - len(dm.wheels) * mw
    L, W, H = robot.length_m, robot.width_m, robot.body_height_m
    zc = robot.ground_clearance_m + H / 2 - r  # chassis box centre relative to the axle height
    if robot.inertia_kgm2 is not None:
        ixx, iyy, izz = robot.inertia_kgm2
    else:
        ixx = mc * (W**2 + H**2) / 12
        iyy = mc * (L**2 + H**2) / 12
        izz = mc * (L**2 + W**2) / 12
    bx = max(robot.wheelbase_m / 2, 0.05)
    by = max(robot.track_m / 2 - robot.wheel_width_m / 2 - 0.01, 0.05)
    fric = f'friction="{_xml_float(cfg.friction)} 0.005 0.0001"'
    wheels = []
    for wh in dm.wheels:
        n = wh.name
        wheel = (f'<joint name="wheel_{n}" type="hinge" axis="0 1 0" armature="{_xml_float(dm.armature_kgm2)}"/>'
                 f'<geom name="wheel_{n}" type="sphere" size="{_xml_float(r)}" mass="{_xml_float(mw)}" '
                 f'group="{ROBOT_GROUP}" '
                 f'contype="{GROUND_BIT}" conaffinity="{GROUND_BIT}" condim="3" {fric} rgba="0.1 0.1 0.1 1"/>')
        if wh.steered:  # a steering hinge (z) between the chassis and the wheel
            # its limit: the inner wheel's Ackermann angle at the bicycle model's limit
            t = math.tan(dm.max_steer_rad)
            L = robot.wheelbase_m
            lock = math.atan2(L * t, L - abs(wh.y) * t)
            ms = 0.1 * mw
            wheels.append(
                f'<body name="steer_{n}" pos="{_xml_float(wh.x)} {_xml_float(wh.y)} 0">'
                f'<joint name="steer_{n}" type="hinge" axis="0 0 1" '
                f'range="{_xml_float(-lock)} {_xml_float(lock)}" '
                f'armature="{_xml_float(dm.armature_kgm2)}" damping="{_xml_float(dm.steer_kv)}"/>'
                f'<inertial pos="0 0 0" mass="{_xml_float(ms)}" diaginertia="{_xml_float(ms * r * r / 4)} '
                f'{_xml_float(ms * r * r / 4)} {_xml_float(ms * r * r / 4)}"/>'
                f'<body name="wheel_{n}" pos="0 0 0">{wheel}</body></body>')
        else:
            wheels.append(f'<body name="wheel_{n}" pos="{_xml_float(wh.x)} {_xml_float(wh.y)} 0">{wheel}</body>')
    casters = "".join(
        f'<geom name="caster_{i}" type="sphere" size="{_xml_float(dm.caster_radius_m)}" '
        f'pos="{_xml_float(cx)} {_xml_float(cy)} {_xml_float(dm.caster_radius_m - r)}" mass="0" '
        f'group="{ROBOT_GROUP}" contype="{GROUND_BIT}" conaffinity="{GROUND_BIT}" condim="1" priority="1" '
        f'rgba="0.1 0.1 0.1 1"/>' for i, (cx, cy) in enumerate(dm.casters))
    lm = robot.lidar
    bumper_aff = OBSTACLE_BIT | (MOVER_BIT if movers else 0)
    body = (
        f'<body name="chassis" pos="{_xml_float(x)} {_xml_float(y)} {_xml_float(zg + r + 0.002)}" '
        f'euler="0 0 {_xml_float(yaw)}">'
        f'<freejoint name="chassis"/>'
        f'<inertial pos="{_xml_float(dm.com_x_m) if dm.com_x_m else "0"} 0 {_xml_float(zc)}" mass="{_xml_float(mc)}" '
        f'diaginertia="{_xml_float(ixx)} {_xml_float(iyy)} {_xml_float(izz)}"/>'
        f'<geom name="belly" type="box" size="{_xml_float(bx)} {_xml_float(by)} {_xml_float(H / 2)}" '
        f'pos="0 0 {_xml_float(zc)}" mass="0" '
        f'group="{ROBOT_GROUP}" contype="{GROUND_BIT}" conaffinity="{GROUND_BIT}" {fric} rgba="0.8 0.3 0.1 1"/>'
        f'<geom name="bumper" {_bumper_geom(robot)} '
        f'pos="0 0 {_xml_float(zc)}" mass="0" '
        f'group="{ROBOT_GROUP}" contype="{OBSTACLE_BIT}" conaffinity="{bumper_aff}" rgba="0.8 0.3 0.1 0.3"/>'
        f'<site name="lidar" pos="{_xml_float(lm.x_m)} {_xml_float(lm.y_m)} {_xml_float(lm.z_m)}"/>'
        + casters + "".join(wheels) + "</body>")
    act = "".join(
        f'<velocity name="wheel_{w.name}" joint="wheel_{w.name}" kv="{_xml_float(dm.kv)}" '
        f'forcerange="{_xml_float(-dm.torque_nm)} {_xml_float(dm.torque_nm)}"/>' for w in dm.wheels if w.driven)
    act += "".join(
        f'<position name="steer_{w.name}" joint="steer_{w.name}" kp="{_xml_float(dm.steer_kp)}" '
        f'ctrllimited="false"/>'
        for w in dm.wheels if w.steered)
    return body, act


def mover_centre_z(world: World, k: int, x: float, y: float) -> float:
    """Height of mover ``k``'s body centre standing at (x, y): the ground under its centre plus
    half its height."""
    return world.terrain.height_at(x, y) + world.movers[k].size[2] / 2


def _movers_xml(world: World) -> str:
    """The movers' mocap bodies at their start poses."""
    out = []
    for k, mv in enumerate(world.movers):
        x, y, yaw = mv.start
        ln, wd, h = mv.size
        if mv.shape == "disc":
            geom = f'type="cylinder" size="{_xml_float(ln / 2)} {_xml_float(h / 2)}"'
        else:
            geom = f'type="box" size="{_xml_float(ln / 2)} {_xml_float(wd / 2)} {_xml_float(h / 2)}"'
        out.append(f'<body name="mover_{mv.id}" mocap="true" '
                   f'pos="{_xml_float(x)} {_xml_float(y)} {_xml_float(mover_centre_z(world, k, x, y))}" '
                   f'euler="0 0 {_xml_float(yaw)}"><geom name="mover_{mv.id}" {geom} group="{MOVER_GROUP}" '
                   f'contype="{MOVER_BIT}" conaffinity="0" rgba="0.2 0.3 0.8 1"/></body>')
    return "\n".join(out)


@dataclass(frozen=True, eq=False)
class RobotModel:
    """A compiled model and the indices the simulation needs."""

    model: mujoco.MjModel
    chassis_body: int
    wheel_bodies: np.ndarray  # (n,) the drive model's wheels in order (skid steer: FL, RL, FR, RR)
    wheel_dofs: np.ndarray  # (n,) dof index of each wheel hinge
    wheel_qpos: np.ndarray  # (n,) qpos index of each wheel hinge
    wheel_of_geom: np.ndarray  # (ngeom,) wheel index 0..n-1, or -1
    obstacle_of_geom: np.ndarray  # (ngeom,) obstacle index, or -1
    bumper_geom: int
    lidar_site: int
    map_size: tuple[float, float]
    slot_geoms: np.ndarray  # (K,) geom of each obstacle slot (empty: obstacles are static geoms)
    slot_bodies: np.ndarray  # (K,) mocap body of each slot
    mover_geoms: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # (n,) geom of each mover (World.movers order)
    mover_mocap: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # (n,) mocap index of each mover body
    wheel_act: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # (n,) actuator of each wheel, -1: passive
    axle_bodies: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # (n,) body whose y axis is the wheel's axle
    steer_qpos: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # (k,) qpos of each steering hinge
    steer_act: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # (k,) its position actuator


def build_model(world: World, robot: RobotSpec = RobotSpec(), cfg: SimConfig = SimConfig(),
                start: tuple[float, float, float] | None = None, *, obstacle_pool: int = 0) -> RobotModel:
    """Compile world + robot; the robot starts at ``start`` (x, y, yaw), default the mission start.

    ``obstacle_pool`` = 0: every obstacle is a static geom. K > 0: K empty obstacle slots instead,
    to be filled by an :class:`ObstaclePool` (the obstacles near the robot)."""
    if obstacle_pool < 0:
        raise SimulationError(f"obstacle_pool={obstacle_pool} must be >= 0")
    sx, sy, syaw = start if start is not None else world.mission.start
    size = world.terrain.size_m
    if not (0.0 <= sx <= size[0] and 0.0 <= sy <= size[1]):
        raise SimulationError(f"start=({sx}, {sy}) lies outside the map [0, {size[0]}] x [0, {size[1]}]")
    # ground under the start: the highest of the four wheel footprints, so no wheel starts buried
    c, s = math.cos(syaw), math.sin(syaw)
    zg = max(world.terrain.height_at(sx + c * dx - s * dy, sy + s * dx + c * dy)
             for dx in (-robot.wheelbase_m / 2, 0.0, robot.wheelbase_m / 2)
             for dy in (-robot.track_m / 2, 0.0, robot.track_m / 2))
    asset, wbody, norm = _world_xml(world, inline=False, pool=obstacle_pool)
    if world.movers:
        wbody += "\n" + _movers_xml(world)
    rbody, act = _robot_xml(robot, cfg, (sx, sy, zg, syaw), movers=bool(world.movers))
    rasset = _robot_asset(robot)
    if rasset:
        asset += "\n" + rasset
    xml = (f'<mujoco model="navstress">\n<compiler angle="radian"/>\n'
           f'<option timestep="{_xml_float(cfg.timestep_s)}" integrator="implicitfast" solver="Newton" '
           f'iterations="{cfg.solver_iterations}" ls_iterations="10" cone="pyramidal"/>\n'
           f'<default><geom solref="0.02 1"/></default>\n'
           f"<asset>\n{asset}\n</asset>\n<worldbody>\n{wbody}\n{rbody}\n</worldbody>\n"
           f"<actuator>{act}</actuator>\n</mujoco>\n")
    try:
        m = mujoco.MjModel.from_xml_string(xml)
    except ValueError as err:
        raise SimulationError(f"MuJoCo rejected the model: {err}") from None
    m.hfield_data[:] = norm.astype(np.float32).ravel()  # row 0 = -y = World row 0
    def name(t: mujoco.mjtObj, n: str) -> int:
        return int(mujoco.mj_name2id(m, t, n))

    G, B, J = mujoco.mjtObj.mjOBJ_GEOM, mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_JOINT
    dm = drive_model(robot)
    names = tuple(w.name for w in dm.wheels)
    if len(names) > MAX_WHEELS:
        raise SimulationError(f"{len(names)} wheels: at most {MAX_WHEELS}")
    wheel_of_geom = -np.ones(m.ngeom, np.int64)
    obstacle_of_geom = -np.ones(m.ngeom, np.int64)
    for i, n in enumerate(names):
        wheel_of_geom[name(G, f"wheel_{n}")] = i
    for k in range(len(world.obstacles) if obstacle_pool == 0 else 0):
        obstacle_of_geom[name(G, f"obstacle_{k}")] = k
    joints = [name(J, f"wheel_{n}") for n in names]
    rm = RobotModel(
        model=m, chassis_body=name(B, "chassis"),
        wheel_bodies=np.array([name(B, f"wheel_{n}") for n in names], np.int64),
        wheel_dofs=np.array([m.jnt_dofadr[j] for j in joints], np.int64),
        wheel_qpos=np.array([m.jnt_qposadr[j] for j in joints], np.int64),
        wheel_of_geom=wheel_of_geom, obstacle_of_geom=obstacle_of_geom,
        bumper_geom=name(G, "bumper"), lidar_site=mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "lidar"),
        map_size=(float(size[0]), float(size[1])),
        slot_geoms=np.array([name(G, f"obstacle_slot_{k}") for k in range(obstacle_pool)], np.int64),
        slot_bodies=np.array([name(B, f"obstacle_slot_{k}") for k in range(obstacle_pool)], np.int64),
        mover_geoms=np.array([name(G, f"mover_{mv.id}") for mv in world.movers], np.int64),
        mover_mocap=np.array([m.body_mocapid[name(B, f"mover_{mv.id}")] for mv in world.movers], np.int64),
        wheel_act=np.array([name(mujoco.mjtObj.mjOBJ_ACTUATOR, f"wheel_{w.name}") if w.driven else -1
                            for w in dm.wheels], np.int64),
        axle_bodies=np.array([name(B, f"steer_{w.name}") if w.steered else name(B, "chassis") for w in dm.wheels],
                             np.int64),
        steer_qpos=np.array([m.jnt_qposadr[name(J, f"steer_{w.name}")] for w in dm.wheels if w.steered], np.int64),
        steer_act=np.array([name(mujoco.mjtObj.mjOBJ_ACTUATOR, f"steer_{w.name}") for w in dm.wheels if w.steered],
                           np.int64))
    m.geom_contype[rm.slot_geoms] = 0  # parked
    return rm


class ObstaclePool:
    """Keeps the obstacles near the robot in the model's obstacle slots.

    :meth:`update` puts in a slot every obstacle whose footprint comes within ``margin_m`` of the
    robot's footprint circle (the distance from the robot's centre to the obstacle's footprint:
    a box's turned rectangle, a cylinder's circle, at most robot reach + margin) and empties the
    slots of the others (parked far below the map, collisions off). A slot takes either shape:
    its geom's type, size, bounding radius and boxes are rewritten with the obstacle it gets. A
    long wall thus enters the pool only where the robot comes near it, not from half its length
    away. An obstacle keeps its slot while it stays near. Exact as long as the robot moves less
    than ``margin_m`` between updates (the simulation updates every 0.1 s; 1.2 m/s top speed).
    With more near obstacles than slots, the nearest ones (by gap) are kept: the pool is then
    approximate, and ``overflows`` counts such updates.
    """

    def __init__(self, rm: RobotModel, world: World, robot: RobotSpec, margin_m: float) -> None:
        m = rm.model
        self.rm = rm
        obs = world.obstacles
        n = len(obs)
        self.centre = np.array([[o.x, o.y, o.z + o.size[2] / 2] for o in obs], np.float64).reshape(n, 3)
        # a cylinder's half sizes: (radius, radius, half height)
        self.half = np.array([[s / 2 for s in o.size] for o in obs], np.float64).reshape(n, 3)
        self.quat = np.array([[1.0, 0.0, 0.0, 0.0] if o.is_cylinder else
                              [math.cos(o.yaw / 2), 0.0, 0.0, math.sin(o.yaw / 2)] for o in obs],
                             np.float64).reshape(n, 4)
        self.turn = np.array([[math.cos(o.yaw), math.sin(o.yaw)] for o in obs], np.float64).reshape(n, 2)
        self.geom_type = np.array([GEOM_CYLINDER if o.is_cylinder else GEOM_BOX for o in obs], np.int64)
        robot_reach = math.hypot(robot.length_m, robot.width_m) / 2
        self.reach = np.full(n, robot_reach + margin_m, np.float64)
        k = len(rm.slot_geoms)
        self.slot_obstacle = -np.ones(k, np.int64)
        self.mocap = np.array([m.body_mocapid[b] for b in rm.slot_bodies], np.int64)
        self.bvh = np.array([m.body_bvhadr[b] for b in rm.slot_bodies], np.int64)
        self.arrays = PoolArrays(self.centre, self.half, self.quat, self.turn, self.geom_type, self.reach,
                                 np.zeros(n, np.float64), self.slot_obstacle, rm.slot_geoms, self.mocap, self.bvh)
        self.overflows = 0

    def update(self, data: mujoco.MjData) -> int:
        """Refill the slots for the robot's current position; returns the number of filled slots."""
        m, rm = self.rm.model, self.rm
        slots = MjSlotArrays(data.mocap_pos, data.mocap_quat, m.geom_size, m.geom_rbound, m.geom_aabb, m.bvh_aabb,
                             m.geom_contype, m.geom_type)
        nfill = fill_obstacle_slots(float(data.qpos[0]), float(data.qpos[1]), self.arrays, rm.obstacle_of_geom, slots,
                                    PARK_Z_M, OBSTACLE_BIT)
        if nfill < 0:
            self.overflows += 1
            nfill = -nfill
        return nfill


GEOM_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)
GEOM_CYLINDER = int(mujoco.mjtGeom.mjGEOM_CYLINDER)


class PoolArrays(NamedTuple):
    """The arrays of an obstacle pool that :func:`fill_obstacle_slots` reads and updates."""

    centre: np.ndarray  # (n, 3) obstacle centres (footprint centre, half height)
    half: np.ndarray  # (n, 3) half sizes (a cylinder: radius, radius, half height)
    quat: np.ndarray  # (n, 4) orientation (a cylinder: none)
    turn: np.ndarray  # (n, 2) cos, sin of the yaw (a box's footprint)
    geom_type: np.ndarray  # (n,) MuJoCo geom type: GEOM_BOX or GEOM_CYLINDER
    reach: np.ndarray  # (n,) distance from the robot's centre to the footprint within which an obstacle is near
    dist: np.ndarray  # (n,) scratch: gap of each obstacle
    slot_obstacle: np.ndarray  # (K,) obstacle in each slot, -1: empty
    slot_geom: np.ndarray  # (K,) geom of each slot
    slot_mocap: np.ndarray  # (K,) mocap index of each slot body
    slot_bvh: np.ndarray  # (K,) BVH node of each slot body


class MjSlotArrays(NamedTuple):
    """The MuJoCo arrays that :func:`fill_obstacle_slots` writes: mjData's mocap poses, mjModel's
    geom sizes, bounds, AABBs, BVH boxes, collision types and geom types."""

    mocap_pos: np.ndarray
    mocap_quat: np.ndarray
    geom_size: np.ndarray
    geom_rbound: np.ndarray
    geom_aabb: np.ndarray
    bvh_aabb: np.ndarray
    geom_contype: np.ndarray
    geom_type: np.ndarray


def empty_pool_arrays() -> PoolArrays:
    """The :class:`PoolArrays` of no pool (same array types as a pool's)."""
    e2, e1, ei = np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64)
    return PoolArrays(e2, e2.copy(), np.zeros((0, 4)), np.zeros((0, 2)), ei.copy(), e1, e1.copy(), ei, ei.copy(),
                      ei.copy(), ei.copy())


@numba.njit(cache=True, inline="always")
def footprint_distance(dx: float, dy: float, hx: float, hy: float, c: float, s: float,
                       cylinder: bool) -> float:  # pragma: no cover - compiled
    """Distance from a point at (dx, dy) from an obstacle's footprint centre to its footprint
    (0 inside): a cylinder's circle of radius ``hx``, a box's rectangle of half sides (hx, hy)
    turned by the yaw whose cos, sin are ``c``, ``s``."""
    if cylinder:
        return max(math.sqrt(dx * dx + dy * dy) - hx, 0.0)
    ex = max(abs(c * dx + s * dy) - hx, 0.0)
    ey = max(abs(-s * dx + c * dy) - hy, 0.0)
    return math.sqrt(ex * ex + ey * ey)


@numba.njit(cache=True)
def fill_obstacle_slots(x: float, y: float, pool: PoolArrays, obstacle_of_geom: np.ndarray, slots: MjSlotArrays,
                        park_z: float, contype: int) -> int:  # pragma: no cover - compiled
    """Numba core of :meth:`ObstaclePool.update` for the robot at (x, y): empty slots parked at
    ``park_z`` (minus 10 m per slot), filled ones given collision type ``contype`` and the geom
    type, size, bounds of their obstacle; returns minus the count when it overflowed."""
    mocap_pos, mocap_quat, geom_size = slots.mocap_pos, slots.mocap_quat, slots.geom_size
    geom_rbound, geom_aabb, bvh_aabb = slots.geom_rbound, slots.geom_aabb, slots.bvh_aabb
    geom_contype, slot_type = slots.geom_contype, slots.geom_type
    centre, half, quat, reach, dist = pool.centre, pool.half, pool.quat, pool.reach, pool.dist
    turn, gtype = pool.turn, pool.geom_type
    slot_obstacle, slot_geom, slot_mocap, slot_bvh = pool.slot_obstacle, pool.slot_geom, pool.slot_mocap, pool.slot_bvh
    n = centre.shape[0]
    k = slot_obstacle.shape[0]
    near = 0
    for i in range(n):
        cyl = gtype[i] == GEOM_CYLINDER
        d = footprint_distance(x - centre[i, 0], y - centre[i, 1], half[i, 0], half[i, 1], turn[i, 0], turn[i, 1],
                               cyl) - reach[i]
        dist[i] = d
        if d <= 0.0:
            near += 1
    limit = np.inf
    if near > k:  # keep the k nearest (by gap)
        order = np.argsort(dist)
        limit = dist[order[k - 1]]
    want = np.zeros(n, np.bool_)
    taken = 0
    for i in range(n):
        if dist[i] <= 0.0 and dist[i] <= limit and taken < k:
            want[i] = True
            taken += 1
    # keep obstacles that stay near in their slot, free the others
    for s in range(k):
        o = slot_obstacle[s]
        if o >= 0 and want[o]:
            want[o] = False  # already placed
        elif o >= 0:
            slot_obstacle[s] = -1
            g = slot_geom[s]
            obstacle_of_geom[g] = -1
            geom_contype[g] = 0
            mocap_pos[slot_mocap[s], 0] = 0.0
            mocap_pos[slot_mocap[s], 1] = 0.0
            mocap_pos[slot_mocap[s], 2] = park_z - 10.0 * s
    s = 0
    for i in range(n):
        if not want[i]:
            continue
        while slot_obstacle[s] >= 0:
            s += 1
        slot_obstacle[s] = i
        g = slot_geom[s]
        b = slot_mocap[s]
        obstacle_of_geom[g] = i
        geom_contype[g] = contype
        slot_type[g] = gtype[i]
        for a in range(3):
            mocap_pos[b, a] = centre[i, a]
            geom_aabb[g, a] = 0.0
            geom_aabb[g, 3 + a] = half[i, a]
            bvh_aabb[slot_bvh[s], a] = 0.0
            bvh_aabb[slot_bvh[s], 3 + a] = half[i, a]
        if gtype[i] == GEOM_CYLINDER:  # MuJoCo's cylinder size: radius, half height
            geom_size[g, 0] = half[i, 0]
            geom_size[g, 1] = half[i, 2]
            geom_size[g, 2] = 0.0
        else:
            for a in range(3):
                geom_size[g, a] = half[i, a]
        for a in range(4):
            mocap_quat[b, a] = quat[i, a]
        geom_rbound[g] = (half[i, 0] ** 2 + half[i, 1] ** 2 + half[i, 2] ** 2) ** 0.5 if gtype[i] != GEOM_CYLINDER \
            else (half[i, 0] ** 2 + half[i, 2] ** 2) ** 0.5
    filled = 0
    for s in range(k):
        if slot_obstacle[s] >= 0:
            filled += 1
    return -filled if near > k else filled
