"""reference-2d-v1's compiled parts on analytic layouts: raytracing, inflation, A*, rollouts."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.nav.reference2d import kernels as K
from navstress.nav.reference2d.config import Reference2dConfig
from navstress.nav.reference2d.costmap import Costmap, footprint_radii
from navstress.robot import profile

CFG = Reference2dConfig(map_margin_m=3.0)
JACKAL = profile("jackal")


def empty(length: float = 10.0) -> Costmap:
    return Costmap.covering([(0.0, 0.0), (length, 0.0)], CFG, JACKAL)


def free(cm: Costmap) -> Costmap:
    """Every cell seen free."""
    cm.occ[:] = K.FREE
    cm.update_costs(np.array([-20.0, -20.0]), np.array([40.0, 20.0]))
    return cm


def plan(cm: Costmap, start: tuple[float, float], goal: tuple[float, float], r: float = 0.2) -> np.ndarray:
    si, sj = cm.cell_of(*start)
    gi = (goal[1] - cm.origin[1]) / cm.cell - 0.5
    gj = (goal[0] - cm.origin[0]) / cm.cell - 0.5
    cells = K.astar(cm.cost, si, sj, gi, gj, r / cm.cell, CFG.unknown_cell_cost, CFG.cost_weight,
                    escape_r=cm.circumscribed_m / cm.cell)
    return cm.centre(cells) if len(cells) else np.zeros((0, 2))


def wall(cm: Costmap, x: float, y0: float, y1: float) -> None:
    """A wall along x = const, seen: its cells marked (every 2 cm)."""
    ys = np.arange(y0, y1, 0.02)
    cm.mark_points(np.column_stack([np.full(len(ys), x), ys]))


def test_footprint_radii_of_a_box() -> None:
    ins, circ, outline = footprint_radii(JACKAL, 0.0)
    assert ins == JACKAL.width_m / 2
    assert math.isclose(circ, math.hypot(JACKAL.length_m, JACKAL.width_m) / 2)
    assert np.all(np.abs(outline[:, 0]) <= JACKAL.length_m / 2 + 1e-9)
    assert np.isclose(np.abs(outline).max(axis=0), [JACKAL.length_m / 2, JACKAL.width_m / 2]).all()


def test_raytracing_clears_to_the_hit_and_marks_it() -> None:
    cm = empty()
    n = 19
    ang = np.linspace(-0.3, 0.3, n)
    r = 3.0 / np.cos(ang)  # a wall at x = 3 seen from the origin
    ends = np.column_stack([r * np.cos(ang), r * np.sin(ang)])
    cm.integrate(np.zeros((n, 2)), ends, np.ones(n, bool))
    for e in ends:
        i, j = cm.cell_of(*e)
        assert cm.occ[i, j] == K.OCCUPIED
    i0, j0 = cm.cell_of(0.05, 0.0)
    i3, j3 = cm.cell_of(2.85, 0.0)
    assert (cm.occ[i0, j0:j3] == K.FREE).all()  # the beam along y = 0 cleared up to the wall
    assert cm.occ[cm.cell_of(5.0, 0.0)] == K.UNKNOWN  # behind the wall: never seen
    # a later beam through an old hit clears it (a moved obstacle), a no-return beam too
    cm.integrate(np.zeros((1, 2)), np.array([[5.0, 0.0]]), np.zeros(1, bool))
    assert cm.occ[cm.cell_of(3.0, 0.0)] == K.FREE
    assert cm.cost_xy(3.0, 0.0) == K.INSCRIBED  # no longer an obstacle; its neighbours still are


def test_inflation_follows_the_footprint() -> None:
    cm = empty()
    cm.mark_points(np.array([[5.0, 0.05]]))
    assert cm.cost_xy(5.0, 0.05) == K.LETHAL
    assert cm.cost_xy(5.0, 0.05 + cm.inscribed_m - 0.05) == K.INSCRIBED
    far = cm.cost_xy(5.0, 0.05 + cm.inscribed_m + 0.15)
    assert 0 < far < K.INSCRIBED
    expected = 252 * math.exp(-CFG.cost_scaling_factor * 0.15)
    assert abs(far - expected) < 40  # the exponential decay, within a cell's offset
    assert cm.cost_xy(5.0, 0.05 + cm.radius_m + 0.2) == K.NO_INFORMATION  # unknown beyond the radius


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(1.0, 9.0), st.floats(-2.0, 2.0)), min_size=1, max_size=12),
       st.floats(0.0, 2 * math.pi), st.floats(0.0, 0.8), st.floats(0.0, 0.8))
def test_an_inflated_cell_never_costs_less_than_a_farther_one(obstacles: list[tuple[float, float]], a: float,
                                                              d1: float, d2: float) -> None:
    cm = empty()
    free(cm)
    cm.mark_points(np.array(obstacles))
    ox, oy = obstacles[0]
    near, far = sorted((d1, d2))
    # along a ray from an obstacle cell's centre: nearer (to every obstacle, here to this one) costs at least as much
    i, j = cm.cell_of(ox, oy)
    cx, cy = cm.centre(np.array([[i, j]]))[0]
    def nearest(x: float, y: float) -> float:
        c = cm.centre(np.argwhere(cm.occ == K.OCCUPIED))
        return float(np.min(np.hypot(c[:, 0] - x, c[:, 1] - y)))
    p_near = (cx + near * math.cos(a), cy + near * math.sin(a))
    p_far = (cx + far * math.cos(a), cy + far * math.sin(a))
    if nearest(*p_near) <= nearest(*p_far) - cm.cell * 1.5:
        assert cm.cost_xy(*p_near) >= cm.cost_xy(*p_far)
    # and every cell's cost is the kernel's at its distance to the nearest obstacle cell
    for p in (p_near, p_far):
        pi, pj = cm.cell_of(*p)
        c = cm.centre(np.array([[pi, pj]]))[0]
        d = nearest(*c)
        got = cm.cost_xy(*c)
        if d == 0:
            assert got == K.LETHAL
        elif d <= cm.inscribed_m:
            assert got == K.INSCRIBED
        elif d > cm.radius_m:
            assert got == 0
        else:
            assert got == int(252 * math.exp(-CFG.cost_scaling_factor * (d - cm.inscribed_m)))


def test_astar_in_a_corridor_stays_in_its_middle() -> None:
    cm = empty()
    free(cm)
    for y in (-1.0, 1.0):
        xs = np.arange(-1.0, 11.0, 0.02)
        cm.mark_points(np.column_stack([xs, np.full(len(xs), y)]))
    path = plan(cm, (0.0, 0.0), (10.0, 0.0))
    assert len(path) > 0
    assert np.abs(path[:, 1]).max() < 0.3
    assert np.hypot(*(path[-1] - (10.0, 0.0))) <= 0.2 + cm.cell


def gap_wall(gap: float) -> Costmap:
    cm = empty()
    wall(cm, 5.0, -3.0, -gap / 2)
    wall(cm, 5.0, gap / 2 + 0.02, 3.0)
    return cm


def test_astar_through_a_gap_wider_than_the_footprint_not_a_narrower_one() -> None:
    ins = footprint_radii(JACKAL, CFG.footprint_padding_m)[0]
    wide = plan(gap_wall(2 * ins + 0.5), (2.0, 0.0), (8.0, 0.0))
    assert len(wide) > 0 and np.abs(wide[np.abs(wide[:, 0] - 5.0) < 0.1, 1]).max() < 0.2
    narrow = plan(gap_wall(2 * ins - 0.15), (2.0, 0.0), (8.0, 0.0))
    # the only ways are around the wall's ends, never through the gap
    assert len(narrow) == 0 or np.abs(narrow[np.abs(narrow[:, 0] - 5.0) < 0.1, 1]).min() > 2.5


def test_astar_goal_behind_a_closed_wall_has_no_path() -> None:
    cm = empty()
    free(cm)
    for (x0, y0, x1, y1) in ((7, -1, 7, 1), (7, 1, 10, 1), (10, -1, 10, 1), (7, -1, 10, -1)):
        n = int(max(abs(x1 - x0), abs(y1 - y0)) / 0.02) + 1
        cm.mark_points(np.column_stack([np.linspace(x0, x1, n), np.linspace(y0, y1, n)]))
    assert len(plan(cm, (0.0, 0.0), (8.5, 0.0))) == 0
    assert len(plan(cm, (0.0, 0.0), (5.0, 0.0))) > 0


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(0.5, 9.5), st.floats(-2.5, 2.5)), max_size=40), st.integers(0, 3))
def test_astar_never_crosses_lethal_or_inscribed_cells(obstacles: list[tuple[float, float]], unknown: int) -> None:
    cm = empty()
    if unknown % 2:
        free(cm)
    pts = [(x, y) for x, y in obstacles if math.hypot(x, y) > 0.8 and math.hypot(x - 10, y) > 0.8]
    if pts:
        cm.mark_points(np.array(pts))
    si, sj = cm.cell_of(0.0, 0.0)
    gi, gj = cm.cell_of(10.0, 0.0)
    cells = K.astar(cm.cost, si, sj, float(gi), float(gj), 1.0, CFG.unknown_cell_cost, CFG.cost_weight)
    if len(cells):  # the start is free (no obstacle within 0.8 m): no cell of the path may be impassable
        c = cm.cost[cells[:, 0], cells[:, 1]]
        assert not ((c == K.INSCRIBED) | (c == K.LETHAL)).any()
        assert (np.abs(np.diff(cells, axis=0)) <= 1).all()  # 8-connected steps


def test_astar_leaves_the_inscribed_zone_it_starts_in() -> None:
    cm = empty()
    free(cm)
    cm.mark_points(np.array([[0.0, 0.15]]))  # an obstacle within the inscribed radius of the start
    path = plan(cm, (0.0, 0.0), (6.0, 0.0))
    assert len(path) > 0
    costs = [cm.cost_xy(x, y) for x, y in path[1:]]
    first_free = next(k for k, c in enumerate(costs) if c < K.INSCRIBED)
    assert all(c < K.INSCRIBED for c in costs[first_free:])  # once out, never back in


def rollouts(cm: Costmap, vs: list[float], ws: list[float]) -> np.ndarray:
    path = np.column_stack([np.arange(0.0, 6.0, 0.1), np.zeros(60)])
    togo = 10.0 - path[:, 0]
    weights = np.array([CFG.obstacle_weight, CFG.path_dist_weight, CFG.path_align_weight, CFG.goal_dist_weight,
                        CFG.speed_weight, CFG.oscillation_weight, CFG.forward_point_m])
    return K.score_rollouts(cm.cost, cm.grid, (0.0, 0.0, 0.0), (np.array(vs, float), np.array(ws, float)),
                            cm.footprint, (path, togo), weights,
                            K.Rollouts(17, 0.1, float(CFG.unknown_cell_cost), 1.0, 0.0))


def test_rollouts_prefer_the_path_and_refuse_collisions() -> None:
    cm = empty()
    free(cm)
    cm.update_costs(np.array([-3.0, -3.0]), np.array([13.0, 3.0]))
    s = rollouts(cm, [1.0, 1.0, 1.0, 0.0], [0.0, 0.5, -0.5, 0.0])
    assert np.argmin(s) == 0 and np.isfinite(s).all()
    wall(cm, 1.2, -0.5, 0.5)  # a wall 1.2 m ahead: straight on collides within 1.7 s
    s = rollouts(cm, [1.0, 0.3, 0.0], [0.0, 0.0, 0.0])
    assert math.isinf(s[0]) and math.isfinite(s[1]) and math.isfinite(s[2])
