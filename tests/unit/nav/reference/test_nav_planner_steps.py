"""The planner's kernel, step by step: the CYCLE and MAP_CONSTANTS records refuse a missing or an
unknown field, and each step of ``_evaluate_fan`` (the window's classes, the fine obstacle squares,
the exemption under the robot, the squares near an arc, the fine contact test) matches an oracle
written from the map's own definitions (``TerrainMap.obstacles``, ``fine_obstacles``,
``footprint_cells``) and exact polygon overlap, on random maps."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.nav.reference.planner import (_CLEAR, _EXEMPT, _HIT, _KNOWN, _OBSTACLE, _RING, _UNKNOWN, CYCLE,
                                              CYCLE_FIELDS, TerrainArrays, _classify, _exempt_cells, _fine_contact,
                                              _fine_squares, _FineTest, _Grid, _rect, _squares_near, footprint_cells,
                                              new_cycle)
from navstress.nav.reference.terrain_map import (MAP_CONSTANTS, MAP_CONSTANTS_FIELDS, TerrainMap,
                                                 new_map_constants)
from tests.oracles.polygon import clip_area

CYCLE_VALUES = dict(ox=-1.0, oy=-2.0, cell=0.25, step=0.3, sub=3, hl=0.6, hw=0.4, rx=1.0, ry=2.0, ryaw=0.3, exempt=1,
                    max_slope_tan=0.5, max_rough=0.2, w_s=1.0, w_r=2.0, unknown_cost=math.inf, clear_m=0.2,
                    clear_cost=1.5, length=3.0, spin_dir=-1, spin_angle=1.25)
MAP_VALUES = dict(ox=-1.0, oy=-2.0, cell=0.25, sub=3, step=0.3, max_range2=900.0)
RECORDS = [(new_cycle, CYCLE, CYCLE_FIELDS, CYCLE_VALUES),
           (new_map_constants, MAP_CONSTANTS, MAP_CONSTANTS_FIELDS, MAP_VALUES)]


def test_the_example_values_name_every_field() -> None:
    assert set(CYCLE_VALUES) == CYCLE_FIELDS and set(MAP_VALUES) == MAP_CONSTANTS_FIELDS


@pytest.mark.parametrize("make, dtype, fields, values", RECORDS, ids=["CYCLE", "MAP_CONSTANTS"])
def test_a_record_holds_every_field_given(make, dtype, fields, values) -> None:  # type: ignore[no-untyped-def]
    rec = make(**values)
    assert rec.dtype == dtype and rec.shape == (1,)
    for name, v in values.items():
        assert rec[name][0] == v and type(rec[name][0].item()) is type(v), name


@pytest.mark.parametrize("make, fields, values", [(r[0], r[2], r[3]) for r in RECORDS], ids=["CYCLE", "MAP_CONSTANTS"])
def test_a_record_refuses_each_missing_field(make, fields, values) -> None:  # type: ignore[no-untyped-def]
    for name in sorted(fields):
        with pytest.raises(TypeError, match=f"missing: \\['{name}'\\], unknown: \\[\\]"):
            make(**{k: v for k, v in values.items() if k != name})


@pytest.mark.parametrize("make, values", [(r[0], r[3]) for r in RECORDS], ids=["CYCLE", "MAP_CONSTANTS"])
@pytest.mark.parametrize("extra", ["x", "hl_m", "spin", "OX"])
def test_a_record_refuses_an_unknown_field(make, values, extra: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(TypeError, match=f"missing: \\[\\], unknown: \\['{extra}'\\]"):
        make(**values, **{extra: 1.0})


# --- random maps ---------------------------------------------------------------------------------

def random_map(seed: int) -> TerrainMap:
    """A map with a tilted, noisy ground, tall cells, a fine layer below each cell's max z (as a
    lidar builds it: fine obstacle cells only inside coarse obstacle cells) and unknown patches."""
    g = np.random.default_rng(seed)
    cell = float(g.choice([0.2, 0.25, 0.3]))
    sub = int(g.integers(1, 5))
    rows, cols = int(g.integers(12, 40)), int(g.integers(12, 40))
    m = TerrainMap((float(g.uniform(-5, 0)), float(g.uniform(-5, 0))), (rows, cols), cell,
                   step_m=float(g.uniform(0.1, 0.5)), obstacle_subcells=sub)
    ii, jj = np.mgrid[0:rows, 0:cols]
    z = 0.05 * jj * cell - 0.04 * ii * cell + g.normal(0, 0.02, (rows, cols))
    zmax = z + g.uniform(0, 0.05, (rows, cols))
    tall = g.random((rows, cols)) < 0.1
    zmax[tall] += g.uniform(0.2, 2.0, int(tall.sum()))
    n = g.integers(1, 5, (rows, cols)).astype(np.float64)
    m.stats[:, :, 0], m.stats[:, :, 1], m.stats[:, :, 2], m.stats[:, :, 3] = z, zmax, (z + 0.01) * n, n
    f = z[..., None] + g.random((rows, cols, sub * sub)) * (zmax - z)[..., None]
    f[g.random(f.shape) < 0.3] = -np.inf  # not hit by the cell's last scan
    m.fine[:, :, :sub * sub] = f.astype(np.float32)
    for _ in range(int(g.integers(0, 5))):
        a, b = int(g.integers(0, rows)), int(g.integers(0, cols))
        m.stats[a:a + int(g.integers(1, 6)), b:b + int(g.integers(1, 6))] = (np.inf, -np.inf, 0.0, 0.0)
    return m


def _grid(m: TerrainMap) -> _Grid:
    return _Grid(m.origin[0], m.origin[1], m.cell_m, m.shape[0], m.shape[1], m.sub)


def maps_of(m: TerrainMap) -> TerrainArrays:
    return TerrainArrays(m.zmin, m.zmax, m.zsum, m.count, m.fine)


def random_window(m: TerrainMap, g: np.random.Generator) -> tuple[int, int, int, int]:
    rows, cols = m.shape
    i0, j0 = int(g.integers(0, rows)), int(g.integers(0, cols))
    return i0, int(g.integers(i0, rows)), j0, int(g.integers(j0, cols))


def corners(x: float, y: float, yaw: float, hl: float, hw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[x + a * c - b * s, y + a * s + b * c] for a, b in ((hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw))])


def overlap(rect: np.ndarray, cx: float, cy: float, h: float) -> float:
    return clip_area(rect, cx - h, cy - h, 2 * h)


# --- the steps -----------------------------------------------------------------------------------

@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_window_classes_are_the_maps_own(seed: int) -> None:
    m = random_map(seed)
    i0, i1, j0, j1 = random_window(m, np.random.default_rng(seed + 1))
    win = _classify(maps_of(m), _grid(m), i0, i1, j0, j1, m.step_m)
    known = m.count[i0:i1 + 1, j0:j1 + 1] > 0
    obstacle = m.obstacles()[i0:i1 + 1, j0:j1 + 1]
    want = np.where(known, np.where(obstacle, _OBSTACLE, _KNOWN), _UNKNOWN)
    assert (win.i0, win.j0) == (i0, j0) and np.array_equal(win.cls, want)
    assert win.n_obstacle == int(obstacle.sum())
    zmin = np.where(m.count > 0, m.zmin, np.inf)
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            if known[i - i0, j - j0]:
                ground = zmin[max(0, i - 1):i + 2, max(0, j - 1):j + 2].min()
                assert win.ground[i - i0, j - j0] == ground
                assert win.zmean[i - i0, j - j0] == m.zsum[i, j] / m.count[i, j]
            else:
                assert win.zmean[i - i0, j - j0] == 0.0
    assert np.array_equal(win.xc, [m.cell_center(i0, j)[0] for j in range(j0, j1 + 1)])
    assert np.array_equal(win.yc, [m.cell_center(i, j0)[1] for i in range(i0, i1 + 1)])


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_the_fine_squares_are_the_fine_obstacle_cells_less_those_under_the_robot(seed: int, exempt: bool) -> None:
    m = random_map(seed)
    g = np.random.default_rng(seed + 2)
    i0, i1, j0, j1 = random_window(m, g) if g.random() < 0.5 else (0, m.shape[0] - 1, 0, m.shape[1] - 1)
    grid = _grid(m)
    win = _classify(maps_of(m), grid, i0, i1, j0, j1, m.step_m)
    fc, s = m.fine_cell_m, m.sub
    fine = m.fine_obstacles()
    yaw, hl, hw = g.uniform(-math.pi, math.pi), g.uniform(0.1, 1.5), g.uniform(0.1, 1.0)
    # the robot's border through the fine obstacle cells (near one of them, when there is one)
    fi, fj = np.nonzero(fine) if fine.any() else (np.array([s * m.shape[0] // 2]), np.array([s * m.shape[1] // 2]))
    k = int(g.integers(0, len(fi)))
    x = m.origin[0] + (fj[k] + 0.5) * fc + g.uniform(-1.2, 1.2) * hl
    y = m.origin[1] + (fi[k] + 0.5) * fc + g.uniform(-1.2, 1.2) * hl
    robot = _rect(x, y, math.cos(yaw), math.sin(yaw), hl, hw)
    pts, n = _fine_squares(m.fine, win, grid, m.step_m, robot, exempt)
    got = {(round((py - m.origin[1]) / fc - 0.5), round((px - m.origin[0]) / fc - 0.5)) for px, py in pts[:n]}
    assert len(got) == n
    rect = corners(x, y, yaw, hl, hw)
    for fi, fj in zip(*np.nonzero(fine)):
        if not (i0 <= fi // s <= i1 and j0 <= fj // s <= j1):
            assert (fi, fj) not in got
            continue
        area = overlap(rect, m.origin[0] + (fj + 0.5) * fc, m.origin[1] + (fi + 0.5) * fc, 0.5 * fc)
        if not exempt or area == 0.0:
            assert (fi, fj) in got, (fi, fj)
        elif area > 1e-9:
            assert (fi, fj) not in got, (fi, fj, area)
    assert got <= set(zip(*np.nonzero(fine)))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_only_the_unknown_cells_under_the_robot_are_exempt(seed: int) -> None:
    m = random_map(seed)
    g = np.random.default_rng(seed + 3)
    grid = _grid(m)
    win = _classify(maps_of(m), grid, 0, m.shape[0] - 1, 0, m.shape[1] - 1, m.step_m)
    before = win.cls.copy()
    x = m.origin[0] + g.uniform(-0.5, m.shape[1] * m.cell_m + 0.5)
    y = m.origin[1] + g.uniform(-0.5, m.shape[0] * m.cell_m + 0.5)
    yaw, hl, hw = g.uniform(-math.pi, math.pi), g.uniform(0.1, 1.5), g.uniform(0.1, 1.0)
    _exempt_cells(win, grid, x, y, yaw, hl, hw)
    want = before.copy()
    under = footprint_cells(x, y, yaw, hl, hw, m)
    if under is not None:  # a footprint leaving the map exempts nothing
        sel = want[under] == _UNKNOWN
        want[under[0][sel], under[1][sel]] = _EXEMPT
    assert np.array_equal(win.cls, want)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 30), st.floats(0.0, 3.0))
def test_the_squares_near_an_arc_are_those_within_reach_of_its_nodes_box(seed: int, n: int, r: float) -> None:
    g = np.random.default_rng(seed)
    pts = g.uniform(-5, 5, (n, 2))
    nodes = int(g.integers(1, 16))
    arc = np.column_stack([g.uniform(-2, 2, (nodes, 2)), g.uniform(-3, 3, nodes)])  # (N, 3) x, y, heading
    out = np.empty((max(n, 1), 2))
    k = _squares_near(pts, arc, r, out)
    lo, hi = arc[:, :2].min(axis=0) - r, arc[:, :2].max(axis=0) + r
    inside = ((pts > lo) & (pts < hi)).all(axis=1)
    assert np.array_equal(out[:k], pts[inside])


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_the_fine_contact_is_an_exact_overlap_of_the_footprint_then_its_ring(seed: int, ring_costs: bool) -> None:
    g = np.random.default_rng(seed)
    x, y, yaw = g.uniform(-1, 1), g.uniform(-1, 1), g.uniform(-math.pi, math.pi)
    hl, hw, clear_m, h = g.uniform(0.2, 1.2), g.uniform(0.1, 0.8), g.uniform(0.0, 0.5), g.uniform(0.02, 0.2)
    near = g.uniform(-3, 3, (int(g.integers(0, 12)), 2))
    r_hit = math.hypot(hl, hw) + h * math.sqrt(2.0)  # as _fan_costs gives them
    r_clear = math.hypot(hl + clear_m, hw + clear_m) + h * math.sqrt(2.0)
    test = _FineTest(h, r_hit, r_clear, clear_m, ring_costs)
    got = _fine_contact(_rect(x, y, math.cos(yaw), math.sin(yaw), hl, hw), near, len(near), test)
    hit = [overlap(corners(x, y, yaw, hl, hw), px, py, h) for px, py in near]
    ring = [overlap(corners(x, y, yaw, hl + clear_m, hw + clear_m), px, py, h) for px, py in near]
    if any(0.0 < a <= 1e-9 for a in hit + ring):
        return  # touching within rounding: either answer is right
    want = _HIT if any(a > 0 for a in hit) else _RING if ring_costs and any(a > 0 for a in ring) else _CLEAR
    assert got == want
