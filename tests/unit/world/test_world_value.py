"""World value object: exact save/load round trip, atomic writes, clear errors."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress.errors import WorldFileError
from navstress.world import Mission, Obstacle, Terrain, World, WorldSpec


def small_world(heights: np.ndarray, obstacles: list[Obstacle], seed: int) -> World:
    rows, cols = heights.shape
    spec = WorldSpec(size_m=((cols - 1) * 0.5, (rows - 1) * 0.5), cell_m=0.5)
    return World(spec=spec, seed=seed, terrain=Terrain(heights, 0.5), obstacles=tuple(obstacles),
                 mission=Mission((1.0, 1.0, 0.3), (9.0, 9.0), 2.0), descriptors={"note": "x", "v": 1.5})


floats = st.floats(-50, 50, allow_nan=False, width=32)
obstacle = st.builds(Obstacle, kind=st.sampled_from(["tree", "building"]), x=floats, y=floats,
                     yaw=st.floats(-math.pi, math.pi), size=st.tuples(*[st.floats(0.1, 10)] * 3), z=floats)


@settings(max_examples=25, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.integers(21, 30), st.lists(obstacle, max_size=5), st.integers(0, 2**62), st.integers(0, 2**32))
def test_save_load_round_trips_exactly(tmp_path: Path, n: int, obs: list[Obstacle], seed: int, hseed: int) -> None:
    h = np.random.default_rng(hseed).normal(0, 3, (n, n)).astype(np.float32)
    w = small_world(h, obs, seed)
    d = tmp_path / f"w{seed}-{hseed}-{n}"
    w.save(d)
    back = World.load(d)
    assert back == w
    assert back.terrain.heights.dtype == np.float32
    # saving again gives byte-identical files
    d2 = tmp_path / f"again{seed}-{hseed}-{n}"
    back.save(d2)
    assert (d / "world.json").read_bytes() == (d2 / "world.json").read_bytes()
    assert np.array_equal(np.load(d / "terrain.npz")["heights"], np.load(d2 / "terrain.npz")["heights"])


def test_world_json_schema(tmp_path: Path) -> None:
    w = small_world(np.zeros((21, 21), np.float32), [Obstacle("tree", 3.0, 4.0, 0.1, (1.0, 1.0, 5.0), 0.0)], 5)
    w.save(tmp_path / "w")
    meta = json.loads((tmp_path / "w" / "world.json").read_text())
    assert meta["obstacles"][0] == {"kind": "tree", "x": 3.0, "y": 4.0, "yaw": 0.1, "size": [1.0, 1.0, 5.0], "z": 0.0}
    assert meta["mission"]["start"] == [1.0, 1.0, 0.3] and meta["mission"]["goal"] == [9.0, 9.0]
    assert meta["seed"] == 5 and "spec" in meta


def test_save_refuses_a_non_world_directory(tmp_path: Path) -> None:
    (tmp_path / "taken").mkdir()
    (tmp_path / "taken" / "precious.txt").write_text("keep me")
    w = small_world(np.zeros((21, 21), np.float32), [], 1)
    with pytest.raises(WorldFileError, match="exists and is not a world"):
        w.save(tmp_path / "taken")
    assert (tmp_path / "taken" / "precious.txt").read_text() == "keep me"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken"]  # no temp dir left behind


def test_load_errors_are_clear(tmp_path: Path) -> None:
    with pytest.raises(WorldFileError, match="not a world directory"):
        World.load(tmp_path)
    w = small_world(np.zeros((21, 21), np.float32), [], 1)
    w.save(tmp_path / "w")
    (tmp_path / "w" / "world.json").write_text("{not json")
    with pytest.raises(WorldFileError, match="corrupt"):
        World.load(tmp_path / "w")


@given(st.floats(0, 10), st.floats(0, 10))
def test_height_at_is_exact_on_a_plane(x: float, y: float) -> None:
    # A plane is represented exactly by any triangulation: height_at must reproduce it.
    i, j = np.mgrid[0:21, 0:21]
    h = (0.3 * j * 0.5 - 0.2 * i * 0.5 + 1.0).astype(np.float32)
    t = Terrain(h, 0.5)
    assert t.height_at(x, y) == pytest.approx(0.3 * x - 0.2 * y + 1.0, abs=1e-5)


@given(st.integers(0, 19), st.integers(0, 19))
def test_height_at_vertices(i: int, j: int) -> None:
    h = np.random.default_rng(i * 100 + j).normal(0, 1, (21, 21)).astype(np.float32)
    t = Terrain(h, 0.5)
    assert t.height_at(j * 0.5, i * 0.5) == pytest.approx(float(h[i, j]), abs=1e-5)
