"""Ground height fields: ``subdivide`` (a smooth reading of the paper's), ``blender`` (the paper's
tool reproduced, in :mod:`navstress.world.blender`) and a ``fractal`` noise model.

All models are pure functions of (GroundSpec, grid shape, cell size, Generator): all draws
come from the generator passed in (the ``"terrain"`` sub-stream of the world seed).

``subdivide`` (the paper's s and d read as "subdivided s times", smoothly). A plane over the whole
map is subdivided ``s`` times, giving ``n = 2**s + 1`` control vertices per side, spaced
``L = size / 2**s`` meters. Each control vertex (a, b) is displaced along z by

    c[a, b] = d * U(-1/2, 1/2)        (i.i.d., uniform; so |c| <= d/2, std d / sqrt(12))

so ``d`` is exactly the peak-to-peak bound of the control heights. The surface between the
control vertices is the tensor-product Catmull-Rom spline through them (C1, interpolating:
it passes through every control vertex), with linearly extrapolated ghost vertices at the
border. Hence ``s = 0`` is a bilinear (gently tilted and twisted) plane through the four
corner heights and ``d = 0`` is flat zero. See ``docs/worlds.md`` for the slope scale.

``fractal``: sum over octaves k = 0..octaves-1 of ``amplitude_m * persistence**k * N_k``
where ``N_k`` is 2-D gradient (Perlin) noise of lattice spacing ``wavelength_m / 2**k``,
normalised to [-1, 1], with random unit gradients and a random lattice offset per octave.
Octaves whose wavelength is below two grid cells are dropped (they would alias).

    >>> import numpy as np
    >>> from navstress.world.spec import GroundSpec
    >>> h = make_heights(GroundSpec(subdivisions=3, deformation=2.0), (11, 11), 1.0, np.random.default_rng(0))
    >>> h.shape, h.dtype
    ((11, 11), dtype('float64'))
"""

from __future__ import annotations

import numpy as np

from navstress.errors import SpecError
from navstress.world.blender import blender_heights
from navstress.world.spec import GroundSpec


def make_heights(ground: GroundSpec, shape: tuple[int, int], cell_m: float,
                 gen: np.random.Generator) -> np.ndarray:
    """Heights (float64, meters) on a ``shape`` = (rows along y, cols along x) vertex grid."""
    rows, cols = shape
    if rows < 2 or cols < 2:
        raise SpecError("grid_shape", shape, "at least 2 x 2 vertices")
    if ground.model == "subdivide":
        return subdivide_heights(ground.subdivisions, ground.deformation, shape, gen)
    if ground.model == "blender":
        return blender_heights(ground.subdivisions, ground.deformation, ground.plane_m, shape, cell_m, gen)
    return fractal_heights(ground.octaves, ground.persistence, ground.wavelength_m, ground.amplitude_m,
                           shape, cell_m, gen)


def control_heights(subdivisions: int, deformation: float, gen: np.random.Generator) -> np.ndarray:
    """The ``(2**s + 1)**2`` control-vertex heights: ``d * U(-1/2, 1/2)`` each."""
    n = 2 ** subdivisions + 1
    return deformation * (gen.random((n, n)) - 0.5)


def _catmull_rom_taps(n_samples: int, n_ctrl: int) -> tuple[np.ndarray, np.ndarray]:
    """For samples spread evenly over control indices [0, n_ctrl-1]: the first padded control
    index of each 4-tap window (shape (n_samples,)) and the 4 weights (shape (n_samples, 4))."""
    t = np.linspace(0.0, n_ctrl - 1.0, n_samples)
    i = np.minimum(np.floor(t).astype(np.int64), n_ctrl - 2)
    u = t - i
    u2, u3 = u * u, u * u * u
    w = np.stack([(-u3 + 2 * u2 - u) / 2, (3 * u3 - 5 * u2 + 2) / 2,
                  (-3 * u3 + 4 * u2 + u) / 2, (u3 - u2) / 2], axis=1)
    return i, w  # padded indices i .. i+3 correspond to control i-1 .. i+2


def catmull_rom_surface(ctrl: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Tensor-product Catmull-Rom surface through ``ctrl`` sampled on a ``shape`` grid whose
    corners coincide with the control grid's corners. Ghost control vertices are linear
    extrapolations, so linear data are reproduced exactly (2 x 2 controls give bilinear)."""
    ny, nx = ctrl.shape
    pad = np.empty((ny + 2, nx + 2))
    pad[1:-1, 1:-1] = ctrl
    pad[0, 1:-1] = 2 * ctrl[0] - ctrl[1]
    pad[-1, 1:-1] = 2 * ctrl[-1] - ctrl[-2]
    pad[:, 0] = 2 * pad[:, 1] - pad[:, 2]
    pad[:, -1] = 2 * pad[:, -2] - pad[:, -3]
    iy, wy = _catmull_rom_taps(shape[0], ny)
    ix, wx = _catmull_rom_taps(shape[1], nx)
    out = np.zeros(shape)
    # 16 elementwise terms (no BLAS): bit-identical on every run.
    for a in range(4):
        rows = pad[iy + a]
        for b in range(4):
            out += wy[:, a, None] * wx[None, :, b] * rows[:, ix + b]
    return out


def subdivide_heights(subdivisions: int, deformation: float, shape: tuple[int, int],
                      gen: np.random.Generator) -> np.ndarray:
    """The paper's model: Catmull-Rom surface through ``d * U(-1/2, 1/2)`` control heights."""
    ctrl = control_heights(subdivisions, deformation, gen)
    if deformation == 0.0:
        return np.zeros(shape)
    return catmull_rom_surface(ctrl, shape)


def _fade(t: np.ndarray) -> np.ndarray:
    out: np.ndarray = t * t * t * (t * (t * 6 - 15) + 10)
    return out


def gradient_noise(xs: np.ndarray, ys: np.ndarray, wavelength: float, gen: np.random.Generator) -> np.ndarray:
    """2-D gradient (Perlin) noise in [-1, 1] on the grid ``xs`` (cols) x ``ys`` (rows), lattice
    spacing ``wavelength`` meters, random unit gradients and lattice offset from ``gen``."""
    off = gen.random(2)
    u = xs / wavelength + off[0]
    v = ys / wavelength + off[1]
    nlx, nly = int(np.floor(u[-1])) + 2, int(np.floor(v[-1])) + 2
    ang = gen.random((nly, nlx)) * (2 * np.pi)
    gx, gy = np.cos(ang), np.sin(ang)
    j0 = np.floor(u).astype(np.int64)
    i0 = np.floor(v).astype(np.int64)
    fu, fv = (u - j0)[None, :], (v - i0)[:, None]
    I0, J0 = i0[:, None], j0[None, :]

    def corner(di: int, dj: int) -> np.ndarray:
        c: np.ndarray = gx[I0 + di, J0 + dj] * (fu - dj) + gy[I0 + di, J0 + dj] * (fv - di)
        return c

    su, sv = _fade(fu), _fade(fv)
    top = corner(0, 0) + su * (corner(0, 1) - corner(0, 0))
    bot = corner(1, 0) + su * (corner(1, 1) - corner(1, 0))
    out: np.ndarray = np.sqrt(2.0) * (top + sv * (bot - top))
    return out


def fractal_heights(octaves: int, persistence: float, wavelength_m: float, amplitude_m: float,
                    shape: tuple[int, int], cell_m: float, gen: np.random.Generator) -> np.ndarray:
    """Multi-octave gradient noise; octave k has wavelength ``wavelength_m / 2**k`` and
    amplitude ``amplitude_m * persistence**k``; octaves finer than 2 cells are dropped."""
    rows, cols = shape
    xs = np.arange(cols) * cell_m
    ys = np.arange(rows) * cell_m
    out = np.zeros(shape)
    for k in range(octaves):
        lam = wavelength_m / 2 ** k
        sub = np.random.default_rng(gen.integers(0, 2**63 - 1))  # one draw per octave: stable
        if lam < 2 * cell_m or amplitude_m == 0.0:
            continue
        out += amplitude_m * persistence ** k * gradient_noise(xs, ys, lam, sub)
    return out


def slope_deg(heights: np.ndarray, cell_m: float) -> np.ndarray:
    """Slope angle in degrees at every vertex (central differences, one-sided at borders)."""
    gy, gx = np.gradient(np.asarray(heights, dtype=np.float64), cell_m)
    out: np.ndarray = np.degrees(np.arctan(np.hypot(gx, gy)))
    return out
