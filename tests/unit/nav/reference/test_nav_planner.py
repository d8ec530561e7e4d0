"""P3D: footprint coverage, arc costs around posts, unknown cells and the believed footprint."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.support.nav_scenes import Scene, grid_points

from navstress.nav.reference.config import ReferenceConfig
from navstress.nav.reference.planner import ArcPlanner, arc_nodes, footprint_cells, node_cost
from navstress.nav.reference.pose import Pose
from navstress.nav.reference.terrain_map import TerrainMap, step_threshold
from navstress.robot import RobotSpec
from tests.oracles.polygon import clip_area


@settings(max_examples=80, deadline=None)
@given(st.floats(-3, 3), st.floats(-3, 3), st.floats(-math.pi, math.pi), st.floats(0.05, 1.5),
       st.floats(0.05, 1.0), st.sampled_from([0.1, 0.25, 0.3, 0.4]))
def test_footprint_cells_are_exactly_the_overlapped_cells(x: float, y: float, yaw: float, hl: float, hw: float,
                                                         cell: float) -> None:
    m = TerrainMap((-6.0, -6.0), (int(12 / cell) + 1, int(12 / cell) + 1), cell)
    got = footprint_cells(x, y, yaw, hl, hw, m)
    assert got is not None
    cells = set(zip(got[0].tolist(), got[1].tolist()))
    c, s = math.cos(yaw), math.sin(yaw)
    rect = np.array([[x + a * c - b * s, y + a * s + b * c] for a, b in ((hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw))])
    i0, j0 = m.cell_of(rect[:, 0].min(), rect[:, 1].min())
    i1, j1 = m.cell_of(rect[:, 0].max(), rect[:, 1].max())
    for i in range(i0 - 1, i1 + 2):
        for j in range(j0 - 1, j1 + 2):
            area = clip_area(rect, m.origin[0] + j * cell, m.origin[1] + i * cell, cell)
            if area > 1e-9:
                assert (i, j) in cells, f"cell {(i, j)} overlapped by {area} m2 but not covered"
            elif area == 0.0:
                assert (i, j) not in cells
    assert len(cells) * cell * cell >= 4 * hl * hw - 1e-9


def test_footprint_leaving_the_map_is_none() -> None:
    m = TerrainMap((0.0, 0.0), (10, 10), 0.3)
    assert footprint_cells(0.2, 1.5, 0.0, 0.57, 0.33, m) is None
    assert footprint_cells(1.5, 1.5, 0.0, 0.57, 0.33, m) is not None


def test_arc_nodes_lie_on_circles_of_the_right_curvature() -> None:
    k = np.array([-1.0, -0.3, 0.0, 0.5])
    n = arc_nodes(1.0, 2.0, 0.7, k, 3.0, 15)
    assert n.shape == (4, 15, 3)
    for a, kk in enumerate(k):
        seg = np.hypot(*np.diff(np.vstack([[1.0, 2.0], n[a, :, :2]]), axis=0).T)
        chord = 2 * np.sin(kk * 0.1) / kk if kk else 0.2
        assert np.allclose(seg, chord, atol=1e-9)  # equally spaced at arc length 0.2
        assert n[a, -1, 2] == pytest.approx(0.7 + kk * 3.0)


def _known_map(scene: Scene, cell: float = 0.3, skip: tuple[float, float, float, float] | None = None,
               origin: float = -10.0) -> TerrainMap:
    m = TerrainMap((origin, origin), (int(-2 * origin / cell), int(-2 * origin / cell)), cell,
                   step_threshold(0.3, 25.0, cell), 100.0)
    pts = grid_points(scene, origin + 0.5, -origin - 0.5, origin + 0.5, -origin - 0.5, skip=skip)
    m.integrate(pts, (0.0, 0.0, 0.0), Pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    return m


def _goal_terms(planner: ArcPlanner, ev, goal: tuple[float, float], here: tuple[float, float]) -> np.ndarray:  # type: ignore[no-untyped-def]
    ends = ev.nodes[:, -1, :2]
    d = np.hypot(ends[:, 0] - goal[0], ends[:, 1] - goal[1])
    return np.where(ev.is_spin, math.hypot(here[0] - goal[0], here[1] - goal[1]) + 1.0, d)


def test_prefers_a_free_arc_around_a_post() -> None:
    post = (1.8, -0.5, 0.0, 2.8, 0.5, 5.0)  # a 1 m tree 1.8 m ahead
    m = _known_map(Scene(boxes=(post,)))
    p = ArcPlanner(ReferenceConfig(), RobotSpec())
    ev = p.evaluate(m, 0.0, 0.0, 0.0, 1)
    straight = int(np.flatnonzero(ev.curvatures == 0.0)[0])
    assert math.isinf(ev.terrain_cost[straight])
    idx = p.elect(ev, _goal_terms(p, ev, (9.0, 0.0), (0.0, 0.0)))
    assert idx >= 0 and not ev.is_spin[idx] and ev.curvatures[idx] != 0.0
    assert ev.terrain_cost[idx] < 5.0
    # the elected arc's footprints never touch a post cell, and it is the best free one toward the goal
    obst = m.obstacles()
    for x, y, th in ev.nodes[idx]:
        ci, cj = footprint_cells(x, y, th, p.half_length, p.half_width, m)  # type: ignore[misc]
        assert not obst[ci, cj].any()
    free = np.isfinite(ev.terrain_cost)
    assert free.sum() >= 4  # many arcs still free on both sides
    v, w = p.command(ev, idx)
    assert 0 < v <= 1.0 and w == pytest.approx(v * ev.curvatures[idx])


def test_never_drives_through_unknown() -> None:
    # the ground ahead-right is never seen: only arcs that stay in known cells may be elected
    m = _known_map(Scene(), skip=(1.0, 10.0, -10.0, 0.6))
    p = ArcPlanner(ReferenceConfig(), RobotSpec())
    ev = p.evaluate(m, 0.0, 0.0, 0.0, 1)
    known = m.known()
    for a in range(len(ev.curvatures)):
        touches_unknown = False
        for x, y, th in ev.nodes[a]:
            ci, cj = footprint_cells(x, y, th, p.half_length, p.half_width, m)  # type: ignore[misc]
            touches_unknown |= bool((~known[ci, cj]).any())
        assert math.isinf(ev.terrain_cost[a]) == touches_unknown
    idx = p.elect(ev, _goal_terms(p, ev, (9.0, -3.0), (0.0, 0.0)))
    assert idx >= 0 and (ev.is_spin[idx] or ev.curvatures[idx] > 0)  # left, away from the unknown


def test_finite_unknown_cost_lets_arcs_through_at_a_price() -> None:
    m = _known_map(Scene(), skip=(1.5, 10.0, -10.0, 10.0))
    inf_p = ArcPlanner(ReferenceConfig(), RobotSpec())
    fin_p = ArcPlanner(ReferenceConfig(unknown_cell_cost=0.01), RobotSpec())
    blocked = ~np.isfinite(inf_p.evaluate(m, 0.0, 0.0, 0.0, 1).terrain_cost)
    assert blocked.sum() >= 10  # every arc that reaches x > 1.5 m
    ev = fin_p.evaluate(m, 0.0, 0.0, 0.0, 1)
    assert np.isfinite(ev.terrain_cost).all()
    assert (ev.terrain_cost[blocked] > 0.01).all() and (ev.terrain_cost[~blocked] < 0.01).all()


def test_smaller_believed_footprint_squeezes_through_a_gap_the_nominal_refuses() -> None:
    # two walls leave a 0.75 m gap, cells [0, 0.75) in y (cell 0.25): the real robot is 0.67 wide,
    # with a 0.1 m hard margin the nominal belief needs 0.87 m; the faulty belief (0.45 + 0.2) fits.
    walls = ((1.5, -3.0, 0.0, 3.0, -0.01, 2.0), (1.5, 0.76, 0.0, 3.0, 3.0, 2.0))
    m = _known_map(Scene(boxes=walls), cell=0.25)
    y0 = 0.375
    results = {}
    for name, robot in (("nominal", RobotSpec()), ("fault", RobotSpec.footprint_fault())):
        p = ArcPlanner(ReferenceConfig(footprint_margin_m=0.1), robot)
        ev = p.evaluate(m, -0.5, y0, 0.0, 1)
        straight = int(np.flatnonzero(ev.curvatures == 0.0)[0])
        idx = p.elect(ev, _goal_terms(p, ev, (10.0, y0), (-0.5, y0)))
        results[name] = (ev.terrain_cost[straight], idx == straight)
    assert math.isinf(results["nominal"][0]) and not results["nominal"][1]
    assert math.isfinite(results["fault"][0]) and results["fault"][1]


def test_steep_slope_is_untraversable_and_moderate_slope_costs_more() -> None:
    flat = ArcPlanner(ReferenceConfig(), RobotSpec()).evaluate(_known_map(Scene()), 0.0, 0.0, 0.0, 1)
    mid = ArcPlanner(ReferenceConfig(), RobotSpec()).evaluate(_known_map(Scene(a=math.tan(math.radians(12)))), 0.0, 0.0, 0.0, 1)
    steep = ArcPlanner(ReferenceConfig(), RobotSpec()).evaluate(_known_map(Scene(a=math.tan(math.radians(30)))), 0.0, 0.0, 0.0, 1)
    assert np.all(flat.terrain_cost < 0.5)
    assert np.all(mid.terrain_cost > flat.terrain_cost + 5.0) and np.isfinite(mid.terrain_cost).all()
    assert not np.isfinite(steep.terrain_cost).any()
    # 12 deg over 15 nodes: 15 * 12/25 = 7.2 with the default weights
    assert mid.terrain_cost[9] == pytest.approx(15 * 12 / 25, abs=0.6)


def _posts_map(posts: np.ndarray, half: float = 5.0) -> TerrainMap:
    """Flat known ground with thin vertical posts (columns of points up to 1.6 m) at ``posts``."""
    ground = grid_points(Scene(), -half, half, -half, half, step=0.1)
    cols = [np.column_stack([np.full(8, px), np.full(8, py), np.linspace(0.2, 1.6, 8)]) for px, py in posts]
    m = TerrainMap((-half, -half), (int(2 * half / 0.3) + 1,) * 2, 0.3, step_threshold(0.3, 25.0, 0.3), 100.0)
    m.integrate(np.vstack([ground, *cols]), (0.0, 0.0, 0.0), Pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    return m


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), st.floats(-math.pi, math.pi),
       st.booleans())
def test_node_is_blocked_exactly_when_a_fine_obstacle_cell_overlaps_the_footprint(
        seed: int, x: float, y: float, yaw: float, faulty: bool) -> None:
    posts = np.random.default_rng(seed).uniform(-2.8, 2.8, (8, 2))
    m = _posts_map(posts)
    p = ArcPlanner(ReferenceConfig(), RobotSpec.footprint_fault() if faulty else RobotSpec())
    cost = node_cost(p, m, x, y, yaw)
    fine = m.fine_obstacles()
    f = m.fine_cell_m
    c, s = math.cos(yaw), math.sin(yaw)
    hl, hw = p.half_length, p.half_width
    rect = np.array([[x + a * c - b * s, y + a * s + b * c] for a, b in ((hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw))])
    areas = [clip_area(rect, m.origin[0] + fj * f, m.origin[1] + fi * f, f) for fi, fj in zip(*np.nonzero(fine))]
    post_cells = {(int((py - m.origin[1]) // f), int((px - m.origin[0]) // f)) for px, py in posts}
    assert set(zip(*np.nonzero(fine))) == post_cells  # the posts' fine cells, and only them
    if max(areas) > 1e-9:
        assert math.isinf(cost)
    if max(areas) == 0.0:
        assert math.isfinite(cost) and cost < 0.1  # flat ground; post cells are left out of the plane fit


def test_clearance_ring_costs_extra_only_near_a_fine_obstacle() -> None:
    # a post 0.15 m beside the straight arc's footprint (inside the 0.3 m ring), another 0.5 m beside
    p = ArcPlanner(ReferenceConfig(), RobotSpec())
    straight = int(np.flatnonzero(p.curvatures == 0.0)[0])
    near = p.evaluate(_posts_map(np.array([[1.5, p.half_width + 0.15]])), 0.0, 0.0, 0.0, 1)
    far = p.evaluate(_posts_map(np.array([[1.5, p.half_width + 0.5]])), 0.0, 0.0, 0.0, 1)
    extra = near.node_cost[straight] - far.node_cost[straight]
    assert np.isfinite(near.terrain_cost[straight])
    assert np.allclose(extra[extra > 1e-9], 0.2) and 5 <= int((extra > 1e-9).sum()) <= 15
    assert np.all(far.node_cost[straight] < 0.1)


def test_evaluate_matches_one_node_at_a_time() -> None:
    # the one-call fan (window, flags, fine list) gives each node the same cost as a lone evaluation
    m = _posts_map(np.array([[1.2, 0.9], [2.0, -0.4], [-1.0, 1.5]]))
    p = ArcPlanner(ReferenceConfig(clearance_cost=0.0, exempt_current_footprint=False), RobotSpec.footprint_fault())
    ev = p.evaluate(m, 0.1, -0.2, 0.4, 1)
    for a in range(ev.nodes.shape[0]):
        for k in range(ev.nodes.shape[1]):
            one = node_cost(p, m, *ev.nodes[a, k])
            if math.isinf(ev.node_cost[a, k]) and k > 0 and math.isinf(ev.node_cost[a, k - 1]):
                continue  # after the first blocked node the rest of the arc is not evaluated
            assert ev.node_cost[a, k] == pytest.approx(one) or (math.isinf(one) and math.isinf(ev.node_cost[a, k]))


def test_quadratic_curvature_spacing_is_denser_near_straight() -> None:
    lin = ArcPlanner(ReferenceConfig(), RobotSpec()).curvatures
    quad = ArcPlanner(ReferenceConfig(curvature_spacing="quadratic", max_curvature_per_m=0.8), RobotSpec()).curvatures
    assert np.allclose(np.diff(lin), 2.0 / 18)
    assert quad[9] == 0.0 and quad[0] == pytest.approx(-0.8) and quad[-1] == pytest.approx(0.8)
    assert np.allclose(quad, -quad[::-1])
    gaps = np.diff(quad[9:])
    assert np.all(np.diff(gaps) > 0) and gaps[0] == pytest.approx(0.8 / 81)


def _brute_node_cost(m: TerrainMap, p: ArcPlanner, x: float, y: float, yaw: float) -> float:
    """The module doc's node cost (coarse layer only), cell by cell in numpy: footprint cells,
    unknown -> inf, least-squares plane over the known non-obstacle cells' mean heights."""
    cells = footprint_cells(x, y, yaw, p.half_length, p.half_width, m)
    if cells is None:
        return math.inf
    pts = []
    for i, j in zip(*cells):
        if m.count[i, j] == 0:
            return math.inf
        nb = [(a, b) for a in range(i - 1, i + 2) for b in range(j - 1, j + 2)
              if 0 <= a < m.shape[0] and 0 <= b < m.shape[1] and m.count[a, b] > 0]
        ground = min(m.zmin[a, b] for a, b in nb)
        if m.zmax[i, j] - ground > m.step_m:
            continue
        pts.append((m.origin[0] + (j + 0.5) * m.cell_m, m.origin[1] + (i + 0.5) * m.cell_m, m.zsum[i, j] / m.count[i, j]))
    if len(pts) < 3:
        return 0.0
    a = np.array(pts)
    sol, *_ = np.linalg.lstsq(np.c_[a[:, 0], a[:, 1], np.ones(len(a))], a[:, 2], rcond=None)
    rough = float(np.abs(a[:, 2] - np.c_[a[:, 0], a[:, 1], np.ones(len(a))] @ sol).max())
    slope = math.hypot(sol[0], sol[1])
    cfg = p.config
    tmax = math.tan(math.radians(cfg.max_slope_deg))
    if slope > tmax or rough > cfg.max_roughness_m:
        return math.inf
    return cfg.slope_weight * math.atan(slope) / math.atan(tmax) + cfg.roughness_weight * rough / cfg.max_roughness_m


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-math.pi, math.pi))
def test_fan_node_costs_match_a_brute_force_plane_fit(seed: int, yaw: float) -> None:
    # rough random terrain with a never-seen patch and a few coarse obstacle cells (no fine ones)
    rng = np.random.default_rng(seed)
    m = TerrainMap((-6.0, -6.0), (40, 40), 0.3, step_m=0.5)
    ii, jj = np.mgrid[0:40, 0:40]
    z = 0.15 * np.sin(0.3 * ii + rng.uniform(0, 6)) + 0.1 * np.cos(0.2 * jj) + rng.normal(0, 0.03, (40, 40))
    m.stats[:, :, 0] = z
    m.stats[:, :, 1] = z
    m.stats[:, :, 2] = 2.0 * z
    m.stats[:, :, 3] = 2.0
    for _ in range(4):
        i, j = rng.integers(5, 35, 2)
        m.stats[i, j, 1] = z[i, j] + 1.0
    i, j = rng.integers(5, 30, 2)
    m.stats[i:i + 3, j:j + 4] = (np.inf, -np.inf, 0.0, 0.0)
    p = ArcPlanner(ReferenceConfig(clearance_cost=0.0, exempt_current_footprint=False), RobotSpec())
    ev = p.evaluate(m, 0.0, 0.0, yaw, 1)
    for a in range(ev.nodes.shape[0]):
        for k in range(ev.nodes.shape[1]):
            if k > 0 and math.isinf(ev.node_cost[a, k - 1]):
                break  # after the first blocked node the rest of the arc is not evaluated
            want = _brute_node_cost(m, p, *ev.nodes[a, k])
            got = ev.node_cost[a, k]
            assert (math.isinf(want) and math.isinf(got)) or got == pytest.approx(want, abs=1e-9), (a, k)
