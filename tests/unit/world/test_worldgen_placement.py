"""Obstacle placement constraints (hypothesis), obstruction targets, capacity and levelling."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress.errors import GenerationError
from navstress.world.generate import generate
from navstress.world.placement import level_terrain
from navstress.world.spec import WorldSpec
from navstress.world.world import Obstacle, World


def sat_overlap(p: np.ndarray, q: np.ndarray, eps: float = 1e-9) -> bool:
    """Separating-axis test for two convex polygons (4 x 2 corners): True iff the interiors
    overlap by more than ``eps`` along every axis (touching is not overlapping)."""
    for poly in (p, q):
        for k in range(4):
            e = poly[(k + 1) % 4] - poly[k]
            axis = np.array([-e[1], e[0]]) / np.hypot(*e)
            a, b = p @ axis, q @ axis
            if min(a.max(), b.max()) - max(a.min(), b.min()) <= eps:
                return False
    return True


def box_disc_distance(o: Obstacle, cx: float, cy: float) -> float:
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    px, py = cx - o.x, cy - o.y
    lx, ly = c * px + s * py, -s * px + c * py
    return math.hypot(max(abs(lx) - o.size[0] / 2, 0.0), max(abs(ly) - o.size[1] / 2, 0.0))


def check_world(w: World) -> None:
    """Every placement constraint, checked independently of the generator's bookkeeping."""
    sx, sy = w.spec.size_m
    obs = w.obstacles
    corners = np.array([o.corners() for o in obs]).reshape(-1, 4, 2)
    # inside the map
    assert np.all(corners >= -1e-9) and np.all(corners[..., 0] <= sx + 1e-9) and np.all(corners[..., 1] <= sy + 1e-9)
    # no overlap: candidate pairs by bounding boxes, then exact SAT
    if len(obs) > 1:
        lo, hi = corners.min(axis=1), corners.max(axis=1)
        order = np.argsort(lo[:, 0])
        for n, i in enumerate(order):
            for j in order[n + 1:]:
                if lo[j, 0] >= hi[i, 0]:
                    break
                if lo[j, 1] < hi[i, 1] and lo[i, 1] < hi[j, 1]:
                    assert not sat_overlap(corners[i], corners[j]), (obs[i], obs[j])
    # free discs around start and goal
    m = w.mission
    for o in obs:
        for cx, cy in (m.start[:2], m.goal):
            assert box_disc_distance(o, cx, cy) >= m.free_radius_m - 1e-9
    # on the ground: corners and interior points at the base height on the triangulated surface
    g = np.random.default_rng(0)
    for o in obs:
        pts = list(o.corners())
        for u, v in g.random((3, 2)):
            pts.append(np.array([o.x + (u - 0.5) * o.size[0], o.y + (v - 0.5) * o.size[1]]))
        for x, y in pts:
            assert abs(w.terrain.height_at(float(x), float(y)) - o.z) <= 1e-5 * max(1.0, abs(o.z))
    # achieved obstruction within 0.5 pp of every target, and the descriptor agrees with the obstacles
    for kind, target in w.spec.obstacles.targets().items():
        area = sum(o.area for o in obs if o.kind == kind)
        pct = 100.0 * area / (sx * sy)
        assert abs(pct - target) <= 0.5
        assert w.descriptors["obstruction_pct"][kind] == pytest.approx(pct)


specs = st.fixed_dictionaries({
    "size": st.sampled_from([20.0, 40.0, 60.0]),
    "tree": st.sampled_from([0.0, 1.0, 5.0, 12.0]),
    "building": st.sampled_from([0.0, 5.0, 20.0]),
    "rock": st.sampled_from([0.0, 3.0]),
    "var": st.sampled_from([0.0, 0.3]),
    "s": st.integers(0, 5),
    "d": st.sampled_from([0.0, 1.0, 3.0]),
    "mode": st.sampled_from(["paper", "random"]),
    "radius": st.sampled_from([0.0, 2.0, 5.0]),
    "seed": st.integers(0, 2**40),
})


@given(p=specs)
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_every_constraint_holds_or_generation_error_says_why(p: dict) -> None:
    spec = WorldSpec.model_validate({
        "size_m": (p["size"], p["size"]),
        "ground": {"subdivisions": p["s"], "deformation": p["d"]},
        "obstacles": {"types": {"rock": {"base_m": (2.0, 0.7), "height_m": 1.0, "variability": p["var"]},
                                "tree": {"base_m": (1.0, 1.0), "height_m": 5.0, "variability": p["var"]}},
                      "obstruction": {"tree": p["tree"], "building": p["building"], "rock": p["rock"]}},
        "mission": {"mode": p["mode"], "free_radius_m": p["radius"], "min_distance_m": p["size"] / 2},
    })
    try:
        w = generate(spec, p["seed"])
    except GenerationError as err:
        assert re.search(r"reached \d+\.\d+% of the map, target \d+\.\d+%", str(err)), str(err)
        return
    check_world(w)
    types = spec.obstacles.all_types()
    for kind in spec.obstacles.targets():
        t = types[kind]
        mine = [o for o in w.obstacles if o.kind == kind]
        out_of_envelope = [o for o in mine if not all(
            b * (1 - t.variability) - 1e-9 <= s_ <= b * (1 + t.variability) + 1e-9 for b, s_ in zip(t.base_m, o.size[:2]))]
        assert len(out_of_envelope) <= w.descriptors["placement_trimmed"][kind] <= 1
        assert all(o.size[0] < t.base_m[0] * (1 + t.variability) for o in out_of_envelope)  # trimmed: smaller


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_35_percent_buildings_on_100m_map(seed: int) -> None:
    w = generate(WorldSpec(obstacles={"obstruction": {"building": 35}}), seed)
    check_world(w)
    assert w.descriptors["placement_attempts"]["building"] > 0


def test_impossible_target_raises_with_achieved_value() -> None:
    spec = WorldSpec(size_m=(40.0, 40.0), obstacles={"obstruction": {"building": 70}})
    with pytest.raises(GenerationError) as ei:
        generate(spec, 0)
    m = re.search(r"reached (\d+\.\d+)% of the map, target 70\.00%.*attempts", str(ei.value))
    assert m, str(ei.value)
    assert 20.0 < float(m.group(1)) < 69.5


def test_free_disc_too_large_for_any_obstacle_raises() -> None:
    # the largest disc inside the map (start = goal at its centre): no 9 m building fits a corner
    spec = WorldSpec(size_m=(20.0, 20.0), mission={"free_radius_m": 10.0, "start": (10, 10, 0), "goal": (10, 10)},
                     obstacles={"obstruction": {"building": 10}})
    with pytest.raises(GenerationError, match="reached 0.00%"):
        generate(spec, 0)


def test_levelling_of_close_obstacles_is_exact_and_blends_back() -> None:
    h = np.fromfunction(lambda i, j: 0.05 * i + 0.02 * j, (101, 101))  # a tilted plane, 0.4 m cells
    obs = [Obstacle("tree", 10.0, 10.0, 0.0, (1.0, 1.0, 5.0)), Obstacle("tree", 11.3, 10.0, 0.0, (1.0, 1.0, 5.0)),
           Obstacle("tree", 30.0, 30.0, 0.0, (1.0, 1.0, 5.0))]
    lev = level_terrain(h, 0.4, obs)
    a, b, c = lev.obstacles
    assert a.z == b.z != c.z  # the two close trees share vertices, hence one base height
    assert lev.n_clusters == 2 and lev.largest_cluster == 2
    far = np.fromfunction(lambda i, j: np.hypot(j * 0.4 - 30, i * 0.4 - 30) > 4, (101, 101)) & \
        np.fromfunction(lambda i, j: np.hypot(j * 0.4 - 10.6, i * 0.4 - 10) > 5, (101, 101))
    np.testing.assert_allclose(lev.heights[far], h[far], atol=1e-6)
