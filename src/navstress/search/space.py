"""The search space: the algorithms' normalised box [0, 1]^d and the candidates its points decode to.

Dimension i < n is the spec's parameter i (:meth:`~navstress.search.spec.ParameterSpec.value`:
floats scaled and rounded to 6 significant digits of the range, integers in equal-width bins,
``size_m`` snapped to the terrain grid). With ``space.map_seed: true`` one more, last, dimension
picks the map seed: index ``k = min(floor(u * map_seeds), map_seeds - 1)``, map seed
``derive_seed(seed, "search-map", k)``; with ``map_seed: false`` every candidate has the search's one
map seed ``derive_seed(seed, "search-map")``, so that a candidate's world depends on its parameters
alone (never on when it was asked).

A candidate's ``key`` is ``w`` and 12 hex digits of a hash of its values and map seed: the same
point gives the same key, two different worlds different keys (up to a 48-bit hash), and it is a
valid directory and configuration name. Two points may decode to the same candidate (integers,
rounding): the driver evaluates a key once per generation and tells its fitness for each point.

    >>> from navstress.search.spec import parse_search
    >>> spec = parse_search({"seed": 3, "space": {"map_seed": False, "parameters": [
    ...     {"path": "obstacles.obstruction.tree", "low": 0, "high": 10},
    ...     {"path": "ground.subdivisions", "low": 0, "high": 4, "kind": "int"}]},
    ...     "objective": {"name": "failure"}, "budget": {"runs": 80}})
    >>> space = Space.from_spec(spec)
    >>> c = space.decode([0.25, 0.99])
    >>> c.params, c.world_overrides
    ({'obstacles.obstruction.tree': 2.5, 'ground.subdivisions': 4}, {'obstacles': {'obstruction': {'tree': 2.5}}, 'ground': {'subdivisions': 4}})
"""

from __future__ import annotations

import hashlib
from navstress import _json
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from navstress.seeding import derive_seed
from navstress.campaign.spec import deep_merge
from navstress.search.spec import (SIZE_PATH, MovesSpec, ParameterSpec, SearchSpec, base_cell_m, scaled,
                                   world_overrides)
from navstress.world.spec import WorldSpec, parse_spec

#: The seed path of the map seeds of a search (under the search's seed).
MAP_SEED_PATH = "search-map"


@dataclass(frozen=True)
class Candidate:
    """One world to evaluate: its key, map seed, the WorldSpec overrides on the search's base world,
    the searched values (path -> value) and the map seed's index (None when the seed is not searched)."""

    key: str
    map_seed: int
    world_overrides: dict[str, Any]
    params: dict[str, float | int]
    seed_index: int | None = field(default=None)


@dataclass(frozen=True)
class Space:
    """The box [0, 1]^dimension and its decoding into candidates (see module doc)."""

    parameters: tuple[ParameterSpec, ...]
    seed: int
    base: dict[str, Any]
    map_seeds: int | None  # None: the map seed is not searched
    moves: MovesSpec | None = None
    #: an imported base world's extent in its source's frame, (x0, y0, x1, y1): where searched
    #: moves' points are drawn (None: a generated world's map, from (0, 0) to its size)
    extent: tuple[float, float, float, float] | None = None

    @classmethod
    def from_spec(cls, spec: SearchSpec) -> "Space":
        s = spec.space
        extent = None
        if s.moves is not None and isinstance(spec.world.get("source"), dict):
            from navstress.world.sources import load_source  # here: importing a source (numba, scipy) only where a world names one

            options = parse_spec(spec.world).source
            assert options is not None
            w = load_source(options)
            ox, oy = w.source.origin if w.source is not None else (0.0, 0.0)
            extent = (ox, oy, ox + w.spec.size_m[0], oy + w.spec.size_m[1])
        return cls(tuple(s.parameters), spec.seed, dict(spec.world), s.map_seeds if s.map_seed else None, s.moves,
                   extent)

    @property
    def n_moves(self) -> int:
        return self.moves.count if self.moves is not None else 0

    @property
    def dimension(self) -> int:
        """The number of coordinates of a point: one per parameter, four per searched obstacle move,
        plus one for a searched map seed."""
        return len(self.parameters) + MOVE_COORDS * self.n_moves + (self.map_seeds is not None)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The box the algorithms search: lower bounds 0 and upper bounds 1, per dimension."""
        return np.zeros(self.dimension), np.ones(self.dimension)

    @property
    def names(self) -> list[str]:
        """The name of each dimension: the parameter paths, the moves' coordinates (:func:`move_name`),
        then ``map_seed`` when searched."""
        return ([p.path for p in self.parameters] + [move_name(i, f) for i in range(self.n_moves) for f in MOVE_FIELDS]
                + (["map_seed"] if self.map_seeds is not None else []))

    def decode(self, x: ArrayLike) -> Candidate:
        """The candidate at point ``x`` (coordinates clipped to [0, 1]; a NaN counts as 0)."""
        u = np.asarray(x, dtype=np.float64).reshape(-1)
        if u.shape != (self.dimension,):
            raise ValueError(f"a point of {self.dimension} coordinates expected, got shape {np.shape(x)}")
        cell = base_cell_m(self.base)
        params = {p.path: p.value(float(ui), cell) for p, ui in zip(self.parameters, u)}
        overrides = world_overrides(params, self.base)
        if self.moves is not None:
            size = self._size(params)
            x0, y0, x1, y1 = self.extent if self.extent is not None else (0.0, 0.0, size[0], size[1])
            moves = []
            r = self.moves.radius_m
            for i in range(self.moves.count):
                ux, uy, udx, udy = (float(v) for v in u[len(self.parameters) + MOVE_COORDS * i:][:MOVE_COORDS])
                mv = {"at_x": scaled(ux, x0, x1), "at_y": scaled(uy, y0, y1),
                      "dx": scaled(udx, -r, r), "dy": scaled(udy, -r, r)}
                params.update({move_name(i, f): v for f, v in mv.items()})
                moves.append({"at": [mv["at_x"], mv["at_y"]], "by": [mv["dx"], mv["dy"]]})
            base_moves = list((self.base.get("obstacles") or {}).get("moves") or [])
            overrides.setdefault("obstacles", {})["moves"] = base_moves + moves
        if self.map_seeds is None:
            index, seed = None, derive_seed(self.seed, MAP_SEED_PATH)
        else:
            last = float(u[-1])
            last = min(max(last, 0.0), 1.0) if math.isfinite(last) else 0.0
            index = min(int(math.floor(last * self.map_seeds)), self.map_seeds - 1)
            seed = derive_seed(self.seed, MAP_SEED_PATH, index)
        return Candidate(key=candidate_key(params, seed), map_seed=seed,
                         world_overrides=overrides, params=params, seed_index=index)

    def _size(self, params: dict[str, float | int]) -> tuple[float, float]:
        """The candidate's map size: the searched ``size_m``, else the base world's."""
        if SIZE_PATH in params:
            v = float(params[SIZE_PATH])
            return v, v
        sx, sy = self.base.get("size_m", WorldSpec.model_fields["size_m"].default)
        return float(sx), float(sy)

    def world(self, candidate: Candidate) -> dict[str, Any]:
        """The candidate's whole WorldSpec mapping (its overrides on the base world)."""
        return deep_merge(self.base, candidate.world_overrides)


#: A searched obstacle move's coordinates: the point its obstacle is nearest, and its displacement.
MOVE_FIELDS = ("at_x", "at_y", "dx", "dy")
MOVE_COORDS = len(MOVE_FIELDS)


def move_name(i: int, field: str) -> str:
    """The name of a searched move's value in a candidate's ``params`` (``moves.0.dx``)."""
    return f"moves.{i}.{field}"


def candidate_key(params: dict[str, float | int], map_seed: int) -> str:
    """``w`` + 12 hex digits of a hash of the values and the map seed (a valid directory name)."""
    text = _json.dumps({"map_seed": map_seed, "params": params}, sort_keys=True, separators=(",", ":"))
    return "w" + hashlib.blake2b(text.encode("utf-8"), digest_size=6).hexdigest()
