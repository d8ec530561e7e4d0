"""The compiled inner loop of :class:`~navstress.sim.simulation.Simulation`.

One numba call (:func:`run_steps`) runs physics steps until something needs Python: a ray sensor
(lidar, scanner, camera) that is due,
a collision or stop event, instability, full sample buffers or used-up pre-drawn random numbers,
or the requested step. Each step is the pending velocity command (when its step has come), the
drive firmware, the obstacle pool refill (every ``pool_every`` steps), the stages of MuJoCo's
``mj_fwdPosition`` up to ``mj_collision``, the skid-steer contact rewrite
(:func:`_align_wheel_contacts`; optionally analytic wheel contacts first), the remaining stages
(``mj_makeConstraint``, ``mj_transmission``, ``mj_projectConstraint``), ``mj_fwdVelocity``,
``mj_step2``, then the event checks; odometry, IMU, pose and observer readings are recorded in
buffers, IMU and pose noise from standard normals that Python pre-draws from the sensors'
generators in batches (Python turns the last rows into readings, see ``Simulation._flush``).

What the loop keeps between calls is named:

* :data:`STATE`, a record (numpy structured dtype, one field a line) of what the loop changes:
  step count, pending command, drive firmware, odometry, IMU bias, collision counters;
* :data:`PARAMS`, a record of the constants of a run (gains, limits, noise levels, addresses);
* the arrays, in named groups (:class:`MjArrays`, :class:`RobotArrays`,
  :class:`~navstress.sim.model.PoolArrays`, :class:`SensorArrays`, :class:`CollisionArrays`,
  :class:`WheelContactArrays`, :class:`MoverArrays`) that :func:`loop_arrays` flattens and
  :func:`run_steps` regroups into a :class:`LoopArrays` (numba dispatches a flat argument list
  several microseconds faster than tuples).

The helpers of the loop take these records and groups too (a helper reads the fields it needs,
once, at its top), or small NamedTuples of scalars (:class:`Sphere`, :class:`HFieldGrid`).

Adding a state variable is one line in :data:`STATE` (zero at the start; give another start value
in :func:`new_state`); a constant, one line in :data:`PARAMS` (then :func:`new_params` demands it).
MuJoCo's C ABI (calls by symbol, contact layout, addresses) is :mod:`navstress.sim.mjabi`'s.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import mujoco
import numba
import numpy as np

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress._records import full_record
from navstress.errors import SimulationError
from navstress.sim.mjabi import (CF_DIST, CF_FRAME, CF_FRICTION, CF_POS, CI_EFC, CI_EXCLUDE, CI_GEOM, CI_GEOM1, CI_GEOM2,
                                 add_contact, contact_row, contacts, fwd_position_collision,
                                 fwd_position_constraints, mj_fwdVelocity, mj_step2)
from navstress.sim.drives import ACKERMANN, MAX_WHEELS
from navstress.sim.model import MjSlotArrays, PoolArrays, fill_obstacle_slots
from navstress.sensors.base import MAX_RAY_SENSORS

# status bits returned by run_steps (RAYS: one or more ray sensors are due, STATE.due says which)
DONE, RAYS, CONTACT, LEFT_MAP, FLIPPED, UNSTABLE, FLUSH, MOVERS = 0, 1, 2, 4, 8, 16, 32, 64
LIDAR = RAYS  # (its name before sensors were declared)
# rows of the schedule arrays (the order in which sensors fire within a step): the built-in
# sensors, then the ray sensors of the run's suite (navstress.sim.suite), row RAY0 + i for the
# i-th; rows past RAY0 + PARAMS.n_rays are never looked at
ODOM, IMU, POSE, OBSERVER = 0, 1, 2, 3
NBUILTIN = 4  # rows with recorded samples (SensorArrays.samples)
RAY0 = NBUILTIN
NROWS = NBUILTIN + MAX_RAY_SENSORS
NSENSORS = NROWS
NO_CMD = np.iinfo(np.int64).max  # STATE.cmd_k when no command is pending
# MuJoCo warnings that mean the physics went unstable (MuJoCo would reset the state)
BAD_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)
# rows of the pre-drawn standard-normal noise array (7 values per IMU sample, 6 per pose sample)
IMU_NOISE, POSE_NOISE = 0, 1
NOISE_BATCH = 42 * 16  # a multiple of 7 and 6: a row is used up exactly

_I, _F = np.int64, np.float64
STATE = np.dtype([
    ("k", _I),  # physics steps done
    ("cmd_k", _I),  # step at which the pending command takes effect (NO_CMD: none)
    ("cmd_v", _F), ("cmd_w", _F),  # the pending command (clamped to the speed limits)
    ("tv", _F), ("tw", _F),  # the command in effect (drive firmware targets)
    ("v", _F), ("w", _F),  # ramped speed and yaw rate
    ("yaw_i", _F),  # yaw-rate PI integral
    ("ref", _F, (MAX_WHEELS,)),  # wheel angle references (each wheel tracks its integrated speed command)
    ("steer", _F),  # ackermann: the bicycle steering angle commanded now (rate limited)
    ("odom_x", _F), ("odom_y", _F), ("odom_yaw", _F),  # wheel odometry pose
    ("odom_a", _F, (MAX_WHEELS,)),  # wheel angles at the last odometry sample (PARAMS.wheel_qpos order)
    ("odom_gyro_yaw", _F),  # the chassis yaw at the last odometry sample (gyro heading)
    ("odom_t", _F), ("odom_v", _F), ("odom_w", _F),  # last odometry sample time, speed, yaw rate
    ("imu_bias", _F), ("imu_t", _F),  # IMU yaw bias (random walk) and last sample time
    ("n_imu", _I), ("n_pose", _I),  # next unused value of the noise rows IMU_NOISE / POSE_NOISE
    ("next_k", _I, (NROWS,)),  # step at which each sensor fires next (rows ODOM ... OBSERVER, then the rays)
    ("jitter_idx", _I, (NROWS,)),  # next unused column of SensorArrays.jitter (its width: used up)
    ("nsamples", _I, (NBUILTIN,)),  # rows of SensorArrays.samples recorded since the last flush
    ("due", _I, (MAX_RAY_SENSORS,)),  # 1: ray sensor i is due (RAYS returned; Python casts it, clears it)
    ("touching", _I),  # size of the touching set (CollisionArrays.previous)
    ("ncontact", _I),  # obstacles the bumper touched after the last step
    ("starts", _I), ("nevent", _I),  # contact starts / collision events not yet flushed
    ("up_z", _F),  # z of the chassis up-vector after the last step
    ("mover_k", _I),  # step at which the movers' controller runs next (NO_CMD: never, no movers)
    ("mover_k0", _I),  # step of its last run (MoverArrays.pose0 is the movers' pose then)
], align=True)
PARAMS = np.dtype([
    ("model", _I), ("data", _I), ("ncon_addr", _I), ("contact_field", _I),  # mjabi.Addresses
    ("chassis", _I), ("bumper", _I), ("terrain", _I),  # body, geom, geom ids
    ("n_wheels", _I),  # wheels of the drive model (the first n entries of the wheel arrays)
    ("wheel_body", _I, (MAX_WHEELS,)), ("wheel_qpos", _I, (MAX_WHEELS,)), ("wheel_dof", _I, (MAX_WHEELS,)),
    ("wheel_x", _F, (MAX_WHEELS,)), ("wheel_y", _F, (MAX_WHEELS,)),  # wheel centres in base_link
    ("wheel_act", _I, (MAX_WHEELS,)),  # velocity actuator of each wheel (-1: passive)
    ("axle_body", _I, (MAX_WHEELS,)),  # body whose y axis is the wheel's axle (the chassis or a steering body)
    ("steer_act", _I, (MAX_WHEELS,)), ("steer_qpos", _I, (MAX_WHEELS,)),  # steering hinge of each wheel (-1: none)
    ("odom_side", _I, (MAX_WHEELS,)),  # odometry: 1 a left encoder, 2 a right one, 0 not used
    ("odom_inv_l", _F), ("odom_inv_r", _F),  # 1 / number of left / right odometry wheels
    ("odom_gyro", _I),  # odometry heading from the gyro (the chassis yaw) instead of the wheels
    ("drive", _I),  # navstress.sim.drives: SKID_STEER, DIFFERENTIAL, ACKERMANN
    ("wheelbase", _F), ("rear_x", _F),  # ackermann: bicycle model
    ("max_steer", _F), ("steer_step", _F), ("min_turn_speed", _F),  # steering limit, rate limit per step
    ("warning_ids", _I, (len(BAD_WARNINGS),)),  # BAD_WARNINGS
    ("dt", _F),  # time step (s)
    ("dv", _F), ("dw", _F),  # speed / yaw-rate change per step at the acceleration limits
    ("skid", _F), ("kp", _F), ("ki", _F),  # skid factor, yaw-rate PI gains
    ("wheel_radius", _F), ("hold", _F),  # wheel radius, wheel-angle hold gain
    ("mu", _F), ("friction_floor", _F), ("slip_eps", _F),  # skid-steer friction rewrite
    ("max_speed", _F),  # body speed above which the physics is unstable
    ("size_x", _F), ("size_y", _F), ("margin", _F),  # map size, margin of the left-map stop
    ("cos_flip", _F),  # up-vector z below which the robot has flipped
    ("debounce", _F),  # collision debounce (s)
    ("odom_radius", _F), ("odom_track", _F),  # odometry wheel radius and (calibrated) track
    ("period", _F, (NROWS,)),  # nominal sensor periods (s)
    ("n_rays", _I),  # ray sensors of the run (rows RAY0 .. RAY0 + n_rays - 1)
    ("jitter", _I), ("rate_jitter", _F),  # sensor rate jitter on, its relative amplitude
    ("noise", _I),  # sensor noise on
    ("imu_att", _F), ("imu_rate", _F), ("imu_drift", _F),  # IMU noise
    ("pose_pos", _F), ("pose_att", _F),  # pose noise
    ("warn0", _I),  # MuJoCo's bad-qpos/qvel/qacc warning count at the start
    ("pool_every", _I), ("pool_contype", _I), ("park_z", _F),  # obstacle pool refill (0: no pool)
    ("hfield_x0", _F), ("hfield_y0", _F), ("hfield_dx", _F), ("hfield_dy", _F),  # WheelContactArrays.hfield grid
    ("mover_every", _I),  # steps per control period of the movers (0: no movers)
    ("n_obstacles", _I),  # contact index n_obstacles + i is mover i (RobotArrays.obstacle_of_geom)
], align=True)
STATE_FIELDS: frozenset[str] = frozenset(STATE.names or ())
PARAMS_FIELDS: frozenset[str] = frozenset(PARAMS.names or ())


def new_state(**values: Any) -> np.ndarray:
    """A one-record :data:`STATE` array: the fields given, zero elsewhere."""
    unknown = set(values) - STATE_FIELDS
    if unknown:
        raise TypeError(f"not STATE fields: {sorted(unknown)}")
    s = np.zeros(1, STATE)
    for name, v in values.items():
        s[name] = v
    return s


def new_params(**values: Any) -> np.ndarray:
    """A one-record :data:`PARAMS` array; every field must be given."""
    return full_record(PARAMS, "PARAMS", values)


class MjArrays(NamedTuple):
    """Views of the mjModel / mjData arrays the loop reads or writes."""

    qpos: np.ndarray
    qvel: np.ndarray
    ctrl: np.ndarray
    xpos: np.ndarray
    xmat: np.ndarray
    warning: np.ndarray  # d.warning.number
    mocap_pos: np.ndarray
    mocap_quat: np.ndarray
    geom_size: np.ndarray
    geom_rbound: np.ndarray
    geom_aabb: np.ndarray
    bvh_aabb: np.ndarray
    geom_contype: np.ndarray
    geom_type: np.ndarray


class RobotArrays(NamedTuple):
    """Indices of the robot in the model (:class:`~navstress.sim.model.RobotModel`)."""

    wheel_of_geom: np.ndarray  # (ngeom,) wheel index or -1
    obstacle_of_geom: np.ndarray  # (ngeom,) obstacle index or -1 (pool slots change it)


class SensorArrays(NamedTuple):
    """Sensor buffers (the schedule is in STATE/PARAMS); rows ODOM, IMU, POSE, OBSERVER, then the
    ray sensors (:data:`NROWS` rows; samples only for the :data:`NBUILTIN` built-in ones)."""

    jitter: np.ndarray  # (NROWS, B) pre-drawn uniforms of the rate jitter
    samples: np.ndarray  # (NBUILTIN, S, 7) recorded readings (STATE.nsamples rows), see _fire
    noise: np.ndarray  # (2, NOISE_BATCH) pre-drawn standard normals, rows IMU_NOISE, POSE_NOISE


class CollisionArrays(NamedTuple):
    """Collision bookkeeping (:func:`contact_events`)."""

    current: np.ndarray  # obstacles touched after this step
    previous: np.ndarray  # the touching set (STATE.touching entries)
    last_touch: np.ndarray  # per obstacle: time last touched (-inf: never)
    events: np.ndarray  # (E, EVENT_COLS) collision events, STATE.nevent rows (EVENT_FIELDS)


class MoverArrays(NamedTuple):
    """The movers' bodies between two runs of their controller (:func:`_place_movers`): each moves
    linearly from ``pose0`` (at step ``STATE.mover_k0``) to ``pose1`` (``PARAMS.mover_every``
    steps later); empty without movers."""

    mocap: np.ndarray  # (n,) mocap index of each mover body
    pose0: np.ndarray  # (n, 4) x, y, z (body centre), yaw at the last controller run
    pose1: np.ndarray  # (n, 4) the same one control period later
    vel: np.ndarray  # (n, 2) the planar velocity in between (m/s)


class WheelContactArrays(NamedTuple):
    """Analytic wheel contacts (:func:`_add_wheel_contacts`); no wheel geoms: off."""

    wheel_geom: np.ndarray  # wheel geoms (empty: MuJoCo's collision makes the contacts)
    hfield: np.ndarray  # terrain heights (rows y, columns x; grid in PARAMS.hfield_*)
    template: np.ndarray  # raw bytes of a MuJoCo wheel-ground contact (mjabi.CF float64)
    scratch: np.ndarray  # (4, 7) contacts of one wheel


class LoopArrays(NamedTuple):
    """Every array group of the loop (:func:`_steps`), as :func:`run_steps` regroups them."""

    mj: MjArrays
    robot: RobotArrays
    pool: PoolArrays
    sensors: SensorArrays
    collisions: CollisionArrays
    wheels: WheelContactArrays
    movers: MoverArrays


class Sphere(NamedTuple):
    """A sphere (a wheel): centre and radius (m)."""

    x: float
    y: float
    z: float
    r: float


class HFieldGrid(NamedTuple):
    """Where a heightfield's vertices lie: ``hf[i, j]`` at (x0 + j dx, y0 + i dy)."""

    x0: float
    y0: float
    dx: float
    dy: float


#: Columns of CollisionArrays.events: the robot's and the obstacle's planar speed (m/s, 0 for a
#: static obstacle) and the norm of their velocity difference, at the step of the contact.
EVENT_FIELDS = ("t", "x", "y", "obstacle", "robot_speed", "obstacle_speed", "relative_speed")
EVENT_COLS = len(EVENT_FIELDS)

GROUPS = (MjArrays, RobotArrays, PoolArrays, SensorArrays, CollisionArrays, WheelContactArrays, MoverArrays)
# where each group ends in run_steps' flat argument list
_E_MJ = len(MjArrays._fields)
_E_ROBOT = _E_MJ + len(RobotArrays._fields)
_E_POOL = _E_ROBOT + len(PoolArrays._fields)
_E_SENSORS = _E_POOL + len(SensorArrays._fields)
_E_COLLISIONS = _E_SENSORS + len(CollisionArrays._fields)
_E_WHEELS = _E_COLLISIONS + len(WheelContactArrays._fields)
_E_MOVERS = _E_WHEELS + len(MoverArrays._fields)


def loop_arrays(mj: MjArrays, robot: RobotArrays, pool: PoolArrays, sensors: SensorArrays,
                collisions: CollisionArrays, wheels: WheelContactArrays,
                movers: MoverArrays | None = None) -> tuple[np.ndarray, ...]:
    """The array groups as :func:`run_steps` takes them (one flat tuple, in :data:`GROUPS` order;
    ``movers`` None: no movers)."""
    groups = (mj, robot, pool, sensors, collisions, wheels, movers if movers is not None else empty_mover_arrays())
    for g, cls in zip(groups, GROUPS):
        if type(g) is not cls:
            raise TypeError(f"expected {cls.__name__}, got {type(g).__name__}")
    return tuple(a for g in groups for a in g)


def empty_mover_arrays() -> MoverArrays:
    """The :class:`MoverArrays` of a world without movers."""
    return MoverArrays(np.zeros(0, np.int64), np.zeros((0, 4)), np.zeros((0, 4)), np.zeros((0, 2)))


def contact_template(m: mujoco.MjModel, d0: mujoco.MjData, wheel_geoms: np.ndarray, chassis_qpos: int) -> np.ndarray:
    """The raw bytes (as mjabi.CF float64) of a wheel-ground contact as MuJoCo's collision makes
    it (solref, solimp, friction mixing, dim ...): the chassis of a scratch copy of ``d0`` is
    lowered until a wheel touches the ground."""
    d = mujoco.MjData(m)
    d.qpos[:] = d0.qpos
    d.mocap_pos[:] = d0.mocap_pos
    wheels = set(int(g) for g in wheel_geoms)
    for drop in np.arange(0.0, 2.0, 0.01):
        d.qpos[chassis_qpos + 2] = d0.qpos[chassis_qpos + 2] - drop
        mujoco.mj_forward(m, d)
        for i in range(d.ncon):
            if int(d.contact.geom[i, 0]) in wheels or int(d.contact.geom[i, 1]) in wheels:
                return contact_row(d, i)
    raise SimulationError("no wheel-ground contact found to copy contact parameters from")


@numba.njit(cache=True)
def _add_wheel_contacts(p: Any, xpos: np.ndarray, wc: WheelContactArrays) -> int:  # pragma: no cover - compiled
    """Add every wheel's sphere-terrain contacts (:func:`sphere_terrain_contacts`) to MuJoCo's
    contact list, copying ``wc.template`` (a MuJoCo wheel-ground contact) for the other fields
    (``p``: a :data:`PARAMS` record; wheel bodies at ``xpos``)."""
    maddr, daddr, wbody, terrain, r = p.model, p.data, p.wheel_body, p.terrain, p.wheel_radius
    grid = HFieldGrid(p.hfield_x0, p.hfield_y0, p.hfield_dx, p.hfield_dy)
    wgeom, hf, tmpl, cbuf = wc.wheel_geom, wc.hfield, wc.template, wc.scratch
    ti = tmpl.view(np.int32)
    added = 0
    for w in range(wgeom.shape[0]):  # no wheel geoms given: MuJoCo's collision makes the contacts
        b = wbody[w]
        nc = sphere_terrain_contacts(Sphere(xpos[b, 0], xpos[b, 1], xpos[b, 2], r), hf, grid, cbuf)
        for k in range(nc):
            nx, ny, nz = cbuf[k, 4], cbuf[k, 5], cbuf[k, 6]
            tmpl[CF_DIST] = cbuf[k, 0]
            tmpl[CF_POS], tmpl[CF_POS + 1], tmpl[CF_POS + 2] = cbuf[k, 1], cbuf[k, 2], cbuf[k, 3]
            # frame: normal, then any orthonormal tangents (the skid-steer rewrite turns them)
            if abs(nz) < 0.9:
                tx, ty, tz = ny, -nx, 0.0
            else:
                tx, ty, tz = 0.0, nz, -ny
            ln = (tx * tx + ty * ty + tz * tz) ** 0.5
            tx, ty, tz = tx / ln, ty / ln, tz / ln
            f = CF_FRAME
            tmpl[f], tmpl[f + 1], tmpl[f + 2] = nx, ny, nz
            tmpl[f + 3], tmpl[f + 4], tmpl[f + 5] = tx, ty, tz
            tmpl[f + 6], tmpl[f + 7], tmpl[f + 8] = ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx
            ti[CI_GEOM1], ti[CI_GEOM2], ti[CI_GEOM], ti[CI_GEOM + 1] = terrain, wgeom[w], terrain, wgeom[w]
            ti[CI_EFC] = -1
            ti[CI_EXCLUDE] = 0
            if add_contact(maddr, daddr, tmpl):
                added += 1
    return added


@numba.njit(cache=True)
def _align_wheel_contacts(cf: np.ndarray, ci: np.ndarray, p: Any, qvel: np.ndarray, xmat: np.ndarray,
                          xpos: np.ndarray, wheel_of_geom: np.ndarray) -> int:  # pragma: no cover
    """Turn wheel contact frames to (normal, rolling, lateral) and split ``mu`` by slip direction.

    ``cf``/``ci``: the contacts as rows of float64/int32 (:func:`navstress.sim.mjabi.contacts`);
    ``p``: a :data:`PARAMS` record (``mu``, ``friction_floor``, ``slip_eps``, the chassis and the
    wheels' bodies and dofs); ``qvel``, ``xmat``, ``xpos``: MuJoCo's (:class:`MjArrays`).
    The pyramidal limits become ``mu*|s_roll|/|s|`` and ``mu*|s_lat|/|s|`` (at least
    ``floor*mu``; full ``mu`` both ways when ``|s| << eps``), with ``s`` the wheel's slip velocity
    at the contact at the start of the step: Coulomb friction opposing the slip, one step late.
    Returns the number of contacts changed.
    """
    cm, cpos = xmat[p.chassis], xpos[p.chassis]
    wbody, wdof, mu, floor, eps = p.wheel_body, p.wheel_dof, p.mu, p.friction_floor, p.slip_eps
    k = 0
    wx = cm[0] * qvel[3] + cm[1] * qvel[4] + cm[2] * qvel[5]
    wy = cm[3] * qvel[3] + cm[4] * qvel[4] + cm[5] * qvel[5]
    wz = cm[6] * qvel[3] + cm[7] * qvel[4] + cm[8] * qvel[5]
    fi, pi, ri = CF_FRAME, CF_POS, CF_FRICTION
    for i in range(cf.shape[0]):
        w = wheel_of_geom[ci[i, CI_GEOM]]
        if w < 0:
            w = wheel_of_geom[ci[i, CI_GEOM + 1]]
        if w < 0:
            continue
        nx, ny, nz = cf[i, fi], cf[i, fi + 1], cf[i, fi + 2]
        ab = p.axle_body[w]
        if ab != p.chassis:  # a steered wheel: its axle is its steering body's y axis
            sm = xmat[ab]
            ax, ay, az = sm[1], sm[4], sm[7]
        else:
            ax, ay, az = cm[1], cm[4], cm[7]
        tx = ay * nz - az * ny
        ty = az * nx - ax * nz
        tz = ax * ny - ay * nx
        s = (tx * tx + ty * ty + tz * tz) ** 0.5
        if s < 1e-6:
            continue
        tx /= s
        ty /= s
        tz /= s
        ux = ny * tz - nz * ty
        uy = nz * tx - nx * tz
        uz = nx * ty - ny * tx
        cf[i, fi + 3] = tx
        cf[i, fi + 4] = ty
        cf[i, fi + 5] = tz
        cf[i, fi + 6] = ux
        cf[i, fi + 7] = uy
        cf[i, fi + 8] = uz
        spin = qvel[wdof[w]]
        px, py, pz = cf[i, pi], cf[i, pi + 1], cf[i, pi + 2]
        rx, ry, rz = px - cpos[0], py - cpos[1], pz - cpos[2]
        vx = qvel[0] + wy * rz - wz * ry
        vy = qvel[1] + wz * rx - wx * rz
        vz = qvel[2] + wx * ry - wy * rx
        b = wbody[w]
        qx, qy, qz = px - xpos[b, 0], py - xpos[b, 1], pz - xpos[b, 2]
        vx += spin * (ay * qz - az * qy)
        vy += spin * (az * qx - ax * qz)
        vz += spin * (ax * qy - ay * qx)
        sl = vx * tx + vy * ty + vz * tz
        st = vx * ux + vy * uy + vz * uz
        mag = (sl * sl + st * st + eps * eps) ** 0.5
        e = eps / mag
        cf[i, ri] = mu * max(abs(sl) / mag, e, floor)
        cf[i, ri + 1] = mu * max(abs(st) / mag, e, floor)
        k += 1
    return k


@numba.njit(cache=True)
def _closest_on_triangle(px: float, py: float, pz: float, a: np.ndarray, b: np.ndarray,
                         c: np.ndarray) -> tuple[float, float, float, bool]:  # pragma: no cover - compiled
    """Closest point of triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5) and
    whether it lies in the triangle's interior (a face contact) rather than on an edge/vertex."""
    abx, aby, abz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    acx, acy, acz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    apx, apy, apz = px - a[0], py - a[1], pz - a[2]
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return a[0], a[1], a[2], False
    bpx, bpy, bpz = px - b[0], py - b[1], pz - b[2]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return b[0], b[1], b[2], False
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return a[0] + v * abx, a[1] + v * aby, a[2] + v * abz, False
    cpx, cpy, cpz = px - c[0], py - c[1], pz - c[2]
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return c[0], c[1], c[2], False
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return a[0] + w * acx, a[1] + w * acy, a[2] + w * acz, False
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return b[0] + w * (c[0] - b[0]), b[1] + w * (c[1] - b[1]), b[2] + w * (c[2] - b[2]), False
    den = 1.0 / (va + vb + vc)
    v = vb * den
    w = vc * den
    return a[0] + abx * v + acx * w, a[1] + aby * v + acy * w, a[2] + abz * v + acz * w, True


@numba.njit(cache=True)
def sphere_terrain_contacts(sphere: Sphere, hf: np.ndarray, grid: HFieldGrid,
                            out: np.ndarray) -> int:  # pragma: no cover - compiled
    """Contacts of a sphere (centre c, radius r) with the triangulated heightfield ``hf[i, j]`` at
    (x0 + j*dx, y0 + i*dy) (``grid``), cells split along the (i, j)-(i+1, j+1) diagonal (MuJoCo's hfield).

    Writes rows (dist < 0, pos x3 on the midway surface, normal x3 from the ground to the sphere)
    into ``out`` and returns how many (at most ``out.shape[0]``). Exact sphere-mesh geometry: every
    triangle whose interior holds the closest point to the centre is a face contact (a valley
    gives two) and, when the deepest point of the whole surface lies on an edge or vertex (a
    ridge), that point with the normal towards the centre; other edge points (e.g. the borders of
    coplanar neighbours) are not contacts. Coincident face points count once; with more than
    ``out.shape[0]`` contacts the deepest are kept.
    """
    cx, cy, cz, r = sphere
    x0, y0, dx, dy = grid
    rows, cols = hf.shape
    j0 = max(int(np.floor((cx - r - x0) / dx)), 0)
    j1 = min(int(np.floor((cx + r - x0) / dx)), cols - 2)
    i0 = max(int(np.floor((cy - r - y0) / dy)), 0)
    i1 = min(int(np.floor((cy + r - y0) / dy)), rows - 2)
    a, b, c = np.empty(3), np.empty(3), np.empty(3)
    nface = 0
    best = 0.0  # deepest penetration over all triangles
    best_is_edge = False
    ex = ey = ez = 0.0
    cap = out.shape[0]
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            h00, h01, h10, h11 = hf[i, j], hf[i, j + 1], hf[i + 1, j], hf[i + 1, j + 1]
            if cz - r >= max(max(h00, h01), max(h10, h11)):
                continue
            xa, xb, ya, yb = x0 + j * dx, x0 + (j + 1) * dx, y0 + i * dy, y0 + (i + 1) * dy
            for tri in range(2):
                a[0], a[1], a[2] = xa, ya, h00
                c[0], c[1], c[2] = xb, yb, h11
                if tri == 0:  # (i,j) (i,j+1) (i+1,j+1)
                    b[0], b[1], b[2] = xb, ya, h01
                else:  # (i,j) (i+1,j+1) (i+1,j)
                    b[0], b[1], b[2] = c[0], c[1], c[2]
                    c[0], c[1], c[2] = xa, yb, h10
                qx, qy, qz, inside = _closest_on_triangle(cx, cy, cz, a, b, c)
                if inside:
                    # a centre behind this face's plane (a steep neighbouring face) cannot have its
                    # closest surface point inside the face: judge that point by its distance alone
                    fx = (b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1])
                    fy = (b[2] - a[2]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[2] - a[2])
                    fz = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
                    inside = (cx - qx) * fx + (cy - qy) * fy + (cz - qz) * fz >= 0.0
                if not inside:  # edge/vertex point: a candidate only as the deepest point of all
                    ddx, ddy, ddz = cx - qx, cy - qy, cz - qz
                    pen = r - (ddx * ddx + ddy * ddy + ddz * ddz) ** 0.5
                    if pen > best:
                        best, best_is_edge = pen, True
                        ex, ey, ez = qx, qy, qz
                    continue
                # face point: upward face normal, penetration along it
                nx = (b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1])
                ny = (b[2] - a[2]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[2] - a[2])
                nz = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
                ln = (nx * nx + ny * ny + nz * nz) ** 0.5
                nx, ny, nz = nx / ln, ny / ln, nz / ln
                dist = (cx - qx) * nx + (cy - qy) * ny + (cz - qz) * nz - r
                if dist >= 0.0:
                    continue
                if -dist >= best:
                    best, best_is_edge = -dist, False
                dup = False
                for k in range(nface):
                    dup = dup or (abs(out[k, 1] - qx) + abs(out[k, 2] - qy) < 1e-6 and
                                  abs(out[k, 4] - nx) + abs(out[k, 5] - ny) < 1e-6)
                if dup:
                    continue
                k = nface
                if nface == cap:  # full: replace the shallowest if this one is deeper
                    k = 0
                    for kk in range(1, cap):
                        if out[kk, 0] > out[k, 0]:
                            k = kk
                    if out[k, 0] <= dist:
                        continue
                else:
                    nface += 1
                out[k, 0] = dist
                out[k, 1], out[k, 2], out[k, 3] = qx, qy, qz
                out[k, 4], out[k, 5], out[k, 6] = nx, ny, nz
    if best_is_edge:  # the deepest point is on an edge or vertex (a ridge): it is a contact too
        ddx, ddy, ddz = cx - ex, cy - ey, cz - ez
        ln = (ddx * ddx + ddy * ddy + ddz * ddz) ** 0.5
        if ln > 1e-9:
            k = nface if nface < cap else cap - 1
            out[k, 0] = -best
            out[k, 1], out[k, 2], out[k, 3] = ex, ey, ez
            out[k, 4], out[k, 5], out[k, 6] = ddx / ln, ddy / ln, ddz / ln
            nface = k + 1
    for k in range(nface):  # MuJoCo's contact position: midway between the two surfaces
        for a_ in range(3):
            out[k, 1 + a_] += 0.5 * out[k, 0] * out[k, 4 + a_]
    return nface



@numba.njit(cache=True)
def _drive(s: Any, p: Any, qpos: np.ndarray, qvel: np.ndarray, ctrl: np.ndarray,
           wqpos: np.ndarray) -> None:  # pragma: no cover - compiled
    """Robot firmware: ramp to the acceleration limits, yaw-rate PI on the gyro, wheel-angle hold
    (``s``: a :data:`STATE` record, ``p``: a :data:`PARAMS` record); Ackermann steering in
    :func:`_drive_ackermann`.

    Each wheel tracks the integral of its speed command (bounded lag 0.5 rad), so a stopped
    robot holds on a slope instead of creeping at torque / kv."""
    dt = p.dt
    s.v += min(max(s.tv - s.v, -p.dv), p.dv)
    s.w += min(max(s.tw - s.w, -p.dw), p.dw)
    if p.drive == ACKERMANN:
        _drive_ackermann(s, p, qpos, ctrl, wqpos)
        return
    err = s.w - qvel[5]  # free joint: body-frame angular velocity
    s.yaw_i = min(max(s.yaw_i + err * dt, -0.5), 0.5)
    dw_cmd = p.skid * s.w + p.kp * err + p.ki * s.yaw_i
    ref, wy, act = s.ref, p.wheel_y, p.wheel_act
    for i in range(p.n_wheels):
        cmd = (s.v - dw_cmd * wy[i]) / p.wheel_radius
        a = qpos[wqpos[i]]
        e = min(max(ref[i] + cmd * dt - a, -0.5), 0.5)
        ref[i] = a + e
        ctrl[act[i]] = cmd + p.hold * e


@numba.njit(cache=True)
def _drive_ackermann(s: Any, p: Any, qpos: np.ndarray, ctrl: np.ndarray,
                     wqpos: np.ndarray) -> None:  # pragma: no cover - compiled
    """Ackermann firmware (:mod:`navstress.sim.drives.ackermann`): the ramped twist through the
    bicycle model about the rear axle to a steering angle (limit, rate limit), each steered wheel to
    its Ackermann angle, each driven wheel at its contact point's speed."""
    v, w, L = s.v, s.w, p.wheelbase
    if abs(v) >= p.min_turn_speed:
        target = math.atan(L * w / v)
    elif w != 0.0:
        target = math.copysign(p.max_steer, w)
    else:
        target = 0.0
    target = min(max(target, -p.max_steer), p.max_steer)
    s.steer += min(max(target - s.steer, -p.steer_step), p.steer_step)
    t = math.tan(s.steer)
    wk = v * t / L  # the yaw rate of this steering at this speed
    ref, act = s.ref, p.wheel_act
    for i in range(p.n_wheels):
        y = p.wheel_y[i]
        vx, vy = v - wk * y, wk * (p.wheel_x[i] - p.rear_x)
        if p.steer_act[i] >= 0:
            d = math.atan2(L * t, L - y * t)
            ctrl[p.steer_act[i]] = d
            roll = vx * math.cos(d) + vy * math.sin(d)
        else:
            roll = vx
        if act[i] < 0:
            continue
        cmd = roll / p.wheel_radius
        a = qpos[wqpos[i]]
        e = min(max(ref[i] + cmd * p.dt - a, -0.5), 0.5)
        ref[i] = a + e
        ctrl[act[i]] = cmd + p.hold * e


@numba.njit(cache=True)
def odom_update(s: Any, p: Any, qpos: np.ndarray, t: float) -> None:  # pragma: no cover
    """``WheelOdometry.update`` (the reference in ``tests/oracles/sensors.py``) on the :data:`STATE`
    record ``s`` with the :data:`PARAMS` record ``p`` (same arithmetic), the wheel angles read from
    ``qpos`` at time ``t``: each side's travel is the radius times its encoders' mean rotation
    (``PARAMS.odom_side``); the heading change (right - left) / track, or (ackermann) the travel
    times the measured bicycle steering tangent / wheelbase, or (``odom_gyro``) the chassis yaw
    change; exact-arc integration."""
    oa, wq, side = s.odom_a, p.wheel_qpos, p.odom_side
    suml = sumr = 0.0
    nl = nr = 0
    for i in range(p.n_wheels):
        a = qpos[wq[i]]
        d = a - oa[i]
        oa[i] = a
        if side[i] == 1:
            suml = d if nl == 0 else suml + d
            nl += 1
        elif side[i] == 2:
            sumr = d if nr == 0 else sumr + d
            nr += 1
    r = p.odom_radius
    dl = r * p.odom_inv_l * suml
    dr = r * p.odom_inv_r * sumr
    ds = 0.5 * (dl + dr)
    if p.odom_gyro != 0:
        gy = _euler(qpos)[0]
        dth = _wrap(gy - s.odom_gyro_yaw)
        s.odom_gyro_yaw = gy
    elif p.drive == ACKERMANN:
        tsum = 0.0
        ns = 0
        L = p.wheelbase
        for i in range(p.n_wheels):
            if p.steer_qpos[i] >= 0:
                tj = math.tan(qpos[p.steer_qpos[i]])
                tsum += L * tj / (L + p.wheel_y[i] * tj)
                ns += 1
        dth = ds * (tsum / max(ns, 1)) / L
    else:
        dth = (dr - dl) / p.odom_track
    yaw = s.odom_yaw
    if abs(dth) > 1e-9:
        k = ds / dth
        s.odom_x += k * (math.sin(yaw + dth) - math.sin(yaw))
        s.odom_y += k * (math.cos(yaw) - math.cos(yaw + dth))
    else:
        s.odom_x += ds * math.cos(yaw)
        s.odom_y += ds * math.sin(yaw)
    s.odom_yaw = (yaw + dth + math.pi) % (2 * math.pi) - math.pi
    dt = t - s.odom_t
    s.odom_t = t
    if dt > 0:
        s.odom_v, s.odom_w = ds / dt, dth / dt


@numba.njit(cache=True)
def _euler(qpos: np.ndarray) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """(yaw, pitch, roll), Z-Y-X, of the chassis quaternion qpos[3:7] (as ``euler_from_mat``)."""
    w, x, y, z = qpos[3], qpos[4], qpos[5], qpos[6]
    r00 = 1.0 - 2.0 * (y * y + z * z)
    r10 = 2.0 * (x * y + w * z)
    r20 = 2.0 * (x * z - w * y)
    r21 = 2.0 * (y * z + w * x)
    r22 = 1.0 - 2.0 * (x * x + y * y)
    return np.arctan2(r10, r00), np.arcsin(max(-1.0, min(1.0, -r20))), np.arctan2(r21, r22)


@numba.njit(cache=True)
def _wrap(a: float) -> float:  # pragma: no cover - compiled
    """``wrap`` of ``tests/oracles/sensors.py`` (same arithmetic: Python's float modulo)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


@numba.njit(cache=True)
def _fire(k: int, s: Any, p: Any, qpos: np.ndarray, qvel: np.ndarray, wqpos: np.ndarray,
          sens: SensorArrays) -> int:  # pragma: no cover - compiled
    """Record the readings of the sensors due at step ``k``; RAYS when a ray sensor is due (its
    schedule already advanced, ``s.due`` set for it), FLUSH when a buffer is full or a noise/jitter row used up
    (nothing recorded for that sensor).

    Rows: odometry (t, x, y, yaw, v, omega); IMU (t, roll, pitch, yaw, wx, wy, wz) and pose
    (t, x, y, z, yaw, pitch, roll) with their noise, as ``ImuSensor.read``/``PoseSensor.read``
    compute it from the same standard normals (``noise``, pre-drawn in order); observer
    (t, x, y, z, yaw, pitch, roll), true."""
    next_k, period, jitter, jitter_idx = s.next_k, p.period, sens.jitter, s.jitter_idx
    samples, nsamp, noise = sens.samples, s.nsamples, sens.noise
    status = DONE
    t = k * p.dt
    noisy = p.noise != 0
    nb = noise.shape[1]
    for sn in range(RAY0 + p.n_rays):
        if next_k[sn] > k:
            continue
        jittered = p.jitter != 0 and p.rate_jitter > 0 and sn != OBSERVER
        if (sn < RAY0 and nsamp[sn] >= samples.shape[1]) or (jittered and jitter_idx[sn] >= jitter.shape[1]):
            return status | FLUSH
        if noisy and ((sn == IMU and s.n_imu + 7 > nb) or (sn == POSE and s.n_pose + 6 > nb)):
            return status | FLUSH
        if sn >= RAY0:
            status |= RAYS
            s.due[sn - RAY0] = 1
        else:
            row = samples[sn, nsamp[sn]]
            row[0] = t
            if sn == ODOM:  # integrated here; the row is the reading (t, x, y, yaw, v, omega)
                odom_update(s, p, qpos, t)
                row[1], row[2], row[3], row[4], row[5] = s.odom_x, s.odom_y, s.odom_yaw, s.odom_v, s.odom_w
            else:
                yaw, pitch, roll = _euler(qpos)
                if sn == IMU:
                    wx, wy, wz = qvel[3], qvel[4], qvel[5]
                    if noisy:  # ImuSensor.read: bias random walk, white noise
                        j = s.n_imu
                        e = noise[IMU_NOISE]
                        s.imu_bias += p.imu_drift * math.sqrt(max(t - s.imu_t, 0.0)) * e[j]
                        a, rs = p.imu_att, p.imu_rate
                        row[1], row[2] = roll + a * e[j + 1], pitch + a * e[j + 2]
                        row[3] = _wrap(yaw + s.imu_bias + a * e[j + 3])
                        row[4], row[5], row[6] = wx + rs * e[j + 4], wy + rs * e[j + 5], wz + rs * e[j + 6]
                        s.n_imu = j + 7
                    else:
                        row[1], row[2], row[3], row[4], row[5], row[6] = roll, pitch, yaw, wx, wy, wz
                    s.imu_t = t
                elif sn == POSE and noisy:  # PoseSensor.read: independent Gaussian noise
                    j = s.n_pose
                    e = noise[POSE_NOISE]
                    pp, a = p.pose_pos, p.pose_att
                    row[1], row[2], row[3] = qpos[0] + pp * e[j], qpos[1] + pp * e[j + 1], qpos[2] + pp * e[j + 2]
                    row[4], row[5], row[6] = _wrap(yaw + a * e[j + 3]), pitch + a * e[j + 4], roll + a * e[j + 5]
                    s.n_pose = j + 6
                else:  # pose without noise, observer
                    row[1], row[2], row[3], row[4], row[5], row[6] = qpos[0], qpos[1], qpos[2], yaw, pitch, roll
            nsamp[sn] += 1
        per = period[sn]
        if jittered:
            per *= 1.0 + p.rate_jitter * (2.0 * jitter[sn, jitter_idx[sn]] - 1.0)
            jitter_idx[sn] += 1
        next_k[sn] = k + max(1, int(np.rint(per / p.dt)))
    return status


@numba.njit(cache=True)
def contact_events(s: Any, col: CollisionArrays, ncur: int, t: float, x: float, y: float,
                   debounce: float) -> bool:  # pragma: no cover
    """:meth:`Observer.contacts` on arrays: ``col.current[:ncur]`` (distinct obstacle indices) is
    the touching set after the step at ``t`` (robot at x, y), ``col.previous[:s.touching]`` the
    previous one (``s``: a :data:`STATE` record). A newly touched obstacle counts a start
    (``s.starts``) and, when last touched more than ``debounce`` ago (``col.last_touch``, -inf:
    never), appends a collision event (t, x, y, obstacle) to ``col.events`` (``s.nevent`` rows).
    Returns False when ``col.events`` is now full."""
    cur, prev, last_touch, events = col.current, col.previous, col.last_touch, col.events
    for i in range(ncur):
        o = cur[i]
        new = True
        for j in range(s.touching):
            if prev[j] == o:
                new = False
                break
        if new:
            s.starts += 1
            if t - last_touch[o] > debounce:
                e = s.nevent
                events[e, 0], events[e, 1], events[e, 2], events[e, 3] = t, x, y, o
                s.nevent = e + 1
        last_touch[o] = t
    for i in range(ncur):
        prev[i] = cur[i]
    s.touching = ncur
    return bool(s.nevent + ncur < events.shape[0])


@numba.njit(cache=True)
def run_steps(k_stop: int, state: np.ndarray, params: np.ndarray, *arrays: np.ndarray) -> int:  # pragma: no cover
    """Fire the sensors due at the current step, then step until ``k_stop`` (or an event).

    ``state``/``params``: one-record :data:`STATE`/:data:`PARAMS` arrays; ``arrays``: the groups
    as :func:`loop_arrays` flattens them. Returns the status bits (see :func:`_steps`)."""
    return _steps(k_stop, state[0], params[0],
                  LoopArrays(MjArrays(*arrays[:_E_MJ]), RobotArrays(*arrays[_E_MJ:_E_ROBOT]),
                             PoolArrays(*arrays[_E_ROBOT:_E_POOL]), SensorArrays(*arrays[_E_POOL:_E_SENSORS]),
                             CollisionArrays(*arrays[_E_SENSORS:_E_COLLISIONS]),
                             WheelContactArrays(*arrays[_E_COLLISIONS:_E_WHEELS]),
                             MoverArrays(*arrays[_E_WHEELS:_E_MOVERS])))


@numba.njit(cache=True)
def _place_movers(f: float, mv: MoverArrays, mocap_pos: np.ndarray, mocap_quat: np.ndarray) -> None:  # pragma: no cover
    """Put every mover body at ``pose0 + f (pose1 - pose0)`` (the yaw along the shorter turn)."""
    p0, p1 = mv.pose0, mv.pose1
    for i in range(mv.mocap.shape[0]):
        b = mv.mocap[i]
        mocap_pos[b, 0] = p0[i, 0] + f * (p1[i, 0] - p0[i, 0])
        mocap_pos[b, 1] = p0[i, 1] + f * (p1[i, 1] - p0[i, 1])
        mocap_pos[b, 2] = p0[i, 2] + f * (p1[i, 2] - p0[i, 2])
        yaw = p0[i, 3] + f * _wrap(p1[i, 3] - p0[i, 3])
        mocap_quat[b, 0] = math.cos(0.5 * yaw)
        mocap_quat[b, 1] = 0.0
        mocap_quat[b, 2] = 0.0
        mocap_quat[b, 3] = math.sin(0.5 * yaw)


@numba.njit(cache=True)
def ground_height(h: np.ndarray, cell: float, x: float, y: float) -> float:  # pragma: no cover - compiled
    """``Terrain.height_at`` (the same triangles and arithmetic, in float64: numba's ``float()`` of
    a float32 stays float32) on the heights ``h``."""
    rows, cols = h.shape
    fx = np.float64(min(max(x / cell, 0.0), cols - 1.000001))
    fy = np.float64(min(max(y / cell, 0.0), rows - 1.000001))
    j, i = int(fx), int(fy)
    u, v = fx - j, fy - i
    h00, h10 = np.float64(h[i, j]), np.float64(h[i, j + 1])
    h01, h11 = np.float64(h[i + 1, j]), np.float64(h[i + 1, j + 1])
    if u >= v:
        return h00 + u * (h10 - h00) + v * (h11 - h10)
    return h00 + v * (h01 - h00) + u * (h11 - h01)


@numba.njit(cache=True)
def mover_targets(ctrl: np.ndarray, half_h: np.ndarray, h: np.ndarray, cell: float, period: float,
                  pose0: np.ndarray, pose1: np.ndarray, vel: np.ndarray) -> None:  # pragma: no cover - compiled
    """After a controller run (``ctrl``: its state, columns x, y, yaw first), on the
    :class:`MoverArrays` (passed one by one: numba unboxes a tuple slowly): ``pose0`` takes
    ``pose1`` (where the bodies are now), ``pose1`` the controller's poses (z: the ground under the
    centre plus ``half_h``), ``vel`` the velocity in between."""
    for i in range(pose0.shape[0]):
        for a in range(4):
            pose0[i, a] = pose1[i, a]
        x, y = ctrl[i, 0], ctrl[i, 1]
        pose1[i, 0] = x
        pose1[i, 1] = y
        pose1[i, 2] = ground_height(h, cell, x, y) + half_h[i]
        pose1[i, 3] = ctrl[i, 2]
        vel[i, 0] = (x - pose0[i, 0]) / period
        vel[i, 1] = (y - pose0[i, 1]) / period


@numba.njit(cache=True)
def mover_shapes(f: float, p0: np.ndarray, p1: np.ndarray, size: np.ndarray, disc_idx: np.ndarray,
                 box_idx: np.ndarray, discs: np.ndarray, boxes: np.ndarray) -> None:  # pragma: no cover
    """The movers' lidar shapes at fraction ``f`` of the control period (as :func:`_place_movers`,
    between ``MoverArrays.pose0`` and ``pose1``; arrays passed one by one: numba unboxes a tuple
    slowly): the last ``len(disc_idx)`` rows of ``discs`` (x, y, r, z bottom, z top) those of the
    movers ``disc_idx``, the last ``len(box_idx)`` rows of ``boxes`` (x, y, yaw, half length, half width, z bottom, z top, cos
    yaw, sin yaw) those of the movers ``box_idx``; ``size``: the movers' (length, width, height)."""
    first_box = boxes.shape[0] - box_idx.shape[0]
    first_disc = discs.shape[0] - disc_idx.shape[0]
    for r in range(disc_idx.shape[0]):
        i = disc_idx[r]
        d = first_disc + r
        z = p0[i, 2] + f * (p1[i, 2] - p0[i, 2])
        discs[d, 0] = p0[i, 0] + f * (p1[i, 0] - p0[i, 0])
        discs[d, 1] = p0[i, 1] + f * (p1[i, 1] - p0[i, 1])
        discs[d, 2] = 0.5 * size[i, 0]
        discs[d, 3] = z - 0.5 * size[i, 2]
        discs[d, 4] = z + 0.5 * size[i, 2]
    for r in range(box_idx.shape[0]):
        i = box_idx[r]
        b = first_box + r
        z = p0[i, 2] + f * (p1[i, 2] - p0[i, 2])
        yaw = p0[i, 3] + f * _wrap(p1[i, 3] - p0[i, 3])
        boxes[b, 0] = p0[i, 0] + f * (p1[i, 0] - p0[i, 0])
        boxes[b, 1] = p0[i, 1] + f * (p1[i, 1] - p0[i, 1])
        boxes[b, 2] = yaw
        boxes[b, 3] = 0.5 * size[i, 0]
        boxes[b, 4] = 0.5 * size[i, 1]
        boxes[b, 5] = z - 0.5 * size[i, 2]
        boxes[b, 6] = z + 0.5 * size[i, 2]
        boxes[b, 7] = math.cos(yaw)
        boxes[b, 8] = math.sin(yaw)


@numba.njit(cache=True)
def _event_speeds(s: Any, p: Any, e0: int, vx: float, vy: float, mv: MoverArrays,
                  events: np.ndarray) -> None:  # pragma: no cover
    """Fill the speed columns of the collision events ``e0 .. s.nevent`` (:data:`EVENT_FIELDS`):
    (vx, vy) is the robot's planar velocity at the start of the step (before the contact's push)."""
    for e in range(e0, s.nevent):
        o = int(events[e, 3]) - p.n_obstacles
        ox, oy = (mv.vel[o, 0], mv.vel[o, 1]) if o >= 0 else (0.0, 0.0)
        events[e, 4] = (vx * vx + vy * vy) ** 0.5
        events[e, 5] = (ox * ox + oy * oy) ** 0.5
        events[e, 6] = ((vx - ox) ** 2 + (vy - oy) ** 2) ** 0.5


@numba.njit(cache=True)
def _steps(k_stop: int, s: Any, p: Any, g: LoopArrays) -> int:  # pragma: no cover - compiled
    """:func:`run_steps` on the records (``s``: :data:`STATE`, ``p``: :data:`PARAMS`) and the
    groups ``g``. The step count is ``s.k``. The pending
    command (``s.cmd_k``) is applied at the start of its step. Bumper contacts go through
    :func:`contact_events` (collision events in ``col.events[:s.nevent]``, contact starts counted
    in ``s.starts``); FLUSH also when the event buffer is full. The up-vector z is in ``s.up_z``.
    """
    mj, rb, pool, sens, col, wc, mv = g
    maddr, daddr, ncon_addr, con_field = p.model, p.data, p.ncon_addr, p.contact_field
    bumper = p.bumper
    qpos, qvel, xpos = mj.qpos, mj.qvel, mj.xpos
    wqpos, obstacle_of_geom, contact_out = p.wheel_qpos, rb.obstacle_of_geom, col.current
    slots = MjSlotArrays(mj.mocap_pos, mj.mocap_quat, mj.geom_size, mj.geom_rbound, mj.geom_aabb, mj.bvh_aabb,
                         mj.geom_contype, mj.geom_type)
    pool_every = p.pool_every
    while True:
        k = s.k
        st = _fire(k, s, p, qpos, qvel, wqpos, sens)
        if st != DONE or k >= k_stop:
            return st
        if k >= s.mover_k:  # the movers' controller runs (in Python) before this step
            return MOVERS
        # ---- one physics step
        if k >= s.cmd_k:  # the pending command takes effect at the start of its step
            s.tv, s.tw = s.cmd_v, s.cmd_w
            s.cmd_k = NO_CMD
        _drive(s, p, qpos, qvel, mj.ctrl, wqpos)
        vx0, vy0 = qvel[0], qvel[1]  # the robot's velocity before this step (collision speeds)
        if p.mover_every > 0:
            _place_movers((k - s.mover_k0) / p.mover_every, mv, mj.mocap_pos, mj.mocap_quat)
        if pool_every > 0 and k % pool_every == 0:
            fill_obstacle_slots(qpos[0], qpos[1], pool, obstacle_of_geom, slots, p.park_z, p.pool_contype)
        fwd_position_collision(maddr, daddr)
        _add_wheel_contacts(p, xpos, wc)
        cf, ci = contacts(ncon_addr, con_field)
        if cf.shape[0] > 0:
            _align_wheel_contacts(cf, ci, p, qvel, mj.xmat, xpos, rb.wheel_of_geom)
        fwd_position_constraints(maddr, daddr)
        mj_fwdVelocity(maddr, daddr)
        mj_step2(maddr, daddr)
        k += 1
        s.k = k
        # ---- checks after the step
        sp = abs(qvel[0]) + abs(qvel[1]) + abs(qvel[2])
        if not sp < p.max_speed:
            return UNSTABLE
        if k % 50 == 0:
            tot = 0
            for w in p.warning_ids:
                tot += mj.warning[w]
            if tot != p.warn0:
                return UNSTABLE
        status = DONE
        cf, ci = contacts(ncon_addr, con_field)
        nk = 0
        for i in range(ci.shape[0]):
            g0, g1 = ci[i, CI_GEOM], ci[i, CI_GEOM + 1]
            o = -1
            if g0 == bumper:
                o = obstacle_of_geom[g1]
            elif g1 == bumper:
                o = obstacle_of_geom[g0]
            if o >= 0 and nk < contact_out.shape[0]:
                for j in range(nk):
                    if contact_out[j] == o:
                        o = -1
                        break
                if o >= 0:
                    contact_out[nk] = o
                    nk += 1
        s.ncontact = nk
        if nk > 0 or s.touching > 0:
            e0 = s.nevent
            if not contact_events(s, col, nk, k * p.dt, qpos[0], qpos[1], p.debounce):
                status |= FLUSH  # event buffer full: Python empties it before the next step
            _event_speeds(s, p, e0, vx0, vy0, mv, col.events)
        x, y = qpos[0], qpos[1]
        mg = p.margin
        if not (mg <= x <= p.size_x - mg and mg <= y <= p.size_y - mg):
            status |= LEFT_MAP
        qw, qx, qy, qz = qpos[3], qpos[4], qpos[5], qpos[6]
        up_z = 1.0 - 2.0 * (qx * qx + qy * qy) / (qw * qw + qx * qx + qy * qy + qz * qz)
        s.up_z = up_z
        if up_z < p.cos_flip:
            status |= FLIPPED
        if status != DONE:
            return status
