"""Standard normal draws from raw 64-bit words: a ziggurat (internal; used by ``Lidar.scan``).

Marsaglia & Tsang (2000), "The ziggurat method for generating random variables", 256 layers of
equal area under f(x) = exp(-x^2/2), tables built once at import in float64 (r found by
bisection so that the top layer closes at x = 0 to double precision). The method is exact: a
sample is accepted only under the density, rejected points are redrawn, and the tail beyond r
is drawn by Marsaglia's exact exponential method (x = -ln(U1)/r, y = -ln(U2), accept when
2y > x^2). The only departures from N(0, 1) are float64 rounding and the 2^-53 grid of the
uniforms (as for any float64 sampler).

Stream (what :func:`standard_normals` and :func:`noisy_points` read), for ``n`` samples:

* ``bitgen.random_raw(m + spare)`` with ``m = ceil(n / 2)``: sample k's first draw is a 32-bit
  half of word ``k // 2`` (low half for even k, high for odd): bits 0-7 the layer, bit 8 the
  sign, bits 9-31 a 23-bit uniform (the same layout and resolution as numpy's float32
  ziggurat, which this replaces in ``Lidar.scan``); words ``m ..`` are the spare words;
* a sample not accepted by that draw (~1.1 % of them) takes whole 64-bit words (53-bit
  uniforms) from the spare words, in sample order: one per wedge test, two per tail attempt,
  one per redraw after a rejection (a redraw's layer/sign/uniform come from bits 0-7 / 8 / 11-63);
* if the spare words run out during a sample, ``bitgen.random_raw(spare)`` is drawn and that
  sample is redone from its first draw with the new spare words (exact: the redo is a fresh
  run of the same conditional process); unused spare words are discarded.

``spare = n // 16 + 64`` (several times the expected need; at lidar sizes a refill is
practically never needed). The words consumed are a pure function of the bit generator's state
and ``n``. Precision: the first draw puts ``|x|`` on a grid of X[i] / 2^23 within its layer
(as numpy's float32 sampler); the bisection closes the top layer's area to ~1e-12 relative.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.errors import SpecError

__all__ = ["LAYERS", "R", "default_spare", "standard_normals", "noisy_points"]

LAYERS = 256
_TWO53 = float(2 ** 53)


def _density(x: float) -> float:
    """f(x) = exp(-x^2/2): the standard normal density without its constant (the ziggurat's f)."""
    return math.exp(-0.5 * x * x)


def _layers(r: float, n: int) -> tuple[float, list[float]]:
    """Common area ``v`` and widths X[1..n-1] (X[1] = r, decreasing) for a trial ``r``; the
    residual of the top layer's area is ``X[n-1] * (1 - f(X[n-1])) - v`` (0 when r is right)."""
    v = r * _density(r) + math.sqrt(math.pi / 2.0) * math.erfc(r / math.sqrt(2.0))
    xs = [r]
    for _ in range(n - 2):
        y = v / xs[-1] + _density(xs[-1])
        if y >= 1.0:  # overshoot: r too small
            return v, []
        xs.append(math.sqrt(-2.0 * math.log(y)))
    return v, xs


def _build(n: int) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """r, W[i] = X[i] / 2^53, K[i] = floor(2^53 X[i+1] / X[i]) (uint64), F[i] = f(X[i]) for
    i = 0..n (X[0] = v / f(r), the base strip's pseudo-width, X[n] = 0)."""
    lo, hi = 2.0, 5.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        v, xs = _layers(mid, n)
        if not xs:
            lo = mid  # layers too thick: they close below the top, r too small
        elif xs[-1] * (1.0 - _density(xs[-1])) > v:
            hi = mid  # top layer wider than the others: layers too thin, r too large
        else:
            lo = mid
        if hi - lo <= 4.0 * np.spacing(hi):
            break
    r = hi
    v, xs = _layers(r, n)
    x = np.array([v / _density(r)] + xs + [0.0])
    w = x / _TWO53
    k = np.array([math.floor(x[i + 1] / x[i] * _TWO53) for i in range(n)], np.int64)
    f = np.exp(-0.5 * x * x)
    return r, w, k, f


R, _W, _K, _F = _build(LAYERS)
_W32 = _W * (_TWO53 / 2.0 ** 23)  # X[i] / 2^23 (exact: a power-of-two rescaling)
_K32 = np.array([math.floor(float(q) / 2.0 ** 30) for q in _K], np.int64)  # floor(2^23 X[i+1] / X[i])
for _a in (_W, _K, _F, _W32, _K32):
    _a.setflags(write=False)
_INV_R = 1.0 / R


def default_spare(n: int) -> int:
    """Spare words drawn with the ``n`` first words (and per refill)."""
    return n // 16 + 64


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _u01(w: np.uint64) -> float:
    return float(w >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(cache=True, nogil=True, error_model="numpy")
def _slow(i: int | np.int64, x: float, neg: bool, spare: np.ndarray, pos: int) -> tuple[float, int]:
    """Finish a sample in layer ``i`` at ``|x|`` that failed the quick test; returns (z, new pos),
    or (nan, -1) if the spare words ran out. Redraws use whole 64-bit spare words."""
    ns = spare.shape[0]
    while True:
        if i == 0:  # tail beyond R
            while True:
                if pos + 2 > ns:
                    return np.nan, -1
                a = -math.log1p(-_u01(spare[pos])) * _INV_R
                b = -math.log1p(-_u01(spare[pos + 1]))
                pos += 2
                if b + b > a * a:
                    x = R + a
                    return (-x if neg else x), pos
        if pos + 1 > ns:
            return np.nan, -1
        y = _F[i] + _u01(spare[pos]) * (_F[i + 1] - _F[i])
        pos += 1
        if y < math.exp(-0.5 * x * x):
            return (-x if neg else x), pos
        if pos + 1 > ns:  # rejected: redraw from a 64-bit word
            return np.nan, -1
        w = spare[pos]
        pos += 1
        i = np.int64(w & np.uint64(0xFF))
        neg = ((w >> np.uint64(8)) & np.uint64(1)) != 0
        u = np.int64(w >> np.uint64(11))
        x = float(u) * _W[i]
        if u < _K[i]:
            return (-x if neg else x), pos


@njit(cache=True, nogil=True, error_model="numpy")
def fill_normals(first: np.ndarray, spare: np.ndarray, start: int, out: np.ndarray) -> int:
    """out[k] for k >= start (first draws from ``first``, then the spare words; stream in the
    module docstring); returns len(out) when done, else the sample that ran out of spare words (to redo
    with new spare words)."""
    pos = 0
    for k in range(start, out.shape[0]):
        h = np.int64((first[k >> 1] >> np.uint64(32 * (k & 1))) & np.uint64(0xFFFFFFFF))
        i = h & 0xFF
        u = h >> 9
        x = float(u) * _W32[i]
        neg = (h & 0x100) != 0
        if u < _K32[i]:
            out[k] = x * float(1 - ((h >> 7) & 2))  # branch-free sign (a branch mispredicts half the time)
        else:
            z, pos = _slow(i, x, neg, spare, pos)
            if pos < 0:
                return k
            out[k] = z
    return int(out.shape[0])


@njit(cache=True, nogil=True, error_model="numpy")
def noisy_points(r: np.ndarray, dirs: np.ndarray, first: np.ndarray, spare: np.ndarray, start: int,
                 std: float, pts: np.ndarray) -> int:
    """Hit points (sensor frame, channel-major) of the finite ranges ``r`` with range noise
    ``std * z``, z the k-th standard normal of ``first``/``spare`` for the k-th finite range
    (exactly as :func:`fill_normals`), range clamped at 0. Writes points k >= start; returns the
    number of points (all written) or the sample that ran out of spare words."""
    n = 0
    pos = 0
    for c in range(r.shape[0]):
        for a in range(r.shape[1]):
            d = r[c, a]
            if d < np.inf:
                if n >= start:
                    h = np.int64((first[n >> 1] >> np.uint64(32 * (n & 1))) & np.uint64(0xFFFFFFFF))
                    i = h & 0xFF
                    u = h >> 9
                    x = float(u) * _W32[i]
                    neg = (h & 0x100) != 0
                    if u < _K32[i]:
                        z = x * float(1 - ((h >> 7) & 2))  # branch-free sign
                    else:
                        z, pos = _slow(i, x, neg, spare, pos)
                        if pos < 0:
                            return n
                    d = max(d + std * z, 0.0)
                    pts[n, 0] = dirs[c, a, 0] * d
                    pts[n, 1] = dirs[c, a, 1] * d
                    pts[n, 2] = dirs[c, a, 2] * d
                n += 1
    return n


def standard_normals(rng: np.random.Generator, n: int, *, spare: int | None = None) -> np.ndarray:
    """``n`` N(0, 1) float64 samples from ``rng.bit_generator`` (stream: see the module docstring;
    ``spare`` overrides :func:`default_spare`, for tests of the refill)."""
    n = int(n)
    s = default_spare(n) if spare is None else int(spare)
    if n < 0:
        raise SpecError("n", n, "a sample count >= 0")
    if s < 2:
        raise SpecError("spare", s, "at least 2 spare words (a tail attempt takes 2)")
    m = (n + 1) // 2
    words = rng.bit_generator.random_raw(m + s)
    first, sp = words[:m], words[m:]
    out = np.empty(n)
    k = fill_normals(first, sp, 0, out)
    while k < n:
        k = fill_normals(first, rng.bit_generator.random_raw(s), k, out)
    return out
