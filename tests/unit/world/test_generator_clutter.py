"""The ``clutter`` generator (BARN's kind) and BARN's five metrics: the automaton against a direct
port of BARN's loop, worlds' constraints over hypothesis-drawn ClutterSpecs (inside the map, no
overlap, start and goal clear, the goal reachable by the test's own flood fill), determinism,
bad parameters; the metrics on analytic cases and on BARN's own worlds (BARN's path is free in
BARN's C-space; finite, in range, denser worlds harder)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import ndimage
from scipy.stats import spearmanr

from navstress.errors import SpecError
from navstress.robot import PROFILES
from navstress.world import generate, parse_spec
from navstress.world.barn_metrics import barn_cspace, barn_difficulty_of, grid_metrics
from navstress.world.generators.clutter import ca_field
from navstress.world.spec import ClutterSpec
from tests.support.barn import barn_dir
from navstress.world.world import Obstacle

JACKAL = PROFILES["jackal"]


def barn_rule(grid: np.ndarray, iterations: int) -> np.ndarray:
    """BARN's ``ObstacleMap._smooth`` as written (rows across the travel: our columns)."""
    m = grid.T.astype(int).tolist()  # BARN's map[r][c]: r across (our x), c along (our y)
    rows, cols = len(m), len(m[0])
    for _ in range(iterations):
        new = [row[:] for row in m]
        for r in range(rows):
            for c in range(cols):
                n = 0
                for i in range(r - 1, r + 2):
                    for j in range(c - 1, c + 2):
                        if 0 <= i < rows and 0 <= j < cols:
                            if i != r or j != c:
                                n += m[i][j]
                        elif i < 0 or i >= rows:
                            n += 1
                if n >= 5:
                    new[r][c] = 1
                elif n <= 1:
                    new[r][c] = 0
        m = new
    return np.array(m, bool).T


@settings(max_examples=25, deadline=None)
@given(fill=st.floats(0, 60), it=st.integers(0, 5), nx=st.integers(5, 25), ny=st.integers(1, 25), seed=st.integers(0, 99))
def test_the_automaton_is_barns_rule(fill: float, it: int, nx: int, ny: int, seed: int) -> None:
    cs = ClutterSpec(fill_pct=fill, smooth_iterations=it, cells_x=nx, cells_y=ny)
    got = ca_field(cs, np.random.default_rng(seed))
    start = ca_field(cs.model_copy(update={"smooth_iterations": 0}), np.random.default_rng(seed))
    assert start[:, 0].all() and start[:, -1].all()
    assert np.array_equal(got, barn_rule(start, it))


def footprint_dist(px: np.ndarray, py: np.ndarray, obs: tuple[Obstacle, ...]) -> np.ndarray:
    out = np.full(px.shape, np.inf)
    for o in obs:  # within 1 m of each cylinder only (the clearance is far less)
        cols = np.nonzero(np.abs(px[0] - o.x) < 1.0)[0]
        rows = np.nonzero(np.abs(py[:, 0] - o.y) < 1.0)[0]
        win = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
        out[win] = np.minimum(out[win], np.maximum(np.hypot(px[win] - o.x, py[win] - o.y) - o.size[0] / 2, 0.0))
    return out


@st.composite
def clutter_specs(draw: st.DrawFn) -> dict:
    lat = draw(st.sampled_from([0.1, 0.15, 0.2]))
    cs = {"fill_pct": draw(st.floats(0, 45)), "smooth_iterations": draw(st.integers(0, 5)),
          "cells_x": draw(st.integers(int(1.4 / lat) + 2, 30)), "cells_y": draw(st.integers(3, 30)),
          "corridor_cells": draw(st.integers(int(3.5 / lat), int(5 / lat))), "lattice_m": lat,
          "radius_m": lat / 2 * draw(st.sampled_from([0.5, 0.8, 1.0])), "start_m": 3.0,
          "goal_m": draw(st.sampled_from([6.0, 10.0]))}
    c = ClutterSpec.model_validate(cs)
    size = (math.ceil(c.width_m + 1), math.ceil(c.span_m + draw(st.integers(0, 3))))
    return {"size_m": [float(max(10, size[0])), float(max(10, size[1]))], "cell_m": 0.5, "generator": "clutter",
            "clutter": cs}


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=clutter_specs(), seed=st.integers(0, 2**32))
def test_clutter_worlds_keep_their_constraints(data: dict, seed: int) -> None:
    spec = parse_spec(data)
    w = generate(spec, seed, robot=JACKAL)
    sx, sy = spec.size_m
    obs = w.obstacles
    assert obs and all(o.is_cylinder and o.kind in ("wall", "clutter") for o in obs)
    xy = np.array([(o.x, o.y) for o in obs])
    r = obs[0].size[0] / 2
    assert ((xy - r >= -1e-9) & (xy + r <= np.array([sx, sy]) + 1e-9)).all()
    d = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
    np.fill_diagonal(d, np.inf)
    assert d.min() >= 2 * r - 1e-9
    m = w.mission
    assert m.start[2] == pytest.approx(math.pi / 2) and m.goal[1] - m.start[1] == pytest.approx(spec.clutter.goal_m)
    clear = JACKAL.width_m / 2
    cell = 0.03
    xs, ys = (np.arange(round(sx / cell)) + 0.5) * cell, (np.arange(round(sy / cell)) + 0.5) * cell
    px, py = np.meshgrid(xs, ys)
    free = footprint_dist(px, py, obs) >= clear
    free &= (px >= clear) & (px <= sx - clear) & (py >= clear) & (py <= sy - clear)
    labels, _ = ndimage.label(free)
    a = labels[int(m.start[1] // cell), int(m.start[0] // cell)]
    assert a > 0 and labels[int(m.goal[1] // cell), int(m.goal[0] // cell)] == a
    assert w.descriptors["clutter"]["draws"] >= 1
    b = w.descriptors["barn"]
    if b.get("reason") is None:
        assert b["dist_closest_m"] > 0 and b["tortuosity"] >= 1 and 0 <= b["dispersion"] <= 16


def test_clutter_determinism_and_seeds(tmp_path: Path) -> None:
    spec = parse_spec({"size_m": [10, 16], "cell_m": 0.25, "generator": "clutter", "clutter": {"fill_pct": 25}})
    a, b = generate(spec, 4), generate(spec, 4)
    assert a == b
    a.save(tmp_path / "a")
    b.save(tmp_path / "b")
    for f in ("world.json", "terrain.npz"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()
    assert len({generate(spec, s).digest() for s in range(5)}) == 5


def test_a_blocked_field_is_drawn_again_or_cleared() -> None:
    spec = parse_spec({"size_m": [10, 16], "cell_m": 0.5, "generator": "clutter", "clutter": {"fill_pct": 60}})
    w = generate(spec, 0, robot=JACKAL)
    c = w.descriptors["clutter"]
    assert c["draws"] == 20 and c["cleared_cells"] > 0
    assert w.descriptors["barn"]["tortuosity"] == pytest.approx(1.0)


BAD = [
    ({"clutter": {"radius_m": 0.1}}, "clutter.radius_m", "half the lattice"),
    ({"size_m": [10, 10]}, "clutter.cells_y", "fits the map's height"),
    ({"size_m": [10, 16], "clutter": {"cells_x": 80}}, "clutter.cells_x", "fits the map's width"),
    ({"size_m": [10, 16], "clutter": {"start_m": 6.0}}, "clutter.start_m", "inside the corridor"),
]


@pytest.mark.parametrize("over,field,words", BAD)
def test_bad_clutter_parameters_are_one_line_spec_errors(over: dict, field: str, words: str) -> None:
    with pytest.raises(SpecError) as err:
        parse_spec({"size_m": [10, 16], "generator": "clutter", **over})
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(field) and words in msg


def test_a_field_narrower_than_the_robot_is_a_spec_error() -> None:
    spec = parse_spec({"size_m": [10, 16], "generator": "clutter", "clutter": {"cells_x": 6}})
    with pytest.raises(SpecError, match=r"^clutter.cells_x=6 is invalid: expected a field wider than the robot 'rmp400'"):
        generate(spec, 0, robot=PROFILES["rmp400"])


# ---- BARN's metrics ---------------------------------------------------------------------------

def test_an_empty_corridor_scores_as_computed_by_hand() -> None:
    """Walls with faces at y = 4 and 6, clearance 0.3, cells of 0.1: the C-space's free rows are
    4.35..5.65; along row 5.05 the nearest obstacle row is 5.75 (0.7 m), the narrowest axis the
    vertical one (7 + 6 free cells: 1.3 m), no obstacle within the dispersion radius, a straight path."""
    walls = (Obstacle("wall", 6.0, 3.95, 0.0, (10.0, 0.1, 2.0)), Obstacle("wall", 6.0, 6.05, 0.0, (10.0, 0.1, 2.0)))
    m = barn_difficulty_of((12.0, 10.0), walls, (2.02, 5.02), (10.02, 5.02), clearance_m=0.3, cell_m=0.1)
    assert m["reason"] is None and m["path_cells"] == 81
    assert m["tortuosity"] == pytest.approx(1.0)
    assert m["dist_closest_m"] == pytest.approx(0.7)
    assert m["characteristic_dim_m"] == pytest.approx(1.3)
    assert m["dispersion"] == 0.0
    assert m["visibility_m"] > 0.7
    bent = barn_difficulty_of((12.0, 10.0), (), (0, 0), (0, 0), clearance_m=0.1, cell_m=0.15,
                              path=np.array([[1.0, 1.0], [5.0, 1.0], [5.0, 5.0]]))
    assert bent["tortuosity"] == pytest.approx(math.sqrt(2)) and bent["dist_closest_m"] > 0  # (the map edge)
    shut = barn_difficulty_of((12.0, 10.0), walls + (Obstacle("wall", 6.0, 5.0, 0.0, (0.1, 10.0, 2.0)),),
                              (2.02, 5.02), (10.02, 5.02), clearance_m=0.3, cell_m=0.1)
    assert shut["reason"] == "no path from start to goal" and shut["tortuosity"] is None


POSE = re.compile(r"<model name='unit_cylinder_\d+'>\s*<static>1</static>\s*<pose frame=''>([-\d.e]+) ([-\d.e]+)")
WORLDS = list(range(0, 300, 25))


@pytest.fixture(scope="module")
def barn(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """BARN worlds and paths (the members needed only, tests/support/barn.py)."""
    return barn_dir(tmp_path_factory, WORLDS)


def test_barn_worlds_score_finite_in_range_and_denser_harder(barn: Path) -> None:
    dens, ours, theirs = [], [], []
    for n in WORLDS:
        text = (barn / f"world_{n}.world").read_text().split("<state")[0]
        p = np.array(POSE.findall(text), float)
        # BARN's lattice: x = -4.5 + 0.15 (i + 1/2), y = 0.15 (k + 1/2); the field rows k >= 34
        i = np.round((p[:, 0] + 4.5) / 0.15 - 0.5).astype(int)
        k = np.round(p[:, 1] / 0.15 - 0.5).astype(int)
        assert np.allclose(p[:, 0], -4.5 + 0.15 * (i + 0.5)) and np.allclose(p[:, 1], 0.15 * (k + 0.5))
        lat = np.zeros((30, 30), bool)  # BARN's map[r][c]: r across the travel, c along it
        lat[i[k >= 34], k[k >= 34] - 34] = True
        path = np.load(barn / "path_files" / f"path_{n}.npy")
        theirs.append(grid_metrics(barn_cspace(lat, 2), path, 0.15))  # raises if BARN's path is not free
        with pytest.raises(ValueError):
            grid_metrics(barn_cspace(lat, 4), path, 0.15)  # a fatter robot's C-space blocks BARN's path
        obs = tuple(Obstacle("clutter", x + 5.5, y + 1.0, 0.0, (0.15, 0.15, 1.0), shape="cylinder") for x, y in p)
        ours.append(barn_difficulty_of((10.0, 16.0), obs, (3.25, 4.0), (3.25, 14.0), robot=JACKAL, origin=(1.0, 1.0)))
        dens.append(int((k >= 34).sum()))
    for m in ours + theirs:
        assert m.get("reason") is None
        assert 0 < m["dist_closest_m"] < 5 and 0 < m["visibility_m"] < 15 and 0 < m["characteristic_dim_m"] < 15
        assert 0 <= m["dispersion"] <= 16 and m["tortuosity"] >= 1.0
    for ms in (ours, theirs):
        assert spearmanr(dens, [m["dist_closest_m"] for m in ms]).correlation < -0.4
        assert spearmanr(dens, [m["characteristic_dim_m"] for m in ms]).correlation < -0.4
        assert spearmanr(dens, [m["dispersion"] for m in ms]).correlation > 0.3
