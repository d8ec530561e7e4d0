"""Terrain models: exact properties of the subdivide (Catmull-Rom) model and the fractal model."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.world.spec import GroundSpec
from navstress.world.terrain import catmull_rom_surface, control_heights, gradient_noise, make_heights, slope_deg

SHAPE = (129, 129)  # 0.4 m cells -> 51.2 m
CELL = 0.4


def sub(s: int, d: float, seed: int = 0, shape: tuple[int, int] = SHAPE) -> np.ndarray:
    return make_heights(GroundSpec(subdivisions=s, deformation=d), shape, CELL, np.random.default_rng(seed))


@given(s=st.integers(0, 6), seed=st.integers(0, 2**32))
@settings(max_examples=15, deadline=None)
def test_zero_deformation_is_flat_zero(s: int, seed: int) -> None:
    assert not sub(s, 0.0, seed).any()


@given(s=st.integers(0, 5), d=st.floats(0.1, 10.0), seed=st.integers(0, 2**32))
@settings(max_examples=20, deadline=None)
def test_surface_passes_through_control_vertices(s: int, d: float, seed: int) -> None:
    n = 2**s + 1
    shape = ((n - 1) * 4 + 1, (n - 1) * 4 + 1)  # every 4th sample is a control vertex
    ctrl = control_heights(s, d, np.random.default_rng(seed))
    assert np.all(np.abs(ctrl) <= d / 2)
    h = sub(s, d, seed, shape)
    np.testing.assert_allclose(h[::4, ::4], ctrl, atol=1e-9)


def test_s0_is_the_bilinear_plane_through_the_corners() -> None:
    ctrl = control_heights(0, 3.0, np.random.default_rng(5))
    h = sub(0, 3.0, 5, (11, 21))
    v = np.linspace(0, 1, 11)[:, None]
    u = np.linspace(0, 1, 21)[None, :]
    bil = (ctrl[0, 0] * (1 - u) * (1 - v) + ctrl[0, 1] * u * (1 - v) + ctrl[1, 0] * (1 - u) * v + ctrl[1, 1] * u * v)
    np.testing.assert_allclose(h, bil, atol=1e-12)


def test_catmull_rom_reproduces_linear_data_and_is_c1() -> None:
    yy, xx = np.mgrid[0:9, 0:9].astype(float)
    np.testing.assert_allclose(catmull_rom_surface(2 * xx - 3 * yy + 1, (33, 33)),
                               (2 * np.mgrid[0:33, 0:33][1] - 3 * np.mgrid[0:33, 0:33][0]) / 4 + 1, atol=1e-12)
    # C1: on a very fine sampling the first differences have no jumps at control vertices
    h = catmull_rom_surface(np.random.default_rng(1).random((5, 5)), (4001, 5))
    d1 = np.diff(h[:, 2])
    assert np.max(np.abs(np.diff(d1))) < 1e-5  # a kink would show up as an O(step) jump


def test_height_scales_linearly_with_deformation() -> None:
    np.testing.assert_allclose(sub(4, 3.0, 9), 1.5 * sub(4, 2.0, 9), rtol=1e-12, atol=1e-12)
    assert np.ptp(sub(4, 4.0, 9)) > np.ptp(sub(4, 1.0, 9))


def _corr_length(h: np.ndarray) -> float:
    """Lag (cells) where the row autocorrelation first drops below 1/2."""
    r = h - h.mean(axis=1, keepdims=True)
    var = np.mean(r * r)
    for lag in range(1, h.shape[1] // 2):
        if np.mean(r[:, lag:] * r[:, :-lag]) / var < 0.5:
            return lag
    return h.shape[1] / 2


def test_more_subdivisions_shorter_correlation_and_steeper() -> None:
    slopes, corr = [], []
    for s in (2, 4, 6):
        hs = [sub(s, 2.0, seed, (251, 251)) for seed in range(4)]
        slopes.append(np.mean([slope_deg(h, CELL).mean() for h in hs]))
        corr.append(np.mean([_corr_length(h) for h in hs]))
    assert slopes[0] < slopes[1] < slopes[2]
    assert corr[0] > corr[1] > corr[2]


def test_same_generator_state_same_heights_different_differs() -> None:
    np.testing.assert_array_equal(sub(3, 2.0, 11), sub(3, 2.0, 11))
    assert not np.array_equal(sub(3, 2.0, 11), sub(3, 2.0, 12))


def test_gradient_noise_bounded_and_fractal_scales_with_amplitude() -> None:
    xs = np.arange(200) * 0.4
    n = gradient_noise(xs, xs, 7.0, np.random.default_rng(0))
    assert np.abs(n).max() <= 1.0 + 1e-12 and n.std() > 0.1

    def frac(a: float, seed: int = 3) -> np.ndarray:
        return make_heights(GroundSpec(model="fractal", amplitude_m=a), (101, 101), CELL, np.random.default_rng(seed))

    assert not frac(0.0).any()
    np.testing.assert_allclose(frac(2.0), 2 * frac(1.0), atol=1e-12)
    assert np.abs(frac(1.0)).max() <= sum(0.5**k for k in range(5)) + 1e-9
    assert not np.array_equal(frac(1.0, 3), frac(1.0, 4))
