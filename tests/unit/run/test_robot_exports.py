"""The robot in the exports: its footprint and its sensor frames in the Foxglove trace and in the
ROS 2 bag (read back with the real readers: mcap and rosbags), for box, circle and polygon robots
with mounts of their own."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navstress.robot import PROFILES, Footprint, Mount, RobotSpec
from navstress.run.ros2 import export_ros2
from navstress.run.trace import BELIEF, FRAME, TOPIC_PERCEIVED, TOPIC_TRUTH, TraceWriter

ROBOTS = {
    "box": PROFILES["jackal"].model_copy(update={"mounts": {"lidar": Mount(xyz=(0.12, 0.0, 0.21)),
                                                            "camera": Mount(xyz=(0.2, 0.05, 0.25),
                                                                            rpy=(0.0, 0.3, 0.1))}}),
    "circle": PROFILES["turtlebot4"],
    "polygon": RobotSpec(name="pentagon", footprint=Footprint(shape="polygon", points=(
        (0.6, 0.0), (0.2, 0.4), (-0.4, 0.3), (-0.4, -0.3), (0.2, -0.4))),
        mounts={"front_lidar": Mount(xyz=(0.5, 0.0, 0.5)), "imu": Mount(xyz=(0.0, 0.0, 0.4))}),
}


def _trace(path: Path, robot: RobotSpec) -> None:
    rows = np.array([[t, 1.0 + t, 2.0, 0.3, 0.1 * t, 0.0, 0.0] for t in np.arange(5) * 0.5])
    with TraceWriter(path) as tw:
        tw.poses(TOPIC_TRUTH, rows)
        tw.transforms(FRAME, "base_link", rows)
        tw.poses(TOPIC_PERCEIVED, rows)
        tw.transforms(FRAME, BELIEF + "base_link", rows)
        tw.robot(robot, belief=True)


def _read(bag: Path) -> dict[str, list[Any]]:
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    out: dict[str, list[Any]] = {}
    with Reader(bag) as reader:
        for conn, _t, raw in reader.messages():
            out.setdefault(conn.topic, []).append(ts.deserialize_cdr(raw, conn.msgtype))
    return out


@pytest.mark.parametrize("kind", sorted(ROBOTS))
def test_the_bag_holds_the_mount_frames_and_the_footprint(kind: str, tmp_path: Path) -> None:
    robot = ROBOTS[kind]
    _trace(tmp_path / "t.mcap", robot)
    export_ros2(tmp_path / "t.mcap", tmp_path / "bag")
    msgs = _read(tmp_path / "bag")
    static = {(tf.header.frame_id, tf.child_frame_id): tf for m in msgs["/tf_static"] for tf in m.transforms}
    dynamic = {(tf.header.frame_id, tf.child_frame_id) for m in msgs["/tf"] for tf in m.transforms}
    assert dynamic == {("map", "base_link"), ("map", "perceived/base_link")}
    want = set(robot.mounts) | {"lidar"}
    assert static.keys() == {(p + "base_link", p + n) for p in ("", BELIEF) for n in want}
    for name, m in robot.mounts.items():
        tr = static[("base_link", name)].transform.translation
        assert (tr.x, tr.y, tr.z) == pytest.approx(m.xyz)
        q = static[("base_link", name)].transform.rotation
        yaw = np.arctan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2))
        assert yaw == pytest.approx(m.rpy[2], abs=1e-9)
    (arr,) = msgs["/robot/markers"]
    ring = robot.footprint_points()
    strips = [mk for mk in arr.markers if mk.type == mk.LINE_STRIP]
    assert {mk.header.frame_id for mk in strips} == {"base_link", "perceived/base_link"}
    for mk in strips:
        pts = np.array([(p.x, p.y) for p in mk.points])
        assert np.allclose(pts, np.vstack([ring, ring[:1]]))
        assert all(p.z == pytest.approx(-robot.wheel_radius_m) for p in mk.points)  # on the ground
    bodies = [mk for mk in arr.markers if mk.type in (mk.CUBE, mk.TRIANGLE_LIST)]
    assert len(bodies) == 2
    for mk in bodies:
        if kind == "box":
            assert mk.type == mk.CUBE and (mk.scale.x, mk.scale.y) == pytest.approx((robot.length_m, robot.width_m))
        else:  # a prism of the footprint: its points lie on the outline
            assert mk.type == mk.TRIANGLE_LIST and len(mk.points) % 3 == 0
            xy = np.array([(p.x, p.y) for p in mk.points])
            d = np.min(np.hypot(xy[:, None, 0] - ring[None, :, 0], xy[:, None, 1] - ring[None, :, 1]), axis=1)
            assert np.all(d < 1e-9)


@pytest.mark.parametrize("kind", sorted(ROBOTS))
def test_the_trajectory_picture_draws_the_robots_true_outline_where_the_run_ended(kind: str) -> None:
    from matplotlib.patches import Polygon

    from navstress.run.figures import RunTrack, draw_tracks, footprint_at, world_axes

    robot = ROBOTS[kind]
    ring = robot.footprint_points()
    truth = np.array([[0.0, 1.0, 1.0, 0.0, 0.0, 0, 0], [1.0, 4.0, 3.0, 0.0, 0.7, 0, 0]])
    _fig, ax = world_axes()
    draw_tracks(ax, [RunTrack("r", "success", truth, footprint=ring)])
    (patch,) = [p for p in ax.patches if isinstance(p, Polygon)]
    xy = patch.get_xy()[: len(ring)]
    assert np.allclose(xy, footprint_at(ring, truth[-1]))
    assert np.allclose(np.mean(xy, axis=0), truth[-1, 1:3] + [[np.cos(0.7), -np.sin(0.7)], [np.sin(0.7), np.cos(0.7)]]
                       @ np.mean(ring, axis=0))
    _fig, ax = world_axes()
    draw_tracks(ax, [RunTrack("r", "success", truth)])  # no footprint given: none drawn (the report's maps)
    assert not [p for p in ax.patches if isinstance(p, Polygon)]
