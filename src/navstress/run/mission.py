"""One run: the navigator under test drives the simulated robot through a world's mission.

:func:`run_mission` is the lockstep loop (DESIGN invariant 3)::

    observe -> navigator.step -> command (applied after the simulated latency) -> advance one
    control period (jittered from the run seed) -> ... until the navigator says arrived or
    error, the robot flips or leaves the mission area (the geofence ``NavMission.bounds``),
    or the (simulated) timeout.

The run is then classified (:mod:`navstress.run.outcome`) and its MCAP trace written
atomically (:mod:`navstress.run.trace`). :func:`execute` does all of it from a plain
:class:`~navstress.run.record.RunTask` and never raises for a run-level problem: a navigator
that raises, a navigator process that dies or hangs, an unstable simulation each become a
classified record with the reason (DESIGN invariant 4).

Wall-clock time is measured (``wall_s``) but never enters the simulation or the trace: the
same task gives a byte-identical trace.
"""

from __future__ import annotations

import math
import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import mujoco
import numpy as np

from navstress.errors import NavstressError, SimulationError
from navstress.nav.api import (DebugDraw, InvalidAnswer, NavMission, Navigator, PriorMap, Status, check_answer,
                               check_debug, raised_by_navigator)
from navstress.nav.registry import NavigatorNote, make_navigator
from navstress.robot import RobotSpec
from navstress.run.metrics import drop_jitter, path_length, tortuousness
from navstress.run.outcome import Classification, RunFacts, classify
from navstress.run.record import RunRecord, RunTask
from navstress.run.robot import check_stable, robot_of
from navstress.run.trace import (BELIEF, FRAME, FRAME_LIDAR, FRAME_ROBOT, TOPIC_MAP, TOPIC_PERCEIVED, TOPIC_TERRAIN,
                                 TOPIC_TRUTH, SensorRecorder, TraceMessages, TraceWriter)
from navstress.seeding import derive_seed, rng
from navstress.sim.config import SimConfig
from navstress.sim.sensors import euler_from_mat
from navstress.sim.simulation import Simulation
from navstress.sensors import rotation_rpy
from navstress.world.freespace import rasterise
from navstress.world.world import World

DEFAULT_CONTROL_RATE_HZ = 10.0
CONTROL_JITTER = 0.05
LIDAR_TRACE_PERIOD_S = 1.0  # with record_lidar, one full scan per simulated second goes into the trace  # each control period is scaled by 1 + U(-j, j), drawn from the run seed
#: With ``record_navigator``, the navigator's map goes into the trace once per this many simulated seconds.
MAP_TRACE_PERIOD_S = 1.0
#: The most cells a prior map (:func:`prior_map`) may have.
MAX_PRIOR_MAP_CELLS = 4096 * 4096


@dataclass
class RunResult:
    """Everything one run produced (the record is derived from it)."""

    classification: Classification
    facts: RunFacts
    duration_s: float
    wall_s: float
    truth: np.ndarray  # (N, 7) t, x, y, z, yaw, pitch, roll
    perceived: np.ndarray | None
    final_map: tuple[np.ndarray, tuple[float, float], float] | None
    events: list[tuple[float, str, str]] = field(default_factory=list)  # (t, level, message)
    path_length_m: float = 0.0
    tortuousness: float = 0.0
    #: the movers' poses (``Simulation.mover_track``): times (m,), poses (m, n, 4) x, y, z, yaw;
    #: None in a world without movers
    movers: tuple[np.ndarray, np.ndarray] | None = None
    #: the navigator's velocity commands: (N, 3) t (when given), linear m/s, angular rad/s
    commands: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    #: with ``record_navigator``: its debug drawing after each step, (t, drawing)
    drawings: list[tuple[float, DebugDraw]] = field(default_factory=list)
    #: with ``record_navigator``: its map once per simulated second, cropped to its known cells:
    #: (t, grid, origin xy, cell_m)
    maps: list[tuple[float, np.ndarray, tuple[float, float], float]] = field(default_factory=list)


def attr_through_wrappers(nav: Any, name: str) -> Any:
    """``nav.name``, looking through fault wrappers (``.inner``)."""
    seen = 0
    while nav is not None and seen < 8:
        if hasattr(nav, name):
            return getattr(nav, name)
        nav = getattr(nav, "inner", None)
        seen += 1
    return None


def _run_notes(navigator: Any, t: float) -> list[tuple[float, str, str]]:
    """The navigator's own notes on the run (optional hook ``run_notes()``, read after ``close``:
    texts such as the ``ros2`` navigator's missed cycles), as info events at ``t``; a hook that
    raises or answers anything but a list of strings is one warning event."""
    hook = attr_through_wrappers(navigator, "run_notes")
    if not callable(hook):
        return []
    try:
        notes = hook()
    except BaseException as err:
        if not raised_by_navigator(err):
            raise
        return [(t, "warning", f"navigator run_notes() raised {type(err).__name__}: {err}")]
    if not isinstance(notes, (list, tuple)) or not all(isinstance(n, str) for n in notes):
        return [(t, "warning", f"navigator run_notes() answered {type(notes).__name__}, not a list of strings")]
    return [(t, "info", f"navigator: {n[:500]}") for n in notes]


def check_map(answer: object) -> tuple[np.ndarray, tuple[float, float], float]:
    """A navigator's map (``final_map()``'s ``answer``) as (float32 grid, (x, y), cell_m);
    :class:`InvalidAnswer` when it is not a 2-D grid with a finite origin and a cell size > 0."""
    try:
        parts: Any = answer
        grid, origin, cell = parts
        g = np.asarray(grid, dtype=np.float32)
        ox, oy = (float(v) for v in origin)
        c = float(cell)
    except (TypeError, ValueError) as err:
        raise InvalidAnswer(f"final_map returned something that is not (grid, (x, y), cell_m): {err}") from None
    if g.ndim != 2 or not (math.isfinite(ox) and math.isfinite(oy) and math.isfinite(c) and c > 0):
        raise InvalidAnswer(f"final_map returned a grid of shape {g.shape}, origin ({ox}, {oy}), cell {c}: "
                            "expected a 2-D grid, a finite origin and a cell size > 0")
    return g, (ox, oy), c


def crop_known(answer: object) -> tuple[np.ndarray, tuple[float, float], float] | None:
    """A navigator's map (:func:`check_map`) cut to the rows and columns that hold a known
    (finite) cell, its origin moved to match; None when no cell is known.

        >>> g = np.full((4, 5), np.nan, dtype=np.float32); g[1, 2] = g[2, 3] = 1.0
        >>> v, o, c = crop_known((g, (10.0, 20.0), 0.5))
        >>> v.shape, o, c
        ((2, 2), (11.0, 20.5), 0.5)
    """
    g, (ox, oy), c = check_map(answer)
    known = np.isfinite(g)
    rows, cols = np.flatnonzero(known.any(axis=1)), np.flatnonzero(known.any(axis=0))
    if not len(rows):
        return None
    r0, r1, c0, c1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    return np.ascontiguousarray(g[r0:r1, c0:c1]), (ox + c0 * c, oy + r0 * c), c


class NavigatorView:
    """What a run records of the navigator's own view when asked (``record_navigator``): its
    debug drawing after every step (hook ``debug()``, checked by
    :func:`~navstress.nav.api.check_debug`) and its map once per :data:`MAP_TRACE_PERIOD_S` of
    simulated time (hook ``final_map()``, cut by :func:`crop_known`). A hook that raises or
    answers garbage gets one warning event and is not asked again; the run goes on unchanged
    (nothing recorded here feeds back into the simulation or the navigator)."""

    def __init__(self, navigator: Navigator, events: list[tuple[float, str, str]]) -> None:
        self._events = events
        self._debug = attr_through_wrappers(navigator, "debug")
        self._map = attr_through_wrappers(navigator, "final_map")
        self._next_map = 0.0
        self.map_dropped = False
        self.drawings: list[tuple[float, DebugDraw]] = []
        self.maps: list[tuple[float, np.ndarray, tuple[float, float], float]] = []

    def _drop(self, t: float, hook: str, err: BaseException) -> None:
        if not isinstance(err, InvalidAnswer) and not raised_by_navigator(err):
            raise err
        what = str(err) if isinstance(err, InvalidAnswer) else f"raised {type(err).__name__}: {err}"
        self._events.append((t, "warning", f"navigator {hook}: {what}; not recorded from here on"))

    def after_step(self, t: float) -> None:
        if callable(self._debug):
            try:
                draw = self._debug()
                if draw is not None:
                    self.drawings.append((t, check_debug(draw)))
            except BaseException as err:
                self._debug = None
                self._drop(t, "debug()", err)
        if callable(self._map) and t >= self._next_map - 1e-9:
            self._next_map = t + MAP_TRACE_PERIOD_S
            try:
                snap = crop_known(self._map())
                if snap is not None:
                    self.maps.append((t, *snap))
            except BaseException as err:
                self._map, self.map_dropped = None, True
                self._drop(t, "final_map()", err)


class RunWatcher(Protocol):
    """Something that follows a run as it goes (``run_mission(watch=...)``; the live view,
    :class:`navstress.run.live.LivePublisher`). It reads the run, never changes it."""

    def start(self, world: World, robot: RobotSpec, sim: Simulation) -> None: ...

    def update(self, sim: Simulation, obs: Any, navigator: Any, commands: list[tuple[float, float, float]],
               events: list[tuple[float, str, str]], view: NavigatorView | None) -> None: ...

    def finish(self, result: RunResult, view: NavigatorView | None) -> None: ...


def control_rate_hz(nav: Navigator) -> float:
    """The rate at which the framework calls ``step``: ``nav.control_rate_hz`` or
    ``nav.config.control_rate_hz`` if the navigator declares one, else 10 Hz."""
    rate = attr_through_wrappers(nav, "control_rate_hz")
    if rate is None:
        cfg = attr_through_wrappers(nav, "config")
        rate = getattr(cfg, "control_rate_hz", None)
    rate = float(rate) if rate is not None else DEFAULT_CONTROL_RATE_HZ
    return rate if math.isfinite(rate) and rate > 0 else DEFAULT_CONTROL_RATE_HZ


def mission_bounds(world: World, sim_config: Any = None) -> tuple[float, float, float, float]:
    """The mission area told to the navigator (``NavMission.bounds``): the map less the
    simulation's ``map_margin_m`` on every side, exactly where the simulation stops a robot
    whose centre leaves it (before MuJoCo would go unstable at the edge)."""
    m = float((sim_config if sim_config is not None else SimConfig()).map_margin_m)
    sx, sy = world.terrain.size_m  # the extent the simulation checks
    return (m, m, float(sx) - m, float(sy) - m)


def prior_map(world: World, cell_m: float) -> PriorMap:
    """The world's static obstacles as a :class:`~navstress.nav.api.PriorMap` of ``cell_m``
    cells over the whole world (origin (0, 0); :func:`navstress.world.freespace.rasterise`), for
    the optional hook ``prior_map``. This is ground truth: a navigator gets it only when its user
    chose to give it a map (the ``ros2`` navigator's ``map: world``, as a ROS 2 user gives Nav2's
    ``map_server`` a map file); a navigator never sees the world otherwise. ValueError, one line,
    for a cell size that is not positive or a map of more than :data:`MAX_PRIOR_MAP_CELLS` cells."""
    sx, sy = world.terrain.size_m  # the extent the simulation holds (as mission_bounds)
    if not (math.isfinite(cell_m) and cell_m > 0):
        raise ValueError(f"a prior map's cell size must be a positive number of metres, not {cell_m!r}")
    cells = math.ceil(sx / cell_m - 1e-9) * math.ceil(sy / cell_m - 1e-9)
    if cells > MAX_PRIOR_MAP_CELLS:
        raise ValueError(f"a prior map of the {sx:g} x {sy:g} m world at {cell_m:g} m would have {cells:,} cells, "
                         f"more than {MAX_PRIOR_MAP_CELLS:,}: use larger cells")
    return PriorMap(occupied=rasterise(world.obstacles, (float(sx), float(sy)), float(cell_m)), origin_xy=(0.0, 0.0),
                    cell_m=float(cell_m))


def true_pose(sim: Any) -> tuple[float, float, float, float, float, float, float]:
    """The chassis pose now, from the free joint's qpos (what the observer records)."""
    q = sim.data.qpos
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, q[3:7])
    yaw, pitch, roll = euler_from_mat(rot.reshape(3, 3))
    return (sim.t, float(q[0]), float(q[1]), float(q[2]), yaw, pitch, roll)


def run_mission(world: World, navigator: Navigator, *, run_seed: int, robot: Any = None,
                timeout_s: float = 400.0, goal_tolerance_m: float = 2.0, sim_config: Any = None,
                trace: TraceWriter | None = None, record_lidar: bool = False, record_navigator: bool = False,
                stop_on_collision: bool = True, watch: RunWatcher | None = None) -> RunResult:
    """Run ``navigator`` on ``world``'s mission in the simulation seeded by ``run_seed``.

    ``robot`` is the simulated truth: a :class:`RobotSpec`, a profile name (``"jackal"``), a
    robot file path or a mapping (:func:`navstress.run.robot.robot_of`; default ``rmp400``,
    the paper's robot); one the simulation cannot hold stable is refused before anything runs
    (:func:`navstress.run.robot.check_stable`). The navigator is told the same robot (a fault
    wrapper may change what it believes). The trace records it (name, digest, description). A collision ends the run by default
    (``stop_on_collision``: the operator's emergency stop), so Fail-Collision runs keep the
    time and place of their first collision. ``record_navigator`` records the navigator's own
    view (:class:`NavigatorView`) into the result and the trace. ``watch`` follows the run as it
    goes (:class:`RunWatcher`: the live view).
    """
    robot = robot_of(robot)
    cfg = sim_config if sim_config is not None else SimConfig()
    check_stable(robot, cfg)
    wall0 = time.perf_counter()
    events: list[tuple[float, str, str]] = []
    clouds: list[tuple[float, np.ndarray, tuple[float, float, float], tuple[float, float, float]]] = []
    error: str | None = None
    nav_failure = False
    arrived = timed_out = False
    other: list[str] = []
    commands: list[tuple[float, float, float]] = []  # (t, v, omega) as given to the robot
    left_area: str | None = None
    sim = None
    view: NavigatorView | None = None
    try:
        sim = Simulation(world, robot, cfg, seed=run_seed)
        mission = NavMission(start=world.mission.start, goal=world.mission.goal, goal_tolerance_m=goal_tolerance_m,
                             bounds=mission_bounds(world, cfg))
        period = 1.0 / control_rate_hz(navigator)
        jitter = rng(run_seed, "loop", "control")
        view = NavigatorView(navigator, events) if record_navigator else None
        want = attr_through_wrappers(navigator, "want_debug")
        try:
            if callable(want):
                want(bool(record_navigator))
        except BaseException as err:  # an optional hook: a warning, not the run's failure
            if not raised_by_navigator(err):
                raise
            events.append((0.0, "warning", f"navigator want_debug() raised {type(err).__name__}: {err}"))
        give_map = attr_through_wrappers(navigator, "prior_map")  # only a navigator told to take a map asks
        try:
            if callable(give_map):
                give_map(lambda cell_m: prior_map(world, cell_m))
        except BaseException as err:  # an optional hook: a warning, not the run's failure
            if not raised_by_navigator(err):
                raise
            events.append((0.0, "warning", f"navigator prior_map() raised {type(err).__name__}: {err}"))
        try:
            # the navigator learns the sensors at reset: the robot with its resolved suite, never None
            navigator.reset(mission, robot.model_copy(update={"sensors": sim.sensors}),
                            seed=derive_seed(run_seed, "navigator"))
        except BaseException as err:  # the stack under test failed (sys.exit included); record, don't crash
            if not raised_by_navigator(err):
                raise
            error, nav_failure = f"navigator reset raised {type(err).__name__}: {err}", True
        if watch is not None:
            watch.start(world, robot, sim)
        next_cloud_t = 0.0
        # every sensor but the default lidar, through its kind's trace encoder (SensorRecorder's policy)
        recorder = SensorRecorder(sim.sensors) if trace is not None else None
        while error is None:
            obs = sim.observe()
            if record_lidar:
                for scan in obs.scans:
                    if scan.sensor == FRAME_LIDAR and scan.t >= next_cloud_t - 1e-9 and len(scan.points):
                        clouds.append((scan.t, np.array(scan.points, dtype=np.float32), scan.mount, scan.rpy))
                        next_cloud_t = scan.t + LIDAR_TRACE_PERIOD_S
            if recorder is not None and trace is not None:
                for sensor, reading in recorder.take(obs.readings):
                    trace.reading(sensor, reading)
            try:
                out = check_answer(navigator.step(obs))
            except InvalidAnswer as err:
                error, nav_failure = f"navigator returned an invalid answer: {err}", True
                events.append((sim.t, "error", error))
                break
            except BaseException as err:
                if not raised_by_navigator(err):
                    raise
                error, nav_failure = f"navigator raised {type(err).__name__}: {err}", True
                events.append((sim.t, "error", error))
                break
            if view is not None:
                view.after_step(sim.t)
            if isinstance(out, Status):
                if out.kind == "arrived":
                    arrived = True
                    events.append((sim.t, "info", f"navigator: arrived {out.message}".rstrip()))
                else:
                    error, nav_failure = out.message or "navigator reported an error", out.infrastructure
                    events.append((sim.t, "error", f"navigator: {error}"))
                break
            try:
                sim.command(out)
                commands.append((sim.t, float(out.v), float(out.omega)))
            except NavstressError as err:
                error, nav_failure = f"navigator sent an invalid command: {err}", True
                events.append((sim.t, "error", error))
                break
            dt = period * (1.0 + CONTROL_JITTER * (2.0 * float(jitter.random()) - 1.0)) if cfg.jitter else period
            t_before = sim.t
            sim.advance(min(dt, timeout_s - sim.t))
            if watch is not None:
                watch.update(sim, obs, navigator, commands, events, view)
            if sim.observer.collisions and stop_on_collision:
                break
            if sim.stopped is not None:
                break
            # the clock moves in whole physics steps: less than half a step left is the end
            if sim.t >= timeout_s - cfg.timestep_s / 2 or sim.t == t_before:
                timed_out = True
                events.append((sim.t, "warning", f"timeout after {timeout_s:g} s"))
                break
    except SimulationError as err:
        other.append(str(err))
        events.append((sim.t if sim is not None else 0.0, "error", str(err)))
    finally:
        try:
            navigator.close()
        except BaseException as err:  # close must not lose the run
            if not raised_by_navigator(err):
                raise
            events.append((sim.t if sim is not None else 0.0, "warning", f"navigator close raised {err!r}"))
        events.extend(_run_notes(navigator, sim.t if sim is not None else 0.0))

    if sim is None:  # the world could not be simulated at all
        truth = np.zeros((0, 7))
        duration = 0.0
        goal_d = float("inf")
        collisions, collisions_hit, first_col = 0, 0, None
    else:
        final = true_pose(sim)
        obs_poses = sim.observer.poses
        truth = np.array(obs_poses)
        if not len(truth) or sim.t > truth[-1, 0] + 1e-9:
            truth = np.vstack([truth.reshape(-1, 7), np.array(final)[None, :]])
        p = final[1:4]
        duration = sim.t
        goal_d = math.hypot(float(p[0]) - world.mission.goal[0], float(p[1]) - world.mission.goal[1])
        collisions = len(sim.observer.collisions)
        collisions_hit = sum(c.robot_hit for c in sim.observer.collisions)
        first_col = sim.observer.collisions[0].t if collisions else None
        for c in sim.observer.collisions:
            if c.mover is not None:
                mk = world.movers[c.mover].kind if 0 <= c.mover < len(world.movers) else "?"
                how = "hit by" if c.robot_hit else "collision with"
                events.append((c.t, "warning", f"{how} mover {c.mover} ({mk}) at ({c.x:.2f}, {c.y:.2f}), relative "
                                               f"speed {c.relative_speed:.2f} m/s (robot {c.robot_speed:.2f}, "
                                               f"mover {c.mover_speed:.2f})"))
                continue
            kind = world.obstacles[c.obstacle].kind if 0 <= c.obstacle < len(world.obstacles) else "?"
            events.append((c.t, "warning", f"collision with obstacle {c.obstacle} ({kind}) at ({c.x:.2f}, {c.y:.2f})"))
        st = sim.stopped
        if st is not None and st.kind == "left_map":
            left_area = f"left the mission area (geofence) at t={st.t:.1f} s, ({st.x:.2f}, {st.y:.2f})"
            events.append((st.t, "error", left_area))
        elif st is not None:
            other.append(f"{st.reason} at t={st.t:.1f} s")
            events.append((st.t, "error", st.reason))

    facts = RunFacts(arrived=arrived, goal_distance_m=goal_d, goal_tolerance_m=goal_tolerance_m,
                     collisions=collisions, collisions_hit=collisions_hit, first_collision_s=first_col, error=error,
                     navigator_failure=nav_failure, timed_out=timed_out, other=tuple(other), left_area=left_area)
    cls = classify(facts)
    perceived = attr_through_wrappers(navigator, "perceived_trajectory")
    final_map = attr_through_wrappers(navigator, "final_map")
    try:
        perceived_arr = np.asarray(perceived(), dtype=np.float64).reshape(-1, 7) if callable(perceived) else None
    except BaseException as err:
        if not raised_by_navigator(err):
            raise
        perceived_arr = None
    try:
        fmap = check_map(final_map()) if callable(final_map) else None
    except BaseException as err:
        if not isinstance(err, InvalidAnswer) and not raised_by_navigator(err):
            raise
        fmap = None
        if view is None or not view.map_dropped:  # one warning per hook and run
            what = str(err) if isinstance(err, InvalidAnswer) else f"raised {type(err).__name__}: {err}"
            events.append((duration, "warning", f"navigator final_map(): {what}; the map is not recorded"))
    events.sort(key=lambda e: e[0])
    events.append((duration, "info", f"end of run: {cls.outcome.label}: {cls.reason}"))
    xy = drop_jitter(truth[:, 1:3], 0.02) if len(truth) else np.zeros((0, 2))
    result = RunResult(classification=cls, facts=facts, duration_s=duration, wall_s=time.perf_counter() - wall0,
                       truth=truth, perceived=perceived_arr, final_map=fmap, events=events,
                       path_length_m=path_length(xy), tortuousness=tortuousness(truth[:, 1:3]) if len(truth) else 0.0,
                       movers=sim.mover_track() if sim is not None and world.movers else None,
                       commands=np.array(commands, dtype=np.float64).reshape(-1, 3),
                       drawings=view.drawings if view is not None else [], maps=view.maps if view is not None else [])
    if watch is not None and sim is not None:
        watch.finish(result, view)
    if trace is not None:
        _write_trace(trace, world, result, robot)
        for t, pts, mount, rpy in clouds:
            trace.points(t, _to_map_frame(pts, mount, truth, t, rpy))
    return result


def _to_map_frame(pts: np.ndarray, mount: tuple[float, float, float], truth: np.ndarray, t: float,
                  rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Sensor-frame points into the map frame with the TRUE pose at ``t`` (interpolated between
    observer samples, 10 Hz: a few cm off while turning; for visualisation only); ``rpy``: the
    sensor's mount rotation (none for the default lidar)."""
    from scipy.spatial.transform import Rotation, Slerp  # here: runs that record no lidar never import it

    ts = truth[:, 0]
    k = int(np.clip(np.searchsorted(ts, t), 1, len(ts) - 1)) if len(ts) > 1 else 0
    if len(ts) > 1:
        a, b = truth[k - 1], truth[k]
        w = 0.0 if b[0] == a[0] else float(np.clip((t - a[0]) / (b[0] - a[0]), 0.0, 1.0))
        pos = a[1:4] + w * (b[1:4] - a[1:4])
        rots = Rotation.from_euler("ZYX", [a[4:7], b[4:7]])
        rot = Slerp([0.0, 1.0], rots)([w])[0]
    else:
        pos, rot = truth[0, 1:4], Rotation.from_euler("ZYX", truth[0, 4:7])
    local = np.asarray(pts, dtype=np.float64)
    if any(rpy):
        local = local @ rotation_rpy(*rpy).T
    local = local + np.asarray(mount)
    out: np.ndarray = (rot.apply(local) + pos).astype(np.float32)
    return out


def world_messages(tm: TraceMessages, world: World) -> None:
    """The world's messages (the trace's and the live view's): obstacles, start and goal; the
    height grid; the ground surface."""
    h, m, c = world.terrain.heights, world.mission, world.terrain.cell_m
    tm.scene([o.to_json() for o in world.obstacles], m.start, m.goal,
             (world.terrain.height_at(m.start[0], m.start[1]), world.terrain.height_at(m.goal[0], m.goal[1])))
    tm.grid(TOPIC_TERRAIN, 0.0, h, (-c / 2, -c / 2), c, field="height")
    tm.terrain(h, c)


def _write_trace(tw: TraceWriter, world: World, r: RunResult, robot: RobotSpec) -> None:
    world_messages(tw, world)
    tw.commands(r.commands)
    tw.poses(TOPIC_TRUTH, r.truth)
    tw.transforms(FRAME, FRAME_ROBOT, r.truth)
    belief = r.perceived is not None and len(r.perceived) > 0
    if r.perceived is not None and belief:
        tw.poses(TOPIC_PERCEIVED, r.perceived)
        tw.transforms(FRAME, BELIEF + FRAME_ROBOT, r.perceived)
    tw.robot(robot, belief=belief)
    for t, level, msg in r.events:
        tw.event(t, level, msg)
    for t, draw in r.drawings:
        tw.debug(t, draw)
    for t, grid, origin, cell in r.maps:
        tw.grid(TOPIC_MAP, t, grid, origin, cell)
    if r.final_map is not None:
        grid, origin, cell = r.final_map
        tw.grid(TOPIC_MAP, r.duration_s, np.asarray(grid, dtype=np.float32), origin, float(cell))
    if r.movers is not None:
        tw.movers(r.movers[0], r.movers[1], [(mv.id, mv.kind, mv.shape, mv.size) for mv in world.movers])


def source_fields(world: World) -> dict[str, str]:
    """A record's source fields for a run on ``world``: its source's kind, path and sha256 (an
    imported world), none for a generated world."""
    if world.source is None:
        return {}
    return {"source_kind": world.source.kind, "source_path": world.source.path, "source_sha256": world.source.sha256}


def execute(task: RunTask, watch: RunWatcher | None = None) -> RunRecord:
    """Run one planned run end to end and return its record; writes ``task.trace_path``.

    Never raises for a problem of the run itself; such problems are classified. Raises only
    for an unusable task (a world directory that cannot be loaded, an unknown navigator or
    fault): those are campaign errors, caught and recorded by the executors.
    """
    wall0 = time.perf_counter()
    world = World.load(task.world_dir)
    with warnings.catch_warnings():  # an unversioned name's note: the campaign said it once (check_runnable)
        warnings.simplefilter("ignore", NavigatorNote)
        nav = make_navigator(task.navigator, task.navigator_config or None, fault=task.fault)
    sim_cfg = None
    if task.sim_overrides:
        sim_cfg = SimConfig(**task.sim_overrides)
    robot = task.robot_spec()  # (an unusable robot is the task's error, as an unknown navigator)
    meta = {k: str(v) for k, v in {
        "run_id": task.run_id, "run_seed": task.run_seed, "map_seed": task.map_seed, "world_seed": world.seed,
        "navigator": task.navigator, "fault": task.fault or "", "timeout_s": task.timeout_s,
        "goal_tolerance_m": task.goal_tolerance_m}.items()}
    trace_path = Path(task.trace_path)
    tw = TraceWriter(trace_path, meta)
    try:
        res = run_mission(world, nav, run_seed=task.run_seed, robot=robot, timeout_s=task.timeout_s,
                          goal_tolerance_m=task.goal_tolerance_m, sim_config=sim_cfg, trace=tw,
                          record_lidar=task.record_lidar, record_navigator=task.record_navigator, watch=watch)
        tw.close()
    except BaseException:
        tw.abort()
        raise
    f = res.facts
    errors = [msg for _t, level, msg in res.events if level == "error"]
    return RunRecord(
        run_id=task.run_id, experiment=task.experiment, config=dict(task.config), map_index=task.map_index,
        run_index=task.run_index, map_seed=task.map_seed, run_seed=task.run_seed, navigator=task.navigator,
        fault=task.fault, outcome=res.classification.outcome.value, reason=res.classification.reason,
        duration_s=res.duration_s, wall_s=time.perf_counter() - wall0,
        goal_distance_m=f.goal_distance_m if math.isfinite(f.goal_distance_m) else math.nan,  # NaN = unknown
        path_length_m=res.path_length_m, tortuousness=res.tortuousness, collisions=f.collisions,
        first_collision_s=f.first_collision_s, errors=errors, trace=os.fspath(trace_path),
        robot=robot.name, robot_digest=robot.digest, **source_fields(world))
