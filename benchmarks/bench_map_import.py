"""Import time of a large occupancy-grid map (`navstress world import map.yaml`).

    python benchmarks/bench_map_import.py [--cells 4000] [--rounds 3] [--cli]

Writes a CELLS x CELLS PGM (0.05 m per cell: an office floor of 5 m rooms with 1 m doors, 3-cell
walls, an unknown border and 2,000 small pillars) and its YAML in a temporary folder, then times
the steps of `world import` in this process (compiled kernels warmed on a small map first): the
map read into walls (:func:`navstress.world.sources.occupancy.load`), the free space and the
default mission for the Jackal, and the world directory written with its preview. Prints each
step's median over ROUNDS and the total (target: <= 5 s for 4,000 x 4,000 cells). With --cli also
the wall time of the command itself in a fresh interpreter (its start-up and imports included).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from navstress.robot import PROFILES
from navstress.world.export.images import save_with_preview
from navstress.world.freespace import default_mission, free_space
from navstress.world.sources import occupancy
from navstress.world.spec import SourceSpec


def office_map(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = np.full((n, n), 254, np.uint8)
    b = max(2, n // 100)
    img[:b, :] = img[-b:, :] = img[:, :b] = img[:, -b:] = 205
    for k in range(b, n - b, 100):
        img[k:k + 3, b:n - b] = 0
        img[b:n - b, k:k + 3] = 0
    for k in range(b, n - b, 100):
        for door in range(b + 50, n - b, 100):
            img[k:k + 3, door - 10:door + 10] = 254
            img[door - 10:door + 10, k:k + 3] = 254
    for _ in range(2000):
        i, j = rng.integers(b + 5, n - b - 10, 2)
        img[i:i + 6, j:j + 6] = 0
    return img


def write_map(d: Path, n: int) -> Path:
    img = office_map(n)
    with open(d / "map.pgm", "wb") as f:
        f.write(b"P5\n%d %d\n255\n" % (n, n))
        f.write(img.tobytes())
    y = d / "map.yaml"
    y.write_text("image: map.pgm\nresolution: 0.05\norigin: [-10.0, -10.0, 0.0]\nnegate: 0\n"
                 "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return y


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=4000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--cli", action="store_true", help="also time the command in a fresh interpreter")
    a = ap.parse_args()
    jackal = PROFILES["jackal"]
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        small = d / "small"
        small.mkdir()
        ys = write_map(small, 300)
        occupancy.load(ys, SourceSpec(path=str(ys)))  # compile / load the kernels
        y = write_map(d, a.cells)
        steps: dict[str, list[float]] = {"read + walls": [], "free space + mission": [], "save + preview": []}
        for r in range(a.rounds):
            t0 = time.perf_counter()
            w = occupancy.load(y, SourceSpec(path=str(y)))
            t1 = time.perf_counter()
            m = default_mission(w, half_width_m=jackal.width_m / 2, half_diagonal_m=jackal.half_diagonal_m,
                                fs=free_space(w))
            t2 = time.perf_counter()
            save_with_preview(w, d / f"out{r}")
            t3 = time.perf_counter()
            for k, v in zip(steps, (t1 - t0, t2 - t1, t3 - t2)):
                steps[k].append(v)
        print(f"map {a.cells}x{a.cells} cells at 0.05 m: {len(w.obstacles)} walls, world {w.size_m[0]:g} x "
              f"{w.size_m[1]:g} m (cell {w.spec.cell_m:g} m), mission {m.straight_distance_m:.1f} m")
        total = 0.0
        for k, v in steps.items():
            med = statistics.median(v)
            total += med
            print(f"{k:<24} {med:8.3f} s")
        print(f"{'total (in process)':<24} {total:8.3f} s")
        if a.cli:
            t = time.perf_counter()
            subprocess.run([sys.executable, "-m", "navstress.cli", "world", "import", str(y), "-o", str(d / "cli"),
                            "--robot", "jackal"], check=True, stdout=subprocess.DEVNULL)
            print(f"{'navstress world import':<24} {time.perf_counter() - t:8.3f} s (fresh interpreter)")


if __name__ == "__main__":
    main()
