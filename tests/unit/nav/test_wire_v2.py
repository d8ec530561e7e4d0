"""The line protocol's version 2 (every sensor's readings by name, the robot's sensors at reset)
beside version 1 (unchanged for the navigators written for it), with real processes; and
``nav check`` giving a navigator a reading of every sensor kind its robot carries."""

from __future__ import annotations

import json
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navstress.nav import wire
from navstress.nav.api import Command, NavMission, Observation, Status
from navstress.nav.check import check_navigator, synthetic_observations, with_suite
from navstress.nav.external import ExternalNavigator
from navstress.robot import RobotSpec, profile
from navstress.run.sensors import apply_sensor_flags

MISSION = NavMission((0.0, 0.0, 0.0), (20.0, 0.0), 2.0)
SUITE = ["front_laser=lidar2d:ust10,mount=0.12:0:0.3,rpy=0:0.2:0", "cam=depth:d435,width=32,height=24,mount=0.2:0:0.3,rpy=0:0.4:0",
         "top=lidar3d:vlp16,azimuth_steps=90,mount=0:0:0.5"]


def _robot() -> RobotSpec:
    return apply_sensor_flags(profile("jackal"), SUITE, None)


def _obs(robot: RobotSpec) -> Observation:
    return synthetic_observations(robot, 2)[1]


def test_version_1_is_what_it_was() -> None:
    """A v1 reset carries no sensors (whether the robot lists them or not) and a v1 step no
    readings: the default robot's messages are the ones of before sensors were declared."""
    rmp = RobotSpec()
    for robot in (rmp, with_suite(rmp)):
        msg = wire.reset_message(MISSION, robot, 7)
        assert "sensors" not in msg["robot"]
        assert set(msg["robot"]) == set(RobotSpec.model_fields) - {"sensors"}
    assert wire.dumps(wire.reset_message(MISSION, rmp, 7)) == wire.dumps(wire.reset_message(MISSION, with_suite(rmp), 7))
    obs = synthetic_observations(rmp, 2)[1]
    assert obs.readings  # the check's observations carry readings; v1 does not send them
    bare = Observation(obs.t, obs.odom, obs.imu, obs.pose, obs.scans)
    assert wire.dumps(wire.step_message(obs)) == wire.dumps(wire.step_message(bare))
    assert set(wire.step_message(obs)["obs"]) == {"t", "odom", "imu", "pose", "scans"}


def test_version_2_carries_every_sensor() -> None:
    robot = _robot()
    reset = wire.reset_message(MISSION, robot, 7, protocol=2)
    assert [s["name"] for s in reset["robot"]["sensors"]] == ["front_laser", "cam", "top"]
    assert RobotSpec.model_validate(reset["robot"]) == robot
    # the default robot is told its default suite
    assert [s["kind"] for s in wire.reset_message(MISSION, RobotSpec(), 7, protocol=2)["robot"]["sensors"]] == ["lidar3d"]
    obs = _obs(robot)
    line = wire.dumps(wire.step_message(obs, protocol=2))
    sent = wire.loads(line)["obs"]
    assert "scans" not in sent and {"front_laser", "cam", "top", "odom", "imu"} <= set(sent["readings"])
    assert sent["readings"]["cam"][0]["kind"] == "depth" and sent["readings"]["cam"][0]["depth"]["dtype"] == "<f4"
    back = wire.decode_observation(sent)
    assert set(back.readings) == set(obs.readings)
    for name, items in obs.readings.items():
        for a, b in zip(items, back.readings[name]):
            assert type(a) is type(b)
            for f in a.__dataclass_fields__:
                x, y = getattr(a, f), getattr(b, f)
                assert np.array_equal(x, y) if isinstance(x, np.ndarray) else tuple(x) == tuple(y) \
                    if isinstance(x, tuple) else x == y, (name, f)
    assert len(back.scans) == 1 and back.scans[0].sensor == "top"  # the lidar3d clouds, as scans
    assert (back.t, back.odom, back.imu, back.pose) == (obs.t, obs.odom, obs.imu, obs.pose)


@pytest.mark.parametrize("damage,needle", [
    (lambda r: r.update(cam=[{"kind": "camera"}]), "no known kind"),
    (lambda r: r.update(cam="x"), "not a list"),
    (lambda r: r["cam"][0].update(depth={"dtype": "<f4", "shape": [2, 2], "data": "AAAA"}), "not a depth reading"),
    (lambda r: r["front_laser"][0].pop("angle_min"), "not a lidar2d reading"),
    (lambda r: r["top"][0].update(points={"dtype": "<f4", "shape": [1, 2], "data": "AAAAAAAAAAA="}), "3 columns"),
])
def test_bad_readings_are_wire_errors(damage: Any, needle: str) -> None:
    sent = json.loads(wire.dumps(wire.step_message(_obs(_robot()), protocol=2)))["obs"]
    damage(sent["readings"])
    with pytest.raises(wire.WireError, match=needle):
        wire.decode_observation(sent)


V2_NAV = textwrap.dedent('''
    import json, sys
    kinds = {}
    for line in sys.stdin:
        msg = json.loads(line)
        if msg["type"] == "hello":
            print(json.dumps({"type": "hello", "protocol": int(sys.argv[1]), "name": "v2"}), flush=True)
        elif msg["type"] == "reset":
            kinds = {s["name"]: s["kind"] for s in msg["robot"].get("sensors") or []}
            print(json.dumps({"type": "ok"}), flush=True)
        elif msg["type"] == "step":
            got = {n: [r["kind"] for r in items] for n, items in msg["obs"].get("readings", {}).items()}
            v2 = int(sys.argv[1]) == 2
            ok = all(got.get(n) == [k] for n, k in kinds.items()) and ("scans" in msg["obs"]) != v2 \\
                and ("readings" in msg["obs"]) == v2
            reply = {"type": "command", "v": 0.5, "omega": 0.0} if ok else \\
                {"type": "status", "kind": "error", "message": json.dumps([kinds, got])}
            print(json.dumps(reply), flush=True)
        elif msg["type"] == "close":
            break
''')


@pytest.mark.parametrize("version", [1, 2, 3])
def test_a_navigator_process_chooses_its_version(tmp_path: Path, version: int) -> None:
    script = tmp_path / "nav.py"
    script.write_text(V2_NAV, encoding="utf-8")
    robot = _robot()
    nav = ExternalNavigator([sys.executable, str(script), str(version)], step_budget_s=10.0, reset_budget_s=20.0)
    try:
        nav.reset(MISSION, robot, seed=1)
        out = nav.step(_obs(robot))
    finally:
        nav.close()
    if version == 3:
        assert isinstance(out, Status) and out.infrastructure and "speaks 1 or 2" in out.message, out
    elif version == 2:
        assert nav.protocol == 2 and out == Command(0.5, 0.0), out
    else:  # told no sensors (v1): nothing to expect, and no readings sent
        assert nav.protocol == 1 and isinstance(out, Command), out


def test_a_served_navigator_speaks_version_2(tmp_path: Path) -> None:
    """`python -m navstress.nav.external NAME` answers protocol 2: a served Python navigator gets
    the readings of every sensor (here one that checks them, as nav check does)."""
    robot = _robot()
    nav = ExternalNavigator([sys.executable, "-m", "navstress.nav.external", "straightline-v1"], step_budget_s=20.0,
                            reset_budget_s=60.0)
    try:
        nav.reset(MISSION, robot, seed=1)
        out = nav.step(_obs(robot))
    finally:
        nav.close()
    assert nav.protocol == 2 and isinstance(out, Command), out


class _NeedsEverySensor:
    """Refuses any cycle without a reading of each of its robot's sensors, of the right kind."""

    def __init__(self, config: Any = None) -> None:
        self.kinds: dict[str, str] = {}

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        assert robot.sensors is not None
        self.kinds = {s.name: s.kind for s in robot.sensors}

    def step(self, obs: Observation) -> Command | Status:
        names = {"lidar3d": "LidarScan", "lidar2d": "LaserScan", "depth": "DepthImage"}
        for name, kind in self.kinds.items():
            r = obs.latest(name)
            if type(r).__name__ != names[kind]:
                return Status("error", f"no {kind} reading of {name}")
        return Command(0.3, 0.0)

    def close(self) -> None:
        pass


def test_nav_check_gives_every_sensor_kind_a_reading() -> None:
    report = check_navigator(_NeedsEverySensor, robot=_robot(), n_steps=5)
    assert report.passed, str(report)
    laser = _obs(_robot()).readings["front_laser"][0]
    assert np.isfinite(laser.ranges).any() and not np.isfinite(laser.ranges).all()  # pitched down: ground ahead
    cam = _obs(_robot()).readings["cam"][0]
    assert cam.depth.shape == (24, 32) and np.isfinite(cam.depth[-1]).all()  # the image's bottom row sees ground


def test_nav_check_flat_ground_is_exact() -> None:
    """The synthetic readings are the flat ground's: every return lies on z = -(mount height +
    wheel radius) in base_link."""
    robot = _robot()
    obs = _obs(robot)
    for name in ("front_laser", "cam", "top"):
        r = obs.readings[name][0]
        s = next(x for x in robot.sensors or () if x.name == name)
        pts = r.points().astype(np.float64) if callable(r.points) else r.points.astype(np.float64)
        z = pts @ s.mount.rotation()[2] + s.mount.xyz[2]
        assert len(z) > 0 and np.allclose(z, -robot.wheel_radius_m, atol=1e-4), name
