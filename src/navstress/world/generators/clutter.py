"""The ``clutter`` generator (docs/worlds.md, "Generators"). FOUNDATION PLACEHOLDER: the generators helper writes it."""

from __future__ import annotations

from navstress.errors import GenerationError
from navstress.robot import RobotSpec
from navstress.world.spec import WorldSpec
from navstress.world.world import World


def generate_clutter(spec: WorldSpec, seed: int, *, robot: RobotSpec | None = None) -> World:
    raise GenerationError("the clutter generator is not built yet")
