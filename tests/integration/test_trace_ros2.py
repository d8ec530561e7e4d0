"""A real run's trace exported as a ROS 2 bag (``navstress trace export``), read back with
rosbags (the library that wrote it, which reads any rosbag2): every topic, type and value is
the trace's."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from navstress.cli import app
from navstress.nav.registry import make_navigator
from navstress.run.mission import run_mission
from navstress.run.trace import (TOPIC_LIDAR, TOPIC_PERCEIVED, TraceWriter, _messages, read_debug, read_events,
                                 read_grid, read_grids,
                                 read_commands, read_movers, read_poses, read_terrain_mesh,
                                 read_transforms)
from navstress.world import World, generate, parse_spec

pytestmark = pytest.mark.slow
TYPES = {"/tf": "tf2_msgs/msg/TFMessage", "/tf_static": "tf2_msgs/msg/TFMessage",
         "/truth/odom": "nav_msgs/msg/Odometry", "/perceived/odom": "nav_msgs/msg/Odometry",
         "/rosout": "rcl_interfaces/msg/Log", "/world/markers": "visualization_msgs/msg/MarkerArray",
         "/robot/markers": "visualization_msgs/msg/MarkerArray", "/world/movers": "visualization_msgs/msg/MarkerArray",
         "/world/terrain": "sensor_msgs/msg/PointCloud2", "/nav/map": "nav_msgs/msg/OccupancyGrid",
         "/nav/map_points": "sensor_msgs/msg/PointCloud2", "/lidar": "sensor_msgs/msg/PointCloud2",
         "/world/terrain_mesh": "visualization_msgs/msg/MarkerArray", "/cmd_vel": "geometry_msgs/msg/TwistStamped",
         "/nav/debug": "visualization_msgs/msg/MarkerArray"}


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[World, Path, Path]:
    """A 20 s run of reference-v1 with the lidar and the navigator's view recorded, on a 30 m world with trees and two
    crossing pedestrians; its trace exported with the CLI."""
    d = tmp_path_factory.mktemp("ros2")
    world = generate(parse_spec({"size_m": [30, 30], "obstacles": {"obstruction": {"tree": 2}},
                                 "ground": {"subdivisions": 3, "deformation": 0.4},
                                 "movers": {"count": {"pedestrian": 2}}}), 11)
    with TraceWriter(d / "run.mcap") as tw:
        run_mission(world, make_navigator("reference-v1"), run_seed=5, timeout_s=20.0, trace=tw, record_lidar=True,
                    record_navigator=True)
    r = CliRunner().invoke(app, ["trace", "export", str(d / "run.mcap"), "-o", str(d / "bag")])
    assert r.exit_code == 0, r.output
    assert r.stdout.startswith(f"wrote {d / 'bag'} (")
    return world, d / "run.mcap", d / "bag"


def _read(bag: Path) -> tuple[dict[str, list[tuple[int, Any]]], dict[str, Any]]:
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    out: dict[str, list[tuple[int, Any]]] = {}
    with Reader(bag) as reader:
        conns = {c.topic: c for c in reader.connections}
        for conn, t, raw in reader.messages():
            out.setdefault(conn.topic, []).append((t, ts.deserialize_cdr(raw, conn.msgtype)))
    return out, conns


def _euler_yaw(q: Any) -> float:
    return float(np.arctan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2)))


def test_every_topic_has_its_standard_type_and_the_latched_ones_are_transient_local(run: Any) -> None:
    _world, _trace, bag = run
    msgs, conns = _read(bag)
    assert {t: c.msgtype for t, c in conns.items()} == TYPES
    assert set(msgs) == set(TYPES)
    latched = {t for t, c in conns.items() if any(q.durability.name == "TRANSIENT_LOCAL"
                                                   for q in c.ext.offered_qos_profiles)}
    assert latched == {"/tf_static", "/world/markers", "/robot/markers", "/world/terrain", "/world/terrain_mesh"}


def test_frames_odometry_and_events_are_the_traces(run: Any) -> None:
    _world, trace, bag = run
    msgs, _ = _read(bag)
    tf = read_transforms(trace)
    got: dict[tuple[str, str], list[list[float]]] = {}
    for topic in ("/tf", "/tf_static"):
        for t, m in msgs[topic]:
            for x in m.transforms:
                assert x.header.stamp.sec * 10**9 + x.header.stamp.nanosec == t
                p = x.transform.translation
                got.setdefault((x.header.frame_id, x.child_frame_id), []).append(
                    [t / 1e9, p.x, p.y, p.z, _euler_yaw(x.transform.rotation)])
    assert set(got) == set(tf)
    for key, rows in got.items():
        np.testing.assert_allclose(np.array(rows), tf[key][:, :5], atol=1e-9)
    truth, perceived = read_poses(trace), read_poses(trace, TOPIC_PERCEIVED)
    for topic, ref, child in (("/truth/odom", truth, "base_link"), ("/perceived/odom", perceived, "perceived/base_link")):
        rows = [[t / 1e9, m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z,
                 _euler_yaw(m.pose.pose.orientation)] for t, m in msgs[topic]]
        np.testing.assert_allclose(np.array(rows), ref[:, :5], atol=1e-9)
        assert {m.child_frame_id for _, m in msgs[topic]} == {child} and {m.header.frame_id for _, m in msgs[topic]} == {"map"}
    cmds = read_commands(trace)
    assert len(cmds) > 10 and len(msgs["/cmd_vel"]) == len(cmds)
    got = np.array([[t / 1e9, m.twist.linear.x, m.twist.angular.z] for t, m in msgs["/cmd_vel"]])
    np.testing.assert_array_equal(got[:, 1:], cmds[:, 1:])
    np.testing.assert_allclose(got[:, 0], cmds[:, 0], atol=1e-9)
    assert {m.header.frame_id for _, m in msgs["/cmd_vel"]} == {"base_link"}
    events = read_events(trace)
    assert [(t / 1e9, m.msg) for t, m in msgs["/rosout"]] == [(e.t, e.message) for e in events]
    assert {m.level for _, m in msgs["/rosout"]} <= {10, 20, 30, 40, 50}


def test_world_robot_and_movers_are_markers_where_the_trace_has_them(run: Any) -> None:
    world, trace, bag = run
    msgs, _ = _read(bag)
    ((_, scene),) = msgs["/world/markers"]
    cubes = [m for m in scene.markers if m.type == 1]
    assert len(cubes) == len(world.obstacles) and len(scene.markers) == len(world.obstacles) + 2
    for m, o in zip(cubes, world.obstacles):
        assert (m.pose.position.x, m.pose.position.y) == pytest.approx((o.x, o.y))
        assert (m.scale.x, m.scale.y, m.scale.z) == pytest.approx(o.size)
    ((_, robot),) = msgs["/robot/markers"]
    assert {m.header.frame_id for m in robot.markers} == {"base_link", "perceived/base_link"}
    assert all(m.frame_locked for m in robot.markers)
    times, poses = read_movers(trace)
    assert len(msgs["/world/movers"]) == len(times) > 0
    t, last = msgs["/world/movers"][-1]
    assert t / 1e9 == pytest.approx(times[-1])
    got = np.array(sorted((m.pose.position.x, m.pose.position.y) for m in last.markers))
    np.testing.assert_allclose(got, np.array(sorted(map(tuple, poses[-1][:, :2].tolist()))), atol=1e-9)


def test_clouds_and_maps_hold_the_traces_points_and_heights(run: Any) -> None:
    world, trace, bag = run
    msgs, _ = _read(bag)
    lidar = [m for _t, _lt, m in _messages(trace, [TOPIC_LIDAR])]
    assert len(msgs["/lidar"]) == len(lidar) > 0
    for (_, cloud), src in zip(msgs["/lidar"], lidar):
        assert cloud.point_step == 12 and [f.name for f in cloud.fields] == ["x", "y", "z"]
        assert bytes(cloud.data) == bytes(src.data)
    ((_, terrain),) = msgs["/world/terrain"]
    z = np.frombuffer(bytes(terrain.data), "<f4").reshape(-1, 3)[:, 2]
    np.testing.assert_array_equal(z, world.terrain.heights.astype("<f4").ravel())
    grid = read_grid(trace)
    assert grid is not None
    vals, (x0, y0), cell = grid
    # the map once per simulated second, then the final one
    assert len(msgs["/nav/map"]) == len(read_grids(trace)) > 10
    _, occ = msgs["/nav/map"][-1]
    assert (occ.info.width, occ.info.height, occ.info.resolution) == (vals.shape[1], vals.shape[0], pytest.approx(cell))
    assert (occ.info.origin.position.x, occ.info.origin.position.y) == pytest.approx((x0, y0))
    data = np.asarray(occ.data).reshape(vals.shape)
    assert ((data == -1) == np.isnan(vals)).all() and data[~np.isnan(vals)].min() == 0
    assert data[~np.isnan(vals)].max() == 100
    # the ground surface: one TRIANGLE_LIST whose every three points are a triangle of the trace's mesh
    mesh = read_terrain_mesh(trace)
    assert mesh is not None
    verts, tris = mesh
    ((_, surface),) = msgs["/world/terrain_mesh"]
    (tri,) = surface.markers
    assert tri.type == 11 and tri.header.frame_id == "map" and len(tri.points) == 3 * len(tris) > 2
    got = np.array([(p.x, p.y, p.z) for p in tri.points])
    np.testing.assert_array_equal(got, verts[tris.ravel()])
    assert len(tri.colors) == len(tri.points)
    _, pts = msgs["/nav/map_points"][-1]
    xyz = np.frombuffer(bytes(pts.data), "<f4").reshape(-1, 3)
    assert len(xyz) == int(np.isfinite(vals).sum())
    np.testing.assert_allclose(xyz[:, 2], vals[np.isfinite(vals)], atol=1e-6)


def test_the_navigators_drawings_are_marker_arrays_that_replace_the_last(run: Any) -> None:
    _world, trace, bag = run
    msgs, _ = _read(bag)
    draws = read_debug(trace)
    assert len(msgs["/nav/debug"]) == len(draws) > 100 and any(d.lines for _, d in draws)
    for (t, arr), (td, d) in zip(msgs["/nav/debug"], draws):
        assert t / 1e9 == pytest.approx(td, abs=1e-9)
        first, rest = arr.markers[0], arr.markers[1:]
        assert first.action == 3  # DELETEALL: this drawing replaces the last one whole
        strips = [m for m in rest if m.type == 4]
        texts = [m for m in rest if m.type == 9]
        assert len(strips) == len(d.lines) and len(texts) == len(d.texts) and len(rest) == len(strips) + len(texts)
        for m, ln in zip(strips, d.lines):
            assert m.header.frame_id == "map" and m.scale.x == ln.width_m
            np.testing.assert_array_equal(np.array([(p.x, p.y, p.z) for p in m.points]), ln.points)
        for m, tx in zip(texts, d.texts):
            assert m.text == tx.text and m.header.frame_id == "perceived/base_link" and m.frame_locked
            assert m.scale.z == tx.size_m


@pytest.mark.not_traces  # it writes a junk .mcap on purpose
def test_an_existing_output_or_a_bad_trace_is_one_line_and_writes_nothing(run: Any, tmp_path: Path) -> None:
    _world, trace, _bag = run
    (tmp_path / "there").mkdir()
    (tmp_path / "bad.mcap").write_bytes(b"not an mcap")
    for argv, field in ((["trace", "export", str(trace), "-o", str(tmp_path / "there")], "--output"),
                        (["trace", "export", str(tmp_path / "bad.mcap"), "-o", str(tmp_path / "b")], "trace"),
                        (["trace", "export", str(trace), "-f", "ros1", "-o", str(tmp_path / "c")], "--format")):
        r = CliRunner().invoke(app, argv)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert r.exit_code == 2 and len(lines) == 1 and lines[0].startswith(f"error: {field}="), r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.mcap", "there"]
