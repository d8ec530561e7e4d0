"""World generation speed and placement capacity.

Prints: generation time of a 100 m map with 25 % trees (target < 1 s) against a flat empty
map generated in the same run (baseline ratio), the time of the s=4, d=2 benchmark world, of
the paper's ground on ``model: blender`` (s=2 d=7 and s=6 d=3.5, target <= 0.2 s), and
the highest building obstruction reached on a 100 m map (30..50 %, several seeds), with the
placement attempts. Run: ``.venv/bin/python benchmarks/bench_worldgen.py``.
"""

from __future__ import annotations

import statistics
import time

from navstress.errors import GenerationError
from navstress.world import WorldSpec, generate


def best_time(spec: WorldSpec, seeds: range) -> tuple[float, float]:
    """(min, median) wall seconds over seeds (first call compiles numba; done before)."""
    times = []
    for seed in seeds:
        t = time.perf_counter()
        generate(spec, seed)
        times.append(time.perf_counter() - t)
    return min(times), statistics.median(times)


def main() -> None:
    generate(WorldSpec(size_m=(20.0, 20.0), obstacles={"obstruction": {"tree": 5}}), 0)  # warm numba caches
    flat = WorldSpec()
    trees = WorldSpec(obstacles={"obstruction": {"tree": 25}})
    bumpy = WorldSpec(ground={"subdivisions": 4, "deformation": 2.0}, obstacles={"obstruction": {"tree": 6}})
    seeds = range(5)
    f_min, f_med = best_time(flat, seeds)
    t_min, t_med = best_time(trees, seeds)
    b_min, b_med = best_time(bumpy, seeds)
    w = generate(trees, 0)
    print(f"flat empty 100 m map         : median {f_med:.3f} s (min {f_min:.3f})")
    print(f"100 m map, 25% trees         : median {t_med:.3f} s (min {t_min:.3f}), "
          f"{w.descriptors['n_obstacles']['tree']} trees, {t_med / f_med:.1f}x the flat empty map")
    print(f"100 m map, s=4 d=2, 6% trees : median {b_med:.3f} s (min {b_min:.3f})")
    for s, d in ((2, 7.0), (6, 3.5)):  # the paper's steepest ground configurations (target <= 0.2 s)
        g_min, g_med = best_time(WorldSpec(ground={"model": "blender", "subdivisions": s, "deformation": d}), seeds)
        print(f"100 m map, blender s={s} d={d:g}  : median {g_med:.3f} s (min {g_min:.3f}), "
              f"{g_med / f_med:.2f}x the flat empty map (target <= 0.2 s)")
    best = 0.0
    for pct in (30, 35, 40, 45, 50):
        ok, attempts = 0, []
        for seed in range(5):
            try:
                w = generate(WorldSpec(obstacles={"obstruction": {"building": pct}}), seed)
                ok += 1
                attempts.append(w.descriptors["placement_attempts"]["building"])
            except GenerationError as err:
                msg = str(err)
        line = f"buildings {pct}%: {ok}/5 seeds succeed"
        if attempts:
            line += f", attempts median {statistics.median(attempts):.0f}"
            best = max(best, pct) if ok == 5 else best
        if ok < 5:
            line += f"; a failure: {msg[:110]}..."
        print(line)
    print(f"highest building obstruction reached on all 5 seeds: {best:g}% (paper: about 28%)")


if __name__ == "__main__":
    main()
