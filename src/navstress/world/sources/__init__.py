"""Imported worlds (docs/worlds.md, "Imported worlds"): one module per kind of source, each with

- ``KIND``: its name in ``SourceSpec.kind`` (``map``, ``sdf``, ``dir``);
- ``claims(path) -> bool``: whether ``path`` is a source of this kind (for ``kind: auto``);
- ``load(path, options) -> World``: the source's geometry as a navstress world, shifted so that
  its lower-left corner is (0, 0) (``World.source.origin`` says where that is in the source's
  frame), on flat ground unless the source has terrain, with the source's own mission when it has
  one. Bad input: :class:`~navstress.errors.SpecError` naming the file and the fix.

:func:`load_source` reads a source once per process (keyed by its path, size, mtime and the
options), :func:`realise` makes the world of a spec with a ``source`` for a seed: the source's
geometry with the spec's mission (given in the source's frame, or drawn per seed in the free
space with the robot's clearance), added obstacles and moves."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

from navstress.errors import SpecError
from navstress.robot import RobotSpec
from navstress.world.sources import directory, occupancy, sdf
from navstress.world.sources.digest import file_sha256
from navstress.world.spec import SourceSpec, WorldSpec
from navstress.world.world import Mission, World

#: The source modules, in the order ``kind: auto`` asks them.
MODULES: tuple[ModuleType, ...] = (directory, occupancy, sdf)
KINDS = tuple(m.KIND for m in MODULES)

__all__ = ["KINDS", "MODULES", "file_sha256", "load_source", "module_for", "realise"]


def module_for(options: SourceSpec) -> ModuleType:
    """The source module of ``options`` (its ``kind``, or for ``auto`` the first that claims the path)."""
    path = Path(options.path)
    if options.kind != "auto":
        return next(m for m in MODULES if m.KIND == options.kind)
    if not path.exists():
        raise SpecError("source.path", options.path, "an existing map YAML, SDF world or world directory",
                        "fix the path (a relative path is relative to the spec file)")
    for m in MODULES:
        if m.claims(path):
            return m
    raise SpecError("source.path", options.path, "a map_server YAML (.yaml), a Gazebo world (.world, .sdf) "
                    "or a navstress world directory", "name one of these, or set source.kind")


_CACHE: dict[tuple[object, ...], World] = {}


def load_source(options: SourceSpec) -> World:
    """The world of the source ``options`` names (cached per process: a campaign's worker imports
    each source once). A ``sha256`` in ``options`` that the source no longer has is a SpecError."""
    mod = module_for(options)
    path = Path(options.path)
    try:
        st = path.stat()
        key: tuple[object, ...] = (str(path.resolve()), st.st_size, st.st_mtime_ns,
                                   options.model_dump_json(exclude={"sha256"}))
    except OSError:
        key = ()
    world = _CACHE.get(key) if key else None
    if world is None:
        world = mod.load(path, options)
        if key:
            _CACHE[key] = world
    if options.sha256 is not None and world.source is not None and world.source.sha256 != options.sha256:
        raise SpecError("source.sha256", options.sha256, f"the digest of {options.path} when the campaign was "
                        f"planned (it is now {world.source.sha256})",
                        "restore the file, or start a new campaign (a changed source is never mixed with the old one)")
    return world


def realise(spec: WorldSpec, seed: int, *, robot: RobotSpec | None = None) -> World:
    """The world of ``spec`` (with a ``source``) for ``seed``. FOUNDATION: the source's world with
    the spec's given mission (in the source's frame); the anyworld helper adds drawn missions,
    added obstacles and moves, descriptors."""
    assert spec.source is not None
    base = load_source(spec.source)
    m = spec.mission
    mission = base.mission
    if m.start is not None and m.goal is not None and base.source is not None:
        sx, sy = base.source.from_source(m.start[0], m.start[1])
        gx, gy = base.source.from_source(m.goal[0], m.goal[1])
        mission = Mission(start=(sx, sy, m.start[2]), goal=(gx, gy), free_radius_m=0.0)
    return World(spec=base.spec, seed=seed, terrain=base.terrain, obstacles=base.obstacles, mission=mission,
                 descriptors=dict(base.descriptors), movers=base.movers, source=base.source)
