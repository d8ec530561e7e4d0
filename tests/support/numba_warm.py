"""The test session's first step: numba's on-disk cache filled once, before the test workers start.

navstress's kernels are compiled on first use and cached on disk per source tree
(``navstress._jit``). On a fresh machine (CI) or after any source change the cache is empty, and
every process the suite starts (two pytest workers, the campaigns' run workers, the CLI's
subprocesses) compiled the same kernels side by side, each for tens of seconds. Here two
processes compile them once (a world generated with every kind of obstacle, rough ground and
movers; a short mission of the reference navigator on it with the lidar and the navigator's view
recorded, and beside it one of the Jackal with a 2-D scanner and reference-2d-v1; the trace read
back and drawn); a marker file in the cache directory, one per checkout, says it is done.
Best effort: a failure here only costs time, the tests themselves report what is wrong."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_WORLD = ["world", "generate", "--size", "30", "--trees", "4", "--buildings", "3", "--ground", "fractal",
          "--movers", "pedestrian=2", "--seed", "3"]
_AFTER = """
import sys
from navstress.analysis import svgmap
from navstress.run.trace import read_poses
p = sys.argv[1]
xy = read_poses(p)[:, 1:3]
svgmap.simplify(xy, 0.1)
"""


def warm() -> None:
    from navstress._jit import numba_cache_dir

    d = numba_cache_dir()
    if d is None:
        return
    # numba files a kernel under its source folder's absolute path (<folder>_<sha1 of the path>),
    # so two checkouts of the same sources share <cache>/numba/<hash> but not their kernels: the
    # marker is per checkout too, else a second checkout (a fresh clone beside the first, a git
    # worktree) found the first's marker, skipped the warm-up and compiled every kernel lazily in
    # its test processes, two at a time and under load (docs/performance.md, "Test loops")
    import navstress
    where = hashlib.sha1(str(Path(navstress.__file__).resolve().parent).encode()).hexdigest()[:16]
    marker = Path(d) / f".suite-warm-{where}"
    if marker.exists():
        return
    exe = str(Path(sys.executable).with_name("navstress"))
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="navstress-warm-") as tmp:
        env = {**os.environ, "PYTHONWARNINGS": "ignore"}
        quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": env}
        # the mission's kernels (a flat world, no generation) while the generator's are compiled beside it
        mission = subprocess.Popen([sys.executable, "-c", "from navstress.campaign.work import warm_up; warm_up()"],
                                   **quiet)
        gen = subprocess.Popen([exe, *_WORLD, "-o", f"{tmp}/w"], **quiet)
        gen.wait()
        mission.wait()
        # then both together: obstacles, movers, the lidar and navigator view recorded, the trace read and drawn
        # beside it, the Jackal with its 2-D scanner and reference-2d-v1 (the BARN preset's and the
        # robots' tests; else their campaigns' workers compiled that navigator side by side)
        jackal = subprocess.Popen([exe, "run", f"{tmp}/w", "-o", f"{tmp}/j", "--timeout", "3", "--robot", "jackal",
                                   "--sensor", "scan=lidar2d:ust10", "--navigator", "reference-2d-v1"], **quiet)
        # (15 s: the reference navigator sets off after a few seconds, and its planner's kernels with it)
        run = subprocess.run([exe, "run", f"{tmp}/w", "-o", f"{tmp}/r", "--timeout", "15", "--lidar",
                              "--navigator-view"], **quiet)
        jackal.wait()
        traces = sorted(Path(tmp).glob("r/**/*.mcap"))
        if traces:
            subprocess.run([sys.executable, "-c", _AFTER, str(traces[0])], **quiet)
        ok = gen.returncode == mission.returncode == run.returncode == jackal.returncode == 0 and bool(traces)
    if ok:
        marker.write_text(f"{time.perf_counter() - t0:.1f} s\n")


if __name__ == "__main__":  # `make test` runs it beside mypy, on the core mypy leaves idle
    warm()
