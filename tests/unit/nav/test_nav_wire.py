"""The line protocol: exact round trips, compact lidar, garbage rejected with a reason."""

from __future__ import annotations

import base64
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from navstress.nav import wire
from navstress.nav.api import Command, Imu, LidarScan, NavMission, Observation, Odometry, PoseReading, Status
from navstress.robot import RobotSpec

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
points = arrays(np.float32, st.tuples(st.integers(0, 40), st.just(3)),
                elements=st.floats(-100, 100, width=32))


@st.composite
def observations(draw: st.DrawFn) -> Observation:
    t = draw(finite)
    odom = Odometry(*(draw(finite) for _ in range(6)))
    imu = Imu(draw(finite), draw(finite), draw(finite), draw(finite),
              (draw(finite), draw(finite), draw(finite)))
    pose = draw(st.none() | st.builds(PoseReading, *(finite for _ in range(7))))
    scans = tuple(LidarScan(draw(finite), draw(points), (draw(finite), draw(finite), draw(finite)))
                  for _ in range(draw(st.integers(0, 3))))
    return Observation(t, odom, imu, pose, scans)


@settings(max_examples=60, deadline=None)
@given(observations())
def test_observation_round_trip_is_exact(obs: Observation) -> None:
    line = wire.dumps(wire.step_message(obs))
    assert line.endswith(b"\n") and line.count(b"\n") == 1
    back = wire.decode_observation(wire.loads(line)["obs"])
    assert (back.t, back.odom, back.imu, back.pose) == (obs.t, obs.odom, obs.imu, obs.pose)
    assert len(back.scans) == len(obs.scans)
    for a, b in zip(back.scans, obs.scans):
        assert a.t == b.t and a.mount == b.mount
        assert a.points.dtype == np.float32 and a.points.shape == (len(b.points), 3)
        np.testing.assert_array_equal(a.points, b.points)


def test_points_are_little_endian_float32_base64() -> None:
    pts = np.array([[1.0, -2.0, 0.5]], dtype=np.float32)
    raw = base64.b64decode(wire.encode_points(pts))
    assert raw == np.array([1.0, -2.0, 0.5], dtype="<f4").tobytes()
    big_endian = pts.astype(">f4")  # any input byte order encodes the same
    assert wire.encode_points(big_endian) == wire.encode_points(pts)
    # compact: 4/3 * 12 bytes per point, vs ~60 for a JSON list of decimal floats
    scan = np.random.default_rng(0).uniform(-50, 50, (1000, 3)).astype(np.float32)
    assert len(wire.encode_points(scan)) == 16_000
    assert len(json.dumps(scan.tolist())) > 3 * 16_000


@given(st.sampled_from(["v", "omega"]), st.floats(allow_nan=False, allow_infinity=False))
def test_command_round_trip(field: str, value: float) -> None:
    cmd = Command(**{"v": 0.0, "omega": 0.0, field: value})
    assert wire.decode_command_or_status(wire.loads(wire.dumps(wire.encode_command_or_status(cmd)))) == cmd


def test_status_round_trip() -> None:
    for st_ in (Status("arrived", "0.3 m"), Status("error", "no arc elected")):
        assert wire.decode_command_or_status(wire.encode_command_or_status(st_)) == st_


def test_reset_message_carries_robot_and_mission() -> None:
    msg = wire.loads(wire.dumps(wire.reset_message(NavMission((1, 2, 0.5), (3, 4), 1.5),
                                                   RobotSpec.footprint_fault(), 7)))
    assert msg["seed"] == 7 and msg["robot"]["length_m"] == 0.84
    assert RobotSpec.model_validate(msg["robot"]) == RobotSpec.footprint_fault()
    assert wire.decode_mission(msg["mission"]) == NavMission((1.0, 2.0, 0.5), (3.0, 4.0), 1.5)


@pytest.mark.parametrize(("line", "reason"), [
    (b"", "empty line"),
    (b"hello world", "not JSON"),
    (b"[1, 2]", "expected a JSON object, got list"),
    (b'{"v": 1}', "missing string field 'type'"),
    (b"\xff\xfe", "not UTF-8"),
    (b'{"type": "command", "v": Infinity, "omega": 0}', "non-finite number Infinity"),
])
def test_loads_rejects_garbage_with_reason(line: bytes, reason: str) -> None:
    with pytest.raises(wire.WireError, match=reason):
        wire.loads(line)


@pytest.mark.parametrize(("msg", "reason"), [
    ({"type": "command", "v": "fast", "omega": 0}, "Command.v='fast' is a str, not a number"),
    ({"type": "command", "v": True, "omega": 0}, "Command.v=True is a bool, not a number"),
    ({"type": "command", "v": 1.0}, "Command.omega=None is a NoneType, not a number"),
    ({"type": "status", "kind": "done"}, "Status.kind='done' is not 'arrived' or 'error'"),
    ({"type": "status", "kind": "error", "message": 3}, "Status.message=3 is a int, not a string"),
    ({"type": "ok"}, "expected a 'command' or 'status' message, got type 'ok'"),
])
def test_bad_answers_rejected_with_reason(msg: dict[str, object], reason: str) -> None:
    with pytest.raises(wire.WireError, match=reason):
        wire.decode_command_or_status(msg)


def test_bad_points_rejected() -> None:
    with pytest.raises(wire.WireError, match="not a multiple of 12"):
        wire.decode_points(base64.b64encode(b"12345").decode())
    with pytest.raises(wire.WireError, match="not valid base64"):
        wire.decode_points("***")
    with pytest.raises(wire.WireError, match="holds 1 points but n=2"):
        wire.decode_points(wire.encode_points(np.zeros((1, 3))), 2)


def test_dumps_refuses_nan() -> None:
    with pytest.raises(ValueError):
        wire.dumps({"type": "command", "v": float("nan"), "omega": 0.0})
