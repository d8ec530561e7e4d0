"""A navstress world directory as a source (``kind: dir``): its terrain, obstacles and mission
as saved (``navstress world generate``, ``navstress world import``)."""

from __future__ import annotations

from pathlib import Path

from navstress.errors import SpecError, WorldFileError
from navstress.world.sources.digest import file_sha256
from navstress.world.spec import SourceSpec
from navstress.world.world import TERRAIN_NPZ, WORLD_JSON, World, WorldSource, is_world_dir

KIND = "dir"


def claims(path: Path) -> bool:
    return is_world_dir(path)


def load(path: Path, options: SourceSpec) -> World:
    """The world saved in ``path``, its source the directory (digest of its two files)."""
    try:
        world = World.load(path)
    except WorldFileError as err:
        raise SpecError("source.path", str(path), "a navstress world directory", str(err)) from None
    src = world.source or WorldSource(kind=KIND, path=str(path.resolve()), sha256="", origin=(0.0, 0.0))
    digest = file_sha256(path / WORLD_JSON, path / TERRAIN_NPZ)
    return World(spec=world.spec, seed=world.seed, terrain=world.terrain, obstacles=world.obstacles,
                 mission=world.mission, descriptors=world.descriptors, movers=world.movers,
                 source=WorldSource(kind=KIND, path=str(path.resolve()), sha256=digest, origin=src.origin))
