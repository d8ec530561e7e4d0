"""World generators: one module each, a function ``(spec, seed, *, robot) -> World``
(docs/worlds.md, "Generators"). ``WorldSpec.generator`` names one; its parameters are the spec's
field of the same name (``rooms``, ``clutter``; ``outdoor`` uses the spec's ground and obstacles)."""

from __future__ import annotations

from typing import Protocol

from navstress.robot import RobotSpec
from navstress.world.generators.clutter import generate_clutter
from navstress.world.generators.outdoor import generate_outdoor
from navstress.world.generators.rooms import generate_rooms
from navstress.world.spec import GENERATORS, WorldSpec
from navstress.world.world import World


class Generator(Protocol):
    def __call__(self, spec: WorldSpec, seed: int, *, robot: RobotSpec | None = None) -> World: ...


_BY_NAME: dict[str, Generator] = {"outdoor": generate_outdoor, "rooms": generate_rooms, "clutter": generate_clutter}
assert tuple(_BY_NAME) == GENERATORS


def generator(name: str) -> Generator:
    """The generator called ``name`` (one of :data:`navstress.world.spec.GENERATORS`)."""
    return _BY_NAME[name]
