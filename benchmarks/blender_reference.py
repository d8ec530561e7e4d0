"""Measure Blender's own Subdivide + Fractal and write the oracle of ``ground.model: blender``.

Needs Blender as a Python module (``bpy``, not a navstress dependency: about 400 MB), in a
separate environment::

    python3.11 -m venv /tmp/bpyenv && /tmp/bpyenv/bin/pip install bpy==4.2.0
    /tmp/bpyenv/bin/python benchmarks/blender_reference.py tests/oracles/blender_subdivide.json

For s = 1, 2, 4, 6, 10 cuts and 200 seeds it subdivides Blender's default plane (2 m) with
``bpy.ops.mesh.subdivide(number_cuts=s, fractal=1.0, fractal_along_normal=1.0, seed=k)`` and
writes, per s, the 101 percentiles of the heights of the border vertices, of the inner vertices
and of the differences between neighbours along x and along y, and how many quads Blender's
tessellation (``loop_triangles``) split against navstress's rule (``flipped``). ``tests/unit/world/test_worldgen_blender.py`` compares
navstress's model with these distributions.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import bpy  # type: ignore[import-not-found]
import numpy as np

# navstress.world.blender needs numpy only: loaded by path, Blender's environment has no navstress
_SPEC = importlib.util.spec_from_file_location(
    "blender_ground", Path(__file__).resolve().parents[1] / "src" / "navstress" / "world" / "blender.py")
assert _SPEC is not None and _SPEC.loader is not None
_MOD = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(_MOD)
flipped = _MOD.flipped

CUTS = (1, 2, 4, 6, 10)
SEEDS = 200


def subdivided(cuts: int, seed: int) -> tuple[np.ndarray, int, int]:
    """The (n, n, 3) vertex grid (rows along y), and how many quads Blender split along their
    (x-, y-) -> (x+, y+) diagonal against the rule of navstress.world.blender.flipped (mismatches),
    and how many it flipped."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    ob = bpy.context.active_object
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.subdivide(number_cuts=cuts, fractal=1.0, fractal_along_normal=1.0, seed=seed)
    bpy.ops.object.mode_set(mode="OBJECT")
    me = ob.data
    co = np.array([v.co[:] for v in me.vertices])
    me.calc_loop_triangles()
    n = cuts + 2
    order = np.lexsort((np.round(co[:, 0], 4), np.round(co[:, 1], 4)))
    cell = {int(v): (i // n, i % n) for i, v in enumerate(order)}
    grid = co[order].reshape(n, n, 3)
    side = 2.0 / (cuts + 1)
    rule = flipped(grid[:, :, 2], side, side)  # in the plane's own frame, where Blender tessellates
    mismatches = flips = 0
    for tri in me.loop_triangles:
        p = co[list(tri.vertices)][:, :2]
        for a in range(3):
            d = p[(a + 1) % 3] - p[a]
            if abs(d[0]) > 1e-6 and abs(d[1]) > 1e-6:  # the quad's diagonal (each seen twice)
                i = min(cell[v][0] for v in tri.vertices)
                j = min(cell[v][1] for v in tri.vertices)
                is_flipped = d[0] * d[1] < 0
                flips += is_flipped
                mismatches += is_flipped != bool(rule[i, j])
    return grid, mismatches // 2, flips // 2


def rounded(x: object) -> object:
    """Floats to 5 decimals (the heights are float32 in Blender: about 7 digits)."""
    if isinstance(x, float):
        return round(x, 5)
    if isinstance(x, dict):
        return {k: rounded(v) for k, v in x.items()}
    if isinstance(x, list):
        return [rounded(v) for v in x]
    return x


def main(out: str) -> None:
    q = np.linspace(0.0, 1.0, 101)
    result: dict[str, object] = {"blender": bpy.app.version_string, "plane_m": 2.0, "fractal": 1.0,
                                 "seeds": SEEDS, "percentiles": list(q), "cuts": {}}
    for cuts in CUTS:
        grids, mismatches, flips = zip(*(subdivided(cuts, k) for k in range(SEEDS)))
        z = np.array([g[:, :, 2] for g in grids])
        n = cuts + 2
        inner = np.zeros((n, n), bool)
        inner[1:-1, 1:-1] = True
        result["cuts"][str(cuts)] = {  # type: ignore[index]
            "border": np.quantile(z[:, ~inner], q).tolist(),
            "inner": np.quantile(z[:, inner], q).tolist(),
            "dx": np.quantile(np.diff(z, axis=2), q).tolist(),
            "dy": np.quantile(np.diff(z, axis=1), q).tolist(),
            "quads": SEEDS * (cuts + 1) ** 2, "flipped": int(sum(flips)), "rule_mismatches": int(sum(mismatches)),
        }
        print(f"s={cuts}: border std {z[:, ~inner].std():.4f}, inner std {z[:, inner].std():.4f}, "
              f"{sum(flips)} of {SEEDS * (cuts + 1) ** 2} quads flipped, {sum(mismatches)} against the rule")
    with open(out, "w", encoding="utf-8") as fh:
        json.dump(rounded(result), fh, separators=(",", ":"))
        fh.write("\n")


if __name__ == "__main__":
    main(sys.argv[1])
