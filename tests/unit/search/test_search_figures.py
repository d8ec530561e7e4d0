"""The search report's pictures from small real inputs, read back as drawn: the illumination map
and the found-against-runs chart by the real Vega renderer (mark by mark: the map colours exactly
its filled cells, by their best fitness, over their cells' ranges, and leaves the empty ones blank;
the found chart draws each method's line in its colour), the best worlds as a PNG pixel by pixel
with the trajectories of real runs (a tiny batch on a hand-made world)."""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib import colormaps
from matplotlib.colors import to_rgb
from matplotlib.image import imread

from navstress.errors import SpecError
from navstress.run.batch import plan_batch, run_batch
from navstress.run.figures import OUTCOME_COLOURS
from tests.support.chart_render import fields, marks
from tests.support.chart_render import rgb as css_rgb
from navstress.analysis.charts import METHOD_COLOURS
from navstress.search.figures import (BestWorld, Found, MapPoint, best_worlds_figure, cell_of, found_against_runs,
                                      found_curve, illumination_grid, illumination_map, tracks_of)
from navstress.world.world import Mission, World
from tests.support.world_fixtures import small_world


def rgb(png: bytes) -> np.ndarray:
    img = imread(io.BytesIO(png), format="png")
    assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
    return np.asarray(img[..., :3], np.float64)


def coloured(px: np.ndarray) -> np.ndarray:
    """Pixels with a colour (not white, grey or black)."""
    return (px.max(axis=-1) - px.min(axis=-1)) > 0.2


def near(px: np.ndarray, colour: str, tol: float = 0.08) -> np.ndarray:
    return np.abs(px - np.array(to_rgb(colour))).max(axis=-1) < tol


# ---------------------------------------------------------------- (a) the illumination map

X_RANGE, Y_RANGE, BINS = (0.0, 30.0), (0.0, 1.0), (3, 2)


def cmap_rgb(value: float) -> np.ndarray:
    return np.array(colormaps["plasma"](value)[:3]) * 255


def check_map(spec: dict, fit: np.ndarray, keys: list[list[str]], x_range: tuple[float, float],
              y_range: tuple[float, float]) -> None:
    """Every filled cell, and no other, is a rectangle over its cell's ranges in the colour of its
    best fitness (Vega's plasma, against matplotlib's within a few levels), naming its world."""
    rects = marks(spec, "cells")
    ny, nx = fit.shape
    assert len(rects) == int(np.isfinite(fit).sum())
    if not rects:
        return
    # the pixel scale from the drawn axes: a cell is (plot width / nx) wide
    cell_w = rects[0]["width"]
    cell_h = rects[0]["height"]
    plot_h = cell_h * ny
    seen = set()
    for r in rects:
        j = round(r["x"] / cell_w)
        i = ny - 1 - round(r["y"] / cell_h)
        assert r["width"] == pytest.approx(cell_w) and r["height"] == pytest.approx(cell_h)
        assert 0 <= i < ny and 0 <= j < nx and np.isfinite(fit[i, j]), (i, j)
        assert fields(r)["world"] == keys[i][j]
        assert float(fields(r)[next(k for k in fields(r) if k.startswith("best world"))]) == pytest.approx(fit[i, j])
        assert np.abs(np.array(css_rgb(r["fill"])) - cmap_rgb(fit[i, j])).max() <= 12, (i, j, r["fill"])
        seen.add((i, j))
        assert r["y"] + cell_h <= plot_h + 0.5
    assert len(seen) == len(rects)


def test_illumination_map_colours_filled_cells_by_their_best_world() -> None:
    points = [MapPoint(5.0, 0.2, 0.3, "a"),                     # cell (0, 0)
              {"x": 25.0, "y": 0.8, "fitness": 0.9, "key": "b"},  # cell (1, 2)
              MapPoint(26.0, 0.9, 0.1, "c"),                    # same cell, worse: not shown
              MapPoint(100.0, -5.0, 0.6, "d")]                  # outside: clipped to cell (0, 2)
    fit, keys = illumination_grid(points, X_RANGE, Y_RANGE, BINS)
    assert np.array_equal(np.isfinite(fit), [[True, False, True], [False, False, True]])
    assert (fit[0, 0], fit[1, 2], fit[0, 2]) == (0.3, 0.9, 0.6) and keys[1][2] == "b"
    spec = illumination_map(points, x="obstruction", y="roughness", x_range=X_RANGE, y_range=Y_RANGE, bins=BINS)
    check_map(spec, fit, keys, X_RANGE, Y_RANGE)
    assert spec["title"] == "Illumination map: 3 of 6 cells filled"


def test_an_empty_map_is_blank_and_axes_name_their_units() -> None:
    spec = illumination_map([], x="barn_dispersion", y="path_ratio", bins=BINS)
    assert marks(spec, "cells") == []
    titles = [spec["encoding"][a]["title"] for a in ("x", "y")]
    from navstress.search.objectives import get_descriptor
    assert titles == [get_descriptor("barn_dispersion", "x").axis_label, get_descriptor("path_ratio", "y").axis_label]
    with pytest.raises(SpecError) as ei:
        illumination_map([], x="obstructon", y="roughness")
    assert ei.value.field == "x" and "obstruction" in str(ei.value)
    with pytest.raises(SpecError, match="y_range"):
        illumination_map([], x="obstruction", y="roughness", y_range=(1.0, 1.0))
    with pytest.raises(SpecError, match="vmax"):
        illumination_map([], x="obstruction", y="roughness", vmax=0.0)
    with pytest.raises(SpecError, match="bins.x"):
        illumination_grid([], X_RANGE, Y_RANGE, (0, 2))
    with pytest.raises(SpecError, match="fitness"):
        illumination_grid([{"x": 1.0, "y": 0.5}], X_RANGE, Y_RANGE, BINS)


@settings(max_examples=6, deadline=None)
@given(points=st.lists(st.builds(MapPoint, st.floats(-10, 40), st.floats(-0.5, 1.5), st.floats(0, 1),
                                 st.sampled_from("abcdefgh")), max_size=20))
def test_the_drawn_map_is_its_grid(points: list[MapPoint]) -> None:
    fit, keys = illumination_grid(points, X_RANGE, Y_RANGE, BINS)
    check_map(illumination_map(points, x="obstruction", y="roughness", x_range=X_RANGE, y_range=Y_RANGE,
                               bins=BINS), fit, keys, X_RANGE, Y_RANGE)


points_st = st.lists(st.builds(MapPoint, st.floats(-10, 40), st.floats(-0.5, 1.5), st.floats(0, 1),
                               st.sampled_from("abcdefgh")), max_size=30)


@settings(max_examples=80, deadline=None)
@given(points=points_st, data=st.data())
def test_each_cell_keeps_its_best_point(points: list[MapPoint], data: st.DataObject) -> None:
    fit, _ = illumination_grid(points, X_RANGE, Y_RANGE, BINS)
    want: dict[tuple[int, int], float] = {}
    for p in points:
        k = (cell_of(p.y, *Y_RANGE, BINS[1]), cell_of(p.x, *X_RANGE, BINS[0]))
        want[k] = max(want.get(k, -1.0), p.fitness)
    assert {(int(i), int(j)) for i, j in zip(*np.nonzero(np.isfinite(fit)))} == set(want)
    assert all(fit[k] == v for k, v in want.items())
    shuffled, _ = illumination_grid(data.draw(st.permutations(points)), X_RANGE, Y_RANGE, BINS)
    assert np.array_equal(shuffled, fit, equal_nan=True)


# ---------------------------------------------------------------- (b) found against runs spent

found_st = st.lists(st.builds(Found, st.integers(0, 500), st.sampled_from("abcdef"), st.booleans()), max_size=30)


@settings(max_examples=80, deadline=None)
@given(evs=found_st)
def test_found_curve_counts_distinct_worlds_in_run_order(evs: list[Found]) -> None:
    c = found_curve(evs)
    assert c[0] == (0, 0) and len(c) == len(evs) + 1
    assert all(a[0] <= b[0] and a[1] <= b[1] <= a[1] + 1 for a, b in zip(c, c[1:]))
    assert c[-1][1] == len({e.key for e in evs if e.found})
    if len({e.runs for e in evs}) == len(evs):  # distinct run counts: the order given does not matter
        assert found_curve(list(reversed(evs))) == c


def lines_by_method(spec: dict) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for v in marks(spec, "lines"):
        out.setdefault(fields(v)["method"], []).append(v)
    return out


def test_found_chart_draws_each_method_in_its_colour() -> None:
    search = [Found(10 * k, f"s{k % 4}", k % 2 == 0) for k in range(1, 12)]
    rand = [{"runs": 10 * k, "key": f"r{k}", "found": k == 7} for k in range(1, 12)]
    assert found_curve(search)[-1] == (110, 2) and found_curve(rand)[-1] == (110, 1)
    spec = found_against_runs({"search": search, "random": rand}, budget=120)
    lines = lines_by_method(spec)
    assert sorted(lines) == ["random", "search"]
    for m, evs in (("search", search), ("random", rand)):
        assert {css_rgb(v["stroke"]) for v in lines[m]} == {css_rgb(METHOD_COLOURS[m])}
        assert [(int(fields(v)["runs"]), int(fields(v)["found"])) for v in lines[m]] == found_curve(evs)
    # a higher count is drawn higher
    top = {m: min(v["y"] for v in vs) for m, vs in lines.items()}
    assert top["search"] < top["random"]
    only = found_against_runs({"random": rand}, what="failing worlds")
    assert sorted(lines_by_method(only)) == ["random"]
    assert only["title"] == "Failing worlds found against runs spent"
    with pytest.raises(SpecError, match="runs"):
        found_curve([{"runs": -1, "key": "a", "found": True}])


def test_a_confirmed_count_is_a_star_of_its_method() -> None:
    evs = [Found(10 * k, f"s{k}", True) for k in range(1, 4)]
    plain = found_against_runs({"search": evs})
    marked = found_against_runs({"search": evs}, confirmed={"search": (30, 2)})
    assert "confirmed" not in json.dumps(plain)
    (star,) = marks(marked, "confirmed")
    assert css_rgb(star["fill"]) == css_rgb(METHOD_COLOURS["search"])
    assert fields(star)["confirmed"] == "search: 2 confirmed"
    # at (30 runs, 2 worlds): on the line's scales, between its points at 1 and 3 worlds
    pts = {int(fields(v)["found"]): v for v in marks(marked, "lines")}
    assert pts[1]["y"] > star["y"] > pts[3]["y"] and star["x"] == pytest.approx(pts[3]["x"])


# ---------------------------------------------------------------- (c) the best worlds and their runs


@pytest.fixture(scope="module")
def tiny_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list]:
    """Real runs of the reference stack, nominal and faulty, on a small hand-made world (short
    timeout: the trajectories are a few meters long, their traces real)."""
    root = tmp_path_factory.mktemp("best")
    w = small_world(2)
    World(w.spec, w.seed, w.terrain, w.obstacles, Mission((4.0, 4.0, math.pi / 4), (16.0, 16.0), 1.5)).save(root / "w")
    tasks = plan_batch(root / "w", root / "traces", navigator="reference-v1", navigator_config={}, fault=None,
                       runs=2, seed=3, timeout_s=7.0, goal_tolerance_m=1.0)
    tasks += plan_batch(root / "w", root / "traces-f", navigator="reference-v1", navigator_config={},
                        fault="small-footprint", runs=1, seed=3, timeout_s=7.0, goal_tolerance_m=1.0)
    return root, run_batch(tasks, root / "out")


def test_best_worlds_are_drawn_with_their_runs(tiny_runs: tuple[Path, list]) -> None:
    root, records = tiny_runs
    assert all(r.trace for r in records)
    rel = [r.__class__(**{**r.__dict__, "trace": str(Path(r.trace).relative_to(root))}) for r in records]
    tracks = tracks_of(rel, root)
    assert len(tracks) == 3 and all(len(t.truth) > 2 for t in tracks)
    assert all(np.hypot(*(t.truth[-1, 1:3] - t.truth[0, 1:3])) > 1.0 for t in tracks)  # the robot moved
    assert [t.outcome for t in tracks] == [r.outcome for r in records]
    assert [len(t.truth) for t in tracks_of(records, "/nonexistent", max_points=3)] == [3, 3, 3]
    gone = records[0].__class__(**{**records[0].__dict__, "trace": "missing.mcap"})
    assert tracks_of([gone], root) == []
    with_runs = rgb(best_worlds_figure([BestWorld(root / "w", tracks, "w0: fitness 1.00"),
                                        BestWorld(root / "w", tracks[:1], "w1")], columns=2))
    without = rgb(best_worlds_figure([BestWorld(root / "w", [], "w0: fitness 1.00"),
                                      BestWorld(root / "w", [], "w1")], columns=2))
    assert with_runs.shape == without.shape
    changed = np.abs(with_runs - without).max(axis=-1) > 0.1
    assert changed.sum() > 30
    for outcome in {t.outcome for t in tracks}:  # each outcome's colour appears where runs were drawn
        assert (near(with_runs, OUTCOME_COLOURS[outcome]) & changed).sum() > 60, outcome
    with pytest.raises(SpecError, match="worlds"):
        best_worlds_figure([])
