"""The two readings of the paper's ground side by side: ``model: subdivide`` and ``model: blender``.

Prints, per model, s and d, the height range and standard deviation and the slope statistics
(mean, 95th percentile, max, in degrees) of 100 m maps at 0.4 m cells over 4 seeds, and writes a
picture of both models at the paper's steepest setting of each s (s=2 d=7, s=4 d=5.5, s=6 d=3.5).
Run: ``.venv/bin/python benchmarks/ground_models.py [PICTURE.jpg]`` (docs/worlds.md shows both).
"""

from __future__ import annotations

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from navstress.world import WorldSpec, generate  # noqa: E402
from navstress.world.terrain import slope_deg  # noqa: E402

CASES = ((2, 1.0), (2, 3.5), (2, 7.0), (4, 1.0), (4, 3.0), (4, 5.5), (6, 1.0), (6, 2.0), (6, 3.5))
SEEDS = range(4)


def stats(model: str, s: int, d: float) -> dict[str, float]:
    rng_, std, mean, p95, mx = [], [], [], [], []
    for seed in SEEDS:
        w = generate(WorldSpec(ground={"model": model, "subdivisions": s, "deformation": d}), seed)
        h = w.terrain.heights.astype(np.float64)
        sl = slope_deg(h, w.spec.cell_m)
        rng_.append(float(h.max() - h.min()))
        std.append(float(h.std()))
        mean.append(float(sl.mean()))
        p95.append(float(np.percentile(sl, 95)))
        mx.append(float(sl.max()))
    return {"range": float(np.mean(rng_)), "std": float(np.mean(std)), "mean": float(np.mean(mean)),
            "p95": float(np.mean(p95)), "max": float(np.max(mx))}


def main() -> None:
    print("| model | s | d | segments/side | height range (m) | height std (m) | slope mean (deg) | p95 | max |")
    print("|---|---|---|---|---|---|---|---|---|")
    for model in ("blender", "subdivide"):
        for s, d in CASES:
            r = stats(model, s, d)
            segs = s + 1 if model == "blender" else 2 ** s
            print(f"| {model} | {s} | {d:g} | {segs} | {r['range']:.2f} | {r['std']:.2f} | {r['mean']:.1f} | "
                  f"{r['p95']:.1f} | {r['max']:.1f} |")
    if len(sys.argv) > 1:
        fig, axes = plt.subplots(2, 3, figsize=(10.5, 7.2), constrained_layout=True)
        for col, (s, d) in enumerate(((2, 7.0), (4, 5.5), (6, 3.5))):
            for row, model in enumerate(("blender", "subdivide")):
                w = generate(WorldSpec(ground={"model": model, "subdivisions": s, "deformation": d}), 1)
                h = w.terrain.heights
                ax = axes[row, col]
                im = ax.imshow(h, origin="lower", extent=(0, 100, 0, 100), cmap="terrain")
                ax.set_title(f"{model}: s = {s}, d = {d:g}\nheights {h.min():+.1f} .. {h.max():+.1f} m", fontsize=9)
                ax.set_xticks([0, 50, 100])
                ax.set_yticks([0, 50, 100])
                fig.colorbar(im, ax=ax, shrink=0.8, label="m")
        fig.savefig(sys.argv[1], dpi=80, pil_kwargs={"quality": 80})
        print(f"wrote {sys.argv[1]}")


if __name__ == "__main__":
    main()
