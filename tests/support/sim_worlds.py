"""Hand-made worlds for the simulation tests."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from navstress.world.spec import WorldSpec
from navstress.world.world import Obstacle, Terrain, World


def flat(size: float = 40.0, obstacles: tuple[Obstacle, ...] = ()) -> World:
    return World.flat(WorldSpec(size_m=(size, size)), obstacles=obstacles)


def ramp(deg: float, x0: float = 10.0, size: float = 40.0) -> World:
    """Flat up to x = x0, then a plane rising along +x at ``deg`` degrees."""
    w = flat(size)
    spec = w.spec
    rows, cols = spec.grid_shape
    x = np.arange(cols) * spec.cell_m
    h = np.tile(np.clip(x - x0, 0.0, None) * math.tan(math.radians(deg)), (rows, 1)).astype(np.float32)
    return dataclasses.replace(w, terrain=Terrain(h, spec.cell_m))


def rough(seed: int, size: float = 12.0, amp: float = 1.5) -> World:
    """Random heights (a brute-force test terrain, not a realistic one)."""
    w = flat(size)
    rows, cols = w.spec.grid_shape
    h = np.random.default_rng(seed).uniform(-amp, amp, (rows, cols)).astype(np.float32)
    return dataclasses.replace(w, terrain=Terrain(h, w.spec.cell_m))


def bumpy(size: float = 40.0, amp: float = 0.3, wavelength: float = 3.0) -> World:
    """Egg-box bumps of ``amp`` meters every ``wavelength`` meters."""
    w = flat(size)
    rows, cols = w.spec.grid_shape
    y, x = np.mgrid[0:rows, 0:cols] * w.spec.cell_m
    k = 2 * math.pi / wavelength
    h = (amp * np.sin(k * x) * np.sin(k * y)).astype(np.float32)
    return dataclasses.replace(w, terrain=Terrain(h, w.spec.cell_m))
