"""MCAP traces: what is written is read back; same input gives the same bytes; atomic."""

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mcap.reader import NonSeekingReader, make_reader
from tests.support.trace_check import trace_problems

from navstress.errors import StoreError
from navstress.run.trace import (TOPIC_MAP, TOPIC_PERCEIVED, TOPIC_TRUTH, TraceWriter, euler, quaternion, read_events,
                                 read_grid, read_metadata, read_poses, read_transforms)

angle = st.floats(-math.pi + 1e-3, math.pi - 1e-3)


@given(angle, st.floats(-1.5, 1.5), angle)
def test_quaternion_euler_round_trip(yaw: float, pitch: float, roll: float) -> None:
    back = euler(quaternion(yaw, pitch, roll))
    assert back == pytest.approx((yaw, pitch, roll), abs=1e-9)


def write(path: Path) -> np.ndarray:
    rng = np.random.default_rng(3)
    rows = np.column_stack([np.arange(50) * 0.1, rng.normal(size=(50, 3)) * 10,
                            rng.uniform(-3, 3, 50), rng.uniform(-0.5, 0.5, 50), rng.uniform(-0.5, 0.5, 50)])
    grid = rng.normal(size=(7, 9)).astype(np.float32)
    grid[2, 3] = np.nan
    with TraceWriter(path, {"run_seed": "12", "navigator": "reference-v1"}) as tw:
        tw.scene([{"kind": "tree", "x": 3.0, "y": 4.0, "yaw": 0.2, "size": [1, 1, 5], "z": 0.0}], (1, 1, 0), (9, 9), (0, 0))
        tw.poses(TOPIC_TRUTH, rows)
        tw.poses(TOPIC_PERCEIVED, rows + 0.5)
        tw.event(2.0, "warning", "collision with obstacle 0 (tree)")
        tw.event(4.9, "error", "no arc elected")
        tw.grid(TOPIC_MAP, 4.9, grid, (-1.0, -2.0), 0.4)
        tw.points(1.0, rng.normal(size=(100, 3)))
    return rows


def test_round_trip(tmp_path: Path) -> None:
    rows = write(tmp_path / "run.mcap")
    back = read_poses(tmp_path / "run.mcap")
    assert back.shape == (50, 7)
    assert np.allclose(back[:, :4], rows[:, :4], atol=1e-9)
    assert np.allclose(back[:, 4:], rows[:, 4:], atol=1e-9)
    assert np.allclose(read_poses(tmp_path / "run.mcap", TOPIC_PERCEIVED)[:, 1:4], rows[:, 1:4] + 0.5)
    ev = read_events(tmp_path / "run.mcap")
    assert [(e.t, e.message) for e in ev] == [(2.0, "collision with obstacle 0 (tree)"), (4.9, "no arc elected")]
    g = read_grid(tmp_path / "run.mcap")
    assert g is not None
    vals, origin, cell = g
    assert vals.shape == (7, 9) and origin == (-1.0, -2.0) and cell == pytest.approx(0.4)
    assert np.isnan(vals[2, 3]) and np.nansum(np.abs(vals)) > 0
    assert read_metadata(tmp_path / "run.mcap") == {"run_seed": "12", "navigator": "reference-v1"}


def test_same_input_same_bytes(tmp_path: Path) -> None:
    write(tmp_path / "a.mcap")
    write(tmp_path / "b.mcap")
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()


def test_atomic_on_failure(tmp_path: Path) -> None:
    with pytest.raises(RuntimeError):
        with TraceWriter(tmp_path / "x.mcap") as tw:
            tw.pose(TOPIC_TRUTH, 0.0, 0, 0, 0, 0, 0, 0)
            raise RuntimeError("run failed")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.not_traces
def test_unreadable_trace_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(StoreError, match="does not exist"):
        read_poses(tmp_path / "missing.mcap")
    (tmp_path / "junk.mcap").write_bytes(b"not an mcap file at all")
    with pytest.raises(StoreError, match="unreadable"):
        read_poses(tmp_path / "junk.mcap")


_topics = st.sampled_from([TOPIC_TRUTH, TOPIC_PERCEIVED, "events", "lidar", "map"])


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(_topics, st.floats(0.0, 1e4, allow_nan=False)), max_size=60), st.integers(0, 2**32 - 1))
def test_messages_are_written_in_log_time_order(tmp_path_factory: pytest.TempPathFactory,
                                                msgs: list[tuple[str, float]], seed: int) -> None:
    """Whatever order the messages are handed over in (as a run hands them over: topic by
    topic), the file holds them in log-time order, with a valid summary, byte-identically."""
    d = tmp_path_factory.mktemp("order")

    def write(path: Path) -> None:
        with TraceWriter(path) as tw:
            for topic, t in msgs:
                if topic in (TOPIC_TRUTH, TOPIC_PERCEIVED):
                    tw.pose(topic, t, 1.0, 2.0, 0.0, 0.1, 0.0, 0.0)
                elif topic == "events":
                    tw.event(t, "info", "x")
                elif topic == "lidar":
                    tw.points(t, np.random.default_rng(seed).normal(size=(5, 3)))
                else:
                    tw.grid(TOPIC_MAP, t, np.zeros((2, 3)), (0.0, 0.0), 0.5)
            tw.scene([], (0, 0, 0), (1, 1), (0, 0))

    write(d / "a.mcap")
    write(d / "b.mcap")
    assert trace_problems(d / "a.mcap") == []
    assert (d / "a.mcap").read_bytes() == (d / "b.mcap").read_bytes()
    with open(d / "a.mcap", "rb") as f:
        times = [m.log_time for _s, _c, m in NonSeekingReader(f).iter_messages(log_time_order=False)]
    assert times == sorted(times) and len(times) == len(msgs) + 1


def test_trace_with_non_finite_or_negative_pose_times_is_still_valid(tmp_path: Path) -> None:
    """A navigator's perceived trajectory may hold anything: rows with a NaN, infinite or
    negative time are left out, the rest is written."""
    rows = np.array([[0.0, 1, 1, 0, 0, 0, 0], [np.nan, 2, 2, 0, 0, 0, 0], [-1.0, 3, 3, 0, 0, 0, 0],
                     [np.inf, 4, 4, 0, 0, 0, 0], [0.5, 5, 5, 0, 0, 0, 0]])
    rows_nan_pose = rows.copy()
    rows_nan_pose[4, 5] = np.nan  # a NaN pitch: no transform can be drawn from it
    with TraceWriter(tmp_path / "p.mcap") as tw:
        tw.poses(TOPIC_PERCEIVED, rows)
        tw.transforms("map", "perceived/base_link", rows_nan_pose)
    back = read_poses(tmp_path / "p.mcap", TOPIC_PERCEIVED)
    assert back[:, 0].tolist() == [0.0, 0.5] and back[:, 1].tolist() == [1.0, 5.0]
    tf = read_transforms(tmp_path / "p.mcap")
    assert list(tf) == [("map", "perceived/base_link")] and tf[("map", "perceived/base_link")][:, 1].tolist() == [1.0]


@pytest.mark.not_traces
def test_the_trace_check_sees_messages_out_of_order(tmp_path: Path) -> None:
    """The check every test's traces go through can fail: a file written out of order (as
    traces were, topic by topic) is reported."""
    from mcap.writer import Writer as RawWriter
    with open(tmp_path / "bad.mcap", "wb") as f:
        w = RawWriter(f)
        w.start()
        ch = w.register_channel("/a", "json", w.register_schema("s", "jsonschema", b"{}"))
        for q, t in enumerate((5, 6, 1, 2), start=1):
            w.add_message(ch, log_time=t, data=b"{}", publish_time=t, sequence=q)
        w.finish()
    problems = trace_problems(tmp_path / "bad.mcap")
    assert problems and "goes back in time" in problems[0]


@pytest.mark.not_traces
def test_the_trace_check_sees_sequence_numbers_that_do_not_count(tmp_path: Path) -> None:
    """Foxglove shows a message's sequence: every channel's must count 1, 2, 3, ... (they were
    all 0)."""
    from mcap.writer import Writer as RawWriter
    for seqs, ok in (((1, 2, 3), True), ((0, 0, 0), False), ((1, 3, 4), False)):
        with open(tmp_path / "s.mcap", "wb") as f:
            w = RawWriter(f)
            w.start()
            ch = w.register_channel("/a", "json", w.register_schema("s", "jsonschema", b"{}"))
            for t, q in enumerate(seqs):
                w.add_message(ch, log_time=t, data=b"{}", publish_time=t, sequence=q)
            w.finish()
        problems = trace_problems(tmp_path / "s.mcap")
        assert (problems == []) == ok, problems
        assert ok or "sequence" in problems[0]


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(n=st.integers(0, 400), big=st.booleans(), seed=st.integers(0, 2**32 - 1))
def test_indexed_pose_reading_matches_the_library_byte_for_byte(tmp_path: Path, n: int, big: bool, seed: int) -> None:
    """read_poses goes through the message indexes and parses only the topic's records; on any
    trace (poses submitted out of order, equal times, other topics between them, several chunks)
    it returns exactly what the MCAP library's reader yields."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.choice(np.arange(0, 50, 0.05), size=n))  # equal times possible
    rows = np.column_stack([t, rng.normal(size=(n, 3)) * 50, rng.uniform(-3, 3, n),
                            rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n)])
    path = tmp_path / f"t{seed}-{n}-{big}.mcap"
    with TraceWriter(path) as tw:
        order = rng.permutation(n)
        tw.poses(TOPIC_PERCEIVED, rows[order] + 0.25)
        for i in order:  # out of submission order; the writer sorts by log time
            tw.pose(TOPIC_TRUTH, *rows[i])
        if big:  # point clouds between the poses: the file spans several chunks
            for k in range(12):
                tw.points(k * 4.0, rng.normal(size=(12_000, 3)))
    from mcap.reader import make_reader

    from navstress.run.trace import _indexed
    if n:  # the indexed path is the one taken (a file with no message at all has no chunk)
        assert _indexed(path, TOPIC_TRUTH, "foxglove.PoseInFrame") is not None
    if big:
        with open(path, "rb") as f:
            assert len(make_reader(f).get_summary().chunk_indexes) > 1  # type: ignore[union-attr]
    for topic in (TOPIC_TRUTH, TOPIC_PERCEIVED, "/no/such/topic"):
        fast, slow = read_poses(path, topic), read_poses(path, topic, indexed=False)
        assert fast.shape == slow.shape and fast.tobytes() == slow.tobytes()
    assert len(read_poses(path)) == n


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(sizes=st.lists(st.tuples(st.integers(1, 60), st.integers(1, 60)), max_size=5), big=st.booleans(),
       seed=st.integers(0, 2**32 - 1))
def test_indexed_grid_reading_matches_the_library(tmp_path: Path, sizes: list[tuple[int, int]], big: bool,
                                                  seed: int) -> None:
    """read_grids / read_grid (the report's final perceived maps) through the message indexes give
    the library reader's grids: every map in time order with its values (unknown cells NaN), origin
    and cell size, and the last one."""
    from navstress.run.trace import TOPIC_MAP, read_grid, read_grids

    rng = np.random.default_rng(seed)
    path = tmp_path / f"g{seed}-{len(sizes)}-{big}.mcap"
    with TraceWriter(path) as tw:
        tw.poses(TOPIC_TRUTH, np.column_stack([np.arange(10.0), np.zeros((10, 6))]))
        for k, (r, c) in enumerate(sizes):
            g = rng.normal(size=(r, c)).astype(np.float32)
            g[rng.random((r, c)) < 0.3] = np.nan
            tw.grid(TOPIC_MAP, float(k), g, (float(rng.normal()), float(rng.normal())), float(rng.uniform(0.1, 1)))
            if big:
                tw.points(k + 0.5, rng.normal(size=(12_000, 3)))
    fast, slow = read_grids(path), read_grids(path, indexed=False)
    assert len(fast) == len(slow) == len(sizes)
    for a, b in zip(fast, slow):
        assert a[0] == b[0] and a[2:] == b[2:] and a[1].tobytes() == b[1].tobytes()
    last, last_slow = read_grid(path), read_grid(path, indexed=False)
    if not sizes:
        assert last is None and last_slow is None
    else:
        assert last is not None and last_slow is not None
        assert last[0].tobytes() == last_slow[0].tobytes() == fast[-1][1].tobytes() and last[1:] == last_slow[1:]


@pytest.mark.not_traces
def test_indexed_reading_falls_back_on_a_file_without_index(tmp_path: Path) -> None:
    """A valid MCAP file written without chunks (so without message indexes): read_poses reads
    it through the library's reader instead."""
    from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
    from mcap.writer import Writer
    from mcap_protobuf.schema import build_file_descriptor_set

    from navstress.run.trace import _indexed, quaternion
    path = tmp_path / "plain.mcap"
    with open(path, "wb") as f:
        w = Writer(f, use_chunking=False)
        w.start()
        sid = w.register_schema("foxglove.PoseInFrame", "protobuf",
                                build_file_descriptor_set(PoseInFrame).SerializeToString())
        cid = w.register_channel(TOPIC_TRUTH, "protobuf", sid)
        for i in range(5):
            m = PoseInFrame(frame_id="map")
            m.pose.position.x = float(i)
            m.pose.orientation.CopyFrom(quaternion(0.1 * i, 0.0, 0.0))
            w.add_message(cid, log_time=i * 10**9, data=m.SerializeToString(), publish_time=i * 10**9, sequence=i + 1)
        w.finish()
    assert _indexed(path, TOPIC_TRUTH, "foxglove.PoseInFrame") is None
    got = read_poses(path)
    assert got[:, 1].tolist() == [0.0, 1.0, 2.0, 3.0, 4.0] and got[:, 4] == pytest.approx(np.arange(5) * 0.1)


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(2, 260), cols=st.integers(2, 260), cell=st.sampled_from([0.1, 0.4, 1.0]),
       flat=st.booleans(), seed=st.integers(0, 2**32 - 1))
def test_the_terrain_mesh_covers_the_map_on_the_grid_heights(rows: int, cols: int, cell: float, flat: bool,
                                                             seed: int) -> None:
    """Every vertex is a grid node at its exact height; the triangles are counter-clockwise seen
    from above and tile the map exactly; at most MESH_MAX_CELLS cells per side (+ the last);
    flat ground is two triangles."""
    from navstress.run.trace import MESH_MAX_CELLS, terrain_mesh
    h = np.zeros((rows, cols)) if flat else np.random.default_rng(seed).normal(size=(rows, cols))
    verts, tris = terrain_mesh(h, cell)
    i = np.rint(verts[:, 1] / cell).astype(int)
    j = np.rint(verts[:, 0] / cell).astype(int)
    assert (verts[:, 2] == h[i, j]).all()
    a, b, c = verts[tris[:, 0], :2], verts[tris[:, 1], :2], verts[tris[:, 2], :2]
    area = 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    assert (area > 0).all()
    assert area.sum() == pytest.approx((rows - 1) * (cols - 1) * cell * cell, rel=1e-9)
    assert len(np.unique(i)) <= MESH_MAX_CELLS + 2 and len(np.unique(j)) <= MESH_MAX_CELLS + 2
    assert {0, rows - 1} <= set(i.tolist()) and {0, cols - 1} <= set(j.tolist())
    if flat:
        assert len(tris) == 2
    elif max(rows, cols) - 1 <= MESH_MAX_CELLS:
        assert len(verts) == rows * cols  # small grids are kept whole


def test_the_terrain_surface_round_trips_through_a_trace(tmp_path: Path) -> None:
    from navstress.run.trace import read_terrain_mesh, terrain_mesh
    h = np.random.default_rng(1).normal(size=(30, 40))
    with TraceWriter(tmp_path / "t.mcap") as tw:
        tw.terrain(h, 0.5)
    got = read_terrain_mesh(tmp_path / "t.mcap")
    assert got is not None
    verts, tris = terrain_mesh(h, 0.5)
    assert got[0].tobytes() == verts.tobytes() and (got[1] == tris).all()
    with TraceWriter(tmp_path / "none.mcap") as tw:
        tw.event(0.0, "info", "x")
    assert read_terrain_mesh(tmp_path / "none.mcap") is None


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.sampled_from(["tree", "building", "rock", "wall", "hut", "a", "b", "c"]), min_size=0, max_size=12))
def test_the_scene_has_the_pictures_colours(tmp_path: Path, kinds: list[str]) -> None:
    """Foxglove's 3D scene colours each obstacle as the world's pictures do (``kind_colour``:
    the built-in kinds their own colour, other kinds one each, never grey), start and goal too."""
    from mcap_protobuf.decoder import DecoderFactory

    from navstress.world.colours import GOAL_COLOUR, START_COLOUR, kind_colour

    obstacles = [{"kind": k, "x": float(i), "y": 1.0, "yaw": 0.0, "size": [1, 1, 2], "z": 0.0} for i, k in enumerate(kinds)]
    with TraceWriter(tmp_path / "s.mcap") as tw:
        tw.scene(obstacles, (1, 1, 0), (9, 9), (0, 0))
    with open(tmp_path / "s.mcap", "rb") as f:
        [(_, _, _, scene)] = list(make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
            topics=["/world/scene"]))
    [ent] = scene.entities

    def hexed(c: object) -> str:
        return "#" + "".join(f"{round(getattr(c, ch) * 255):02x}" for ch in "rgb")

    distinct = sorted(set(kinds))
    assert [hexed(c.color) for c in ent.cubes] == [kind_colour(k, distinct) for k in kinds]
    assert [hexed(s.color) for s in ent.spheres] == [START_COLOUR, GOAL_COLOUR]
    assert all(c.color.a == 1.0 for c in ent.cubes)
    others = [k for k in distinct if k not in ("tree", "building")]
    if len(others) <= 5:  # up to five other kinds: each its own colour
        assert len({kind_colour(k, distinct) for k in distinct}) == len(distinct)


def test_commands_round_trip_through_a_trace(tmp_path: Path) -> None:
    """The navigator's commands: written with their own schema (navstress.VelocityCommand, kept
    in the file), read back by the MCAP protobuf decoder; non-finite or negative times left out."""
    from navstress.run.trace import TOPIC_CMD, read_commands
    rows = np.array([[0.0, 0.5, 0.1], [0.1, 0.6, -0.2], [float("nan"), 9.0, 9.0], [-1.0, 9.0, 9.0], [0.2, -0.3, 0.0]])
    with TraceWriter(tmp_path / "c.mcap") as tw:
        tw.commands(rows)
    got = read_commands(tmp_path / "c.mcap")
    assert got.tolist() == [[0.0, 0.5, 0.1], [0.1, 0.6, -0.2], [0.2, -0.3, 0.0]]
    with open(tmp_path / "c.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    (ch,) = [c for c in summary.channels.values() if c.topic == TOPIC_CMD]
    assert summary.schemas[ch.schema_id].name == "navstress.VelocityCommand"


@pytest.mark.not_traces
@pytest.mark.parametrize("indexed", [True, False])
def test_a_corrupt_message_is_a_store_error_on_every_reading_path(tmp_path: Path, indexed: bool) -> None:
    """A payload protobuf rejects, read through the message indexes or the library's reader, as a
    pose or as a grid: the same one-line StoreError naming the file (the indexed path let
    protobuf's DecodeError through)."""
    from foxglove_schemas_protobuf.Grid_pb2 import Grid
    from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
    from mcap.writer import Writer
    from mcap_protobuf.schema import build_file_descriptor_set

    from navstress.run.trace import read_grid, read_grids
    path = tmp_path / "bad.mcap"
    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        for topic, cls in ((TOPIC_TRUTH, PoseInFrame), (TOPIC_MAP, Grid)):
            sid = w.register_schema(cls.DESCRIPTOR.full_name, "protobuf",
                                    build_file_descriptor_set(cls).SerializeToString())
            cid = w.register_channel(topic, "protobuf", sid)
            w.add_message(cid, log_time=1, data=b"\x00\x01", publish_time=1, sequence=1)
        w.finish()
    for read in (lambda: read_poses(path, indexed=indexed), lambda: read_grid(path, indexed=indexed),
                 lambda: read_grids(path, indexed=indexed)):
        with pytest.raises(StoreError, match="is unreadable: DecodeError"):
            read()
