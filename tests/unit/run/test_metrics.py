"""Trajectory metrics against hand-computed values."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from navstress.run.metrics import path_length, resample_by_distance, tortuousness


def test_square_path() -> None:
    xy = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    assert path_length(xy) == 30.0
    # resampled every 0.5 m: 61 points, two corners of 90 degrees among 59 heading changes
    assert tortuousness(xy) == pytest.approx(2 * (math.pi / 2) / 59)


def test_circle_heading_change_per_step() -> None:
    r = 10.0
    th = np.linspace(0, 2 * math.pi, 20001)
    xy = np.column_stack([r * np.cos(th), r * np.sin(th)])
    assert path_length(xy) == pytest.approx(2 * math.pi * r, rel=1e-6)
    # a chord of 0.5 m on a circle of radius 10 turns the heading by 0.5/10 rad
    assert tortuousness(xy) == pytest.approx(2 * math.asin(0.25 / r), rel=1e-3)


def test_jitter_at_a_standstill_does_not_count() -> None:
    rng = np.random.default_rng(0)
    still = rng.normal(0, 0.002, (500, 2))  # 2 mm jitter while stopped
    line = np.column_stack([np.linspace(0, 20, 200), np.zeros(200)])
    xy = np.vstack([still, line])
    assert tortuousness(xy) < 0.02


def test_degenerate_inputs() -> None:
    assert path_length(np.zeros((0, 2))) == 0.0 and tortuousness(np.zeros((1, 2))) == 0.0
    assert tortuousness(np.array([[0, 0], [0.1, 0]])) == 0.0
    assert len(resample_by_distance(np.array([[0, 0], [0, 0], [1, 0]]))) == 3


@given(st.floats(-math.pi, math.pi), st.floats(0.5, 50))
def test_straight_line_any_direction(angle: float, length: float) -> None:
    t = np.linspace(0, length, 50)
    xy = np.column_stack([t * math.cos(angle), t * math.sin(angle)])
    assert path_length(xy) == pytest.approx(length)
    assert tortuousness(xy) == pytest.approx(0.0, abs=1e-6)
