"""``generate(spec, seed) -> World``: the one entry point of world generation.

A pure, deterministic function: the same spec and seed give an equal World and byte-identical
saved files. Draws come from independent sub-streams of the seed (``navstress.seeding.rng``):
``"terrain"`` (ground heights), ``"mission"`` (random start/goal) and ``"obstacles", <type>``
(one per obstacle type), so that changing the obstruction does not change the raw terrain or
the mission, and ``"movers", <type>`` (one per mover type, drawn last: adding movers changes
nothing else). Order: raw terrain, mission, levelling of the start and goal free discs
(:mod:`navstress.world.freearea`: drivable start and goal areas; a world whose start or goal
cannot be made drivable raises GenerationError; a world that levels them has a ``free_areas``
descriptor), obstacles (which keep out of the mission's free discs), the spec's obstacle moves
(:func:`~navstress.world.placement.apply_moves`; a world with moves has a ``moves_applied``
descriptor), levelling of the ground under each obstacle (which keeps the free areas flat; when one
obstacle base touches both free areas, they are levelled again at one height first), movers
(:mod:`navstress.world.movers`), descriptors (with the movers' only when the spec has a ``movers`` field).

    >>> from navstress.world.spec import WorldSpec
    >>> w = generate(WorldSpec(size_m=(20.0, 20.0), obstacles={"obstruction": {"tree": 5}}), seed=3)
    >>> abs(w.descriptors["obstruction_pct"]["tree"] - 5.0) <= 0.5
    True
"""

from __future__ import annotations

import numpy as np

from navstress._models import parse
from navstress.errors import SpecError
from navstress.robot import PROFILES, RobotSpec
from navstress.seeding import rng
from navstress.world.descriptors import describe
from navstress.world.freearea import level_free_areas
from navstress.world.mission import make_mission
from navstress.world.movers import mover_descriptors, place_movers
from navstress.world.placement import apply_moves, level_terrain, place_obstacles
from navstress.world.spec import WorldSpec
from navstress.world.terrain import make_heights
from navstress.world.world import Terrain, World


#: The free discs' radius of a spec that sets none (``MissionSpec.free_radius_m``'s default), made
#: for the paper's RMP 400: its initial scanning manoeuvre (turn on the spot, about 3 m forward),
#: its half diagonal (0.661 m) and a margin of about 1 m.
DEFAULT_FREE_RADIUS_M = 5.0


def free_radius_for(robot: RobotSpec) -> float:
    """The free discs' radius for ``robot`` when the spec sets none: the default's with the RMP
    400's half diagonal replaced by ``robot``'s (exactly 5 m for the RMP 400).

        >>> free_radius_for(RobotSpec()), round(free_radius_for(PROFILES["jackal"]), 3)
        (5.0, 4.672)
    """
    return DEFAULT_FREE_RADIUS_M + (robot.half_diagonal_m - PROFILES["rmp400"].half_diagonal_m)


def check_robot_fits(free_radius_m: float, robot: RobotSpec, field: str = "robot") -> None:
    """SpecError naming ``field`` when ``robot`` cannot stand in the world's start and goal free
    discs of radius ``free_radius_m`` (its half diagonal is larger); a world without free discs
    (radius 0) asks nothing."""
    r, hd = float(free_radius_m), robot.half_diagonal_m
    if r > 0 and hd > r:
        raise SpecError(field, robot.name, f"a robot that fits the world's start and goal free discs (radius "
                        f"mission.free_radius_m={r:g} m; the robot's half diagonal is {hd:.3g} m)",
                        "choose a smaller robot, or generate the world for this one (navstress world generate "
                        "--robot) with a larger mission.free_radius_m")


def sized_to_robot(spec: WorldSpec, robot: RobotSpec, field: str = "robot") -> WorldSpec:
    """``spec`` with its free discs sized to ``robot`` (:func:`free_radius_for`) when it sets no
    ``mission.free_radius_m`` of its own (a radius the spec sets is kept); SpecError naming
    ``field`` when the robot does not fit the free discs (:func:`check_robot_fits`) or its
    discs do not fit the spec's mission (a start or goal too near an edge for them)."""
    r = spec.mission.free_radius_m
    if "free_radius_m" not in spec.mission.model_fields_set:
        r = free_radius_for(robot)
    check_robot_fits(r, robot, field)
    if r == spec.mission.free_radius_m:
        return spec  # (the RMP 400's: the same spec, the same files)
    data = spec.model_dump(mode="json")
    data["mission"]["free_radius_m"] = r
    try:
        return parse(WorldSpec, data)
    except SpecError as err:
        raise SpecError(field, robot.name, f"a robot whose start and goal free discs (radius {r:.3g} m, sized to "
                        f"it) fit the world's mission ({err})", "set mission.free_radius_m or mission.inset_m "
                        "in the world spec") from None


def generate(spec: WorldSpec, seed: int, *, robot: RobotSpec | None = None) -> World:
    """Generate the world of ``spec`` for ``seed`` (an int >= 0).

    ``robot`` (default: the nominal :class:`RobotSpec`, the RMP 400) sizes the world: its start
    and goal free discs when the spec sets no ``mission.free_radius_m`` (:func:`sized_to_robot`;
    a robot that does not fit them is a SpecError), and the descriptors' traversability and
    shortest path (the robot's half width). Raises :class:`~navstress.errors.GenerationError`
    when the spec cannot be realised (e.g. an obstruction target with no room left)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise SpecError("seed", seed, "an integer >= 0")
    seed = int(seed)
    if robot is not None:
        spec = sized_to_robot(spec, robot)
    raw = make_heights(spec.ground, spec.grid_shape, spec.cell_m, rng(seed, "terrain"))
    mission = make_mission(spec, rng(seed, "mission"))
    free = level_free_areas(raw, spec.cell_m, mission, spec.size_m)
    placement = place_obstacles(spec, mission, seed)
    placed, moved = apply_moves(placement.obstacles, spec, mission)
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
