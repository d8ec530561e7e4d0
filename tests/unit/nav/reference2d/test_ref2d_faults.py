"""Every fault applies to a robot with a 2D scanner and to reference-2d-v1: the scan faults act
on every ray sensor's readings (by name), with the default lidar's draws unchanged."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pytest

from navstress.nav.api import Command, Imu, LaserScan, LidarScan, NavMission, Observation, Odometry, Status
from navstress.nav.faults import DelayedScans, DroppedScans, FaultyNavigator, OdometryScale, apply_fault, list_faults
from navstress.nav.registry import make_navigator
from navstress.robot import RobotSpec
from tests.support.laser_synth import Layout, drive, jackal

MISSION = NavMission((0.0, 0.0, 0.0), (10.0, 0.0))
EMPTY = np.zeros((0, 3), dtype=np.float32)


class Spy:
    def __init__(self, config: Mapping[str, Any] | None = None) -> None:
        self.robot: RobotSpec | None = None
        self.seen: list[Observation] = []

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self.robot, self.seen = robot, []

    def step(self, obs: Observation) -> Command | Status:
        self.seen.append(obs)
        return Command(0.0, 0.0)

    def close(self) -> None: ...


def laser(t: float, name: str = "front_laser") -> LaserScan:
    return LaserScan(t, np.ones(5, np.float32), -1.0, 0.5, 0.1, 10.0, (0.1, 0.0, 0.3), (0.0, 0.0, 0.0), name)


def obs_at(k: int, *, lidar: int = 1, lasers: int = 2, readings: bool = True, depth_named: str | None = None) -> Observation:
    """Observation k: ``lidar`` default-lidar scans (also in ``scans``) and ``lasers`` 2D scans
    of ``front_laser`` and of ``rear_laser``."""
    t = 0.1 * k
    odom = Odometry(t, 0.1 * k, 0.0, 0.0, 1.0, 0.0)
    imu = Imu(t, 0.0, 0.0, 0.0, (0.0, 0.0, 0.0))
    scans = tuple(LidarScan(t + 0.001 * j, EMPTY, (0.0, 0.0, 1.0)) for j in range(lidar))
    r: dict[str, tuple[Any, ...]] = {"odom": (odom,), "imu": (imu,)}
    if readings:
        if scans:
            r["lidar"] = scans
        for name in ("front_laser", "rear_laser"):
            if lasers:
                r[name] = tuple(laser(t + 0.002 * j, name) for j in range(lasers))
    return Observation(t, odom, imu, None, scans, r)


def run(fault: Any, n: int = 400, seed: int = 5, **kw: Any) -> list[Observation]:
    nav = FaultyNavigator(Spy(), fault)
    nav.reset(MISSION, jackal(), seed=seed)
    for k in range(n):
        nav.step(obs_at(k, **kw))
    return nav.inner.seen  # type: ignore[attr-defined]


def kept_times(seen: list[Observation], name: str) -> list[float]:
    return [r.t for o in seen for r in o.readings.get(name, ())]


def test_dropped_scans_drop_every_ray_sensors_readings_from_its_own_stream() -> None:
    seen = run(DroppedScans(0.3))
    n = 400 * 2
    for name in ("front_laser", "rear_laser"):
        kept = kept_times(seen, name)
        assert abs((n - len(kept)) - 0.3 * n) < 5 * (n * 0.21) ** 0.5  # binomial, 5 sd
    assert kept_times(seen, "front_laser") != kept_times(seen, "rear_laser")  # independent streams
    # obs.scans is exactly the default lidar's kept readings
    assert all(o.scans == o.readings.get("lidar", ()) for o in seen)
    assert all(name not in o.readings or o.readings[name] for o in seen for name in o.readings)  # none left empty
    # the same seed drops the same readings; another seed others
    assert kept_times(run(DroppedScans(0.3)), "front_laser") == kept_times(seen, "front_laser")
    assert kept_times(run(DroppedScans(0.3), seed=6), "front_laser") != kept_times(seen, "front_laser")


def test_dropped_scans_keep_the_default_lidars_draws() -> None:
    """The default lidar's kept scans are those of an observation with only ``scans`` (the draws
    before sensors were declared), whatever other sensors the robot carries."""
    legacy = [[s.t for s in o.scans] for o in run(DroppedScans(0.3), readings=False)]
    with_lasers = [[s.t for s in o.scans] for o in run(DroppedScans(0.3))]
    alone = [[s.t for s in o.scans] for o in run(DroppedScans(0.3), lasers=0)]
    assert legacy == with_lasers == alone
    # and a laser's draws do not depend on the lidar being there
    assert kept_times(run(DroppedScans(0.3), lidar=0), "front_laser") == kept_times(run(DroppedScans(0.3)), "front_laser")


def test_delayed_scans_delay_every_ray_sensor() -> None:
    seen = run(DelayedScans(3), n=10)
    for k, o in enumerate(seen):
        assert o.readings["odom"][0].t == pytest.approx(0.1 * k)  # the built-in sensors are on time
        if k < 3:
            assert "front_laser" not in o.readings and "lidar" not in o.readings and o.scans == ()
        else:
            assert [r.t for r in o.readings["front_laser"]] == pytest.approx([0.1 * (k - 3), 0.1 * (k - 3) + 0.002])
            assert o.scans == o.readings["lidar"] and o.scans[0].t == pytest.approx(0.1 * (k - 3))


def test_odometry_scale_changes_the_readings_too() -> None:
    seen = run(OdometryScale(1.1), n=20)
    assert all(o.readings["odom"] == (o.odom,) for o in seen)
    assert seen[-1].odom.x == pytest.approx(1.1 * 1.9)


def test_small_footprint_keeps_the_sensors() -> None:
    seen = FaultyNavigator(Spy(), apply_fault(Spy, "small-footprint")(config={}).fault)  # type: ignore[attr-defined]
    seen.reset(MISSION, jackal(), seed=0)
    believed = seen.inner.robot  # type: ignore[attr-defined]
    assert believed.length_m < jackal().length_m and believed.sensors == jackal().sensors


TREES = Layout(circles=[(4.0, 0.2, 0.3), (7.0, -0.5, 0.4), (9.0, 1.0, 0.3)])


@pytest.mark.parametrize("fault", [f.name for f in list_faults()])
def test_every_fault_applies_to_reference_2d(fault: str) -> None:
    nav = make_navigator("reference-2d-v1", fault=fault)
    out = drive(nav, TREES, jackal(), (0.0, 0.0, 0.0), (12.0, 0.0), timeout_s=60.0)
    assert out.status == Status("arrived"), (fault, out.status)
    plain = drive(make_navigator("reference-2d-v1"), TREES, jackal(), (0.0, 0.0, 0.0), (12.0, 0.0), timeout_s=60.0)
    if fault in ("small-footprint", "odometry-scale", "delayed-scans"):
        assert out.commands != plain.commands  # the fault changed what the navigator did
    inner = getattr(nav, "inner", nav)
    if fault == "dropped-scans":
        f = nav.fault  # type: ignore[attr-defined]
        assert f.seen == len(out.commands) + 1 and 0 < f.dropped < f.seen
    if fault == "unknown-as-free":
        assert inner.config.unknown_cell_cost == 0.0
    if fault == "permissive-slope":
        assert inner.config.max_slope_deg == 20.0
    if fault == "small-footprint":
        assert inner.costmap.inscribed_m < plain_inscribed()


def plain_inscribed() -> float:
    from navstress.nav.reference2d.costmap import footprint_radii
    return footprint_radii(jackal(), 0.05)[0]


def test_permissive_slope_marks_what_a_tilted_scanner_sees() -> None:
    """Scans taken while the body pitches more than max_slope_deg only clear; the mutant (twice
    the angle) marks them."""
    robot = jackal()
    wall = Layout(segments=[(2.0, -2.0, 2.0, 2.0)])
    from tests.support.laser_synth import scan_of
    from navstress.nav.api import PoseReading
    occupied = []
    for fault in (None, "permissive-slope"):
        nav = make_navigator("reference-2d-v1", fault=fault)
        nav.reset(MISSION, robot, seed=0)
        pitch = -0.25  # nose up 14 degrees: above the default 10, below the mutant's 20
        scan = scan_of(wall, robot, 0.0, 0.0, 0.0, 0.0)
        nav.step(Observation(0.0, Odometry(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), Imu(0.0, 0.0, pitch, 0.0, (0.0, 0.0, 0.0)),
                             PoseReading(0.0, 0.0, 0.0, robot.wheel_radius_m, 0.0, pitch, 0.0),
                             readings={"front_laser": (scan,)}))
        occupied.append(int((getattr(nav, "inner", nav).costmap.occ == 1).sum()))
    assert occupied[0] == 0 and occupied[1] > 10
