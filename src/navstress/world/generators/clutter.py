"""The ``clutter`` generator: BARN's worlds (docs/worlds.md, "Generators: rooms and clutter";
parameters :class:`~navstress.world.spec.ClutterSpec`).

Source: Perille et al., "Benchmarking Metric Ground Navigation" (SSRR 2020) and its generator,
``gen_world_ca.py`` and ``world_writer.py`` in github.com/dperille/jackal-map-creation:

* **The obstacle field** (BARN's ``ObstacleMap``): ``cells_x`` x ``cells_y`` cells; the two side
  columns filled (BARN's first and last rows: its rows run across the travel), every other cell
  filled with probability ``fill_pct`` percent; then ``smooth_iterations`` rounds of BARN's rule,
  all cells at once from the previous round: a cell with 5 or more filled neighbours (of its 8)
  is filled, one with 1 or fewer is emptied, the others keep their state; a neighbour beyond a
  side column counts as filled, one beyond the field's entry or exit as empty.
* **Cylinders** (BARN's ``WorldWriter``): an upright cylinder of ``radius_m`` and ``height_m`` on
  each filled cell of the field that has an empty neighbour or lies on the field's border (BARN
  leaves out the cells of a blob's inside, which no ray or robot can reach).
* **Corridor and entrance**: behind the field, ``corridor_cells`` lattice rows (BARN: 34, 5.1 m)
  walled on both sides by cylinders on the side columns and closed by a back wall of cylinders on
  the lattice's first row; the field's far end is open.
* **Mission** (BARN's): start ``start_m`` above the lattice's lower edge on the field's centre
  line, facing +y; the goal ``goal_m`` ahead (BARN: (-2.25, 3) and (-2.25, 13) in its frame);
  ``mission.start``/``goal`` override them. Free discs only when the spec sets
  ``mission.free_radius_m`` (field cells within them are emptied); else none (radius 0): BARN's
  corridor is free.
* **Frame**: navstress's (lower-left (0, 0)): the lattice is centred across the map, its lower
  edge at (size_y - span) / 2, span = the lattice's or the goal's reach plus 1 m
  (:attr:`ClutterSpec.span_m`). A point of BARN's frame is this world's point minus
  (lattice's left edge + 4.5, lattice's lower edge), for BARN's 30-cell field.
* **Passable**: BARN keeps only worlds with a path through the field (it throws the others
  away). Here the field is drawn again, from the next draw of the field's stream (``rng(seed,
  "clutter", "field", k)``, k = 0, 1, ...), until the goal is reachable from the start with the
  robot's clearance (its half width; a flood fill of a raster of exact distances to the
  cylinders), up to :data:`MAX_DRAWS` draws; after them a straight lane as wide as the robot plus
  its clearance is cleared along the field's centre line. The world's ``clutter`` descriptor says
  how many draws it took and how many cells were cleared.

    >>> from navstress.world.spec import WorldSpec
    >>> w = generate_clutter(WorldSpec(size_m=(10.0, 16.0), cell_m=0.1, generator="clutter"), seed=0)
    >>> w.mission.start[:2], w.mission.goal
    ((5.0, 4.0), (5.0, 14.0))
"""

from __future__ import annotations

import math
import numpy as np

from navstress.errors import SpecError
from navstress.robot import RobotSpec
from navstress.seeding import rng
from navstress.world.barn_metrics import barn_descriptor, barn_difficulty_of
from navstress.world.descriptors import describe
from navstress.world.generators.raster import cell_of, components, free_raster, raster_cell_for
from navstress.world.generators.sizing import check_robot_fits
from navstress.world.movers import mover_descriptors, place_movers
from navstress.world.spec import ClutterSpec, WorldSpec
from navstress.world.world import Mission, Obstacle, Terrain, World

#: Field draws before a lane is cleared (BARN itself keeps drawing, with new seeds).
MAX_DRAWS = 20


def ca_field(cs: ClutterSpec, gen: np.random.Generator) -> np.ndarray:
    """BARN's cellular automaton: the field's occupancy, (cells_y, cells_x) bool, row 0 next to the corridor."""
    ny, nx = cs.cells_y, cs.cells_x
    grid = gen.random((ny, nx)) < cs.fill_pct / 100.0
    grid[:, 0] = grid[:, -1] = True
    for _ in range(cs.smooth_iterations):
        pad = np.zeros((ny + 2, nx + 2), np.int64)
        pad[1:-1, 1:-1] = grid
        pad[:, 0] = pad[:, -1] = 1  # beyond a side column: filled (BARN's rows out of the map)
        count = sum(pad[1 + di:ny + 1 + di, 1 + dj:nx + 1 + dj] for di in (-1, 0, 1) for dj in (-1, 0, 1)
                    if di or dj)
        grid = np.where(count >= 5, True, np.where(count <= 1, False, grid))
    out: np.ndarray = grid
    return out


def _outline(field: np.ndarray) -> np.ndarray:
    """The filled cells that get a cylinder: BARN's writer leaves out those whose 8 neighbours
    (inside the field) are all filled."""
    ny, nx = field.shape
    pad = np.zeros((ny + 2, nx + 2), bool)
    pad[1:-1, 1:-1] = field
    inner = np.ones_like(field)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if di or dj:
                inner &= pad[1 + di:ny + 1 + di, 1 + dj:nx + 1 + dj]
    out: np.ndarray = field & ~inner
    return out


def layout_origin(spec: WorldSpec) -> tuple[float, float]:
    """The lattice's lower-left corner in the map."""
    cs = spec.clutter
    sx, sy = spec.size_m
    return (round((sx - cs.width_m) / 2, 9), round((sy - cs.span_m) / 2, 9))


def _mission(spec: WorldSpec, origin: tuple[float, float], free_r: float) -> Mission:
    cs, m = spec.clutter, spec.mission
    x = origin[0] + cs.width_m / 2
    y = origin[1] + cs.start_m
    start = (float(m.start[0]), float(m.start[1]), float(m.start[2])) if m.start is not None \
        else (round(x, 9), round(y, 9), math.pi / 2)
    goal = (float(m.goal[0]), float(m.goal[1])) if m.goal is not None else (round(x, 9), round(y + cs.goal_m, 9))
    return Mission(start=start, goal=goal, free_radius_m=free_r)


def _cylinders(spec: WorldSpec, origin: tuple[float, float], field: np.ndarray) -> list[Obstacle]:
    cs = spec.clutter
    lat, d, h = cs.lattice_m, 2 * cs.radius_m, cs.height_m
    nx, nc = cs.cells_x, cs.corridor_cells
    out: list[Obstacle] = []

    def put(kind: str, i: int, k: int) -> None:
        out.append(Obstacle(kind, round(origin[0] + (i + 0.5) * lat, 9), round(origin[1] + (k + 0.5) * lat, 9), 0.0,
                            (d, d, h), shape="cylinder"))

    for k in range(nc):  # the corridor: back wall on row 0, side walls on the side columns
        for i in range(nx) if k == 0 else (0, nx - 1):
            put("wall", i, k)
    cells = _outline(field)
    for r, i in zip(*np.nonzero(cells)):
        put("wall" if i in (0, nx - 1) else "clutter", int(i), nc + int(r))
    return out


def _passable(spec: WorldSpec, obstacles: list[Obstacle], mission: Mission, clearance: float) -> bool:
    cell = raster_cell_for(spec.size_m, finest_m=min(0.05, spec.clutter.lattice_m / 3))
    free = free_raster(spec.size_m, cell, obstacles, clearance)
    labels = components(free)
    a = labels[cell_of(mission.start[0], mission.start[1], cell, labels.shape)]
    b = labels[cell_of(mission.goal[0], mission.goal[1], cell, labels.shape)]
    return bool(a > 0 and a == b)


def _clear_discs(spec: WorldSpec, origin: tuple[float, float], field: np.ndarray, mission: Mission) -> np.ndarray:
    """The field less the cells whose cylinder would reach into a free disc."""
    r = mission.free_radius_m
    if r <= 0:
        return field
    cs = spec.clutter
    ny, nx = field.shape
    xs = origin[0] + (np.arange(nx) + 0.5) * cs.lattice_m
    ys = origin[1] + (cs.corridor_cells + np.arange(ny) + 0.5) * cs.lattice_m
    out = field.copy()
    for cx, cy in ((mission.start[0], mission.start[1]), mission.goal):
        near = np.hypot(xs[None, :] - cx, ys[:, None] - cy) < r + cs.radius_m
        near[:, 0] = near[:, -1] = False  # the side walls stay
        out &= ~near
    return out


def generate_clutter(spec: WorldSpec, seed: int, *, robot: RobotSpec | None = None) -> World:
    """The ``clutter`` world of ``spec`` for ``seed`` (module doc). ``robot`` (default: the
    nominal RobotSpec) sets the clearance of the passability check; a field too narrow for it is a
    SpecError."""
    rb = robot or RobotSpec()
    cs = spec.clutter
    if spec.obstacles.targets() or spec.obstacles.moves:
        raise SpecError("obstacles", "set", "no obstacle targets or moves with generator clutter (it places its "
                        "cylinders itself)", "remove obstacles, or set clutter.fill_pct")
    clearance = rb.width_m / 2
    inner = (cs.cells_x - 1) * cs.lattice_m - 2 * cs.radius_m  # clear width between the side walls
    if inner < rb.width_m + 2 * cs.lattice_m:
        raise SpecError("clutter.cells_x", cs.cells_x, f"a field wider than the robot {rb.name!r} ({rb.width_m:.3g} m) "
                        f"by two lattice cells between its side walls ({inner:.3g} m now)", "raise cells_x or choose a smaller robot")
    free_r = float(spec.mission.free_radius_m) if "free_radius_m" in spec.mission.model_fields_set else 0.0
    check_robot_fits(free_r, rb, "robot" if robot is not None else "mission.free_radius_m")
    origin = layout_origin(spec)
    mission = _mission(spec, origin, free_r)
    draws, cleared = 0, 0
    obstacles: list[Obstacle] = []
    field = np.zeros((cs.cells_y, cs.cells_x), bool)
    for k in range(MAX_DRAWS):
        draws = k + 1
        field = _clear_discs(spec, origin, ca_field(cs, rng(seed, "clutter", "field", k)), mission)
        obstacles = _cylinders(spec, origin, field)
        if _passable(spec, obstacles, mission, clearance):
            break
    else:  # a lane along the start-goal line, as wide as the robot plus its clearance each side
        x = mission.start[0] - origin[0]
        half = rb.width_m / 2 + clearance + cs.radius_m
        cols = [i for i in range(1, cs.cells_x - 1) if abs((i + 0.5) * cs.lattice_m - x) < half]
        cleared = int(field[:, cols].sum())
        field[:, cols] = False
        obstacles = _cylinders(spec, origin, field)
    rows, cols_ = spec.grid_shape
    terrain = Terrain(np.zeros((rows, cols_), np.float32), spec.cell_m)
    obs = tuple(obstacles)
    desc = describe(spec, terrain, obs, mission, robot=robot)
    interior = field[:, 1:-1]
    desc["clutter"] = {"draws": draws, "cleared_cells": cleared, "field_fill_pct": 100.0 * float(interior.mean()),
                       "n_cylinders": len(obs), "origin": [origin[0], origin[1]]}
    desc["barn"] = barn_descriptor(barn_difficulty_of(spec.size_m, obs, mission.start[:2], mission.goal, robot=rb,
                                                      cell_m=cs.lattice_m, origin=origin))
    movers = place_movers(spec, mission, obs, seed)
    if not spec.movers.empty:
        desc.update(mover_descriptors(spec, movers))
    return World(spec=spec, seed=seed, terrain=terrain, obstacles=obs, mission=mission, descriptors=desc, movers=movers)
