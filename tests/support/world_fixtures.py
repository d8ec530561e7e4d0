"""Small hand-made worlds for tests (no generator needed), fast to build."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from navstress.world import Mission, Obstacle, Terrain, World, WorldSpec


def small_world(seed: int = 0, *, bumpy: bool = True, size: float = 20.0, cell: float = 0.5) -> World:
    """A size x size m world with random smooth-ish terrain and three non-overlapping boxes."""
    spec = WorldSpec(size_m=(size, size), cell_m=cell,
                     obstacles={"obstruction": {"tree": 1.0, "building": 10.0}})
    rows, cols = spec.grid_shape
    g = np.random.default_rng(seed)
    heights = g.normal(0.0, 0.6, (rows, cols)).cumsum(axis=0).cumsum(axis=1) / 10 if bumpy \
        else np.zeros((rows, cols))
    obstacles = (
        Obstacle("tree", 5.0, 12.0, 0.3, (1.0, 1.0, 5.0), z=0.2),
        Obstacle("building", 12.0, 6.0, math.radians(30), (4.0, 3.0, 8.0), z=-0.4),
        Obstacle("tree", 15.5, 15.0, 0.0, (1.0, 1.2, 4.0), z=1.0),
    )
    return World(spec=spec, seed=seed, terrain=Terrain(heights.astype(np.float32), cell),
                 obstacles=obstacles, mission=Mission((2.0, 2.0, math.pi / 4), (18.0, 18.0), 1.5))


def trees_world_dir(parent: Path) -> Path:
    """A generated 30 m world with 2 % trees (map seed 11) saved under ``parent``: reference-v1
    reaches its goal in about 30 s (run seed 5)."""
    from navstress.world import generate, parse_spec

    d = parent / "w"
    generate(parse_spec({"size_m": [30, 30], "obstacles": {"obstruction": {"tree": 2}}}), 11).save(d)
    return d


def shapes_world(seed: int = 0, *, bumpy: bool = True) -> World:
    """A 20 m world of cylinders (several sizes), a wall polyline of three segments and a box."""
    from navstress.world.shapes import wall_boxes

    spec = WorldSpec(size_m=(20.0, 20.0), cell_m=0.5)
    rows, cols = spec.grid_shape
    g = np.random.default_rng(seed)
    heights = g.normal(0.0, 0.6, (rows, cols)).cumsum(axis=0).cumsum(axis=1) / 10 if bumpy \
        else np.zeros((rows, cols))
    cyl = tuple(Obstacle("tree", x, y, yaw, (d, d, hgt), z=0.1 * k, shape="cylinder")
                for k, (x, y, yaw, d, hgt) in enumerate([(6.0, 14.0, 0.0, 1.0, 3.0), (12.0, 10.0, 0.8, 2.5, 1.5),
                                                         (15.0, 5.0, 0.0, 0.3, 1.0)]))
    walls = tuple(wall_boxes([(3.0, 5.0), (8.0, 5.0), (11.0, 8.0), (11.0, 3.0)], 0.2, 2.5))
    box = Obstacle("building", 16.0, 15.0, 0.4, (2.0, 1.0, 4.0))
    return World(spec=spec, seed=seed, terrain=Terrain(heights.astype(np.float32), 0.5),
                 obstacles=cyl + walls + (box,), mission=Mission((2.0, 2.0, math.pi / 4), (18.0, 18.0), 1.5))
