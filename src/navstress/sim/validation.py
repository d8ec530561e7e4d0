"""The validation course: a robot driven through a few legs on flat ground (and one on the paper's
rough terrain), its true body rates compared with the commanded twist and its odometry with the
truth (``navstress robot check``; docs/simulation.md, "Drive types").

Legs (each from a standstill, in a simulation of its own, sensors without noise or jitter):

* ``stand``: no command; the body must stay still and not rock (pitch swing).
* ``cruise``: the robot's top speed straight ahead; speed tracked, no pitch oscillation, odometry
  position error bounded.
* ``turn-left``: half the top speed and half the top turn rate (an Ackermann base: at most 80 % of
  its tightest turn at that speed); both rates tracked, odometry heading ratio bounded.
* ``spin``: a turn in place at half the top turn rate (an Ackermann base cannot turn in place:
  ``turn-right`` instead, the mirror of ``turn-left``).
* ``rough``: half the top speed straight ahead over the paper's rough terrain (subdivide s=4 d=2 m,
  100 m map, seed 1) for 10 s: stable, i.e. no physics instability, no tip-over, no body speed
  beyond :data:`ROUGH_MAX_SPEED_FACTOR` times the commanded one (plus 1 m/s). Whether the base climbs
  every slope is the terrain's question, not the simulator's: not judged.

Rates are measured over the steady part of a leg (after the ramp at the robot's acceleration
limits, the command latency and :data:`SETTLE_S`): ``measured_v`` the mean forward speed (body x),
``measured_w`` the mean yaw rate (the heading change over the window).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np

from navstress.errors import SimulationError
from navstress.nav.api import Command
from navstress.robot import RobotSpec
from navstress.sim.config import SimConfig
from navstress.sim.drives import ACKERMANN, DIFFERENTIAL, drive_model
from navstress.sim.simulation import Simulation
from navstress.sim.suite import effective_config
from navstress.world.world import World

#: Speed tracking: |measured - commanded| <= max(V_TOL_MPS, V_TOL_REL * |commanded|).
V_TOL_MPS, V_TOL_REL = 0.03, 0.05
#: Turn-rate tracking: |measured - commanded| <= max(W_TOL_RPS, W_TOL_REL * |commanded|).
W_TOL_RPS, W_TOL_REL = 0.05, 0.08
#: No pitch oscillation on flat ground: the pitch swing (max - min over the steady part) at most
#: this (the RMP 400 swings 0.09 deg cruising), and the pitch itself at most PITCH_MAX_DEG.
PITCH_SWING_MAX_DEG = 0.5
PITCH_MAX_DEG = 2.0
#: Odometry heading ratio (odometry turn / true turn) within 1 +- this, per drive: a
#: differential base's wheels do not slide (a few percent); an Ackermann base's heading comes from
#: its steering angle; a skid steer's from a calibrated effective track, which holds only as
#: well as the multiplier fits the turn (docs/simulation.md: measured 0.9 .. 1.1).
ODOM_HEADING_TOL = {"differential": 0.03, "ackermann": 0.05, "skid-steer": 0.15}
#: Odometry position error at a leg's end at most ODOM_POS_REL * distance + ODOM_POS_M.
ODOM_POS_REL, ODOM_POS_M = 0.05, 0.05
#: Rough terrain: the forward speed at most this times the commanded one plus 1 m/s (no blow-up).
ROUGH_MAX_SPEED_FACTOR = 3.0
#: Seconds after the ramp before the steady window; the window's length (quick: half).
SETTLE_S, WINDOW_S = 1.0, 2.0
ROUGH_S = 10.0
#: A turn smaller than this (rad) has no odometry heading ratio.
MIN_TURN_RAD = 0.2
_SAMPLE_S = 0.02


@dataclass(frozen=True)
class CheckLeg:
    """One leg of the course: commanded and measured rates, odometry and pitch, verdict."""

    name: str
    commanded_v: float
    commanded_w: float
    measured_v: float
    measured_w: float
    v_error: float
    w_error: float
    odom_heading_ratio: float | None
    odom_position_error_m: float
    max_pitch_deg: float
    pitch_swing_deg: float
    passed: bool
    why: str


@dataclass(frozen=True)
class RobotCheck:
    """The course's result for one robot."""

    robot: str
    digest: str
    timestep_s: float
    legs: tuple[CheckLeg, ...]
    passed: bool

    def problems(self) -> list[str]:
        """One line per failed leg."""
        return [f"{self.robot}: leg {leg.name}: {leg.why}" for leg in self.legs if not leg.passed]


def _course_config(config: SimConfig | None) -> SimConfig:
    cfg = config if config is not None else SimConfig()
    return replace(cfg, lidar_enabled=False, noise=False, jitter=False)


@functools.lru_cache(maxsize=2)
def _flat(size: float) -> World:
    from navstress.world.spec import WorldSpec  # world data only when a check runs

    return World.flat(WorldSpec(size_m=(size, size)))


@functools.lru_cache(maxsize=1)
def _rough() -> World:
    from navstress.world.generate import generate  # the generator only for the rough leg
    from navstress.world.spec import parse_spec  # (as above)

    return generate(parse_spec({"size_m": [100, 100], "ground": {"subdivisions": 4, "deformation": 2.0}}), 1)


def _yaw_pitch(q: np.ndarray) -> tuple[float, float]:
    w, x, y, z = (float(v) for v in q[3:7])
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - x * z))))
    return yaw, pitch


def _leg(robot: RobotSpec, cfg: SimConfig, name: str, v: float, w: float, quick: bool) -> CheckLeg:
    """Drive one leg and judge it."""
    rough = name == "rough"
    world = _rough() if rough else _flat(120.0)
    sx, sy = (50.0, 50.0) if rough else (60.0, 60.0)
    syaw = 0.0
    ramp = max(abs(v) / robot.max_accel_mps2, abs(w) / robot.max_yaw_accel_rps2) + cfg.command_latency_s
    if robot.drive == "ackermann":
        assert robot.max_steer_rad is not None and robot.max_steer_rate_rps is not None
        ramp += robot.max_steer_rad / robot.max_steer_rate_rps
    settle = SETTLE_S / (2 if quick else 1)
    window = (ROUGH_S if rough else WINDOW_S) / (2 if quick else 1)
    t_total = ramp + settle + window
    fails: list[str] = []
    sim = Simulation(world, robot, cfg, seed=0, start=(sx, sy, syaw))
    q0 = sim.data.qpos.copy()
    o0 = sim.observe().odom
    sim.command(Command(v, w))
    yaws, pitches, fwd, xy = [], [], [], []
    unwrapped, last = 0.0, _yaw_pitch(q0)[0]
    try:
        while sim.t < t_total - 1e-9 and sim.stopped is None:
            sim.advance(_SAMPLE_S)
            q, qv = sim.data.qpos, sim.data.qvel
            yaw, pitch = _yaw_pitch(q)
            unwrapped += (yaw - last + math.pi) % (2 * math.pi) - math.pi
            last = yaw
            if sim.t >= ramp + settle - 1e-9 or (name == "stand" and sim.t >= 0.5):
                yaws.append(unwrapped)
                pitches.append(math.degrees(pitch))
                fwd.append(float(qv[0]) * math.cos(yaw) + float(qv[1]) * math.sin(yaw))
                xy.append((float(q[0]), float(q[1])))
    except SimulationError as err:
        fails.append(f"the simulation became unstable ({err})")
    if sim.stopped is not None:
        fails.append(f"the run stopped: {sim.stopped.reason}")
    n = len(yaws)
    ts = _SAMPLE_S * max(n - 1, 1)
    mv = float(np.mean(fwd)) if n else float("nan")
    mw = (yaws[-1] - yaws[0]) / ts if n > 1 else float("nan")
    q1 = sim.data.qpos
    o1 = sim.observe().odom
    true_turn = unwrapped
    odom_turn = o1.yaw - o0.yaw
    odom_turn = odom_turn + 2 * math.pi * round((true_turn - odom_turn) / (2 * math.pi))
    ratio = odom_turn / true_turn if abs(true_turn) > MIN_TURN_RAD else None
    # displacements in each one's start frame
    dx, dy = float(q1[0] - q0[0]), float(q1[1] - q0[1])
    c, s = math.cos(syaw), math.sin(syaw)
    tx, ty = c * dx + s * dy, -s * dx + c * dy
    co, so = math.cos(o0.yaw), math.sin(o0.yaw)
    ox, oy = co * (o1.x - o0.x) + so * (o1.y - o0.y), -so * (o1.x - o0.x) + co * (o1.y - o0.y)
    pos_err = math.hypot(tx - ox, ty - oy)
    dist = sum(math.dist(a, b) for a, b in zip(xy, xy[1:])) if xy else 0.0
    dist += abs(v) * (ramp + settle) / 2  # about the distance before the window
    ve, we = abs(mv - v), abs(mw - w)
    max_pitch = float(np.max(np.abs(pitches))) if pitches else float("nan")
    swing = float(np.max(pitches) - np.min(pitches)) if pitches else float("nan")
    if not fails and n > 1:
        if rough:  # stable: no blow-up (a body far faster than commanded), no tip-over (above)
            top = float(np.max(np.abs(fwd)))
            if not top <= ROUGH_MAX_SPEED_FACTOR * abs(v) + 1.0:
                fails.append(f"body speed {top:.2f} m/s on rough ground for {v:.2f} commanded")
        else:
            vt, wt = max(V_TOL_MPS, V_TOL_REL * abs(v)), max(W_TOL_RPS, W_TOL_REL * abs(w))
            if not ve <= vt:
                fails.append(f"speed {mv:.3f} m/s for {v:.3f} commanded (error {ve:.3f} > {vt:.3f})")
            if not we <= wt:
                fails.append(f"turn rate {mw:.3f} rad/s for {w:.3f} commanded (error {we:.3f} > {wt:.3f})")
            if name in ("stand", "cruise"):
                if not swing <= PITCH_SWING_MAX_DEG:
                    fails.append(f"pitch swings {swing:.2f} deg on flat ground (at most {PITCH_SWING_MAX_DEG})")
                if not max_pitch <= PITCH_MAX_DEG:
                    fails.append(f"pitch {max_pitch:.2f} deg on flat ground (at most {PITCH_MAX_DEG})")
            tol = ODOM_HEADING_TOL[robot.drive]
            if ratio is not None and not abs(ratio - 1.0) <= tol:
                fails.append(f"odometry heading {ratio:.3f} of the true turn (1 +- {tol})")
            if name == "cruise" and not pos_err <= ODOM_POS_REL * dist + ODOM_POS_M:
                fails.append(f"odometry position error {pos_err:.3f} m over {dist:.2f} m "
                             f"(at most {ODOM_POS_REL:.0%} + {ODOM_POS_M} m)")
    elif not fails:
        fails.append("no steady samples")
    return CheckLeg(name=name, commanded_v=v, commanded_w=w, measured_v=mv, measured_w=mw, v_error=ve,
                    w_error=we, odom_heading_ratio=ratio, odom_position_error_m=pos_err,
                    max_pitch_deg=max_pitch, pitch_swing_deg=swing, passed=not fails, why="; ".join(fails))


def course(robot: RobotSpec) -> list[tuple[str, float, float]]:
    """The legs (name, v, w) of ``robot``'s course."""
    vmax, wmax = robot.max_speed_mps, robot.max_yaw_rate_rps
    vt, wt = 0.5 * vmax, 0.5 * wmax
    legs = [("stand", 0.0, 0.0), ("cruise", vmax, 0.0)]
    if drive_model(robot).kind == ACKERMANN:
        assert robot.max_steer_rad is not None
        wt = min(wt, 0.8 * vt * math.tan(robot.max_steer_rad) / robot.wheelbase_m)
        legs += [("turn-left", vt, wt), ("turn-right", vt, -wt)]
    else:
        legs += [("turn-left", vt, wt), ("spin", 0.0, wt)]
    legs.append(("rough", vt, 0.0))
    return legs


def check_robot(robot: RobotSpec, config: SimConfig | None = None, *, quick: bool = False) -> RobotCheck:
    """Drive ``robot`` through the validation course (``quick``: half-length legs)."""
    cfg = _course_config(config)
    legs = tuple(_leg(robot, cfg, name, v, w, quick) for name, v, w in course(robot))
    return RobotCheck(robot=robot.name, digest=robot.digest, timestep_s=effective_config(robot, cfg).timestep_s,
                      legs=legs, passed=all(leg.passed for leg in legs))


_STABLE: dict[tuple[str, SimConfig], str] = {}


def require_stable(robot: RobotSpec, config: SimConfig | None = None) -> None:
    """SimulationError/SpecError (one line) when the simulation cannot hold this robot stable on flat
    ground at its own top speed; cached per robot digest (cheap after the first call)."""
    cfg = _course_config(config)
    key = (robot.digest, cfg)
    why = _STABLE.get(key)
    if why is None:
        legs = [_leg(robot, cfg, name, v, w, True) for name, v, w in course(robot)[:2]]
        why = "; ".join(f"{leg.name}: {leg.why}" for leg in legs if not leg.passed)
        _STABLE[key] = why
    if why:
        raise SimulationError(f"robot {robot.name!r} is not simulated stably on flat ground at its top speed "
                              f"({why}); check its mass, wheels and limits with `navstress robot check`")
