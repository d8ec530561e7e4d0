"""Time of importing a Gazebo world: the BARN worlds (540 KB of SDF 1.6 each, ~200 cylinders
written twice: the world and its <state>) through ``navstress.world.sources.sdf.load``.

    PYTHONPATH=src python benchmarks/bench_import_sdf.py [--barn DIR | --tar BARN.tar.xz] [--n 300] [--repeat 3]

Prints, over the first N worlds, the median and the slowest import (best of --repeat per world),
and the part of it that is XML parsing (ElementTree over the file's bytes). Target (issue 37): a
BARN world in <= 0.5 s. Without --barn the worlds are extracted from ../shared/barn/BARN.tar.xz
(beside the checkout) into a temporary folder.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tarfile
import tempfile
import time
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

from navstress.world.sources import sdf
from navstress.world.sources.notes import SourceWarning
from navstress.world.spec import SourceSpec


def _tar_default() -> Path:
    here = Path(__file__).resolve().parents[1]
    for d in (here / "tests" / "data", here, *here.parents):  # the repository's copy, or shared/ beside the checkout
        p = d / "barn" / "BARN.tar.xz" if d.name == "data" else d / "shared" / "barn" / "BARN.tar.xz"
        if p.is_file():
            return p
    sys.exit("BARN.tar.xz not found: give --barn DIR or --tar FILE")


def best_s(fn: object, repeat: int) -> float:
    out = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()  # type: ignore[operator]
        out.append(time.perf_counter() - t)
    return min(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--barn", type=Path, help="a BARN folder (world_N.world)")
    ap.add_argument("--tar", type=Path, help="BARN.tar.xz (default: ../shared/barn/ beside the checkout)")
    ap.add_argument("--n", type=int, default=300)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = a.barn
        if d is None:
            with tarfile.open(a.tar or _tar_default(), "r:xz") as tf:
                tf.extractall(tmp, members=[m for m in tf.getmembers() if m.name.endswith(".world")], filter="data")
            d = Path(tmp) / "BARN"
        files = [d / f"world_{i}.world" for i in range(a.n)]
        total, parse = [], []
        warnings.simplefilter("ignore", SourceWarning)
        for f in files:
            spec = SourceSpec(path=str(f))
            total.append(best_s(lambda: sdf.load(f, spec), a.repeat))
            parse.append(best_s(lambda: ET.fromstring(f.read_bytes()), a.repeat))
    print(f"BARN worlds imported: {len(files)} (best of {a.repeat} each)")
    print(f"  import  median {statistics.median(total) * 1000:7.1f} ms   slowest {max(total) * 1000:7.1f} ms   "
          f"(target <= 500 ms)")
    print(f"  of it XML parsing  median {statistics.median(parse) * 1000:7.1f} ms")
    print(f"  all {len(files)} worlds: {sum(total):.1f} s")


if __name__ == "__main__":
    main()
