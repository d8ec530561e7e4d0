"""The report's SVG maps: line simplification keeps every dropped point within its tolerance;
pictures are well-formed XML for any track (NaN poses included) and draw what they are given."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from html import escape

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from navstress.analysis import svgmap
from navstress.run.figures import RunTrack
from navstress.world.generate import generate
from navstress.world.spec import WorldSpec
from navstress.world.world import World

coords = arrays(np.float64, st.tuples(st.integers(0, 120), st.just(2)),
                elements=st.floats(-200, 200, allow_nan=False, allow_infinity=False))


def _seg_dist(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    L = float(ab @ ab)
    if L == 0:
        return float(np.hypot(*(p - a)))
    # distance to the infinite line through a and b, as RDP measures it
    return abs(ab[0] * (p - a)[1] - ab[1] * (p - a)[0]) / math.sqrt(L)


@settings(max_examples=100, deadline=None)
@given(coords, st.floats(0.001, 5.0))
def test_simplify_keeps_the_ends_and_every_dropped_point_within_tolerance(xy: np.ndarray, tol: float) -> None:
    out = svgmap.simplify(xy, tol)
    assert len(out) <= len(xy)
    if len(xy) == 0:
        return
    assert (out[0] == xy[0]).all() and (out[-1] == xy[-1]).all()
    # the kept points are a subsequence of the input, and every dropped point lies within tol of
    # the kept segment spanning it
    idx = []
    j = 0
    for k, p in enumerate(xy):
        if j < len(out) and (p == out[j]).all():
            idx.append(k)
            j += 1
    assert j == len(out)
    for a, b in zip(idx, idx[1:]):
        for m in range(a + 1, b):
            assert _seg_dist(xy[m], xy[a], xy[b]) <= tol + 1e-9


def _rdp_reference(xy: np.ndarray, tol: float) -> np.ndarray:
    """Ramer-Douglas-Peucker in numpy, one segment at a time (the report's simplification before
    it was compiled; ``hypot`` from numpy, i.e. libm's, as the compiled loop's)."""
    n = len(xy)
    if n <= 2:
        return xy
    keep = np.zeros(n, dtype=bool)
    keep[0] = keep[-1] = True
    stack = [(0, n - 1)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        a, b = xy[i], xy[j]
        seg = b - a
        pts = xy[i + 1:j] - a
        length = float(np.hypot(seg[0], seg[1]))
        if length < 1e-12:
            d = np.hypot(pts[:, 0], pts[:, 1])
        else:
            d = np.abs(seg[0] * pts[:, 1] - seg[1] * pts[:, 0]) / length
        k = int(np.argmax(d))
        if d[k] > tol:
            m = i + 1 + k
            keep[m] = True
            stack.append((i, m))
            stack.append((m, j))
    return xy[keep]


# polylines as runs draw them (steps along a heading that turns), with repeated points, spikes,
# collinear stretches and exact ties among them
walks = st.builds(
    lambda steps, turns, x0, y0: np.column_stack([x0 + np.cumsum(np.cos(np.cumsum(turns)) * steps),
                                                  y0 + np.cumsum(np.sin(np.cumsum(turns)) * steps)]),
    arrays(np.float64, 300, elements=st.sampled_from([0.0, 0.05, 0.1, 0.5, 3.0])),
    arrays(np.float64, 300, elements=st.sampled_from([0.0, 0.0, 0.02, -0.3, math.pi / 2, math.pi])),
    st.floats(-100, 100), st.floats(-100, 100))


@settings(max_examples=150, deadline=None)
@given(st.one_of(coords, walks, coords.map(lambda a: np.round(a))), st.sampled_from([0.0, 1e-9, 0.05, 0.2, 1.0, 7.5]))
def test_compiled_simplification_keeps_exactly_the_points_numpy_keeps(xy: np.ndarray, tol: float) -> None:
    """The compiled loop is the numpy algorithm, point for point (same arithmetic, same ties)."""
    assert svgmap.simplify(xy, tol).tobytes() == _rdp_reference(xy, tol).tobytes()


@pytest.fixture(scope="module")
def world() -> World:
    return generate(WorldSpec.model_validate({"size_m": [30.0, 20.0], "cell_m": 0.5,
                                              "obstacles": {"obstruction": {"tree": 3.0}}}), seed=4)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(sorted(svgmap.OUTCOME_COLOURS)),
                          arrays(np.float64, st.tuples(st.integers(0, 50), st.just(7)),
                                 elements=st.floats(-40, 60) | st.just(float("nan")))),
                max_size=4))
def test_a_picture_is_well_formed_for_any_tracks(world: World, runs: list[tuple[str, np.ndarray]]) -> None:
    tracks = [(f"run-{i}", RunTrack(f"r{i}", o, arr, perceived=arr), f"r{i} <&> \u2013") for i, (o, arr) in
              enumerate(runs)]
    tracks = [(rid, tr, escape(tip)) for rid, tr, tip in tracks]
    doc = ("<svg xmlns='http://www.w3.org/2000/svg'><defs>" + svgmap.world_defs(world, "w") + "</defs>"
           + svgmap.runs_svg(world, "w", tracks, perceived=True).replace("<svg ", "<svg xmlns='http://www.w3.org/2000/svg' ", 1)
           + "</svg>")
    root = ET.fromstring(doc)
    ns = "{http://www.w3.org/2000/svg}"
    groups = [g for g in root.iter(f"{ns}g") if g.get("data-run")]
    assert [g.get("data-run") for g in groups] == [t[0] for t in tracks]
    for g, (_rid, tr, _tip) in zip(groups, tracks):
        assert g.get("class") == f"o-{tr.outcome}"
        finite = np.isfinite(tr.truth[:, 1:3]).all(axis=1).sum()
        lines = [p for p in g.iter(f"{ns}polyline") if p.get("class") != "perceived"]
        assert len(lines) == (1 if finite else 0)
        for p in g.iter(f"{ns}polyline"):
            pts = [tuple(map(float, q.split(","))) for q in (p.get("points") or "").split()]
            assert all(math.isfinite(x) and math.isfinite(y) for x, y in pts)


def test_the_world_layer_draws_every_obstacle_start_and_goal(world: World) -> None:
    g = ET.fromstring(svgmap.world_defs(world, "w").replace("<g ", "<g xmlns='http://www.w3.org/2000/svg' ", 1))
    ns = "{http://www.w3.org/2000/svg}"
    d = "".join(p.get("d") or "" for p in g.iter(f"{ns}path"))
    assert d.count("M") == len(world.obstacles) > 0  # one closed outline per obstacle
    sy = world.size_m[1]
    x0, y0, _ = world.mission.start
    start = next(c for c in g.iter(f"{ns}circle") if (c.findtext(f"{ns}title") or "") == "start")
    assert float(start.get("cx") or "nan") == pytest.approx(x0, abs=0.05)
    assert float(start.get("cy") or "nan") == pytest.approx(sy - y0, abs=0.05)  # y flipped
    assert any((p.findtext(f"{ns}title") or "") == "goal" for p in g.iter(f"{ns}polygon"))


def _n_reference(v: float) -> str:
    r = round(v * 20) / 20
    return str(int(r)) if r == int(r) else f"{r:.2f}".rstrip("0")


def _path_reference(corners: np.ndarray, sy: float) -> str:
    q = [(round(float(x) * 20), round(float(sy - y) * 20)) for x, y in corners]
    out = [f"M{_n_reference(q[0][0] / 20)} {_n_reference(q[0][1] / 20)}"]
    for (ax, ay), (bx, by) in zip(q, q[1:]):
        out.append(f"l{_n_reference((bx - ax) / 20)} {_n_reference((by - ay) / 20)}")
    return "".join(out) + "z"


@settings(max_examples=200, deadline=None)
@given(st.floats(-1e6, 1e6), st.lists(arrays(np.float64, st.tuples(st.integers(1, 9), st.just(2)),
                                             elements=st.floats(-5e3, 5e3)), max_size=6),
       st.floats(0, 1e4), st.floats(0.0, 2.0))
def test_rounded_numbers_paths_and_points_are_written_as_one_number_at_a_time(
        v: float, polygons: list[np.ndarray], sy: float, tol: float) -> None:
    """The memoised, vectorised writing of coordinates (5 cm grid) gives the text the plain
    per-number formula gives, for numbers, obstacle paths and run lines."""
    assert svgmap._n(v) == _n_reference(v)
    assert svgmap._paths(polygons, sy) == [_path_reference(p, sy) for p in polygons]
    for p in polygons:
        kept = svgmap.simplify(p, tol)
        assert svgmap._points(p, sy, tol) == " ".join(f"{_n_reference(x)},{_n_reference(sy - y)}" for x, y in kept)
