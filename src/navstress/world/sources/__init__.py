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

from dataclasses import replace
from pathlib import Path
from types import ModuleType

import numpy as np

from navstress.errors import SpecError
from navstress.robot import RobotSpec
from navstress.seeding import rng
from navstress.world.descriptors import describe
from navstress.world.movers import mover_descriptors, place_movers
from navstress.world.placement import apply_moves, level_terrain, place_obstacles
from navstress.world.sources import directory, missions, occupancy, sdf
from navstress.world.sources.digest import file_sha256
from navstress.world.spec import SourceSpec, WorldSpec
from navstress.world.world import Mission, Terrain, World

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
    """The world of ``spec`` (with a ``source``) for ``seed`` (docs/worlds.md, "Any world in
    campaigns, searches, compare and gate"), in this order:

    1. the source's world (:func:`load_source`: its geometry shifted to (0, 0), its terrain);
    2. the mission: a given ``mission.start`` / ``mission.goal`` (the SOURCE's frame, converted
       with ``World.source.from_source``; one outside the map or inside an obstacle is a
       SpecError); the others drawn per seed (``rng(seed, "mission")``) with ``mission.mode:
       random``, else the source's own mission, or drawn when the source has none (a placeholder)
       (:mod:`navstress.world.sources.missions`: the robot's clearance, one connected free area);
       its free discs' radius: ``mission.free_radius_m`` when the spec sets it, else the clearance;
    3. ``obstacles.moves`` (``at`` in the source's frame) applied to the imported obstacles
       (:func:`~navstress.world.placement.apply_moves`: inside the map, no overlap, out of the
       free discs);
    4. added obstacles (``obstacles.obstruction`` / ``total`` + ``mix``, percent of the map's area)
       placed per seed as a generated world's (:func:`~navstress.world.placement.place_obstacles`),
       keeping out of the imported geometry and the free discs, standing on the ground;
    5. movers (``movers``), as a generated world's;
    6. navstress's descriptors (:func:`~navstress.world.descriptors.describe`) of the result.

    The result's ``spec`` is ``spec`` with the import's ``size_m`` and ``cell_m``; its ``source``
    the source's (kind, absolute path, sha256, origin). Deterministic in (spec, seed, robot, the
    source's bytes). ``robot`` (default the RMP 400) sets the clearance and the descriptors'."""
    assert spec.source is not None
    robot = robot or RobotSpec()
    base = load_source(spec.source)
    src = base.source
    if src is None:  # (every source module sets it)
        raise SpecError("source.path", spec.source.path, "a source whose import says where it came from")
    size = base.spec.size_m
    out_spec = spec.model_copy(update={"size_m": base.spec.size_m, "cell_m": base.spec.cell_m})
    imported = tuple(base.obstacles)
    m = spec.mission
    clearance = robot.half_diagonal_m + missions.CLEARANCE_MARGIN_M
    free_r = m.free_radius_m if "free_radius_m" in m.model_fields_set else clearance
    start: tuple[float, float, float] | None = None
    goal: tuple[float, float] | None = None
    if m.start is not None:
        sx, sy = src.from_source(m.start[0], m.start[1])
        missions.check_point("start", m.start, (sx, sy), size, imported, src)
        start = (sx, sy, float(m.start[2]))
    if m.goal is not None:
        gxy = src.from_source(m.goal[0], m.goal[1])
        missions.check_point("goal", m.goal, gxy, size, imported, src)
        goal = gxy
    own = base.mission
    if m.mode != "random" and missions.usable(own, size, imported):
        start = start if start is not None else own.start
        goal = goal if goal is not None else own.goal
    if start is not None and goal is not None:
        mission = Mission(start=start, goal=goal, free_radius_m=free_r)
    else:
        mission = missions.draw_mission(size, imported, rng(seed, "mission"), clearance=clearance,
                                        half_width=robot.width_m / 2, min_distance_m=m.min_distance_m,
                                        free_radius_m=free_r, start=start, goal=goal,
                                        outline=base.descriptors.get("map_outline_m"), where=src.path)
    obstacles = list(imported)
    desc_extra: dict[str, object] = {}
    if spec.obstacles.moves:
        moves = tuple(mv.model_copy(update={"at": src.from_source(*mv.at)}) for mv in spec.obstacles.moves)
        mspec = out_spec.model_copy(update={"obstacles": out_spec.obstacles.model_copy(update={"moves": moves})})
        obstacles, moved = apply_moves(obstacles, mspec, mission)
        desc_extra["moves_applied"] = sum(k >= 0 for k in moved)
    terrain = base.terrain
    placement = None
    if spec.obstacles.targets():
        placement = place_obstacles(out_spec, mission, seed, blocked=tuple(obstacles))
        added = placement.obstacles
        h = np.asarray(terrain.heights)
        if added and float(h.max()) != float(h.min()):  # on terrain: levelled as a generated world's
            lev = level_terrain(h, terrain.cell_m, added)
            added, terrain = list(lev.obstacles), Terrain(lev.heights, terrain.cell_m)
        elif added and float(h.flat[0]) != 0.0:
            added = [replace(o, z=float(h.flat[0])) for o in added]
        obstacles = [*obstacles, *added]
    movers = place_movers(out_spec, mission, tuple(obstacles), seed) if not spec.movers.empty else ()
    # what the import said of its source (a map's cells and outline, its notes), then the world's own
    # descriptors; a world directory's saved descriptors are made anew instead
    desc = {} if src.kind == "dir" else dict(base.descriptors)
    desc.update(describe(out_spec, terrain, tuple(obstacles), mission, robot=robot, placement=placement))
    desc.update(desc_extra)
    if not spec.movers.empty:
        desc.update(mover_descriptors(out_spec, movers))
    return World(spec=out_spec, seed=seed, terrain=terrain, obstacles=tuple(obstacles), mission=mission,
                 descriptors=desc, movers=movers, source=src)
