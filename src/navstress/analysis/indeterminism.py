"""Indeterminism (the paper's Q2): how far apart repeated runs on one map drift.

For the runs on one map, at each time ``t`` on a regular grid (step ``dt``, from 0 to the
end of the longest run), each run's real position is linearly interpolated from its trace;
before its first sample a run is at its first position, and **a run that has ended keeps its
last position**. The spread ``D(t)`` is the maximum Euclidean (x, y) distance between any
two runs. A configuration's curve is the mean of its maps' curves (a map's curve is held at
its last value past its own end, which is exactly what "ended runs keep their last position"
gives), computed separately for all runs, successful runs and unsuccessful runs; a map
contributes to a group only with at least two runs in that group.

Summary numbers per curve: ``peak_m`` (max over t), ``mean_m`` (time average over the
curve's span) and ``final_m`` (the value once every run has ended).

    >>> import numpy as np
    >>> a = np.array([[0.0, 0, 0], [2.0, 2, 0]]); b = np.array([[0.0, 0, 0], [1.0, 0, 1]])
    >>> t, d = max_spread([a, b], dt=1.0)
    >>> [round(float(v), 4) for v in d]
    [0.0, 1.4142, 2.2361]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from navstress.errors import SpecError

GROUPS: tuple[str, ...] = ("all", "success", "failure")
#: Most points of one curve's time grid (a day of simulated time at 1 s is 86,401): a smaller
#: ``dt`` is refused before the grid is allocated (each run of a map is interpolated onto it).
MAX_CURVE_POINTS = 200_000


def grid(end: float, dt: float) -> np.ndarray:
    """The time grid 0, dt, 2 dt, ... up to ``end`` (included); SpecError naming ``dt`` when it is
    not a finite step > 0 or makes more than :data:`MAX_CURVE_POINTS` points.

        >>> grid(2.5, 1.0).tolist()
        [0.0, 1.0, 2.0, 2.5]
    """
    if not (dt > 0 and math.isfinite(dt)):
        raise SpecError("dt", dt, "a finite time step in seconds > 0")
    q = end / dt if math.isfinite(end) and end > 0 else 0.0  # inf for a subnormal dt
    if not q + 1 <= MAX_CURVE_POINTS:
        raise SpecError("dt", dt, f"a time step giving at most {MAX_CURVE_POINTS:,} points over the runs' "
                        f"{end:g} s (this one gives about {q:.3g})", f"use dt >= {end / (MAX_CURVE_POINTS - 1):.3g}")
    n = math.floor(q + 1e-9) + 1
    t = np.arange(n, dtype=np.float64) * dt
    if t[-1] < end - 1e-9:
        t = np.append(t, end)
    return t


def positions_at(traj: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(len(t), 2) positions of a trajectory ``traj`` (N, >=3: t, x, y, ...) at times ``t``:
    linear interpolation, held constant before the first and after the last sample."""
    tr = np.asarray(traj, dtype=np.float64)
    if tr.ndim != 2 or tr.shape[0] == 0 or tr.shape[1] < 3:
        raise SpecError("trajectory", f"shape {tr.shape}", "a non-empty (N, >=3) array of t, x, y")
    return np.column_stack([np.interp(t, tr[:, 0], tr[:, 1]), np.interp(t, tr[:, 0], tr[:, 2])])


def max_spread(trajs: Sequence[np.ndarray], dt: float = 1.0, t_end: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(t, D(t)): the max pairwise distance between the runs ``trajs`` on a grid 0, dt, ...
    up to ``t_end`` (default: the last sample of the longest run, included). One run: D = 0."""
    if not trajs:
        raise SpecError("trajectories", 0, "at least one trajectory")
    end = max(float(np.asarray(tr)[-1, 0]) for tr in trajs) if t_end is None else float(t_end)
    t = grid(end, dt)
    pos = np.stack([positions_at(tr, t) for tr in trajs])  # (runs, T, 2)
    d = np.zeros(len(t))
    for i in range(len(trajs)):
        for j in range(i + 1, len(trajs)):
            d = np.maximum(d, np.hypot(*(pos[i] - pos[j]).T))
    return t, d


@dataclass(frozen=True)
class Curve:
    """A configuration's mean spread over its maps for one group of runs."""

    group: str  # all | success | failure
    t: np.ndarray
    d: np.ndarray
    n_maps: int  # maps that contributed (>= 2 runs of the group)
    n_runs: int

    @property
    def peak_m(self) -> float:
        return float(self.d.max()) if len(self.d) else 0.0

    @property
    def mean_m(self) -> float:
        if len(self.d) < 2:
            return float(self.d[0]) if len(self.d) else 0.0
        return float(np.trapezoid(self.d, self.t) / (self.t[-1] - self.t[0]))

    @property
    def final_m(self) -> float:
        return float(self.d[-1]) if len(self.d) else 0.0

    def summary(self) -> dict[str, float | int | str]:
        return {"group": self.group, "n_maps": self.n_maps, "n_runs": self.n_runs, "peak_m": self.peak_m,
                "mean_m": self.mean_m, "final_m": self.final_m}


def mean_curve(per_map: Sequence[tuple[np.ndarray, np.ndarray]], dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean of map curves on a common grid (each held at its last value past its end)."""
    end = max(float(t[-1]) for t, _ in per_map)
    t = grid(end, dt)
    return t, np.mean([np.interp(t, tm, dm) for tm, dm in per_map], axis=0)


def config_curves(maps: dict[int, list[tuple[bool, np.ndarray]]], dt: float = 1.0) -> dict[str, Curve]:
    """Curves per group for one configuration: ``maps[m]`` is a list of (success, trajectory).

    A group is present only if at least one map has two or more runs of it."""
    out: dict[str, Curve] = {}
    for group in GROUPS:
        per_map = []
        n_runs = 0
        for runs in maps.values():
            sel = [tr for ok, tr in runs if group == "all" or ok == (group == "success")]
            sel = [tr for tr in sel if len(tr)]
            if len(sel) >= 2:
                per_map.append(max_spread(sel, dt))
                n_runs += len(sel)
        if per_map:
            t, d = mean_curve(per_map, dt)
            out[group] = Curve(group, t, d, len(per_map), n_runs)
    return out

