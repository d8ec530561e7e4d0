"""Which cheap a-priori world descriptor predicts the observed difficulty best.

Each world stores its descriptors in ``world.json`` (:mod:`navstress.world.descriptors`);
nested mappings are flattened to dotted names (``obstruction_pct.tree``) and booleans become
0/1. A configuration's descriptor is the mean over its maps (a map without the value is left
out). For every descriptor, the Spearman rank correlation (ties get average ranks) is
computed across configurations against

- the difficulty level's ordinal (easy 0, challenging 1, very difficult 2), and
- the success rate (its sign flipped, so that "higher = harder" reads positive in both).

Descriptors that are constant, or known for fewer than 3 configurations, get no
correlation. The ranking sorts by ``|rho|`` against the level (then against success).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import rankdata, spearmanr

from navstress.world.world import SKIP_PREFIXES, flatten, world_descriptors

__all__ = ["SKIP_PREFIXES", "flatten", "world_descriptors", "mean_descriptors", "spearman", "correlations",
           "Correlation"]


def mean_descriptors(maps: list[dict[str, float]]) -> dict[str, float]:
    """Per descriptor, the mean over the maps that have it."""
    keys = sorted({k for m in maps for k in m})
    return {k: float(np.mean([m[k] for m in maps if k in m])) for k in keys}


def spearman(x: list[float], y: list[float]) -> float | None:
    """Spearman's rho (``scipy.stats.spearmanr``: average ranks for ties); None for fewer than 3
    pairs or a constant side (where scipy's is undefined)."""
    if len(x) != len(y) or len(x) < 3:
        return None

    rx, ry = rankdata(x), rankdata(y)
    if np.ptp(rx) == 0 or np.ptp(ry) == 0:
        return None
    return float(spearmanr(x, y).statistic)


@dataclass(frozen=True)
class Correlation:
    descriptor: str
    n: int  # configurations with both values
    rho_level: float | None
    rho_failure: float | None  # against -success rate

    @property
    def strength(self) -> float:
        return max(abs(self.rho_level or 0.0), 0.0)

    def to_json(self) -> dict[str, object]:
        return {"descriptor": self.descriptor, "n": self.n, "rho_level": self.rho_level,
                "rho_failure": self.rho_failure}


def correlations(desc: dict[tuple[str, str], dict[str, float]], level_rank: dict[tuple[str, str], int],
                 success: dict[tuple[str, str], float]) -> list[Correlation]:
    """Correlations of every descriptor, strongest first (see module doc).

    ``desc``: per configuration, its mean descriptors; ``level_rank``: level ordinals of the
    configurations that have a level; ``success``: success rates of those with runs."""
    names = sorted({k for d in desc.values() for k in d})
    out: list[Correlation] = []
    for name in names:
        lx, ly, sx, sy = [], [], [], []
        for cfg, d in desc.items():
            if name not in d:
                continue
            if cfg in level_rank:
                lx.append(d[name])
                ly.append(float(level_rank[cfg]))
            if cfg in success:
                sx.append(d[name])
                sy.append(-success[cfg])
        out.append(Correlation(name, max(len(lx), len(sx)), spearman(lx, ly), spearman(sx, sy)))
    out.sort(key=lambda c: (c.rho_level is None, -abs(c.rho_level or 0.0),
                            c.rho_failure is None, -abs(c.rho_failure or 0.0), c.descriptor))
    return out
