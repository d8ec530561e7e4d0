"""Every sensor in the outputs: each kind's reading in the trace (Foxglove schemas, read back with the
real MCAP reader), in the ROS 2 bag (read back with rosbags' reader, values checked against the
trace), the frame tree, the robot metadata, the recording policy, and the dispatch by kind (a new
kind needs no edit in navstress.run). Readings here are built by hand; the end-to-end runs are in
test_sensor_runs.py."""

from __future__ import annotations

import ast
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from navstress.robot import RobotSpec, profile
from navstress.robot.files import with_sensors
from navstress.run.ros2 import export_ros2
from navstress.run.trace import (SensorRecorder, TraceWriter, mount_frames, read_robot, read_transforms,
                                 robot_metadata, sensor_topics)
from navstress.sensors import Sensor, SensorKind, SensorParams, kinds, rotation_rpy, user_kinds
from navstress.sensors.kinds.depth import DepthImage, DepthParams
from navstress.sensors.kinds.lidar2d import LaserScan, Lidar2dParams
from navstress.sensors.kinds.lidar3d import LidarScan

RUN = Path(__file__).resolve().parents[3] / "src" / "navstress" / "run"


def _robot(entries: list[dict[str, Any]]) -> RobotSpec:
    return with_sensors(profile("jackal"), sensors=entries)


def _scan(s: Sensor, t: float, rng: np.random.Generator) -> LaserScan:
    p = Lidar2dParams.model_validate(s.params)
    r = rng.uniform(p.min_range_m, p.max_range_m, p.beams).astype(np.float32)
    r[rng.random(p.beams) < 0.2] = np.inf
    return LaserScan(t, r, p.angle_min, p.angle_increment, p.min_range_m, p.max_range_m, s.mount.xyz, s.mount.rpy,
                     s.name)


def _depth(s: Sensor, t: float, rng: np.random.Generator) -> DepthImage:
    p = DepthParams.model_validate(s.params)
    d = rng.uniform(p.min_range_m, p.max_range_m, (p.height, p.width)).astype(np.float32)
    d[rng.random(d.shape) < 0.1] = np.inf
    return DepthImage(t, d, *p.intrinsics(), s.mount.xyz, s.mount.rpy, s.name)


def _cloud(s: Sensor, t: float, rng: np.random.Generator) -> LidarScan:
    return LidarScan(t, rng.normal(size=(int(rng.integers(0, 400)), 3)).astype(np.float32), s.mount.xyz, s.name,
                     s.mount.rpy)


MAKE = {"lidar2d": _scan, "depth": _depth, "lidar3d": _cloud}

#: Suites of hand-made sensors: every profile of every kind, small images, mounts with rotations.
SUITES = [
    [{"name": "front_laser", "kind": "lidar2d", "profile": "ust10", "mount": {"xyz": [0.12, 0, 0.3], "rpy": [0, 0, 0]}},
     {"name": "cam", "kind": "depth", "profile": "d435", "width": 64, "height": 48}],
    [{"name": "rear", "kind": "lidar2d", "profile": "tim571", "mount": {"xyz": [-0.2, 0.05, 0.25], "rpy": [0, 0, 3.14159]}},
     {"name": "spin", "kind": "lidar2d", "profile": "rplidar_a2", "mount": {"xyz": [0, 0, 0.35], "rpy": [0.02, -0.1, 0.5]}},
     {"name": "top", "kind": "lidar3d", "profile": "vlp16", "mount": {"xyz": [0.0, 0.0, 0.4], "rpy": [0, 0.05, 0]}},
     # named as the robot's lidar mount, mounted elsewhere: its frame is the sensor's
     {"name": "lidar", "kind": "lidar2d", "mount": {"xyz": [0.1, 0.0, 0.2], "rpy": [0, 0, 0.3]}}],
    [{"name": "down_cam", "kind": "depth", "profile": "d435", "width": 33, "height": 17, "hfov_deg": 60,
      "vfov_deg": 40, "mount": {"xyz": [0.15, 0.0, 0.3], "rpy": [0.1, 0.4, -0.2]}},
     {"name": "os", "kind": "lidar3d", "profile": "os1_64"},
     {"name": "lidar", "kind": "lidar3d", "profile": "hdl32"}],  # the default lidar: /lidar, not /sensors
]


def _write(tmp_path: Path, robot: RobotSpec, n: int = 3, seed: int = 0) -> tuple[Path, dict[str, list[Any]]]:
    rng = np.random.default_rng(seed)
    readings: dict[str, list[Any]] = {}
    path = tmp_path / "run.mcap"
    with TraceWriter(path) as tw:
        tw.robot(robot, belief=True)
        for s in SensorRecorder(robot.sensors or ()).sensors:
            for k in range(n):
                r = MAKE[s.kind](s, 0.1 + k * 0.25, rng)
                readings.setdefault(s.name, []).append(r)
                tw.reading(s, r)
    return path, readings


def _trace(path: Path) -> dict[str, list[tuple[int, str, Any]]]:
    out: dict[str, list[tuple[int, str, Any]]] = {}
    with open(path, "rb") as f:
        for schema, ch, msg, dec in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            out.setdefault(ch.topic, []).append((msg.log_time, schema.name, dec))
    return out


def _bag(path: Path) -> dict[str, list[tuple[int, str, Any]]]:
    from rosbags.highlevel import AnyReader

    out: dict[str, list[tuple[int, str, Any]]] = {}
    with AnyReader([path]) as rd:
        for c, t, raw in rd.messages():
            out.setdefault(c.topic, []).append((t, c.msgtype, rd.deserialize(raw, c.msgtype)))
    return out


@pytest.mark.parametrize("suite", range(len(SUITES)))
def test_every_reading_is_on_its_kinds_topic_with_its_values(suite: int, tmp_path: Path) -> None:
    robot = _robot(SUITES[suite])
    path, readings = _write(tmp_path, robot, seed=suite)
    got = _trace(path)
    sensors = {s.name: s for s in robot.sensors or ()}
    assert "/lidar" not in got  # the default lidar is recorded as before (record_lidar), never here
    expected_topics = {t for s in SensorRecorder(robot.sensors or ()).sensors for t in sensor_topics(s)}
    assert {t for t in got if t.startswith("/sensors/")} == expected_topics
    for name, rs in readings.items():
        s = sensors[name]
        if s.kind == "lidar2d":
            msgs = got[f"/sensors/{name}"]
            assert [m[1] for m in msgs] == ["foxglove.LaserScan"] * len(rs)
            for (lt, _schema, m), r in zip(msgs, rs):
                assert lt == round(r.t * 1e9) and m.frame_id == name
                np.testing.assert_array_equal(np.array(m.ranges, dtype=np.float32), r.ranges)
                a = np.linspace(m.start_angle, m.end_angle, len(m.ranges))  # how Foxglove places the beams
                np.testing.assert_allclose(a, r.angles, atol=1e-9)
        elif s.kind == "depth":
            imgs, cals = got[f"/sensors/{name}/depth"], got[f"/sensors/{name}/calibration"]
            assert [m[1] for m in imgs] == ["foxglove.RawImage"] * len(rs)
            assert [m[1] for m in cals] == ["foxglove.CameraCalibration"] * len(rs)
            for (lt, _s, img), (lt2, _s2, cal), r in zip(imgs, cals, rs):
                assert lt == lt2 == round(r.t * 1e9)
                assert img.frame_id == cal.frame_id == f"{name}_optical" and img.encoding == "32FC1"
                d = np.frombuffer(img.data, dtype="<f4").reshape(img.height, img.step // 4)
                np.testing.assert_array_equal(d, r.depth)
                assert (cal.width, cal.height) == (r.depth.shape[1], r.depth.shape[0])
        else:
            msgs = got[f"/sensors/{name}"]
            assert [m[1] for m in msgs] == ["foxglove.PointCloud"] * len(rs)
            for (lt, _s, m), r in zip(msgs, rs):
                assert m.frame_id == name and lt == round(r.t * 1e9)
                np.testing.assert_array_equal(np.frombuffer(m.data, dtype="<f4").reshape(-1, 3), r.points)


def _rot(q: Any) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()


@pytest.mark.parametrize("suite", range(len(SUITES)))
def test_every_sensor_frame_is_in_the_tree_and_the_metadata(suite: int, tmp_path: Path) -> None:
    robot = _robot(SUITES[suite])
    path, _ = _write(tmp_path, robot, n=1)
    tf = read_transforms(path)
    for s in robot.sensors or ():
        for parent in ("base_link", "perceived/base_link"):
            row = tf[(parent, s.name if parent == "base_link" else "perceived/" + s.name)][0]
            np.testing.assert_allclose(row[1:4], s.mount.xyz, atol=1e-12)
            np.testing.assert_allclose(rotation_rpy(row[6], row[5], row[4]), s.mount.rotation(), atol=1e-9)
    meta = json.loads(read_metadata_robot(path)["sensors"])
    assert meta == [{"name": s.name, "kind": s.kind, "profile": s.profile,
                     "mount": {"xyz": list(s.mount.xyz), "rpy": list(s.mount.rpy)}} for s in robot.sensors or ()]
    assert read_robot(path) == robot


def read_metadata_robot(path: Path) -> dict[str, str]:
    from navstress.run.trace import read_metadata

    return read_metadata(path, "navstress.robot")


@pytest.mark.parametrize("suite", range(len(SUITES)))
def test_the_ros2_bag_holds_each_sensor_as_its_ros_type_with_the_traces_values(suite: int, tmp_path: Path) -> None:
    robot = _robot(SUITES[suite])
    path, readings = _write(tmp_path, robot, seed=10 + suite)
    trace = _trace(path)
    export_ros2(path, tmp_path / "bag")
    bag = _bag(tmp_path / "bag")
    static = {(m.transforms[0].header.frame_id, m.transforms[0].child_frame_id): m.transforms[0]
              for _t, _ty, m in bag["/tf_static"]}
    for s in robot.sensors or ():
        tr = static[("base_link", s.name)].transform
        np.testing.assert_allclose([tr.translation.x, tr.translation.y, tr.translation.z], s.mount.xyz, atol=1e-12)
        np.testing.assert_allclose(_rot(tr.rotation), s.mount.rotation(), atol=1e-9)
    for name, rs in readings.items():
        s = next(x for x in robot.sensors or () if x.name == name)
        if s.kind == "lidar2d":
            p = Lidar2dParams.model_validate(s.params)
            msgs = bag[f"/sensors/{name}"]
            assert [m[1] for m in msgs] == ["sensor_msgs/msg/LaserScan"] * len(rs)
            for (t, _ty, m), r, (lt, _s, fm) in zip(msgs, rs, trace[f"/sensors/{name}"]):
                assert t == lt == m.header.stamp.sec * 10**9 + m.header.stamp.nanosec and m.header.frame_id == name
                np.testing.assert_array_equal(m.ranges, r.ranges)
                np.testing.assert_array_equal(m.ranges, np.array(fm.ranges, dtype=np.float32))
                # (sensor_msgs/LaserScan's angles are float32)
                assert m.angle_min == pytest.approx(r.angle_min, abs=1e-6)
                assert m.angle_increment == pytest.approx(r.angle_increment, rel=1e-6)
                assert m.angle_max == pytest.approx(r.angles[-1], abs=1e-6)
                assert (m.range_min, m.range_max) == (pytest.approx(p.min_range_m), pytest.approx(p.max_range_m))
                assert m.scan_time == pytest.approx(1.0 / p.rate_hz)
        elif s.kind == "depth":
            imgs, infos = bag[f"/sensors/{name}/depth"], bag[f"/sensors/{name}/camera_info"]
            assert [m[1] for m in imgs] == ["sensor_msgs/msg/Image"] * len(rs)
            assert [m[1] for m in infos] == ["sensor_msgs/msg/CameraInfo"] * len(rs)
            opt = static[(name, f"{name}_optical")].transform
            R = _rot(opt.rotation)  # the optical axes in the sensor frame: z forward, x right, y down
            np.testing.assert_allclose(R[:, 2], [1, 0, 0], atol=1e-12)
            np.testing.assert_allclose(R[:, 0], [0, -1, 0], atol=1e-12)
            np.testing.assert_allclose(R[:, 1], [0, 0, -1], atol=1e-12)
            for (_t, _ty, img), (_t2, _ty2, info), r in zip(imgs, infos, rs):
                assert img.encoding == "32FC1" and img.header.frame_id == info.header.frame_id == f"{name}_optical"
                d = np.frombuffer(img.data.tobytes(), dtype="<f4").reshape(img.height, img.width)
                np.testing.assert_array_equal(d, r.depth)
                # the oracle: pixel (u, v)'s ray (DepthImage's convention), put in the optical
                # frame and projected with CameraInfo's K, lands on (u, v) (ROS: centres on integers)
                h, w = r.depth.shape
                v, u = np.mgrid[0:h, 0:w]
                ray = np.stack([np.ones_like(u, dtype=float), -(u + 0.5 - r.cx) / r.fx, -(v + 0.5 - r.cy) / r.fy], -1)
                opt_xyz = ray @ R  # sensor -> optical: R^T x, for row vectors x R
                K = np.asarray(info.k).reshape(3, 3)
                proj = opt_xyz @ K.T
                np.testing.assert_allclose(proj[..., 0] / proj[..., 2], u, atol=1e-9)
                np.testing.assert_allclose(proj[..., 1] / proj[..., 2], v, atol=1e-9)
                np.testing.assert_allclose(np.asarray(info.p).reshape(3, 4)[:, :3], K)
        else:
            msgs = bag[f"/sensors/{name}"]
            assert [m[1] for m in msgs] == ["sensor_msgs/msg/PointCloud2"] * len(rs)
            for (_t, _ty, m), r in zip(msgs, rs):
                assert m.header.frame_id == name and m.point_step == 12 and m.width == len(r.points)
                np.testing.assert_array_equal(np.frombuffer(m.data.tobytes(), dtype="<f4").reshape(-1, 3), r.points)


def test_the_default_robot_keeps_the_trace_of_before_sensors() -> None:
    """A robot with the default suite (sensors None): no sensors key in its description or its
    metadata, and the frames of before (the byte identity of the RMP 400's traces)."""
    for robot in (RobotSpec(), profile("jackal"), profile("husky")):
        md = robot_metadata(robot)
        assert set(md) == {"name", "digest", "description", "footprint", "mounts"}
        assert "sensors" not in json.loads(md["description"])
        assert [f[0] for f in mount_frames(robot)] == (["lidar"] if "lidar" not in robot.mounts else []) + list(robot.mounts)
    listed = with_sensors(RobotSpec(), sensors_add=[{"name": "scan", "kind": "lidar2d"}])
    assert [s["name"] for s in json.loads(robot_metadata(listed)["sensors"])] == ["lidar", "scan"]


@pytest.mark.parametrize("rate", [5.0, 15.0, 30.0, 40.0, 90.0])
def test_the_recording_policy_keeps_every_scan_and_caps_the_heavy_kinds(rate: float) -> None:
    robot = _robot([{"name": "laser", "kind": "lidar2d", "rate_hz": rate},
                    {"name": "cam", "kind": "depth", "rate_hz": min(rate, 90.0), "width": 8, "height": 6},
                    {"name": "top", "kind": "lidar3d", "profile": "vlp16", "rate_hz": min(rate, 20.0)},
                    {"name": "lidar", "kind": "lidar3d"}])
    rng = np.random.default_rng(1)
    rec = SensorRecorder(robot.sensors or ())
    assert [s.name for s in rec.sensors] == ["laser", "cam", "top"]  # the default lidar is /lidar's
    kept: dict[str, list[float]] = {}
    made: dict[str, list[float]] = {}
    t_end, cycle = 4.0, 0.1
    for k in range(int(t_end / cycle)):  # control cycles: the readings since the previous one
        batch: dict[str, tuple[Any, ...]] = {}
        for s in robot.sensors or ():
            hz = float(s.params["rate_hz"])
            ts = [i / hz for i in range(int(k * cycle * hz - 1e-9) + 1, int((k + 1) * cycle * hz + 1e-9) + 1)]
            batch[s.name] = tuple(MAKE[s.kind](s, t, rng) for t in ts)
            made.setdefault(s.name, []).extend(ts)
        for s, r in rec.take(batch):
            kept.setdefault(s.name, []).append(r.t)
    assert "lidar" not in kept
    assert kept["laser"] == made["laser"]  # every 2D scan
    for name in ("cam", "top"):  # at most one a simulated second, the first of each
        period = kinds()[next(s.kind for s in robot.sensors or () if s.name == name)].extra["trace_period_s"]
        assert period == 1.0
        assert np.all(np.diff(kept[name]) >= period - 1e-9)
        assert kept[name][0] == made[name][0] and len(kept[name]) == math.ceil(t_end / period - 1e-9)


@pytest.mark.parametrize("name", sorted(user_kinds()))
def test_every_kind_declares_its_trace_its_topics_and_the_ros2_converters_of_its_schemas(name: str) -> None:
    k = user_kinds()[name]
    assert k.trace is not None and callable(k.extra.get("topics"))
    robot = _robot([{"name": "probe", "kind": name, **({"width": 4, "height": 3} if name == "depth" else {})}])
    (s,) = robot.sensors or ()
    r = MAKE[name](s, 0.5, np.random.default_rng(0))
    msgs = k.trace(r, s)
    topics = sensor_topics(s)
    assert [t for t, _m in msgs] == list(topics) and all(isinstance(m, topics[t]) for t, m in msgs)
    assert {m.DESCRIPTOR.full_name for _t, m in msgs} <= set(k.ros2)


def _strings_and_imports(path: Path) -> tuple[set[str], set[str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    strings = {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    imports = {n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    imports |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    return strings, imports


@pytest.mark.parametrize("module", ["trace.py", "ros2.py", "live.py", "mission.py"])
def test_the_outputs_dispatch_by_kind_and_name_none(module: str) -> None:
    """No module of the outputs imports a kind module or names a kind (but the default lidar's)."""
    strings, imports = _strings_and_imports(RUN / module)
    assert not {m for m in imports if m.startswith("navstress.sensors.kinds")}
    assert strings & set(user_kinds()) <= {"lidar3d"}


@dataclass(frozen=True)
class Ping:
    t: float
    range_m: float
    sensor: str


def _ping_trace(r: Ping, sensor: Any) -> list[tuple[str, Any]]:
    from foxglove_schemas_protobuf.LaserScan_pb2 import LaserScan as Fx

    return [(f"/sensors/{sensor.name}", Fx(frame_id=sensor.name, start_angle=0.0, end_angle=0.0, ranges=[r.range_m]))]


def _ping_ros2(types: Any, topic: str, m: Any, sensor: Any) -> list[tuple[str, Any]]:
    h = types["std_msgs/msg/Header"](stamp=types["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id=m.frame_id)
    return [(topic + "/range", types["sensor_msgs/msg/Range"](header=h, radiation_type=0, field_of_view=0.1,
                                                              min_range=0.0, max_range=5.0, range=m.ranges[0]))]


def test_a_new_kind_reaches_the_trace_and_the_bag_without_an_edit_in_run(tmp_path: Path) -> None:
    """A kind declared on the fly (a sonar): its readings go through its own encoder into the trace
    and through its own converter into the bag (as a new module under navstress.sensors.kinds would)."""
    from foxglove_schemas_protobuf.LaserScan_pb2 import LaserScan as Fx

    sonar = SensorKind(name="sonar", params=SensorParams, profiles={"maxbotix": {}}, default_profile="maxbotix",
                       reading=Ping, caster="columns", summary="a test sonar", trace=_ping_trace,
                       ros2={"foxglove.LaserScan": _ping_ros2},
                       extra={"topics": lambda s: {f"/sensors/{s.name}": Fx}})
    registry = kinds()
    registry["sonar"] = sonar
    try:
        robot = _robot([{"name": "sonar_l", "kind": "sonar"}])
        path = tmp_path / "run.mcap"
        with TraceWriter(path) as tw:
            tw.robot(robot, belief=False)
            for s, r in SensorRecorder(robot.sensors or ()).take({"sonar_l": (Ping(0.2, 1.25, "sonar_l"),)}):
                tw.reading(s, r)
        assert [m.ranges[0] for _lt, _s, m in _trace(path)["/sensors/sonar_l"]] == [1.25]
        export_ros2(path, tmp_path / "bag")
        got = _bag(tmp_path / "bag")["/sensors/sonar_l/range"]
        assert [(ty, m.range) for _t, ty, m in got] == [("sensor_msgs/msg/Range", 1.25)]
    finally:
        del registry["sonar"]
