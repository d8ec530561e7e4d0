"""A Simulation with declared ray sensors: readings by name in Observation.readings, the streams
keyed by each sensor's name, every sensor on its own schedule row at its own rate."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from navstress.errors import SpecError
from navstress.nav.api import Command, LaserScan, LidarScan
from navstress.robot import profile
from navstress.robot.files import with_sensors
from navstress.sim.config import SimConfig
from navstress.sim.simulation import Simulation
from navstress.world.spec import WorldSpec
from navstress.world.world import Mission, Obstacle, World

LASER = {"name": "front_laser", "kind": "lidar2d", "profile": "ust10"}


def _world() -> World:
    obs = (Obstacle("tree", 9.0, 5.0, 0.0, (1.0, 1.0, 2.0)), Obstacle("tree", 5.0, 8.5, 0.3, (1.0, 1.0, 2.0)))
    return World.flat(WorldSpec(size_m=(20.0, 20.0)), obstacles=obs,
                      mission=Mission(start=(5.0, 5.0, 0.0), goal=(15.0, 15.0), free_radius_m=1.0))


def _run(sensors: list[dict[str, Any]] | None, seed: int = 3, t: float = 1.0,
         config: SimConfig = SimConfig()) -> list[Any]:
    robot = profile("jackal") if sensors is None else with_sensors(profile("jackal"), sensors=sensors)
    sim = Simulation(_world(), robot, config, seed=seed)
    out = []
    for i in range(int(round(t / 0.1))):
        sim.command(Command(0.5, 0.2))
        sim.advance(0.1)
        out.append(sim.observe())
    return out


def test_a_jackal_with_a_ust10_gets_laser_scans_by_name() -> None:
    obs = _run([LASER])
    last = obs[-1]
    assert set(last.readings) >= {"odom", "imu", "front_laser"} and last.scans == ()
    assert last.readings["odom"] == (last.odom,) and last.readings["imu"] == (last.imu,)
    scans = [s for o in obs for s in o.readings["front_laser"]]
    assert all(isinstance(s, LaserScan) for s in scans)
    assert len(scans) == pytest.approx(40, abs=2)  # 40 Hz for 1 s (rate jitter)
    s = scans[-1]
    assert s.ranges.dtype == np.float32 and s.ranges.shape == (1081,) and s.sensor == "front_laser"
    assert s.angle_min == pytest.approx(-0.75 * math.pi) and s.range_max == 10.0
    assert s.mount == profile("jackal").mounts["lidar"].xyz and s.rpy == (0.0, 0.0, 0.0)
    assert np.isfinite(s.ranges).sum() > 10  # the trees
    assert np.all(np.diff([x.t for x in scans]) > 0)
    assert last.latest("front_laser") is last.readings["front_laser"][-1]
    poses = [o for o in obs if o.pose is not None]
    assert poses and all(o.readings["pose"] == (o.pose,) for o in poses)
    assert all("pose" not in o.readings for o in obs if o.pose is None)


def test_the_default_lidar_is_in_readings_and_scans() -> None:
    obs = _run(None)
    scans = [s for o in obs for s in o.scans]
    assert len(scans) == pytest.approx(10, abs=1)
    assert [s for o in obs for s in o.readings.get("lidar", ())] == scans
    assert all(isinstance(s, LidarScan) and s.sensor == "lidar" for s in scans)


def _ranges(obs: list[Any], name: str) -> list[tuple[float, bytes]]:
    return [(s.t, s.ranges.tobytes() if isinstance(s, LaserScan) else s.points.tobytes())
            for o in obs for s in o.readings.get(name, ())]


def test_same_seed_same_readings_and_another_seed_others() -> None:
    a, b, c = _run([LASER], 3), _run([LASER], 3), _run([LASER], 4)
    assert _ranges(a, "front_laser") == _ranges(b, "front_laser")
    assert _ranges(a, "front_laser") != _ranges(c, "front_laser")


def test_a_second_sensor_leaves_the_first_ones_readings_alone() -> None:
    """Streams keyed by name: adding a sensor (before or after) changes nothing of the first one."""
    noisy = dict(LASER, dropout_prob=0.05)
    other = {"name": "rear", "kind": "lidar2d", "profile": "rplidar_a2", "dropout_prob": 0.1,
             "mount": {"xyz": [-0.1, 0.0, 0.35], "rpy": [0.0, 0.0, math.pi]}}
    alone = _ranges(_run([noisy]), "front_laser")
    assert _ranges(_run([noisy, other]), "front_laser") == alone
    assert _ranges(_run([other, noisy]), "front_laser") == alone


def test_sensors_fire_at_their_own_rates() -> None:
    sensors = [{"name": f"s{int(hz)}", "kind": "lidar2d", "profile": "rplidar_a2", "rate_hz": hz, "beams": 40}
               for hz in (5.0, 10.0, 25.0, 50.0)]
    sensors.append({"name": "l3", "kind": "lidar3d", "channels": 4, "azimuth_steps": 36, "rate_hz": 20.0})
    obs = _run(sensors, t=2.0, config=SimConfig(jitter=False))
    for s in sensors:
        ts = [r.t for o in obs for r in o.readings.get(str(s["name"]), ())]
        assert len(ts) == pytest.approx(2.0 * float(s["rate_hz"]), abs=1), s["name"]
        assert np.allclose(np.diff(ts), 1.0 / float(s["rate_hz"]), atol=1e-9)
    assert len([r for o in obs for r in o.scans]) == len([r for o in obs for r in o.readings["l3"]])


def test_lidar_off_casts_nothing_and_nine_sensors_are_refused() -> None:
    obs = _run([LASER], config=SimConfig(lidar_enabled=False))
    assert all(set(o.readings) <= {"odom", "imu", "pose"} for o in obs)
    with pytest.raises(SpecError):
        _run([{"name": f"s{i}", "kind": "lidar2d"} for i in range(9)])
