"""The ``outdoor`` generator: the paper's worlds of rough ground, box trees and buildings, movers.

A pure, deterministic function: the same spec and seed give an equal World and byte-identical
saved files. Draws come from independent sub-streams of the seed (``navstress.seeding.rng``):
``"terrain"`` (ground heights), ``"mission"`` (random start/goal) and ``"obstacles", <type>``
(one per obstacle type), so that changing the obstruction does not change the raw terrain or
the mission, and ``"movers", <type>`` (one per mover type, drawn last: adding movers changes
nothing else). Order: raw terrain, mission, levelling of the start and goal free discs
(:mod:`navstress.world.freearea`: drivable start and goal areas; a world whose start or goal
cannot be made drivable raises GenerationError; a world that levels them has a ``free_areas``
descriptor), the spec's walls (``obstacles.walls``: one box of kind ``wall`` per segment,
:mod:`navstress.world.shapes`; they stand before the mission is drawn: a random mission's free
discs keep clear of them), obstacles (which keep out of the mission's free discs and of the
walls), the spec's obstacle moves
(:func:`~navstress.world.placement.apply_moves`; a world with moves has a ``moves_applied``
descriptor), levelling of the ground under each obstacle (which keeps the free areas flat; when one
obstacle base touches both free areas, they are levelled again at one height first), movers
(:mod:`navstress.world.movers`), descriptors (with the movers' only when the spec has a ``movers`` field).

    >>> from navstress.world.spec import WorldSpec
    >>> w = generate_outdoor(WorldSpec(size_m=(20.0, 20.0), obstacles={"obstruction": {"tree": 5}}), seed=3)
    >>> abs(w.descriptors["obstruction_pct"]["tree"] - 5.0) <= 0.5
    True
"""

from __future__ import annotations

import numpy as np

from navstress.errors import GenerationError
from navstress.robot import RobotSpec
from navstress.seeding import rng
from navstress.world.descriptors import describe
from navstress.world.freearea import level_free_areas
from navstress.world.generators.sizing import sized_to_robot
from navstress.world.mission import make_mission
from navstress.world.movers import mover_descriptors, place_movers
from navstress.world.placement import apply_moves, level_terrain, place_obstacles
from navstress.world.shapes import first_in_disc, wall_obstacles
from navstress.world.spec import WorldSpec
from navstress.world.terrain import make_heights
from navstress.world.world import Mission, Obstacle, Terrain, World


def _check_walls_clear(walls: list[Obstacle], mission: Mission) -> None:
    """GenerationError when a wall enters the start or goal free disc (the spec refuses it for a
    mission it fixes; a random one is drawn clear of the walls)."""
    (sx, sy, _), (gx, gy), r = mission.start, mission.goal, mission.free_radius_m
    for name, (cx, cy) in (("start", (sx, sy)), ("goal", (gx, gy))):
        k = first_in_disc(walls, cx, cy, r)
        if k >= 0:
            raise GenerationError(f"wall segment {k} (centre ({walls[k].x:.3g}, {walls[k].y:.3g})) crosses the {name} "
                                  f"free disc of radius {r:g} m around ({cx:g}, {cy:g}); move the wall or the {name}, "
                                  "or lower mission.free_radius_m")


def generate_outdoor(spec: WorldSpec, seed: int, *, robot: RobotSpec | None = None) -> World:
    """Generate the world of ``spec`` for ``seed`` (an int >= 0).

    ``robot`` (default: the nominal :class:`RobotSpec`, the RMP 400) sizes the world: its start
    and goal free discs when the spec sets no ``mission.free_radius_m`` (:func:`sized_to_robot`;
    a robot that does not fit them is a SpecError), and the descriptors' traversability and
    shortest path (the robot's half width). Raises :class:`~navstress.errors.GenerationError`
    when the spec cannot be realised (e.g. an obstruction target with no room left)."""
    if robot is not None:
        spec = sized_to_robot(spec, robot)
    raw = make_heights(spec.ground, spec.grid_shape, spec.cell_m, rng(seed, "terrain"))
    walls = wall_obstacles(spec.obstacles.walls)
    mission = make_mission(spec, rng(seed, "mission"), avoid=walls)
    _check_walls_clear(walls, mission)
    free = level_free_areas(raw, spec.cell_m, mission, spec.size_m)
    placement = place_obstacles(spec, mission, seed, fixed=walls)
    placed, moved = apply_moves(placement.obstacles, spec, mission, fixed=walls)
    if walls:  # the walls first, then the placed obstacles
        placed = walls + placed
    lev = level_terrain(free.heights, spec.cell_m, placed, pins=free.pins(spec.grid_shape, spec.cell_m) if placed else None)
    if lev.joined >= 0:  # one obstacle base touches both free areas: they are levelled at one height
        free = level_free_areas(raw, spec.cell_m, mission, spec.size_m, together=True)
        lev = level_terrain(free.heights, spec.cell_m, placed, pins=free.pins(spec.grid_shape, spec.cell_m))
    obstacles = lev.obstacles
    terrain = Terrain(lev.heights, spec.cell_m)
    desc = describe(spec, terrain, tuple(obstacles), mission, robot=robot, placement=placement)
    desc["levelled_clusters"] = lev.n_clusters
    desc["levelled_largest_cluster"] = lev.largest_cluster
    free_desc = free.descriptor()
    if free_desc is not None:  # (a flat world has none: its files keep their bytes)
        desc["free_areas"] = free_desc
    if spec.obstacles.moves:
        desc["moves_applied"] = sum(k >= 0 for k in moved)
    movers = place_movers(spec, mission, tuple(obstacles), seed)
    if not spec.movers.empty:
        desc.update(mover_descriptors(spec, movers))
    return World(spec=spec, seed=seed, terrain=terrain, obstacles=tuple(obstacles), mission=mission,
                 descriptors=desc, movers=movers)
