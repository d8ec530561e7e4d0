"""Search algorithms behind one ask/tell protocol, over the normalised box [0, 1]^d of a
:class:`~navstress.search.space.Space`.

    algo = make_algorithm(spec, space)
    while budget left:
        X = algo.ask()                       # (n, d) points, one generation
        ...evaluate space.decode(x) for each row...
        algo.tell(X, fitness, descriptors)   # fitness (n,) maximised; descriptors (n, 2) or None
    algo.elites()                            # the best points, best first

Fitness is always **maximised** (pymoo minimises: its algorithms are told ``-fitness``). A
generation is a barrier: ``tell`` takes back exactly the points of the last ``ask``.

The algorithms come from libraries (docs/search.md, "Algorithms"):

* ``random``: uniform points from a :class:`numpy.random.Generator` (the baseline);
* ``map-elites``: pyribs' :class:`~ribs.archives.GridArchive` over two descriptors, with
  :class:`~ribs.emitters.GaussianEmitter` s (the first generation uniform), asked and told through a
  :class:`~ribs.schedulers.Scheduler`;
* ``cma-me``: the same archive with :class:`~ribs.emitters.EvolutionStrategyEmitter` s (CMA-ES,
  improvement ranking: CMA-ME);
* ``ga`` and ``nsga2``: pymoo's GA and NSGA-II in its ask-and-tell mode, on a problem with the
  space's bounds (SBX crossover, polynomial mutation, duplicates eliminated).

Determinism: every random draw comes from generators seeded from ``derive_seed(spec.seed,
"search-algorithm", name)`` (ribs' archive and emitters, pymoo's ``seed``, numpy's Generator; no
global random state), so the same seed and the same tells give the same asks, in any process:
a search resumes by replaying its stored generations' tells.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from pymoo.algorithms.moo.nsga2 import NSGA2, binary_tournament
from pymoo.algorithms.soo.nonconvex.ga import GA, FitnessSurvival, comp_by_cv_and_fitness
from pymoo.core.evaluator import Evaluator
from pymoo.core.problem import Problem
from pymoo.core.termination import NoTermination
from pymoo.operators.crossover.sbx import SBX
from pymoo.operators.mutation.pm import PM
from pymoo.operators.sampling.rnd import FloatRandomSampling
from pymoo.operators.selection.tournament import TournamentSelection
from pymoo.operators.survival.rank_and_crowding import RankAndCrowding
from pymoo.problems.static import StaticProblem
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting
from ribs.archives import GridArchive
from ribs.emitters import EmitterBase, EvolutionStrategyEmitter, GaussianEmitter
from ribs.schedulers import Scheduler

from navstress.seeding import derive_seed
from navstress.search.space import Space
from navstress.search.spec import DescriptorSpec, SearchSpec

#: The seed path of an algorithm's generators (under the search's seed).
ALGORITHM_SEED_PATH = "search-algorithm"


@dataclass(frozen=True)
class Elite:
    """A point the search keeps: its coordinates, fitness (the first objective; ``objectives`` all of
    them), descriptors (None when none were told) and archive cell (MAP-Elites and CMA-ME)."""

    x: tuple[float, ...]
    fitness: float
    objectives: tuple[float, ...]
    descriptors: tuple[float, ...] | None = None
    cell: tuple[int, ...] | None = None


class Algorithm(abc.ABC):
    """The ask/tell protocol (see module doc); subclasses implement :meth:`_ask` and :meth:`_tell`."""

    name = ""
    #: Whether ``tell`` needs descriptors (the archive algorithms).
    needs_descriptors = False

    def __init__(self, dimension: int, batch: int, seed: int, *, n_obj: int = 1, elites: int = 10) -> None:
        if dimension < 1 or batch < 1 or n_obj < 1:
            raise ValueError(f"dimension, batch and n_obj must be >= 1, got {dimension}, {batch}, {n_obj}")
        self.dimension = dimension
        self.batch = batch
        self.seed = seed
        self.n_obj = n_obj
        self.elite_count = elites
        self._pending: np.ndarray | None = None
        self._X = np.empty((0, dimension))
        self._F = np.empty((0, n_obj))
        self._D: np.ndarray | None = None
        self.generation = 0

    # -- the protocol --

    def ask(self) -> np.ndarray:
        """The next generation's points, an (n, dimension) array in [0, 1] (1 <= n <= batch, most
        often n = batch; pymoo may return fewer when it cannot make enough distinct offspring)."""
        if self._pending is not None:
            raise RuntimeError(f"{self.name}: ask() again before tell() of the last generation")
        X = np.array(self._ask(), dtype=np.float64, copy=True)
        if X.ndim != 2 or X.shape[1] != self.dimension or len(X) == 0:
            raise RuntimeError(f"{self.name}: asked an array of shape {X.shape}")
        self._pending = X
        return X.copy()

    def tell(self, X: ArrayLike, fitness: ArrayLike, descriptors: ArrayLike | None = None) -> None:
        """The evaluation of the last ``ask``'s points: ``fitness`` (n,) or (n, n_obj), maximised;
        ``descriptors`` (n, 2) (required by MAP-Elites and CMA-ME, kept in the history otherwise)."""
        if self._pending is None:
            raise RuntimeError(f"{self.name}: tell() without ask()")
        Xa = np.asarray(X, dtype=np.float64)
        if Xa.shape != self._pending.shape or not np.array_equal(Xa, self._pending):
            raise ValueError(f"{self.name}: tell() must be given the points of the last ask(), in order")
        n = len(Xa)
        F = np.asarray(fitness, dtype=np.float64)
        F = F.reshape(-1, 1) if F.ndim == 1 else F
        if F.shape != (n, self.n_obj):
            raise ValueError(f"{self.name}: fitness of shape ({n},) or ({n}, {self.n_obj}) expected, got {np.shape(fitness)}")
        if not np.all(np.isfinite(F)):
            raise ValueError(f"{self.name}: every fitness must be finite")
        D = None if descriptors is None else np.asarray(descriptors, dtype=np.float64)
        if D is not None and (D.ndim != 2 or len(D) != n or not np.all(np.isfinite(D))):
            raise ValueError(f"{self.name}: descriptors of shape ({n}, k), finite, expected, got {D.shape}")
        if D is None and self.needs_descriptors:
            raise ValueError(f"{self.name}: tell() needs the descriptors of every point")
        self._tell(Xa, F, D)
        self._pending = None
        self.generation += 1
        self._X = np.vstack([self._X, Xa])
        self._F = np.vstack([self._F, F])
        if D is not None:
            self._D = D.copy() if self._D is None else np.vstack([self._D, D])

    def elites(self, k: int | None = None) -> list[Elite]:
        """The ``k`` best distinct points told so far, best first (``k`` None: ``spec.elites``).

        Single objective: by fitness; several: by non-dominated front, then by the first objective
        (ties: the earlier point first)."""
        k = self.elite_count if k is None else k
        if len(self._X) == 0 or k <= 0:
            return []
        _, first = np.unique(self._X, axis=0, return_index=True)
        rows = np.sort(first)
        F = self._F[rows]
        rank = np.zeros(len(rows), dtype=np.int64)
        if self.n_obj > 1:
            for r, front in enumerate(NonDominatedSorting().do(-F)):
                rank[front] = r
        order = np.lexsort((rows, -F[:, 0], rank))[:k]
        return [self._elite(int(rows[i])) for i in order]

    def history(self) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Every point told so far, its fitness (n, n_obj) and its descriptors (or None), in order."""
        return self._X.copy(), self._F.copy(), None if self._D is None else self._D.copy()

    def _elite(self, i: int) -> Elite:
        d = None if self._D is None or i >= len(self._D) else tuple(float(v) for v in self._D[i])
        f = tuple(float(v) for v in self._F[i])
        return Elite(tuple(float(v) for v in self._X[i]), f[0], f, d)

    # -- the implementations --

    @abc.abstractmethod
    def _ask(self) -> np.ndarray: ...

    @abc.abstractmethod
    def _tell(self, X: np.ndarray, F: np.ndarray, D: np.ndarray | None) -> None: ...


class RandomSearch(Algorithm):
    """Uniform random points (the baseline); what it is told changes nothing."""

    name = "random"

    def __init__(self, dimension: int, batch: int, seed: int, **kw: Any) -> None:
        super().__init__(dimension, batch, seed, **kw)
        self._rng = np.random.default_rng(seed)

    def _ask(self) -> np.ndarray:
        return self._rng.random((self.batch, self.dimension))

    def _tell(self, X: np.ndarray, F: np.ndarray, D: np.ndarray | None) -> None:
        return None


def _split(batch: int, parts: int) -> list[int]:
    """``batch`` split into ``parts`` sizes differing by at most one (the larger first)."""
    return [batch // parts + (1 if i < batch % parts else 0) for i in range(parts)]


class _Ribs(Algorithm):
    """pyribs' GridArchive and Scheduler; subclasses make the emitters."""

    needs_descriptors = True

    def __init__(self, dimension: int, batch: int, seed: int, *, descriptors: list[DescriptorSpec],
                 emitters: int = 1, n_obj: int = 1, elites: int = 10) -> None:
        if n_obj != 1:
            raise ValueError(f"{self.name} optimises one fitness, not {n_obj}")
        super().__init__(dimension, batch, seed, n_obj=n_obj, elites=elites)
        if len(descriptors) != 2:
            raise ValueError(f"{self.name} needs two descriptors, got {len(descriptors)}")
        self.descriptors = list(descriptors)
        self.archive = GridArchive(solution_dim=dimension, dims=[d.cells for d in descriptors],
                                   ranges=[(d.low, d.high) for d in descriptors],
                                   seed=derive_seed(seed, "archive"), dtype=np.float64)
        rng = np.random.default_rng(derive_seed(seed, "start"))
        bounds = [(0.0, 1.0)] * dimension
        ems = [self._emitter(i, size, bounds, rng) for i, size in enumerate(_split(batch, emitters))]
        self.scheduler = Scheduler(self.archive, ems)

    @abc.abstractmethod
    def _emitter(self, i: int, size: int, bounds: list[tuple[float, float]],
                 rng: np.random.Generator) -> EmitterBase: ...

    def _ask(self) -> np.ndarray:
        return np.asarray(self.scheduler.ask())

    def _tell(self, X: np.ndarray, F: np.ndarray, D: np.ndarray | None) -> None:
        assert D is not None
        if D.shape[1] != 2:
            raise ValueError(f"{self.name}: two descriptors per point expected, got {D.shape[1]}")
        self.scheduler.tell(F[:, 0], D)

    def elites(self, k: int | None = None) -> list[Elite]:
        """The best ``k`` cells of the archive (``k`` None: ``spec.elites``), best first."""
        k = self.elite_count if k is None else k
        return self.cells()[:max(k, 0)]

    def cells(self) -> list[Elite]:
        """Every occupied cell of the archive (the illumination map), best first."""
        data = self.archive.data()
        if len(data["index"]) == 0:
            return []
        order = np.lexsort((data["index"], -data["objective"]))
        grid = self.archive.int_to_grid_index(data["index"])
        return [Elite(tuple(float(v) for v in data["solution"][i]), float(data["objective"][i]),
                      (float(data["objective"][i]),), tuple(float(v) for v in data["measures"][i]),
                      tuple(int(v) for v in grid[i])) for i in order]


class MapElites(_Ribs):
    """MAP-Elites: Gaussian mutation of elites drawn from the archive (first generation uniform)."""

    name = "map-elites"

    def __init__(self, dimension: int, batch: int, seed: int, *, sigma: float = 0.1, **kw: Any) -> None:
        self.sigma = sigma
        super().__init__(dimension, batch, seed, **kw)

    def _emitter(self, i: int, size: int, bounds: list[tuple[float, float]],
                 rng: np.random.Generator) -> EmitterBase:
        return GaussianEmitter(self.archive, sigma=self.sigma, initial_solutions=rng.random((size, self.dimension)),
                               bounds=bounds, batch_size=size, seed=derive_seed(self.seed, "emitter", i))


class CmaMe(_Ribs):
    """CMA-ME: CMA-ES emitters ranked by improvement of the archive, each started at a uniform point."""

    name = "cma-me"

    def __init__(self, dimension: int, batch: int, seed: int, *, sigma0: float = 0.2, **kw: Any) -> None:
        self.sigma0 = sigma0
        super().__init__(dimension, batch, seed, **kw)

    def _emitter(self, i: int, size: int, bounds: list[tuple[float, float]],
                 rng: np.random.Generator) -> EmitterBase:
        return EvolutionStrategyEmitter(self.archive, x0=rng.random(self.dimension), sigma0=self.sigma0,
                                        ranker="2imp", es="cma_es", bounds=bounds, batch_size=size,
                                        seed=derive_seed(self.seed, "emitter", i))


class _Pymoo(Algorithm):
    """pymoo's ask-and-tell mode on a problem with the space's bounds; fitness told negated."""

    def __init__(self, dimension: int, batch: int, seed: int, *, crossover_prob: float = 0.9,
                 crossover_eta: float = 15.0, mutation_eta: float = 20.0, n_obj: int = 1, elites: int = 10) -> None:
        super().__init__(dimension, batch, seed, n_obj=n_obj, elites=elites)
        self.problem = Problem(n_var=dimension, n_obj=n_obj, xl=np.zeros(dimension), xu=np.ones(dimension))
        self.algorithm = self._make(SBX(prob=crossover_prob, eta=crossover_eta), PM(eta=mutation_eta))
        self.algorithm.setup(self.problem, termination=NoTermination(), seed=seed % (1 << 32), verbose=False)
        self._pop: Any = None

    @abc.abstractmethod
    def _make(self, crossover: SBX, mutation: PM) -> Any: ...

    def _ask(self) -> np.ndarray:
        self._pop = self.algorithm.ask()
        return np.asarray(self._pop.get("X"))

    def _tell(self, X: np.ndarray, F: np.ndarray, D: np.ndarray | None) -> None:
        Evaluator().eval(StaticProblem(self.problem, F=-F), self._pop)
        self.algorithm.tell(infills=self._pop)
        self._pop = None


class GeneticAlgorithm(_Pymoo):
    """pymoo's GA: tournament selection, SBX, polynomial mutation, the best ``batch`` survive."""

    name = "ga"

    def __init__(self, dimension: int, batch: int, seed: int, **kw: Any) -> None:
        if kw.get("n_obj", 1) != 1:
            raise ValueError(f"ga optimises one fitness, not {kw['n_obj']}")
        super().__init__(dimension, batch, seed, **kw)

    def _make(self, crossover: SBX, mutation: PM) -> Any:
        return GA(pop_size=self.batch, n_offsprings=self.batch, sampling=FloatRandomSampling(),
                  selection=TournamentSelection(func_comp=comp_by_cv_and_fitness), crossover=crossover,
                  mutation=mutation, survival=FitnessSurvival(), eliminate_duplicates=True)


class Nsga2(_Pymoo):
    """pymoo's NSGA-II: non-dominated sorting and crowding distance over the fitness columns."""

    name = "nsga2"

    def _make(self, crossover: SBX, mutation: PM) -> Any:
        return NSGA2(pop_size=self.batch, n_offsprings=self.batch, sampling=FloatRandomSampling(),
                     selection=TournamentSelection(func_comp=binary_tournament), crossover=crossover,
                     mutation=mutation, survival=RankAndCrowding(), eliminate_duplicates=True)


def make_algorithm(spec: SearchSpec, space: Space, *, n_obj: int = 1) -> Algorithm:
    """The spec's algorithm over ``space`` (``n_obj``: the fitness columns; NSGA-II only may take
    more than one), seeded from ``derive_seed(spec.seed, "search-algorithm", name)``."""
    a = spec.algorithm
    seed = derive_seed(spec.seed, ALGORITHM_SEED_PATH, a.name)
    d, b, common = space.dimension, a.batch, {"n_obj": n_obj, "elites": spec.elites}
    if a.name == "random":
        return RandomSearch(d, b, seed, **common)
    if a.name == "map-elites":
        return MapElites(d, b, seed, sigma=a.sigma, emitters=a.emitter_count(),
                         descriptors=spec.archive_descriptors(), **common)
    if a.name == "cma-me":
        return CmaMe(d, b, seed, sigma0=a.sigma0, emitters=a.emitter_count(),
                     descriptors=spec.archive_descriptors(), **common)
    cls = GeneticAlgorithm if a.name == "ga" else Nsga2
    return cls(d, b, seed, crossover_prob=a.crossover_prob, crossover_eta=a.crossover_eta,
               mutation_eta=a.mutation_eta, n_obj=n_obj, elites=spec.elites)
