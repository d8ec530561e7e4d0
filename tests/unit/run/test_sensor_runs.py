"""End to end: a real run of a Jackal with a UST-10LX-class scanner (and a depth camera) writes its
scans and images into the trace (read with the real MCAP reader) and the ROS 2 bag (read with
rosbags), the values those the navigator was given."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from navstress.nav.api import Command, NavMission
from navstress.robot import profile
from navstress.robot.files import with_sensors
from navstress.run.mission import run_mission
from navstress.run.ros2 import export_ros2
from navstress.run.trace import TraceWriter
from navstress.world.spec import WorldSpec
from navstress.world.world import Mission, Obstacle, World

LASER = {"name": "front_laser", "kind": "lidar2d", "profile": "ust10",
         "mount": {"xyz": [0.12, 0, 0.3], "rpy": [0, 0, 0]}}
CAM = {"name": "cam", "kind": "depth", "profile": "d435", "width": 32, "height": 24}


class Seer:
    """Drives a slow arc and keeps every reading it is given, by sensor name."""

    def __init__(self) -> None:
        self.seen: dict[str, list[Any]] = {}

    def reset(self, mission: NavMission, robot: Any, seed: int) -> None:
        self.names = [s.name for s in robot.sensors]

    def step(self, obs: Any) -> Command:
        for name in self.names:
            self.seen.setdefault(name, []).extend(obs.readings.get(name, ()))
        return Command(0.4, 0.2)

    def close(self) -> None:
        pass


def _world() -> World:
    obs = (Obstacle("tree", 9.0, 5.0, 0.0, (1.0, 1.0, 2.0)), Obstacle("tree", 6.0, 7.5, 0.3, (1.0, 1.0, 2.0)))
    return World.flat(WorldSpec(size_m=(20.0, 20.0)), obstacles=obs,
                      mission=Mission(start=(5.0, 5.0, 0.0), goal=(15.0, 15.0), free_radius_m=1.0))


def _trace(path: Path) -> dict[str, list[tuple[int, str, Any]]]:
    out: dict[str, list[tuple[int, str, Any]]] = {}
    with open(path, "rb") as f:
        for schema, ch, msg, dec in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            out.setdefault(ch.topic, []).append((msg.log_time, schema.name, dec))
    return out


@pytest.mark.parametrize("sensors", [[LASER], [LASER, CAM]], ids=["ust10", "ust10+depth"])
def test_a_jackal_run_records_its_scans_and_images_in_the_trace_and_the_bag(sensors: list[dict[str, Any]],
                                                                          tmp_path: Path) -> None:
    from rosbags.highlevel import AnyReader

    robot = with_sensors(profile("jackal"), sensors=sensors)
    nav = Seer()
    path = tmp_path / "run.mcap"
    tw = TraceWriter(path)
    run_mission(_world(), nav, run_seed=5, robot=robot, timeout_s=2.0, trace=tw)
    tw.close()
    got = _trace(path)
    scans = nav.seen["front_laser"]
    assert len(scans) == pytest.approx(80, abs=3)  # 40 Hz for 2 s
    msgs = got["/sensors/front_laser"]
    assert len(msgs) == len(scans) and {m[1] for m in msgs} == {"foxglove.LaserScan"}  # every scan
    for (lt, _s, m), r in zip(msgs, scans):
        assert lt == round(r.t * 1e9) and m.frame_id == "front_laser"
        np.testing.assert_array_equal(np.array(m.ranges, dtype=np.float32), r.ranges)
    assert any(np.isfinite(r.ranges).sum() > 5 for r in scans)  # it saw the trees
    images = nav.seen.get("cam", [])
    if CAM in sensors:
        frames = got["/sensors/cam/depth"]
        assert len(images) == pytest.approx(30, abs=2) and len(frames) == 2  # 15 Hz seen, 1 Hz recorded
        first = [images[0]] + [next(r for r in images if r.t >= images[0].t + 1.0 - 1e-9)]
        for (lt, _s, img), r in zip(frames, first):
            assert lt == round(r.t * 1e9) and img.frame_id == "cam_optical"
            np.testing.assert_array_equal(np.frombuffer(img.data, "<f4").reshape(24, 32), r.depth)
        assert len(got["/sensors/cam/calibration"]) == 2
    export_ros2(path, tmp_path / "bag")
    bag: dict[str, list[Any]] = {}
    with AnyReader([tmp_path / "bag"]) as rd:
        for c, _t, raw in rd.messages():
            bag.setdefault(c.topic, []).append((c.msgtype, rd.deserialize(raw, c.msgtype)))
    assert [ty for ty, _m in bag["/sensors/front_laser"]] == ["sensor_msgs/msg/LaserScan"] * len(scans)
    for (_ty, m), r in zip(bag["/sensors/front_laser"], scans):
        np.testing.assert_array_equal(m.ranges, r.ranges)
        assert m.range_max == 10.0 and m.header.frame_id == "front_laser"
    children = {m.transforms[0].child_frame_id for _ty, m in bag["/tf_static"]}
    assert {s["name"] for s in sensors} <= children
    if CAM in sensors:
        assert "cam_optical" in children
        assert [ty for ty, _m in bag["/sensors/cam/depth"]] == ["sensor_msgs/msg/Image"] * 2
        assert [ty for ty, _m in bag["/sensors/cam/camera_info"]] == ["sensor_msgs/msg/CameraInfo"] * 2


def test_the_live_view_advertises_and_sends_each_sensor_on_its_trace_topics() -> None:
    """A real Foxglove server (port 0) and a real simulation: the sensors' topics are advertised
    before the run, a scan and a depth frame go out on them after a step, and the default lidar's
    /lidar gets nothing from a robot without one."""
    from navstress.run.live import LivePublisher, LiveSettings
    from navstress.sim.config import SimConfig
    from navstress.sim.simulation import Simulation

    class Watched(LivePublisher):
        def __init__(self, settings: LiveSettings, robot: Any) -> None:
            self.sent: list[tuple[str, str, int]] = []
            super().__init__(settings, robot)

        def _put(self, topic: str, msg: Any, log_time: int) -> None:
            self.sent.append((topic, msg.DESCRIPTOR.full_name, log_time))
            super()._put(topic, msg, log_time)

    robot = with_sensors(profile("jackal"), sensors=[LASER, CAM])
    world = _world()
    sim = Simulation(world, robot, SimConfig(), seed=2)
    pub = Watched(LiveSettings(port=0, wait_s=0.0, speed=50.0), robot)
    try:
        pub.start(world, robot, sim)
        assert {"/sensors/front_laser", "/sensors/cam/depth", "/sensors/cam/calibration"} <= set(pub._channels)
        assert pub.late_topics == []  # made before the server started (test_live_channels.py)
        for _ in range(3):
            obs = sim.observe()
            sim.command(Command(0.3, 0.0))
            sim.advance(0.1)
            pub.update(sim, obs, Seer(), [], [], None)
    finally:
        pub.close()
    kinds = {(t, s) for t, s, _lt in pub.sent}
    assert {("/sensors/front_laser", "foxglove.LaserScan"), ("/sensors/cam/depth", "foxglove.RawImage"),
            ("/sensors/cam/calibration", "foxglove.CameraCalibration")} <= kinds
    assert not any(t == "/lidar" for t, _s, _lt in pub.sent)
    scan_times = [lt for t, _s, lt in pub.sent if t == "/sensors/front_laser"]
    assert np.all(np.diff(scan_times) >= 0.1e9 - 1)  # at most one per 0.1 simulated s
