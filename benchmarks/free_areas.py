"""The start and goal free areas on rough ground: what levelling them does, per ground.

For each ground (the paper's 100 m map and mission, 20 map seeds, start and goal each) prints a
markdown row: how many maps the generator refused (a start or goal that cannot be made drivable),
the transition's width (median, max), the steepest triangle of the levelled ground in the
transition (median, max) and the steepest raw slope over the same zone (median), in degrees.
Run: ``.venv/bin/python benchmarks/free_areas.py`` (docs/worlds.md, "Drivable start and goal areas").
"""

from __future__ import annotations

import math
import statistics

import numpy as np

from navstress.errors import GenerationError
from navstress.seeding import rng
from navstress.world import WorldSpec, generate
from navstress.world.freearea import _triangle_slope_deg
from navstress.world.terrain import make_heights

GROUNDS = [
    ("subdivide s=2 d=1", {"subdivisions": 2, "deformation": 1.0}),
    ("subdivide s=2 d=3", {"subdivisions": 2, "deformation": 3.0}),
    ("subdivide s=2 d=7", {"subdivisions": 2, "deformation": 7.0}),
    ("subdivide s=4 d=2", {"subdivisions": 4, "deformation": 2.0}),
    ("subdivide s=4 d=5.5", {"subdivisions": 4, "deformation": 5.5}),
    ("subdivide s=6 d=1", {"subdivisions": 6, "deformation": 1.0}),
    ("subdivide s=6 d=3.5", {"subdivisions": 6, "deformation": 3.5}),
    ("fractal amplitude 1 m", {"model": "fractal", "amplitude_m": 1.0}),
    ("fractal amplitude 4 m", {"model": "fractal", "amplitude_m": 4.0}),
    *((f"blender s={s} d={d:g}, plane {w:g} m", {"model": "blender", "subdivisions": s, "deformation": d, "plane_m": w})
      for w in (2.0, 20.0) for s, d in ((2, 7.0), (4, 5.5), (6, 3.5))),
]
SEEDS = range(20)


def row(name: str, ground: dict[str, object]) -> str:
    widths, slopes, raws, refused = [], [], [], 0
    spec = WorldSpec(ground=ground)
    r_flat = spec.mission.free_radius_m + math.sqrt(2.0) * spec.cell_m
    for seed in SEEDS:
        try:
            w = generate(spec, seed)
        except GenerationError:
            refused += 1
            continue
        raw = _triangle_slope_deg(make_heights(spec.ground, spec.grid_shape, spec.cell_m, rng(seed, "terrain")),
                                  spec.cell_m)
        ys, xs = (np.mgrid[0:raw.shape[1], 0:raw.shape[2]] + 0.5) * spec.cell_m
        for key, (cx, cy) in (("start", w.mission.start[:2]), ("goal", w.mission.goal)):
            fa = w.descriptors["free_areas"][key]
            widths.append(fa["transition_m"])
            slopes.append(fa["slope_max_deg"])
            u = np.hypot(xs - cx, ys - cy) - r_flat
            raws.append(float(raw[:, (u > 0) & (u < fa["transition_m"])].max()))
    if not widths:
        return f"| {name} | {refused}/{len(SEEDS)} | - | - | - |"
    return (f"| {name} | {refused}/{len(SEEDS)} | {statistics.median(widths):.1f} ({max(widths):.1f}) | "
            f"{statistics.median(slopes):.0f} ({max(slopes):.0f}) | {statistics.median(raws):.0f} |")


def main() -> None:
    print("| ground | refused | width B median (max), m | steepest transition slope, median (max), deg | "
          "steepest raw slope there, median, deg |")
    print("|---|---|---|---|---|")
    for name, ground in GROUNDS:
        print(row(name, ground))


if __name__ == "__main__":
    main()
