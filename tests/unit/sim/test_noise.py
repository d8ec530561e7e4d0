"""The ziggurat normal sampler of ``navstress.sim._noise`` and its use in ``Lidar.scan``."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from navstress.errors import SpecError
from navstress.sim import _noise
from navstress.sim.lidar import Lidar, LidarConfig, LidarScene


def _binom_ok(count: int, n: int, p: float, z: float = 5.0) -> bool:
    return abs(count - n * p) <= z * math.sqrt(n * p * (1 - p)) + 1


def test_tables_close() -> None:
    # r of the 256-layer ziggurat (Marsaglia & Tsang 2000; numpy's ziggurat_nor_r)
    assert _noise.R == pytest.approx(3.6541528853610088, rel=1e-13)
    v, xs = _noise._layers(_noise.R, _noise.LAYERS)
    assert abs(xs[-1] * (1 - math.exp(-0.5 * xs[-1] ** 2)) - v) < 1e-11 * v


def test_distribution_is_standard_normal() -> None:
    n = 1_000_000
    z = _noise.standard_normals(np.random.default_rng(2024), n)
    assert stats.kstest(z, "norm").pvalue > 1e-4
    assert abs(z.mean()) < 5 / math.sqrt(n)
    assert abs(z.var() - 1) < 5 * math.sqrt(2 / n)
    for t in (1.0, 2.0, 3.0, 3.6541528853610088, 4.0, 4.5):  # tails, R (the tail's start) included
        assert _binom_ok(int(np.sum(np.abs(z) > t)), n, math.erfc(t / math.sqrt(2))), t
    assert _binom_ok(int(np.sum(z > 0)), n, 0.5)


def test_tail_and_wedges_exact_per_layer_shape() -> None:
    # conditional on |z| > R (tail path only), |z| - R follows the normal tail law
    z = np.abs(_noise.standard_normals(np.random.default_rng(7), 2_000_000))
    tail = z[z > _noise.R]
    cdf = lambda x: 1 - np.array([math.erfc(v / math.sqrt(2)) for v in x]) / math.erfc(_noise.R / math.sqrt(2))  # noqa: E731
    assert stats.kstest(tail, cdf).pvalue > 1e-4
    # a fine histogram of |z| against the exact bin probabilities (wedge regions included)
    edges = np.linspace(0, 4, 161)
    counts, _ = np.histogram(z, edges)
    p = np.diff([math.erf(e / math.sqrt(2)) for e in edges])
    assert stats.chisquare(counts, p / p.sum() * counts.sum()).pvalue > 1e-4


def test_same_seed_same_sequence_and_seeds_differ() -> None:
    a = _noise.standard_normals(np.random.default_rng(5), 5000)
    b = _noise.standard_normals(np.random.default_rng(5), 5000)
    c = _noise.standard_normals(np.random.default_rng(6), 5000)
    assert np.array_equal(a, b)
    assert np.mean(a == c) < 0.01


@settings(max_examples=30, deadline=None)
@given(n=st.integers(0, 3000), seed=st.integers(0, 2**32 - 1))
def test_prefix_and_word_count(n: int, seed: int) -> None:
    # one 32-bit half per sample: the first draws do not depend on the other samples
    rng = np.random.default_rng(seed)
    words = rng.bit_generator.random_raw((n + 1) // 2)
    rng2 = np.random.default_rng(seed)
    z = _noise.standard_normals(rng2, n)
    assert z.shape == (n,) and np.all(np.isfinite(z))
    # the generator advanced by exactly ceil(n/2) + spare words (no refill at default spare)
    rng3 = np.random.default_rng(seed)
    rng3.bit_generator.random_raw((n + 1) // 2 + _noise.default_spare(n))
    assert rng2.bit_generator.random_raw() == rng3.bit_generator.random_raw()
    # samples accepted at once are x = u * X[i] / 2^23 with the sign bit, from their half-word
    h = np.empty(2 * len(words), np.int64)
    h[0::2], h[1::2] = words & 0xFFFFFFFF, words >> np.uint64(32)
    h = h[:n]
    i, u = h & 0xFF, h >> 9
    quick = u < _noise._K32[i]
    x = u * _noise._W32[i] * np.where(h & 0x100, -1.0, 1.0)
    assert np.array_equal(z[quick], x[quick])


def test_refill_deterministic_and_exact() -> None:
    # spare=2 forces refills (a tail attempt alone takes 2 words); the result is still N(0, 1)
    a = _noise.standard_normals(np.random.default_rng(11), 200_000, spare=2)
    b = _noise.standard_normals(np.random.default_rng(11), 200_000, spare=2)
    assert np.array_equal(a, b)
    assert stats.kstest(a, "norm").pvalue > 1e-4
    assert _binom_ok(int(np.sum(np.abs(a) > 3)), a.size, math.erfc(3 / math.sqrt(2)))
    # samples before the first refill agree with the default-spare stream's quick samples
    d = _noise.standard_normals(np.random.default_rng(11), 200_000)
    assert np.mean(a == d) > 0.98


def test_bad_arguments() -> None:
    with pytest.raises(SpecError, match="spare"):
        _noise.standard_normals(np.random.default_rng(0), 10, spare=1)
    with pytest.raises(SpecError, match="n="):
        _noise.standard_normals(np.random.default_rng(0), -1)


def _lidar() -> Lidar:
    h = np.zeros((51, 51), np.float32)
    return Lidar(LidarScene(h, 0.4, np.zeros((0, 7))), LidarConfig(range_noise_std_m=0.05))


def test_scan_noise_matches_stream_and_advances() -> None:
    lidar = _lidar()
    o, rot = np.array([10.0, 10.0, 1.0]), np.eye(3)
    clean = lidar.scan(o, rot)
    rng = np.random.default_rng(3)
    p1, p2 = lidar.scan(o, rot, rng), lidar.scan(o, rot, rng)
    assert p1.shape == clean.shape and not np.array_equal(p1, p2)  # the generator advanced
    assert np.array_equal(p1, lidar.scan(o, rot, np.random.default_rng(3)))
    z = _noise.standard_normals(np.random.default_rng(3), len(clean))
    r0 = np.linalg.norm(clean.astype(np.float64), axis=1)
    r1 = np.linalg.norm(p1.astype(np.float64), axis=1)
    expect = np.maximum(r0 + 0.05 * z, 0)
    assert np.allclose(r1, expect, atol=1e-5)
    zz = (r1 - r0) / 0.05
    assert abs(zz.mean()) < 5 / math.sqrt(len(zz)) + 1e-3 and abs(zz.std() - 1) < 0.05


def test_scan_refill_path_matches_standard_normals(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_noise, "default_spare", lambda n: 2)
    lidar = _lidar()
    o, rot = np.array([10.0, 10.0, 1.0]), np.eye(3)
    clean = lidar.scan(o, rot)
    p = lidar.scan(o, rot, np.random.default_rng(9))
    z = _noise.standard_normals(np.random.default_rng(9), len(clean), spare=2)
    r0 = np.linalg.norm(clean.astype(np.float64), axis=1)
    assert np.allclose(np.linalg.norm(p.astype(np.float64), axis=1), np.maximum(r0 + 0.05 * z, 0), atol=1e-5)
