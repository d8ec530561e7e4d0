"""Drive types against analytic kinematics (tests/oracles/kinematics.py), over families of bases.

Each example is one short simulation (a few seconds of simulated time, well under a second of
wall time); the families are hypothesis strategies over sizes, masses and speeds with few examples.
"""

from __future__ import annotations

import hashlib
import math

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from navstress.errors import SimulationError, SpecError
from navstress.nav.api import Command
from navstress.robot import PROFILES, Footprint, Mount, RobotSpec
from navstress.sim import SimConfig, Simulation
from navstress.sim.config import MOVED_TO_ROBOT
from navstress.sim.drives import ACKERMANN, DIFFERENTIAL, SKID_STEER, drive_model, skid_steer
from navstress.sim.model import _robot_xml, build_model
from navstress.world.world import Obstacle

from tests.oracles.kinematics import (ackermann_angles, bicycle_steer, bicycle_yaw_rate, coulomb_track_multiplier,
                                      unicycle)
from tests.support.sim_worlds import flat

CFG = SimConfig(lidar_enabled=False, noise=False, jitter=False)
FAMILY = settings(max_examples=4, deadline=None, derandomize=True,
                  suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


def _robot(**kw: object) -> RobotSpec:
    """A valid robot: the lidar on top of the body."""
    h = float(kw.setdefault("body_height_m", 0.3))  # type: ignore[arg-type]
    c = float(kw.setdefault("ground_clearance_m", 0.1))  # type: ignore[arg-type]
    r = float(kw["wheel_radius_m"])  # type: ignore[arg-type]
    kw.setdefault("mounts", {"lidar": Mount(xyz=(0.0, 0.0, c + h - r + 0.05))})
    kw.setdefault("wheel_torque_nm", None)
    kw.setdefault("wheel_kv", None)
    kw.setdefault("wheel_armature_kgm2", None)
    kw.setdefault("track_multiplier", None)
    return RobotSpec(name="family", **kw)  # type: ignore[arg-type]


def _drive(robot: RobotSpec, v: float, w: float, settle: float, window: float) -> dict[str, float]:
    """Command (v, w) from a standstill; after ``settle`` s, the true pose and the odometry over
    ``window`` s: start and end pose, odometry turn, true turn."""
    sim = Simulation(flat(80.0), robot, CFG, seed=0, start=(40.0, 40.0, 0.0))
    sim.command(Command(v, w))
    sim.advance(settle)

    def pose() -> tuple[float, float, float]:
        q = sim.data.qpos
        yaw = math.atan2(2 * (q[3] * q[6] + q[4] * q[5]), 1 - 2 * (q[5] ** 2 + q[6] ** 2))
        return float(q[0]), float(q[1]), yaw

    p0, o0 = pose(), sim.observe().odom
    turn, last, pitch = 0.0, p0[2], []
    steps = int(round(window / 0.02))
    for _ in range(steps):
        sim.advance(0.02)
        p = pose()
        turn += (p[2] - last + math.pi) % (2 * math.pi) - math.pi
        last = p[2]
        q = sim.data.qpos
        pitch.append(math.degrees(math.asin(max(-1.0, min(1.0, 2 * (q[3] * q[5] - q[4] * q[6]))))))
    p1, o1 = pose(), sim.observe().odom
    oturn = o1.yaw - o0.yaw
    oturn += 2 * math.pi * round((turn - oturn) / (2 * math.pi))
    ex = unicycle(p0, v, w, steps * 0.02)
    return {"turn": turn, "odom_turn": oturn, "w": turn / (steps * 0.02), "pos_err": math.dist(ex[:2], p1[:2]),
            "dist": v * steps * 0.02, "swing": max(pitch) - min(pitch), "moved": math.dist(p0[:2], p1[:2])}


# ---- differential --------------------------------------------------------------------------------

@FAMILY
@given(track=st.floats(0.2, 0.6), mass=st.floats(2.0, 40.0), radius=st.floats(0.03, 0.12),
       v=st.floats(0.1, 0.6), wf=st.floats(0.2, 1.0), gyro=st.booleans())
def test_differential_follows_the_unicycle_and_its_odometry_heading(track: float, mass: float, radius: float,
                                                                      v: float, wf: float, gyro: bool) -> None:
    """Commanded (v, w) is the unicycle's motion within the validation tolerances; the wheel
    odometry's heading is the true turn within 3 %."""
    w = wf * 2 * v / track  # the inner wheel still rolls forward
    r = _robot(drive="differential", length_m=track + 0.1, width_m=track + 0.1, mass_kg=mass,
               wheel_radius_m=radius, wheel_width_m=0.03, wheelbase_m=0.0, track_m=track, wheels_per_side=1,
               caster_positions=((track / 2, 0.0),), ground_clearance_m=radius / 4, body_height_m=0.2,
               gyro=gyro, max_speed_mps=1.0, max_yaw_rate_rps=4.0, max_accel_mps2=1.0, max_yaw_accel_rps2=4.0)
    assert drive_model(r).kind == DIFFERENTIAL
    out = _drive(r, v, w, 2.5, 2.0)
    assert abs(out["w"] - w) <= max(0.05, 0.08 * w), out
    assert out["pos_err"] <= 0.05 * out["dist"] + 0.03, out
    assert abs(out["odom_turn"] / out["turn"] - 1.0) <= 0.03, out


# ---- skid steer ----------------------------------------------------------------------------------

@FAMILY
@given(n=st.integers(2, 4), ratio=st.floats(0.5, 1.3), track=st.floats(0.35, 0.8), mass=st.floats(10.0, 80.0),
       radius=st.floats(0.08, 0.3), vf=st.floats(0.0, 1.0))
def test_skid_steer_tracks_the_commanded_twist_and_bounds_its_odometry(n: int, ratio: float, track: float,
                                                                       mass: float, radius: float, vf: float) -> None:
    """A skid steer of 2..4 wheels a side tracks (v, w) (gyro PI on the derived multiplier) and its
    odometry heading (the derived effective track) stays within 15 % of the truth."""
    v, w = 0.6 * vf, 1.0
    r = _robot(drive="skid-steer", length_m=ratio * track + 2 * radius + 0.05, width_m=track + 0.15, mass_kg=mass,
               wheel_radius_m=radius, wheel_width_m=0.06, wheelbase_m=ratio * track, track_m=track,
               wheels_per_side=n, max_speed_mps=1.2, max_yaw_rate_rps=2.0, max_accel_mps2=2.0,
               max_yaw_accel_rps2=4.0)
    dm = drive_model(r)
    assert dm.kind == SKID_STEER and len(dm.wheels) == 2 * n
    out = _drive(r, v, w, 3.0, 2.0)
    assert abs(out["w"] - w) <= max(0.05, 0.08 * w), out
    assert abs(out["odom_turn"] / out["turn"] - 1.0) <= 0.15, out


def test_skid_steer_calibration_follows_the_geometry() -> None:
    """The derived multiplier grows with wheelbase/track (the Coulomb formula's direction), is 1
    with one wheel a side, and the Coulomb formula is the textbook one; Clearpath's firmware
    figures lie near it (Husky 1.875, Jackal 1.5: docs/simulation.md)."""
    assert coulomb_track_multiplier(0.31, 0.275) == pytest.approx(skid_steer.coulomb_multiplier(RobotSpec()))
    # (Husky: 1.80 with the URDF's track 0.5708 m, 4 % under its firmware's 1.875)
    assert skid_steer.coulomb_multiplier(PROFILES["husky"]) == pytest.approx(1.875, rel=0.05)
    assert skid_steer.coulomb_multiplier(PROFILES["jackal"]) == pytest.approx(1.5, abs=0.03)
    ms = [skid_steer.derived_multiplier(RobotSpec(wheelbase_m=k * 0.55, track_multiplier=None))
          for k in (0.2, 0.5, 0.8, 1.0, 1.5, 2.0)]
    assert all(a < b for a, b in zip(ms, ms[1:])) and ms[0] > 1.0
    one = RobotSpec(wheels_per_side=1, wheelbase_m=0.0, track_multiplier=None)
    assert skid_steer.derived_multiplier(one) == 1.0
    assert drive_model(RobotSpec()).track_multiplier == 3.4  # the RMP 400 keeps its calibrated figure


# ---- ackermann -----------------------------------------------------------------------------------

@FAMILY
@given(wheelbase=st.floats(0.25, 2.5), tf=st.floats(0.5, 0.9), mass=st.floats(2.0, 400.0),
       steer=st.floats(0.3, 0.6), v=st.floats(0.5, 2.5), frac=st.floats(0.2, 0.8), drive=st.sampled_from(["rear", "all"]))
def test_ackermann_follows_the_bicycle_model(wheelbase: float, tf: float, mass: float, steer: float, v: float,
                                             frac: float, drive: str) -> None:
    """A commanded (v, w) within reach turns at the bicycle model's rate for the steering angle
    atan(L w / v); the front wheels take their Ackermann angles; the odometry heading (steering
    angle and rear wheels) is the true turn within 5 %."""
    track = tf * wheelbase
    radius = 0.05 + 0.05 * wheelbase
    w = frac * bicycle_yaw_rate(v, steer, wheelbase)
    r = _robot(drive="ackermann", length_m=wheelbase + 2 * radius + 0.1, width_m=track + 0.1, mass_kg=mass,
               wheel_radius_m=radius, wheel_width_m=0.05, wheelbase_m=wheelbase, track_m=track,
               max_steer_rad=steer, max_steer_rate_rps=3.0, drive_wheels=drive, gyro=False,
               ground_clearance_m=radius / 2, body_height_m=0.2, max_speed_mps=3.0, max_yaw_rate_rps=6.0,
               max_accel_mps2=3.0, max_yaw_accel_rps2=10.0)
    assert drive_model(r).kind == ACKERMANN
    sim = Simulation(flat(80.0), r, CFG, seed=0, start=(40.0, 40.0, 0.0))
    sim.command(Command(v, w))
    sim.advance(2.0)
    delta = bicycle_steer(v, w, wheelbase)
    left, right = ackermann_angles(delta, wheelbase, track)
    np.testing.assert_allclose(sim.data.qpos[sim.rm.steer_qpos], [left, right], atol=0.02)
    out = _drive(r, v, w, 2.0, 1.5)
    assert abs(out["w"] - w) <= max(0.05, 0.08 * w), out
    assert abs(out["odom_turn"] / out["turn"] - 1.0) <= 0.05, out


def test_ackermann_cannot_turn_in_place() -> None:
    """(0, w): the wheels steer to full lock toward the turn, the base neither moves nor turns."""
    r = PROFILES["f1tenth"]
    sim = Simulation(flat(), r, CFG, seed=0, start=(20.0, 20.0, 0.0))
    q0 = sim.data.qpos.copy()
    sim.command(Command(0.0, 1.5))
    sim.advance(2.0)
    assert math.dist(q0[:2], sim.data.qpos[:2]) < 0.01 and abs(sim.data.qvel[5]) < 0.01
    assert r.max_steer_rad is not None
    lock = ackermann_angles(r.max_steer_rad, r.wheelbase_m, r.track_m)  # the bicycle angle at its limit
    np.testing.assert_allclose(sim.data.qpos[sim.rm.steer_qpos], lock, atol=0.01)


# ---- footprint shapes, stability, identity, config --------------------------------------------

@pytest.mark.parametrize("footprint, front", [
    (Footprint(), 0.5), (Footprint(shape="circle", radius_m=0.45), 0.45),
    (Footprint(shape="polygon", points=((0.6, 0.0), (-0.4, 0.4), (-0.4, -0.4))), 0.6)])
def test_the_bumper_is_the_footprint(footprint: Footprint, front: float) -> None:
    """Driving into a wall, the robot touches it when its footprint's front reaches it."""
    wall = Obstacle(kind="wall", x=25.0, y=20.0, size=(0.4, 6.0, 1.0), yaw=0.0, z=0.0)
    r = RobotSpec(name="shape", length_m=1.0, width_m=0.8, footprint=footprint, mounts={})
    sim = Simulation(flat(40.0, (wall,)), r, CFG, seed=0, start=(20.0, 20.0, 0.0))
    sim.command(Command(0.5, 0.0))
    for _ in range(200):
        sim.advance(0.05)
        if sim.observer.collisions:
            break
    hit = sim.observer.collisions[0]
    assert hit.x + front == pytest.approx(25.0 - 0.2, abs=0.05)


def test_rmp400_model_is_byte_identical() -> None:
    """RobotSpec()'s MJCF is main 52e4431's, byte for byte (sha256 prefixes computed there)."""
    b, a = _robot_xml(RobotSpec(), SimConfig(), (1.0, 2.0, 0.5, 0.3))
    assert hashlib.sha256((b + a).encode()).hexdigest()[:16] == "2b747f30504f63f8"
    b, a = _robot_xml(RobotSpec(), SimConfig(), (1.0, 2.0, 0.5, 0.3), movers=True)
    assert hashlib.sha256((b + a).encode()).hexdigest()[:16] == "a788d0d3087fc745"


@pytest.mark.parametrize("key", sorted(MOVED_TO_ROBOT))
def test_drive_figures_in_sim_are_refused_naming_the_robot_field(key: str) -> None:
    with pytest.raises(SpecError, match=rf"sim\.{key}=.*set robot\.{MOVED_TO_ROBOT[key]} instead") as err:
        SimConfig.from_mapping({key: 1.0})
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_every_profile_has_a_wheel_table_and_builds(name: str) -> None:
    r = PROFILES[name]
    dm = drive_model(r)
    rm = build_model(flat(), r, CFG, (20.0, 20.0, 0.0))
    assert len(rm.wheel_bodies) == len(dm.wheels) and rm.model.nu == len(dm.driven) + len(rm.steer_qpos)
    assert dm.timestep_s in (0.01, 0.005)
    g = mujoco.mj_name2id(rm.model, mujoco.mjtObj.mjOBJ_GEOM, "bumper")
    assert g == rm.bumper_geom


def test_unstable_robot_is_refused_and_the_verdict_cached() -> None:
    """A skid steer with one wheel a side has nothing to stand on but its belly: it cannot cruise."""
    from navstress.sim.validation import _STABLE, require_stable

    r = RobotSpec(name="wobbly", wheels_per_side=1, wheelbase_m=0.0, track_multiplier=None, wheel_torque_nm=2.0)
    with pytest.raises(SimulationError, match="not simulated stably") as err:
        require_stable(r)
    assert "\n" not in str(err.value)
    assert any(k[0] == r.digest for k in _STABLE)
    with pytest.raises(SimulationError):
        require_stable(r)
    require_stable(RobotSpec())  # the paper's robot is
