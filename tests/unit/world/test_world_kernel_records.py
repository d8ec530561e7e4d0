"""The world kernels' named record (placement's ROUND) holds every field given and refuses a
missing or an unknown one; one round of acceptance (``_accept``) takes it and the Candidates group
and keeps its contract on random rounds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.world.placement import ROUND, ROUND_FIELDS, Candidates, _accept, new_round

VALUES = dict(rx=0.25, ry=0.2, size_x=30.0, size_y=20.0, achieved=3.5, target=60.0, stop_tol=0.5)


def test_a_round_holds_every_field_given() -> None:
    assert set(VALUES) == ROUND_FIELDS
    rec = new_round(**VALUES)
    assert rec.dtype == ROUND and rec.shape == (1,)
    assert {name: float(rec[name][0]) for name in VALUES} == VALUES


@pytest.mark.parametrize("name", sorted(ROUND_FIELDS))
def test_a_round_refuses_a_missing_field(name: str) -> None:
    with pytest.raises(TypeError, match=f"missing: \\['{name}'\\], unknown: \\[\\]"):
        new_round(**{k: v for k, v in VALUES.items() if k != name})


@pytest.mark.parametrize("extra", ["x", "cell", "RX", "target_pct"])
def test_a_round_refuses_an_unknown_field(extra: str) -> None:
    with pytest.raises(TypeError, match=f"missing: \\[\\], unknown: \\['{extra}'\\]"):
        new_round(**VALUES, **{extra: 1.0})


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_a_round_accepts_non_overlapping_boxes_inside_the_map_up_to_the_target(seed: int) -> None:
    g = np.random.default_rng(seed)
    nx, ny, r = int(g.integers(20, 80)), int(g.integers(20, 80)), float(g.uniform(0.1, 0.3))
    occ = (g.random((ny, nx)) < 0.05).astype(np.uint8)
    before = occ.copy()
    n = int(g.integers(1, 60))
    cand = Candidates(g.uniform(0, nx * r, n), g.uniform(0, ny * r, n), g.uniform(0.2, 2.0, n), g.uniform(0.2, 2.0, n),
                      np.zeros(n, np.bool_))
    sx0, sy0 = cand.sx.copy(), cand.sy.copy()
    target, tol, start = float(g.uniform(1, 40)), float(g.uniform(0.01, 1.0)), float(g.uniform(0, 5))
    achieved, tried, trimmed = _accept(occ, cand, new_round(rx=r, ry=r, size_x=nx * r, size_y=ny * r, achieved=start,
                                                            target=target, stop_tol=tol))
    kept = np.flatnonzero(cand.keep)
    assert achieved == pytest.approx(start + float((cand.sx[kept] * cand.sy[kept]).sum()))
    assert start <= achieved <= max(start, target + tol + 1e-9) and tried <= n and trimmed <= len(kept)
    assert np.array_equal(cand.sx[~cand.keep], sx0[~cand.keep]) and np.array_equal(cand.sy[~cand.keep], sy0[~cand.keep])
    marks = np.zeros_like(occ, np.int64)
    for k in kept:  # inside the map, on free cells only, and no two share a cell
        x0, x1 = cand.x[k] - cand.sx[k] / 2, cand.x[k] + cand.sx[k] / 2
        y0, y1 = cand.y[k] - cand.sy[k] / 2, cand.y[k] + cand.sy[k] / 2
        assert 0.0 <= x0 and x1 <= nx * r and 0.0 <= y0 and y1 <= ny * r
        b0, b1 = int(math.floor(y0 / r)), min(ny - 1, int(math.floor(y1 / r)))
        a0, a1 = int(math.floor(x0 / r)), min(nx - 1, int(math.floor(x1 / r)))
        assert not before[b0:b1 + 1, a0:a1 + 1].any()
        marks[b0:b1 + 1, a0:a1 + 1] += 1
    assert marks.max(initial=0) <= 1
    assert np.array_equal(occ, before | (marks > 0))
