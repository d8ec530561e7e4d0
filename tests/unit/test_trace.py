"""MCAP traces: what is written is read back; same input gives the same bytes; atomic."""

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from navstress.errors import StoreError
from navstress.run.trace import (TOPIC_MAP, TOPIC_PERCEIVED, TOPIC_TRUTH, TraceWriter, euler, quaternion, read_events,
                                 read_grid, read_metadata, read_poses)

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


def test_unreadable_trace_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(StoreError, match="does not exist"):
        read_poses(tmp_path / "missing.mcap")
    (tmp_path / "junk.mcap").write_bytes(b"not an mcap file at all")
    with pytest.raises(StoreError, match="unreadable"):
        read_poses(tmp_path / "junk.mcap")
