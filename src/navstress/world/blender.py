"""``ground.model: blender``: the paper's ground, Blender's Subdivide operator with its Fractal option.

The paper builds its ground in Blender: a plane, the Subdivide operator with ``s`` "the number of
subdivisions" and a Fractal value ``d``, the displacement along the normal only (z). In Blender's
operator (``bmo_subdivide_edges_exec`` and ``alter_co`` in ``bmesh/operators/bmo_subdivide.cc``)
that number is the number of *cuts* per edge, and this module reproduces the operator:

* Geometry. A square plane of side ``W`` (``ground.plane_m``, default 2 m: Blender's default plane)
  centred at the origin, cut ``s`` times per edge: ``s + 1`` segments and ``s + 2`` vertices per
  side, at ``p_j = -W/2 + j W / (s + 1)``. The plane is then scaled to the map in x and y only
  (the map's corner (0, 0) is the plane's corner (-W/2, -W/2)), so z keeps the size it had on the
  plane of side W.
* Displacement. Every vertex of the cut plane, the four original corners included (the operator
  calls ``alter_co`` on each edge's end vertices too), moves along z by

      z = (d / 2.5) * W * (T(10 (p + o)) - 1/2)

  where ``(d / 2.5) * W`` is Blender's ``fac = fractal * len``: the editor's operator (its Fractal
  field, the paper's d) passes ``d / 2.5`` to bmesh's, and ``len`` is the length of the original
  edge being cut, W on a plane (for the grid's inner lines too). ``o`` is the operator's random
  offset (three uniform draws in [0, 200), from the world's ``"terrain"`` stream here, from the
  operator's ``seed`` in Blender) and ``T`` is
  Blender's ``BLI_noise_generic_turbulence(1.0, x, y, z, 15, false, 2)``: 16 octaves (amplitude
  halving, frequency doubling) of improved Perlin noise mapped to [0, 1], normalised by
  ``2**15 / (2**16 - 1)`` so that ``T`` lies in [0, 1]. Each move is therefore at most
  ``d * W / 5``. The four corners and the vertices on the plane's border start at z = 0; the
  inner vertices are cut last, on lines between a bottom and a top border vertex (same x), which
  are displaced by then: an inner vertex starts on that line (its height linear in y between the
  two) and moves from there, so ``|z| <= 2 d W / 5`` inside and ``d W / 5`` on the border.
* Noise. :func:`improved_perlin` is Ken Perlin's improved noise (2002: quintic fade, the 12 edge
  gradients picked by ``hash & 15``) evaluated in float32 like Blender's ``newPerlin``; the only
  difference from Blender is the hash table, a permutation of 0..255 drawn from the world's
  ``"terrain"`` stream where Blender has a fixed table. In float32, from about the tenth octave on
  the coordinates ``2**k * 10 (p + o)`` have no fractional part left, so those octaves add exactly
  1/2 (Perlin noise is 0 on its lattice), in Blender's turbulence too. Measured against Blender 4.2
  (``bpy``, 200 seeds per s): the heights and the neighbour differences have the same distribution
  within a two-sample Kolmogorov-Smirnov distance of 0.05 (docs/worlds.md gives the figures).
* Faces. Between vertices the ground is flat: each of the ``(s + 1)**2`` quads is split into two
  triangles as Blender's tessellation splits it: along its diagonal from its (x-, y-) corner to its
  (x+, y+) corner unless the two triangles would fold over (:func:`flipped`; measured with ``bpy``
  on 6,800 quads of Blender 4.2: the rule predicts every split). The rule is applied on the mesh
  scaled to the map, the one the simulator receives, where a fold takes height differences near
  the segments' length: in practice always the first diagonal.

The height grid samples that piecewise-planar surface exactly at every grid vertex; between grid
vertices the simulator interpolates linearly, so a face is exact except within one cell of a
segment border or diagonal, where the crease is rounded off over at most one cell.

    >>> import numpy as np
    >>> h = blender_heights(6, 3.5, 2.0, (251, 251), 0.4, np.random.default_rng(0))
    >>> h.shape, bool(np.abs(h).max() <= 2 * 3.5 * 2.0 / 5)
    ((251, 251), True)
"""

from __future__ import annotations

import numpy as np

#: Blender's turbulence call in the Subdivide operator: 15 -> octaves 0..15.
OCTAVES = 15
#: Blender multiplies the offset position by 10 before the noise.
NOISE_SCALE = 10.0
#: The operator's random offset is drawn in [0, OFFSET_RANGE) per axis.
OFFSET_RANGE = 200.0
#: The editor's Subdivide (its Fractal field: the paper's d) hands ``d / UI_FRACTAL_DIVISOR`` to the
#: bmesh operator as ``fractal``.
UI_FRACTAL_DIVISOR = 2.5

_F = np.float32


def _fade(t: np.ndarray) -> np.ndarray:
    out: np.ndarray = t * t * t * (t * (t * _F(6) - _F(15)) + _F(10))
    return out


def _grad(h: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The dot product of (x, y, z) with one of the 12 cube-edge gradients chosen by ``h & 15``."""
    h = h & 15
    u = np.where(h < 8, x, y)
    v = np.where(h < 4, y, np.where((h == 12) | (h == 14), x, z))
    out: np.ndarray = np.where(h & 1, -u, u) + np.where(h & 2, -v, v)
    return out


def improved_perlin(x: np.ndarray, y: np.ndarray, z: np.ndarray, perm: np.ndarray) -> np.ndarray:
    """Improved Perlin noise (float32, about [-1, 1]) at the points (x, y, z); ``perm`` is a
    permutation of 0..255 repeated twice (512 entries). Zero at every integer lattice point."""
    x, y, z = (np.asarray(a, dtype=_F) for a in (x, y, z))
    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
    X, Y, Z = (f.astype(np.int64) & 255 for f in (fx, fy, fz))
    x, y, z = x - fx, y - fy, z - fz
    u, v, w = _fade(x), _fade(y), _fade(z)
    p = perm
    A = p[X] + Y
    AA, AB = p[A] + Z, p[A + 1] + Z
    B = p[X + 1] + Y
    BA, BB = p[B] + Z, p[B + 1] + Z
    one = _F(1)

    def lerp(t: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        out: np.ndarray = a + t * (b - a)
        return out

    return lerp(w,
                lerp(v, lerp(u, _grad(p[AA], x, y, z), _grad(p[BA], x - one, y, z)),
                     lerp(u, _grad(p[AB], x, y - one, z), _grad(p[BB], x - one, y - one, z))),
                lerp(v, lerp(u, _grad(p[AA + 1], x, y, z - one), _grad(p[BA + 1], x - one, y, z - one)),
                     lerp(u, _grad(p[AB + 1], x, y - one, z - one), _grad(p[BB + 1], x - one, y - one, z - one))))


def turbulence(x: np.ndarray, y: np.ndarray, z: np.ndarray, perm: np.ndarray, octaves: int = OCTAVES) -> np.ndarray:
    """Blender's generic turbulence with the improved-Perlin basis, in [0, 1]: the normalised sum
    over k = 0..octaves of ``2**-k * (1 + noise(2**k x, 2**k y, 2**k z)) / 2`` (float32)."""
    x, y, z = (np.asarray(a, dtype=_F) for a in (x, y, z))
    total = np.zeros(np.broadcast(x, y, z).shape, dtype=_F)
    amp, scale = _F(1), _F(1)
    for _ in range(octaves + 1):
        t = _F(0.5) * (_F(1) + improved_perlin(scale * x, scale * y, scale * z, perm))
        total += t * amp
        amp *= _F(0.5)
        scale *= _F(2)
    out: np.ndarray = total * _F(float(1 << octaves) / float((1 << (octaves + 1)) - 1))
    return out


def vertex_heights(cuts: int, fractal: float, plane_m: float, gen: np.random.Generator) -> np.ndarray:
    """The ``(cuts + 2)**2`` vertex heights (rows along y, columns along x), meters, float64.

    Draws from ``gen``: the permutation (256 integers), then the offset (3 floats); the same draws
    whatever ``fractal`` is, so worlds differing only in d share their noise."""
    perm = gen.permutation(256).astype(np.int64)
    perm = np.concatenate([perm, perm])
    ofs = (gen.random(3) * OFFSET_RANGE).astype(_F)
    n = cuts + 2
    w = _F(plane_m)
    p = (-w / _F(2) + np.arange(n, dtype=_F) * (w / _F(cuts + 1))).astype(_F)
    px, py = np.meshgrid(p, p)  # rows along y, columns along x
    co_x = (px + ofs[0]) * _F(NOISE_SCALE)
    co_y = (py + ofs[1]) * _F(NOISE_SCALE)
    co_z = np.full_like(co_x, (_F(0) + ofs[2]) * _F(NOISE_SCALE))
    fac = (_F(fractal) / _F(UI_FRACTAL_DIVISOR)) * w
    z = fac * (turbulence(co_x, co_y, co_z, perm) - _F(0.5))
    # The grid's inner vertices are cut on lines between the bottom and the top edge's vertices,
    # which are displaced by then: an inner vertex starts on that line (linear in y), then moves.
    t = (np.arange(n, dtype=_F) / _F(n - 1))[1:-1, None]
    z[1:-1, 1:-1] += (_F(1) - t) * z[0, 1:-1][None, :] + t * z[-1, 1:-1][None, :]
    return z.astype(np.float64)


def flipped(vertices: np.ndarray, lx: float, ly: float) -> np.ndarray:
    """Per quad, True where Blender's tessellation splits it along its other diagonal.

    Blender splits a quad (v1, v2, v3, v4) along v1-v3 unless the two triangles would fold over,
    ``dot((v2 - v1) x (v3 - v1), (v4 - v1) x (v3 - v1)) > 0`` (``is_quad_flip_v3_first_third_fast``),
    with v1 the quad's (x-, y-) corner. ``lx``, ``ly``: the quad's sides. On a map-scaled ground
    this takes height differences close to the sides' lengths."""
    z = vertices
    b = z[:-1, 1:] - z[:-1, :-1]   # x + 1
    c = z[1:, :-1] - z[:-1, :-1]   # y + 1
    e = z[1:, 1:] - z[:-1, :-1]
    dot = -b * ly * ly * (e - c) + lx * lx * c * (b - e) - lx * lx * ly * ly
    out: np.ndarray = dot > 0
    return out


def facet_surface(vertices: np.ndarray, shape: tuple[int, int], cell_m: float) -> np.ndarray:
    """Sample the flat-faced surface over ``vertices`` ((m, m) heights at the corners of m - 1
    equal segments per side spanning the map) at a ``shape`` vertex grid of spacing ``cell_m``.
    Each quad is two triangles split along its (x-, y-) -> (x+, y+) diagonal, or the other one
    where Blender's tessellation flips it (:func:`flipped`)."""
    rows, cols = shape
    segs = vertices.shape[0] - 1

    def axis(n: int) -> tuple[np.ndarray, np.ndarray]:
        extent = (n - 1) * cell_m
        f = np.arange(n) * cell_m * (segs / extent)
        i = np.minimum(np.floor(f).astype(np.int64), segs - 1)
        return i, f - i

    iy, uy = axis(rows)
    ix, ux = axis(cols)
    I, J = iy[:, None], ix[None, :]
    UY, UX = uy[:, None], ux[None, :]
    a = vertices[I, J]
    b = vertices[I, J + 1]      # x + 1
    c = vertices[I + 1, J]      # y + 1
    e = vertices[I + 1, J + 1]
    lower = a + UX * (b - a) + UY * (e - b)   # triangle a, b, e (ux >= uy)
    upper = a + UY * (c - a) + UX * (e - c)   # triangle a, c, e (uy > ux)
    out: np.ndarray = np.where(UX >= UY, lower, upper)
    flip = flipped(vertices, (cols - 1) * cell_m / segs, (rows - 1) * cell_m / segs)
    if flip.any():
        f = flip[I, J]
        below = a + UX * (b - a) + UY * (c - a)                  # triangle a, b, c (ux + uy <= 1)
        above = e + (1 - UX) * (c - e) + (1 - UY) * (b - e)      # triangle b, c, e
        out = np.where(f, np.where(UX + UY <= 1, below, above), out)
    return out


def blender_heights(cuts: int, fractal: float, plane_m: float, shape: tuple[int, int], cell_m: float,
                    gen: np.random.Generator) -> np.ndarray:
    """The paper's ground on a ``shape`` vertex grid (see the module doc)."""
    z = vertex_heights(cuts, fractal, plane_m, gen)
    if fractal == 0.0:
        return np.zeros(shape)
    return facet_surface(z, shape, cell_m)
