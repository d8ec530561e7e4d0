"""Missions: where the robot starts (x, y, yaw) and where it must go (x, y).

``mode="paper"``: start at (inset, inset) facing the goal, goal at (size_x - inset,
size_y - inset); an explicit ``start`` / ``goal`` in the spec overrides either (an explicit
start keeps its own yaw). ``mode="random"``: start and goal drawn uniformly (from the
``"mission"`` sub-stream of the world seed) in the map shrunk by ``free_radius_m`` on every
side, at least ``min_distance_m`` apart, with free discs clear of the spec's walls; up to :data:`MAX_TRIES` pairs are drawn, then
:class:`~navstress.errors.GenerationError`. The mission is made before the obstacles, which
then keep out of the free discs around start and goal.

    >>> import numpy as np
    >>> from navstress.world.spec import WorldSpec
    >>> make_mission(WorldSpec(), np.random.default_rng(0)).goal
    (95.0, 95.0)
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from navstress.errors import GenerationError
from navstress.world.shapes import first_in_disc
from navstress.world.spec import WorldSpec
from navstress.world.world import Mission, Obstacle

MAX_TRIES = 1000


def make_mission(spec: WorldSpec, gen: np.random.Generator, avoid: Sequence[Obstacle] = ()) -> Mission:
    """The mission of a world (``gen`` is only used by ``mode="random"``). ``avoid``: obstacles
    standing before the mission is drawn (the spec's walls): a random start/goal pair whose free
    discs one of them enters is drawn again (the spec refuses a wall in a fixed mission's disc)."""
    m = spec.mission
    sx, sy = spec.size_m
    if m.mode == "paper":
        gx, gy = m.goal if m.goal is not None else (sx - m.inset_m, sy - m.inset_m)
        if m.start is not None:
            start = (float(m.start[0]), float(m.start[1]), float(m.start[2]))
        else:
            x0, y0 = m.inset_m, m.inset_m
            start = (x0, y0, math.atan2(gy - y0, gx - x0))
        return Mission(start=start, goal=(float(gx), float(gy)), free_radius_m=m.free_radius_m)

    r = m.free_radius_m
    lo_x, hi_x, lo_y, hi_y = r, sx - r, r, sy - r
    if hi_x < lo_x or hi_y < lo_y:
        raise GenerationError(f"mission.free_radius_m={r:g} leaves no room on a {sx:g} x {sy:g} m map "
                              "for a random start/goal; lower free_radius_m or enlarge the map")
    reach = math.hypot(hi_x - lo_x, hi_y - lo_y)
    if reach < m.min_distance_m:
        raise GenerationError(f"mission.min_distance_m={m.min_distance_m:g} is more than the longest "
                              f"possible start-goal distance {reach:.2f} m on a {sx:g} x {sy:g} m map with "
                              f"free_radius_m={r:g}; lower min_distance_m")
    for _ in range(MAX_TRIES):
        p = gen.random(4)
        x0, y0 = lo_x + p[0] * (hi_x - lo_x), lo_y + p[1] * (hi_y - lo_y)
        x1, y1 = lo_x + p[2] * (hi_x - lo_x), lo_y + p[3] * (hi_y - lo_y)
        if math.hypot(x1 - x0, y1 - y0) >= m.min_distance_m and not (
                avoid and (first_in_disc(avoid, x0, y0, r) >= 0 or first_in_disc(avoid, x1, y1, r) >= 0)):
            return Mission(start=(float(x0), float(y0), math.atan2(y1 - y0, x1 - x0)),
                           goal=(float(x1), float(y1)), free_radius_m=r)
    raise GenerationError(f"no random start/goal pair at least mission.min_distance_m={m.min_distance_m:g} "
                          f"apart{' with free discs clear of the walls' if avoid else ''} found in {MAX_TRIES} draws "
                          f"on a {sx:g} x {sy:g} m map; lower min_distance_m"
                          f"{' or mission.free_radius_m, or move the walls' if avoid else ''}")
