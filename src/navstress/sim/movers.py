"""The movers' controllers: every mover of a world advanced by one control period (numba, no MuJoCo).

A mover is part of the world, so its controller reads the robot's TRUE pose and velocity (DESIGN
invariant 1 is about the navigator, which never sees this module). Pure and deterministic: the
same plan, state, inputs and generator give the same next state, bit for bit.

    >>> import numpy as np
    >>> from navstress.world import World, WorldSpec
    >>> from navstress.world.world import Mover
    >>> m = Mover(id=0, kind="pedestrian", shape="disc", size=(0.5, 0.5, 1.8), start=(5.0, 5.0, 0.0),
    ...           speed_m_s=1.0, speed_max_m_s=1.5, accel_m_s2=1.0, behaviour="crossing",
    ...           params=(("pause_max_s", 0.0), ("waypoints", 1.0)), waypoints=((15.0, 5.0),))
    >>> plan = make_plan(World.flat(WorldSpec(size_m=(20.0, 20.0)), movers=(m,)))
    >>> state = initial_state(plan)
    >>> for _ in range(50):
    ...     _ = step(plan, state, 0.1, (0.0, 0.0, 0.0), (0.0, 0.0), np.random.default_rng(0))
    >>> round(float(state[0, X]), 2), round(float(state[0, VX]), 2)
    (9.55, 1.0)

**State** (:func:`initial_state`): a float64 array, one row per mover (``World.movers`` order),
columns :data:`STATE_FIELDS` (indices :data:`X`, :data:`Y`, :data:`YAW`, :data:`VX`, :data:`VY`
... are module constants): the pose and velocity the simulation reads, then the controller's own
memory (phase, path index and direction, timers, aim point, counters).

**The rules, exactly** (per call, ``dt`` seconds; every mover decides from the state at the start
of the call, so the order of the movers does not matter):

1. *Desired velocity* ``vd`` by behaviour and phase:

   - path following (``crossing``, ``patrol``, an ``intercept`` mover while it wanders): toward
     the current waypoint at ``min(cruise, sqrt(2 a d), d / dt)`` (``d`` its distance, ``a`` the
     mover's acceleration limit: it stops on each waypoint); within :data:`ARRIVE_M` it has
     arrived: it pauses ``U(0, pause_max_s)`` (run-seed draw) and takes the next point. The path
     is start, waypoints: ``crossing`` walks it there and back, ``patrol`` round and round
     (back to the start after the last). Its segments are free (:mod:`navstress.world.movers`).
   - ``intercept``: wandering switches to *engaged* when the robot is within ``engage_m``; an
     engaged mover re-aims every reaction time (``reaction_s`` x U(0.75, 1.25), run seed; the
     first aim one reaction time after engaging): from the robot's true position ``r``,
     velocity ``v`` and heading ``u`` (the unit velocity; the yaw below 0.05 m/s), predicted at
     constant velocity, it solves ``|r + u lead + v t - p| = s t`` for the least ``t > 0`` (``s``
     its speed limit, ``lead`` = ``ttc_s |v|`` (``aim: ttc``) or ``clearance_m`` (``aim:
     clearance``)): the aim ``c = r + u lead + v t`` is the point of the robot's predicted path
     it reaches ``lead`` ahead of the robot (no root: the robot's predicted position after
     ``|r + u lead - p| / s``). It walks at ``s`` toward the exit point ``c + cross_m`` (beyond
     ``c`` on its line), and commits (no more re-aiming) once ``c`` is within ``s`` x
     max(reaction time, 0.5 s); on reaching the exit it is engaged again (or wanders, the robot
     beyond 1.5 ``engage_m``). So it crosses the robot's path, ``lead`` ahead of the robot's
     predicted position; ``lead`` 0 is a collision course.
   - ``still-then-move``: parked (``vd`` = 0) until the robot is within ``trigger_m``; one
     reaction time later it aims once (as ``intercept``), walks to the exit point and parks
     there for good.
2. *Static obstacles and the map's edge* (exact distance from the mover's centre to each box,
   through a bin grid): ``vd`` is kept when every point of the look-ahead ``p + vd/|vd| x l``,
   ``l`` in [0, |vd|^2/(2a) + |vd| dt], sampled every :data:`LOOK_STEP_M`, keeps the mover's
   disc (``radius_m``: its circumscribed circle) clear; else its x part alone, else its y part
   alone (it slides along an axis-aligned wall), else 0 (it brakes).
3. *Limits*: the velocity moves toward ``vd`` by at most ``a dt`` and its norm is capped at the
   speed limit.
4. *Other movers*: a mover brakes (``vd`` = 0, then 3.) when, both moving on at their current
   velocities for ``tau = max(1 s, |v|/a)``, it would come within ``r_i + r_j +`` :data:`GAP_M` of
   another mover and nearer than it is now. A path mover braked for :data:`BLOCKED_S` turns
   back along its path (head-on meetings do not deadlock); an engaged or committed ``intercept``
   mover braked that long (by a mover or an obstacle) wanders again, a ``still-then-move`` one
   parks for good. Exit points are kept inside the map by the mover's radius.
5. *Move*: ``p += v dt``. A move that would still end with the disc in an obstacle or out of the
   map (the look-ahead keeps this rare) keeps only its x or y part, or does not happen (the
   velocity is set to 0 and :data:`HARD_STOPS` counts it: the one case where the acceleration
   limit is not kept). The yaw follows the velocity's direction above 0.05 m/s.

Cost: one compiled call for all movers; see ``benchmarks/bench_movers.py`` (about 3-6 us per
call for 20 movers on the development machine).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple, Sequence

import numpy as np
from numba import njit

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.world.world import Mover, World

#: Behaviour codes (column :data:`P_BEHAVIOUR` of the plan's parameters).
BEHAVIOUR_CODES = {"crossing": 0, "patrol": 1, "intercept": 2, "still-then-move": 3}
CROSSING, PATROL, INTERCEPT, STILL = 0, 1, 2, 3

#: Phases (column :data:`PHASE`).
PH_PATH, PH_PARKED, PH_TRIGGERED, PH_ENGAGED, PH_COMMITTED, PH_DONE = 0, 1, 2, 3, 4, 5
PHASES = ("path", "parked", "triggered", "engaged", "committed", "done")

#: The state's columns, in order.
STATE_FIELDS = ("x", "y", "yaw", "vx", "vy", "phase", "wp", "wp_dir", "pause", "decide", "aimed", "aim_x", "aim_y",
                "exit_x", "exit_y", "blocked", "hard_stops")
X, Y, YAW, VX, VY, PHASE, WP, WP_DIR, PAUSE, DECIDE, AIMED, AIM_X, AIM_Y, EXIT_X, EXIT_Y, BLOCKED, HARD_STOPS = range(17)
N_STATE = len(STATE_FIELDS)

#: The plan's parameter columns (one row per mover).
PARAM_FIELDS = ("radius", "cruise", "vmax", "amax", "behaviour", "pause_max", "aim_clearance", "ttc", "clearance",
                "reaction", "engage", "cross", "trigger", "n_points")
(P_RADIUS, P_CRUISE, P_VMAX, P_AMAX, P_BEHAVIOUR, P_PAUSE_MAX, P_AIM_CLEARANCE, P_TTC, P_CLEARANCE, P_REACTION,
 P_ENGAGE, P_CROSS, P_TRIGGER, P_NPOINTS) = range(14)
N_PARAMS = len(PARAM_FIELDS)

#: Distance to a waypoint or exit point that counts as arrived (m).
ARRIVE_M = 0.05
#: Spacing of the samples of a look-ahead (m), and the margin added to the radius there (it
#: covers what the disc could reach between two samples).
LOOK_STEP_M = 0.2
LOOK_MARGIN_M = 0.03
#: Least gap kept between two movers' discs (m).
GAP_M = 0.2
#: Seconds braked for another mover before a path mover turns back.
BLOCKED_S = 3.0
#: Side of the bins of the static obstacle grid (m).
BIN_M = 4.0


@dataclass(frozen=True, eq=False)
class MoverPlan:
    """What does not change during a run: per mover parameters (``params``, columns
    :data:`PARAM_FIELDS`), paths (``points[i, k]``: the start then the waypoints, ``params[i,
    P_NPOINTS]`` of them), the static obstacles (``boxes``: cx, cy, half x, half y, cos yaw, sin
    yaw) binned in a grid (``bin_start``, ``bin_items``; ``geo`` = bin side, bins along x and y,
    map size x and y) and the start poses."""

    params: np.ndarray
    points: np.ndarray
    boxes: np.ndarray
    bin_start: np.ndarray
    bin_items: np.ndarray
    geo: np.ndarray
    movers: tuple[Mover, ...]

    @property
    def n(self) -> int:
        return len(self.movers)


class StaticBins(NamedTuple):
    """The static obstacles binned in a grid, as the kernel reads them (:class:`MoverPlan`'s
    ``boxes``, ``bin_start``, ``bin_items``, ``geo``)."""

    boxes: np.ndarray  # (k, 6) cx, cy, half x, half y, cos yaw, sin yaw
    bin_start: np.ndarray  # (bins + 1,) where each bin's items start in bin_items
    bin_items: np.ndarray  # box indices, bin by bin
    geo: np.ndarray  # bin side, bins along x and y, map size x and y


def make_plan(world: World, movers: Sequence[Mover] | None = None) -> MoverPlan:
    """The plan of ``world``'s movers (or of ``movers`` in ``world``'s static scene)."""
    ms = tuple(world.movers if movers is None else movers)
    n = len(ms)
    npts = max([1 + len(m.waypoints) for m in ms] + [1])
    params = np.zeros((n, N_PARAMS))
    points = np.zeros((n, npts, 2))
    for i, m in enumerate(ms):
        pr = dict(m.params)
        params[i, P_RADIUS] = m.radius_m
        params[i, P_CRUISE] = min(m.speed_m_s, m.speed_max_m_s)
        params[i, P_VMAX] = m.speed_max_m_s
        params[i, P_AMAX] = m.accel_m_s2
        params[i, P_BEHAVIOUR] = BEHAVIOUR_CODES[m.behaviour]
        params[i, P_PAUSE_MAX] = float(pr.get("pause_max_s", 0.0))
        params[i, P_AIM_CLEARANCE] = 1.0 if pr.get("aim", "ttc") == "clearance" else 0.0
        params[i, P_TTC] = float(pr.get("ttc_s", 2.0))
        params[i, P_CLEARANCE] = float(pr.get("clearance_m", 2.0))
        params[i, P_REACTION] = float(pr.get("reaction_s", 0.5))
        params[i, P_ENGAGE] = float(pr.get("engage_m", 30.0))
        params[i, P_CROSS] = float(pr.get("cross_m", 3.0))
        params[i, P_TRIGGER] = float(pr.get("trigger_m", 10.0))
        params[i, P_NPOINTS] = 1 + len(m.waypoints)
        points[i, 0] = m.start[:2]
        for k, w in enumerate(m.waypoints):
            points[i, k + 1] = w
    sx, sy = world.size_m
    obs = world.obstacles
    boxes = np.array([[o.x, o.y, o.size[0] / 2, o.size[1] / 2, math.cos(o.yaw), math.sin(o.yaw)] for o in obs],
                     dtype=np.float64).reshape(len(obs), 6)
    gnx, gny = max(1, math.ceil(sx / BIN_M)), max(1, math.ceil(sy / BIN_M))
    reach = float(params[:, P_RADIUS].max()) if n else 0.0
    lists: list[list[int]] = [[] for _ in range(gnx * gny)]
    for k, o in enumerate(obs):
        c = o.corners()
        a0 = max(0, int((c[:, 0].min() - reach) // BIN_M))
        a1 = min(gnx - 1, int((c[:, 0].max() + reach) // BIN_M))
        b0 = max(0, int((c[:, 1].min() - reach) // BIN_M))
        b1 = min(gny - 1, int((c[:, 1].max() + reach) // BIN_M))
        for b in range(b0, b1 + 1):
            for a in range(a0, a1 + 1):
                lists[b * gnx + a].append(k)
    bin_start = np.zeros(gnx * gny + 1, np.int64)
    bin_start[1:] = np.cumsum([len(v) for v in lists])
    bin_items = np.array([k for v in lists for k in v], dtype=np.int64)
    geo = np.array([BIN_M, gnx, gny, sx, sy], dtype=np.float64)
    for arr in (params, points, boxes, bin_start, bin_items, geo):
        arr.setflags(write=False)
    return MoverPlan(params, points, boxes, bin_start, bin_items, geo, ms)


def initial_state(plan: MoverPlan) -> np.ndarray:
    """The state at time 0: every mover at its start pose, at rest, heading for its first waypoint
    (a ``still-then-move`` mover parked)."""
    s = np.zeros((plan.n, N_STATE))
    for i, m in enumerate(plan.movers):
        s[i, X], s[i, Y], s[i, YAW] = m.start
        s[i, PHASE] = PH_PARKED if m.behaviour == "still-then-move" else PH_PATH
        s[i, WP] = 1.0 if m.waypoints else 0.0
        s[i, WP_DIR] = 1.0
    return s


def step(plan: MoverPlan, state: np.ndarray, dt: float, robot_pose_xy_yaw: Sequence[float],
         robot_velocity_xy: Sequence[float], rng: np.random.Generator) -> np.ndarray:
    """Advance every mover by ``dt`` seconds (in place; returns ``state``). ``rng``: the run's
    generator for the movers (2 uniforms per mover per call, drawn whether used or not)."""
    robot = np.array([robot_pose_xy_yaw[0], robot_pose_xy_yaw[1], robot_pose_xy_yaw[2],
                      robot_velocity_xy[0], robot_velocity_xy[1]], dtype=np.float64)
    if not dt > 0.0 or not math.isfinite(dt):
        raise ValueError(f"dt={dt!r} must be a finite time step > 0")
    u = rng.random((plan.n, 2))
    _step(state, robot, u, float(dt), plan.params, plan.points, plan.boxes, plan.bin_start, plan.bin_items, plan.geo)
    return state


def poses(state: np.ndarray) -> np.ndarray:
    """(n, 3) x, y, yaw of every mover (a view)."""
    out: np.ndarray = state[:, X:YAW + 1]
    return out


# ---- the compiled kernel ---------------------------------------------------------------------


@njit(cache=True, nogil=True)
def _clear(px: float, py: float, r: float, bins: StaticBins) -> bool:
    """Whether a disc of radius ``r`` at (px, py) is inside the map and clear of every box."""
    boxes, bin_start, bin_items, geo = bins
    if px < r or py < r or px > geo[3] - r or py > geo[4] - r:
        return False
    a = min(int(px / geo[0]), int(geo[1]) - 1)
    b = min(int(py / geo[0]), int(geo[2]) - 1)
    cell = b * int(geo[1]) + a
    for q in range(bin_start[cell], bin_start[cell + 1]):
        k = bin_items[q]
        dx = px - boxes[k, 0]
        dy = py - boxes[k, 1]
        lx = abs(dx * boxes[k, 4] + dy * boxes[k, 5]) - boxes[k, 2]
        ly = abs(-dx * boxes[k, 5] + dy * boxes[k, 4]) - boxes[k, 3]
        ex = max(lx, 0.0)
        ey = max(ly, 0.0)
        if ex * ex + ey * ey < r * r:
            return False
    return True


@njit(cache=True, nogil=True)
def _ahead_clear(px: float, py: float, vx: float, vy: float, r: float, amax: float, dt: float,
                 bins: StaticBins) -> bool:
    """Whether the look-ahead of a disc of radius ``r`` at (px, py) moving at (vx, vy) (braking
    at ``amax``, plus one step ``dt``) is clear (:func:`_clear` every :data:`LOOK_STEP_M`)."""
    sp = math.sqrt(vx * vx + vy * vy)
    if sp < 1e-9:
        return True
    look = sp * sp / (2.0 * amax) + sp * dt
    n = int(math.ceil(look / LOOK_STEP_M))
    ux = vx / sp
    uy = vy / sp
    for k in range(1, n + 1):
        t = look * k / n
        if not _clear(px + ux * t, py + uy * t, r, bins):
            return False
    return True


@njit(cache=True, nogil=True)
def _toward(px: float, py: float, tx: float, ty: float, speed: float, amax: float, dt: float) -> tuple[float, float, float]:
    """The velocity toward (tx, ty) that stops on it, and the distance left."""
    dx = tx - px
    dy = ty - py
    d = math.sqrt(dx * dx + dy * dy)
    if d < 1e-12:
        return 0.0, 0.0, 0.0
    s = min(speed, math.sqrt(2.0 * amax * d), d / dt)
    return dx / d * s, dy / d * s, d


@njit(cache=True, nogil=True)
def _aim(st: np.ndarray, pr: np.ndarray, robot: np.ndarray, geo: np.ndarray) -> None:
    """Set the aim and exit points of one mover (row ``st``) from the robot's true state."""
    px = st[X]
    py = st[Y]
    s = pr[P_VMAX]
    rx, ry, ryaw, rvx, rvy = robot[0], robot[1], robot[2], robot[3], robot[4]
    rs = math.sqrt(rvx * rvx + rvy * rvy)
    if rs > 0.05:
        ux, uy = rvx / rs, rvy / rs
    else:
        ux, uy = math.cos(ryaw), math.sin(ryaw)
    lead = pr[P_CLEARANCE] if pr[P_AIM_CLEARANCE] > 0.5 else pr[P_TTC] * rs
    dx = rx + ux * lead - px
    dy = ry + uy * lead - py
    qa = rvx * rvx + rvy * rvy - s * s
    qb = 2.0 * (dx * rvx + dy * rvy)
    qc = dx * dx + dy * dy
    t = -1.0
    if abs(qa) < 1e-12:
        if qb < 0.0:
            t = -qc / qb
    else:
        disc = qb * qb - 4.0 * qa * qc
        if disc >= 0.0:
            sq = math.sqrt(disc)
            t1 = (-qb - sq) / (2.0 * qa)
            t2 = (-qb + sq) / (2.0 * qa)
            lo = min(t1, t2)
            hi = max(t1, t2)
            t = lo if lo > 0.0 else hi
    if t <= 0.0:
        t = math.sqrt(qc) / s
    cx = rx + ux * lead + rvx * t
    cy = ry + uy * lead + rvy * t
    ex = cx - px
    ey = cy - py
    d = math.sqrt(ex * ex + ey * ey)
    if d > 1e-9:
        ex, ey = ex / d, ey / d
    else:
        ex, ey = -uy, ux
    r = pr[P_RADIUS]
    st[AIMED] = 1.0
    st[AIM_X] = cx
    st[AIM_Y] = cy
    st[EXIT_X] = min(max(cx + ex * pr[P_CROSS], r), geo[3] - r)
    st[EXIT_Y] = min(max(cy + ey * pr[P_CROSS], r), geo[4] - r)


@njit(cache=True, nogil=True)
def _step(state: np.ndarray, robot: np.ndarray, u: np.ndarray, dt: float, *plan: np.ndarray) -> None:
    """:func:`step` compiled: ``robot`` (x, y, yaw, vx, vy), ``u`` the draws, ``plan`` the
    :class:`MoverPlan`'s ``params``, ``points``, then the :class:`StaticBins` fields (one by one:
    numba dispatches a tuple of arrays slower; regrouped here)."""
    params, points = plan[0], plan[1]
    bins = StaticBins(*plan[2:])
    geo = bins.geo
    n = state.shape[0]
    old = state[:, X:VY + 1].copy()
    nv = np.zeros((n, 2))
    for i in range(n):
        st = state[i]
        pr = params[i]
        beh = int(pr[P_BEHAVIOUR])
        px, py = st[X], st[Y]
        amax = pr[P_AMAX]
        r = pr[P_RADIUS]
        rdx = robot[0] - px
        rdy = robot[1] - py
        rdist = math.sqrt(rdx * rdx + rdy * rdy)
        reaction = pr[P_REACTION] * (0.75 + 0.5 * u[i, 1])
        phase = int(st[PHASE])
        vdx = 0.0
        vdy = 0.0
        # 1. the behaviour's desired velocity
        if beh == INTERCEPT and phase == PH_PATH and rdist <= pr[P_ENGAGE]:
            phase = PH_ENGAGED
            st[DECIDE] = reaction
            st[AIMED] = 0.0
        if beh == INTERCEPT and phase in (PH_ENGAGED, PH_COMMITTED) and rdist > 1.5 * pr[P_ENGAGE]:
            phase = PH_PATH
        if phase == PH_PATH:
            npts = int(pr[P_NPOINTS])
            if npts > 1:
                if st[PAUSE] > 0.0:
                    st[PAUSE] -= dt
                else:
                    k = int(st[WP])
                    vdx, vdy, d = _toward(px, py, points[i, k, 0], points[i, k, 1], pr[P_CRUISE], amax, dt)
                    if d < ARRIVE_M:
                        if beh == PATROL:
                            k = (k + int(st[WP_DIR])) % npts
                        else:
                            if k + int(st[WP_DIR]) < 0 or k + int(st[WP_DIR]) >= npts:
                                st[WP_DIR] = -st[WP_DIR]
                            k = k + int(st[WP_DIR])
                        st[WP] = k
                        st[PAUSE] = u[i, 0] * pr[P_PAUSE_MAX]
                        vdx, vdy, d = _toward(px, py, points[i, k, 0], points[i, k, 1], pr[P_CRUISE], amax, dt)
        elif phase == PH_PARKED:
            if rdist <= pr[P_TRIGGER]:
                phase = PH_TRIGGERED
                st[DECIDE] = reaction
        elif phase == PH_TRIGGERED:
            st[DECIDE] -= dt
            if st[DECIDE] <= 0.0:
                _aim(st, pr, robot, geo)
                phase = PH_COMMITTED
        elif phase == PH_ENGAGED:
            st[DECIDE] -= dt
            if st[DECIDE] <= 0.0:
                _aim(st, pr, robot, geo)
                st[DECIDE] += max(reaction, dt)
            if st[AIMED] == 0.0:  # not aimed yet: carry on as it was
                vdx, vdy = st[VX], st[VY]
            else:
                ax = st[AIM_X] - px
                ay = st[AIM_Y] - py
                if math.sqrt(ax * ax + ay * ay) <= pr[P_VMAX] * max(pr[P_REACTION], 0.5):
                    phase = PH_COMMITTED
                vdx, vdy, d = _toward(px, py, st[EXIT_X], st[EXIT_Y], pr[P_VMAX], amax, dt)
        if phase == PH_COMMITTED:
            vdx, vdy, d = _toward(px, py, st[EXIT_X], st[EXIT_Y], pr[P_VMAX], amax, dt)
            if d < ARRIVE_M:
                vdx, vdy = 0.0, 0.0
                if beh == STILL:
                    phase = PH_DONE
                else:
                    phase = PH_ENGAGED
                    st[DECIDE] = reaction
                    st[AIMED] = 0.0
        st[PHASE] = phase
        want = vdx != 0.0 or vdy != 0.0
        # 4. other movers: brake when a conflict is predicted
        vx, vy = st[VX], st[VY]
        if want:
            cx, cy = _limit(vx, vy, vdx, vdy, amax * dt, pr[P_VMAX])
            tau = max(1.0, math.sqrt(cx * cx + cy * cy) / amax)
            for j in range(n):
                if j != i and _conflict(px - old[j, 0], py - old[j, 1], cx - old[j, 3], cy - old[j, 4], tau,
                                        r + params[j, P_RADIUS] + GAP_M):
                    vdx, vdy = 0.0, 0.0
                    break
        # 2. and 3. static obstacles: the new velocity's look-ahead must be clear: vd, else its x
        # part, else its y part, else brake (which keeps a clear look-ahead clear)
        nx, ny = _limit(vx, vy, 0.0, 0.0, amax * dt, pr[P_VMAX])
        for c in range(3):
            tx = vdx if c != 2 else 0.0
            ty = vdy if c != 1 else 0.0
            if (tx == 0.0 and ty == 0.0) or (c > 0 and (tx == vdx and ty == vdy)):
                continue
            qx, qy = _limit(vx, vy, tx, ty, amax * dt, pr[P_VMAX])
            if _ahead_clear(px, py, qx, qy, r + LOOK_MARGIN_M, amax, dt, bins):
                nx, ny = qx, qy
                vdx, vdy = tx, ty
                break
        else:
            vdx, vdy = 0.0, 0.0
        nv[i, 0], nv[i, 1] = nx, ny
        if want and vdx == 0.0 and vdy == 0.0:
            st[BLOCKED] += dt
        else:
            st[BLOCKED] = 0.0
        if st[BLOCKED] >= BLOCKED_S:  # braked too long: turn back, or give up the aim
            st[BLOCKED] = 0.0
            if phase == PH_PATH:
                npts = int(pr[P_NPOINTS])
                st[WP_DIR] = -st[WP_DIR]
                k = int(st[WP]) + int(st[WP_DIR])
                st[WP] = k % npts if beh == PATROL else min(max(k, 0), npts - 1)
            elif beh == STILL:
                st[PHASE] = PH_DONE
            else:
                st[PHASE] = PH_PATH
    # 5. move
    for i in range(n):
        st = state[i]
        r = params[i, P_RADIUS]
        vx, vy = nv[i, 0], nv[i, 1]
        px, py = st[X], st[Y]
        if not _clear(px + vx * dt, py + vy * dt, r, bins):
            if vx != 0.0 and _clear(px + vx * dt, py, r, bins):
                vy = 0.0
            elif vy != 0.0 and _clear(px, py + vy * dt, r, bins):
                vx = 0.0
            else:
                vx, vy = 0.0, 0.0
            st[HARD_STOPS] += 1.0
        st[X] = px + vx * dt
        st[Y] = py + vy * dt
        st[VX] = vx
        st[VY] = vy
        if vx * vx + vy * vy > 0.0025:
            st[YAW] = math.atan2(vy, vx)


@njit(cache=True, nogil=True)
def _conflict(dx: float, dy: float, wx: float, wy: float, tau: float, need: float) -> bool:
    """Whether two discs at relative position (dx, dy) and relative velocity (wx, wy), approaching,
    come nearer than ``need`` within ``tau`` seconds."""
    ww = wx * wx + wy * wy
    dw = dx * wx + dy * wy
    if dw >= 0.0 or ww < 1e-12:  # not approaching
        return False
    t = min(-dw / ww, tau)
    ex = dx + wx * t
    ey = dy + wy * t
    return ex * ex + ey * ey < need * need


@njit(cache=True, nogil=True)
def _limit(vx: float, vy: float, tx: float, ty: float, dv: float, vmax: float) -> tuple[float, float]:
    """The velocity moved from (vx, vy) toward (tx, ty) by at most ``dv``, its norm capped at ``vmax``."""
    ex = tx - vx
    ey = ty - vy
    e = math.sqrt(ex * ex + ey * ey)
    if e > dv:
        ex *= dv / e
        ey *= dv / e
    nx = vx + ex
    ny = vy + ey
    s = math.sqrt(nx * nx + ny * ny)
    if s > vmax:
        nx *= vmax / s
        ny *= vmax / s
    return nx, ny
