"""``generate(spec, seed) -> World``: the one entry point of world generation.

A pure, deterministic function of the spec and the seed (and, for a spec with a ``source``, of
the source file, whose digest the world records). It dispatches on where the world comes from:

- ``spec.source`` set: an imported world (an occupancy-grid map, a Gazebo world, a world
  directory), :func:`navstress.world.sources.realise`: the source's geometry, with the spec's
  missions (given, or drawn per seed), added obstacles and moves;
- otherwise the generator ``spec.generator`` (:mod:`navstress.world.generators`): ``outdoor``
  (the paper's worlds, the default), ``rooms`` (floor plans), ``clutter`` (BARN's kind).

    >>> from navstress.world.spec import WorldSpec
    >>> w = generate(WorldSpec(size_m=(20.0, 20.0), obstacles={"obstruction": {"tree": 5}}), seed=3)
    >>> abs(w.descriptors["obstruction_pct"]["tree"] - 5.0) <= 0.5
    True
"""

from __future__ import annotations

import numpy as np

from navstress.errors import SpecError
from navstress.robot import RobotSpec
from navstress.world.generators import generator
from navstress.world.generators.sizing import DEFAULT_FREE_RADIUS_M, check_robot_fits, free_radius_for, sized_to_robot
from navstress.world.sources import realise
from navstress.world.spec import WorldSpec
from navstress.world.world import World

__all__ = ["DEFAULT_FREE_RADIUS_M", "check_robot_fits", "free_radius_for", "generate", "sized_to_robot"]


def generate(spec: WorldSpec, seed: int, *, robot: RobotSpec | None = None) -> World:
    """The world of ``spec`` for ``seed`` (an int >= 0).

    ``robot`` (default: the nominal :class:`RobotSpec`, the RMP 400) sizes the world: its start
    and goal free discs when the spec sets no ``mission.free_radius_m`` (a robot that does not fit
    them is a SpecError), the clearance of drawn missions, and the descriptors' traversability and
    shortest path. Raises :class:`~navstress.errors.GenerationError` when the spec cannot be
    realised (e.g. an obstruction target with no room left), :class:`~navstress.errors.SpecError`
    for a bad spec or source."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise SpecError("seed", seed, "an integer >= 0")
    seed = int(seed)
    if spec.source is not None:
        return realise(spec, seed, robot=robot)
    return generator(spec.generator)(spec, seed, robot=robot)
