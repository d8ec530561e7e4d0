"""``ground.model: blender``: Blender's Subdivide + Fractal rule, checked from its definition.

Oracles: the segment count (s cuts -> s + 1 flat-faced segments per side), the bound each move
obeys (``|move| <= fac / 2`` with ``fac = (d / 2.5) * W``), z only (x and y of every sample are the
grid's), flat faces (every sample of a triangle lies on the plane through its three corners),
improved Perlin noise's exact properties (zero on the lattice, the turbulence in [0, 1]), and the
world-level contract (same seed, same heights; d scales heights linearly; spec errors).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.errors import SpecError
from navstress.seeding import rng
from navstress.world import WorldSpec, generate
from navstress.world.blender import (UI_FRACTAL_DIVISOR, facet_surface, flipped, improved_perlin, turbulence,
                                     vertex_heights)
from navstress.world.spec import GroundSpec, parse_spec
from navstress.world.terrain import make_heights

CELL = 0.4


def perm(seed: int) -> np.ndarray:
    p = np.random.default_rng(seed).permutation(256).astype(np.int64)
    return np.concatenate([p, p])


def heights(s: int, d: float, seed: int, shape: tuple[int, int], plane: float = 2.0) -> np.ndarray:
    g = GroundSpec(model="blender", subdivisions=s, deformation=d, plane_m=plane)
    return make_heights(g, shape, CELL, np.random.default_rng(seed))


def aligned_shape(s: int, k: int) -> tuple[int, int]:
    """A grid whose samples fall on the segment borders: k cells per segment."""
    return ((s + 1) * k + 1, (s + 1) * k + 1)


@given(s=st.integers(1, 12), d=st.floats(0.1, 20.0), plane=st.floats(0.5, 50.0), seed=st.integers(0, 2**32))
@settings(max_examples=40, deadline=None)
def test_vertex_moves_are_bounded_by_the_fractal_rule(s: int, d: float, plane: float, seed: int) -> None:
    z = vertex_heights(s, d, plane, np.random.default_rng(seed))
    n = s + 2
    assert z.shape == (n, n)
    fac = d / UI_FRACTAL_DIVISOR * plane
    tol = 1e-5 * fac  # float32 arithmetic, as Blender's
    border = np.ones((n, n), bool)
    border[1:-1, 1:-1] = False
    assert np.all(np.abs(z[border]) <= fac / 2 + tol)
    # an inner vertex starts on the line between its column's bottom and top border vertices
    t = (np.arange(n) / (n - 1))[1:-1, None]
    start = (1 - t) * z[0, 1:-1][None, :] + t * z[-1, 1:-1][None, :]
    assert np.all(np.abs(z[1:-1, 1:-1] - start) <= fac / 2 + tol)


@given(s=st.integers(1, 8), d=st.floats(0.5, 10.0), seed=st.integers(0, 2**32), k=st.integers(2, 6))
@settings(max_examples=25, deadline=None)
def test_s_cuts_give_s_plus_one_flat_faced_segments(s: int, d: float, seed: int, k: int) -> None:
    shape = aligned_shape(s, k)
    h = heights(s, d, seed, shape)
    z = vertex_heights(s, d, 2.0, np.random.default_rng(seed))
    # the samples on segment corners are the cut plane's vertices (z only: x, y are the grid's)
    np.testing.assert_allclose(h[::k, ::k], z, atol=1e-12)
    # inside every quad the samples lie on the two planes through its corners: (a, b, e) and
    # (a, c, e), or (a, b, c) and (b, c, e) where Blender's rule flips the quad
    u = np.arange(k + 1) / k
    UY, UX = u[:, None], u[None, :]
    flip = flipped(z, k * CELL, k * CELL)
    for i in range(s + 1):
        for j in range(s + 1):
            a, b, c, e = z[i, j], z[i, j + 1], z[i + 1, j], z[i + 1, j + 1]
            if flip[i, j]:
                want = np.where(UX + UY <= 1, a + UX * (b - a) + UY * (c - a),
                                e + (1 - UX) * (c - e) + (1 - UY) * (b - e))
            else:
                want = np.where(UX >= UY, a + UX * (b - a) + UY * (e - b), a + UY * (c - a) + UX * (e - c))
            np.testing.assert_allclose(h[i * k:(i + 1) * k + 1, j * k:(j + 1) * k + 1], want, atol=1e-9)


def test_s6_d35_on_the_default_map_shows_7_by_7_segments() -> None:
    """The issue's case: 100 m map, 0.4 m cells, s = 6, d = 3.5: the second differences of the
    heights vanish (flat faces) except along 6 + 6 segment borders and the 13 diagonals."""
    spec = WorldSpec(ground={"model": "blender", "subdivisions": 6, "deformation": 3.5})
    w = generate(spec, seed=3)
    h = make_heights(spec.ground, spec.grid_shape, spec.cell_m, rng(3, "terrain"))  # the world's raw ground
    # the world is that ground but for its levelled start and goal areas (test_freearea.py)
    far = np.hypot(*np.meshgrid(np.arange(251) * CELL - 5.0, np.arange(251) * CELL - 5.0)) > 40.0
    far &= np.hypot(*np.meshgrid(np.arange(251) * CELL - 95.0, np.arange(251) * CELL - 95.0)) > 40.0
    np.testing.assert_array_equal(w.terrain.heights[far], h.astype(np.float32)[far])
    seg = 100.0 / 7
    xs = np.arange(h.shape[1]) * CELL
    # columns whose second difference along x is non-zero somewhere: within a cell of a border
    d2x = np.abs(np.diff(h, 2, axis=1)).max(axis=0)
    creased = xs[1:-1][d2x > 1e-4]
    near_border = np.min(np.abs(creased[:, None] - seg * np.arange(1, 7)[None, :]), axis=1) <= CELL
    # diagonal creases cross every column, but the border creases are the only columns creased in
    # every row: check per row that the creases off the diagonals sit on the 6 inner borders
    assert near_border.sum() >= 6
    for row in (20, 100, 200):
        y = row * CELL
        line = h[row]
        d2 = np.abs(np.diff(line, 2))
        kinks = xs[1:-1][d2 > 1e-4]
        # a kink is within one cell of a segment border or of a diagonal x - y = j * seg (in segment units)
        ux = (kinks / seg) % 1.0
        uy = (y / seg) % 1.0
        on_border = np.minimum(ux, 1 - ux) * seg <= CELL + 1e-9
        on_diag = np.abs(ux - uy) * seg <= CELL + 1e-9
        assert np.all(on_border | on_diag), kinks[~(on_border | on_diag)]
        assert 1 <= len(kinks) <= 3 * 14  # each of 7 segments: its 2 borders and 1 diagonal, <= 2 cells each


@given(seed=st.integers(0, 2**32), s=st.integers(1, 6), d=st.floats(0.1, 8.0), f=st.floats(0.1, 5.0))
@settings(max_examples=20, deadline=None)
def test_heights_scale_linearly_with_d_and_plane_changes_the_noise_positions(seed: int, s: int, d: float,
                                                                             f: float) -> None:
    a = vertex_heights(s, d, 2.0, np.random.default_rng(seed))
    b = vertex_heights(s, d * f, 2.0, np.random.default_rng(seed))
    np.testing.assert_allclose(b, a * f, rtol=1e-5, atol=1e-6 * d * f)


@given(s=st.integers(0, 8), seed=st.integers(0, 2**32))
@settings(max_examples=10, deadline=None)
def test_zero_deformation_is_flat_zero(s: int, seed: int) -> None:
    assert not heights(s, 0.0, seed, (31, 41)).any()


def test_same_seed_same_heights_other_seed_differs() -> None:
    a = heights(4, 3.0, 11, (101, 101))
    b = heights(4, 3.0, 11, (101, 101))
    c = heights(4, 3.0, 12, (101, 101))
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


@given(x=st.lists(st.integers(-1000, 1000), min_size=3, max_size=3), seed=st.integers(0, 100))
@settings(max_examples=30, deadline=None)
def test_improved_perlin_is_zero_on_the_lattice(x: list[int], seed: int) -> None:
    v = improved_perlin(np.array([x[0]]), np.array([x[1]]), np.array([x[2]]), perm(seed))
    assert v[0] == 0.0


def test_improved_perlin_bounded_continuous_and_turbulence_in_unit_interval() -> None:
    gen = np.random.default_rng(0)
    pts = gen.random((3, 20000)) * 400.0
    p = perm(1)
    v = improved_perlin(pts[0], pts[1], pts[2], p)
    assert np.abs(v).max() <= 1.05  # 3-D improved noise: |n| < about 1.04
    assert 0.2 < v.std() < 0.35  # measured ~0.27 (Blender's newPerlin: 0.265 on the same kind of sample)
    eps = 1e-3
    w = improved_perlin(pts[0] + eps, pts[1], pts[2], p)
    assert np.abs(w - v).max() < 20 * eps  # continuous (gradient at most a few units)
    t = turbulence(pts[0], pts[1], pts[2], p)
    assert t.min() >= 0.0 and t.max() <= 1.0
    assert abs(float(t.mean()) - 0.5) < 0.01


@pytest.mark.parametrize(("ground", "message"), [
    ({"model": "blender", "subdivisions": 0, "deformation": 1.0},
     r"^ground\.subdivisions=0 is invalid: expected at least 1 cut for model blender"),
    ({"model": "subdivide", "subdivisions": 11}, r"^ground\.subdivisions=11 is invalid: .*\[0, 10\] for model subdivide"),
    ({"model": "blender", "subdivisions": 101, "deformation": 1.0}, r"^ground\.subdivisions=101 is invalid"),
    ({"model": "blender", "plane_m": 0}, r"^ground\.plane_m=0 is invalid: expected a value > 0"),
    ({"model": "blender", "plane_m": "big"}, r"^ground\.plane_m="),
    ({"model": "blender", "subdivisions": 2.5}, r"^ground\.subdivisions=2\.5 is invalid"),
    ({"model": "blender", "deformation": -1}, r"^ground\.deformation=-1 is invalid"),
    ({"model": "blend"}, r"^ground\.model='blend' is invalid"),
])
def test_spec_errors_are_one_line_and_name_the_field(ground: dict[str, object], message: str) -> None:
    with pytest.raises(SpecError, match=message) as err:
        parse_spec({"ground": ground})
    assert "\n" not in str(err.value)


def test_blender_specs_accepted_at_the_limits() -> None:
    parse_spec({"ground": {"model": "blender", "subdivisions": 0, "deformation": 0.0}})  # flat
    parse_spec({"ground": {"model": "blender", "subdivisions": 100, "deformation": 1.0}})
    parse_spec({"ground": {"model": "subdivide", "subdivisions": 10}})


def test_plane_m_is_written_only_for_the_blender_model() -> None:
    assert "plane_m" not in GroundSpec(subdivisions=3, deformation=1.0).model_dump()
    assert "plane_m" not in GroundSpec(model="fractal").model_dump()
    assert GroundSpec(model="blender", subdivisions=3, deformation=1.0).model_dump()["plane_m"] == 2.0


@given(rows=st.integers(2, 40), cols=st.integers(2, 40), s=st.integers(1, 5), seed=st.integers(0, 1000))
@settings(max_examples=25, deadline=None)
def test_facet_surface_is_bounded_by_its_vertices_on_any_grid(rows: int, cols: int, s: int, seed: int) -> None:
    z = np.random.default_rng(seed).normal(size=(s + 2, s + 2))
    h = facet_surface(z, (rows, cols), 0.4)
    assert h.shape == (rows, cols)
    assert h.min() >= z.min() - 1e-12 and h.max() <= z.max() + 1e-12  # convex combinations of vertices
    assert h[0, 0] == pytest.approx(z[0, 0]) and h[-1, -1] == pytest.approx(z[-1, -1])
    assert h[0, -1] == pytest.approx(z[0, -1]) and h[-1, 0] == pytest.approx(z[-1, 0])


ORACLE = json.loads((Path(__file__).parents[2] / "oracles" / "blender_subdivide.json").read_text())


@pytest.mark.parametrize("cuts", sorted(ORACLE["cuts"], key=int))
def test_heights_follow_blenders_distribution(cuts: str) -> None:
    """Against Blender 4.2 itself (benchmarks/blender_reference.py: ``bpy.ops.mesh.subdivide`` on
    the default 2 m plane, fractal 1, 200 seeds): the heights of the border and of the inner
    vertices and the neighbour differences have Blender's distribution within a Kolmogorov-Smirnov
    distance of 0.06 (or the 0.1 % critical distance for the sample sizes, when larger), and
    Blender's tessellation split every quad as :func:`flipped` says."""
    ref = ORACLE["cuts"][cuts]
    s = int(cuts)
    n = s + 2
    z = np.array([vertex_heights(s, 1.0, 2.0, np.random.default_rng(k)) for k in range(200)])
    inner = np.zeros((n, n), bool)
    inner[1:-1, 1:-1] = True
    ours = {"border": z[:, ~inner], "inner": z[:, inner], "dx": np.diff(z, axis=2), "dy": np.diff(z, axis=1)}
    q = np.array(ORACLE["percentiles"])
    for name, values in ours.items():
        v = np.sort(values.ravel())
        # our empirical CDF at Blender's percentiles, against the percentiles' levels
        cdf = np.searchsorted(v, np.array(ref[name])[1:-1], side="right") / len(v)
        distance = float(np.abs(cdf - q[1:-1]).max())
        critical = 1.95 * np.sqrt(2.0 / len(v))  # two samples of len(v) each (Blender's: as many)
        assert distance < max(0.06, critical), (name, distance)
    assert ref["quads"] == 200 * (s + 1) ** 2 and ref["rule_mismatches"] == 0


def test_a_folding_quad_is_split_along_its_other_diagonal() -> None:
    """Blender's flip rule, on a quad whose (x+, y-) corner is far above the rest: split along
    the (x+, y-) - (x-, y+) diagonal, so the sample at the quad's centre is the mean of those two."""
    z = np.zeros((2, 2))
    z[0, 1] = 3.0  # (x+, y-) corner; the quad is 1 x 1 m
    assert flipped(z, 1.0, 1.0)[0, 0] == (-3.0 * (0 - 0) + 0 - 1.0 > 0)  # no fold: dot = -1
    z[1, 0] = 3.0  # (x-, y+) corner too: dot = 2*3*3 - 0 - 1 = 17 > 0 -> folded
    assert bool(flipped(z, 1.0, 1.0)[0, 0])
    h = facet_surface(z, (3, 3), 0.5)
    assert h[1, 1] == pytest.approx(3.0)  # on the b-c diagonal, both at 3
    z2 = np.zeros((2, 2))
    z2[0, 1] = 0.3
    z2[1, 0] = 0.3  # small: not folded, split along a-e; the centre is on the a-e diagonal
    assert facet_surface(z2, (3, 3), 0.5)[1, 1] == pytest.approx(0.0)
