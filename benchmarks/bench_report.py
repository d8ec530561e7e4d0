"""The report of a campaign: time to write it, its size, peak memory; and pose reading, side by side.

    python benchmarks/bench_report.py DIR [--sample 200]

DIR is a campaign directory (for the issue's figure, the paper preset:
``navstress campaign init --preset paper -o paper.yaml && navstress campaign run paper.yaml -o DIR``;
without DIR the benchmark runs the demo campaign into a temporary folder first). Prints:

- ``navstress report DIR -o OUT`` as a user runs it, in a fresh process: wall time, the file's
  size, the process's peak resident memory. Targets for the paper preset (2,475 runs): under a
  minute and under 20 MB.
- with ``--phases``: the report written again in this process with its parts timed (analysis,
  asking for the trajectories and waiting for the workers that read them, the failing runs'
  views, the charts);
- reading a trajectory from a trace (``read_poses``: through the MCAP message indexes) against
  the MCAP library's own reader, on the same ``--sample`` traces of DIR in this one process: the
  median time per trace and the ratio (a ratio is stable on a noisy machine), and that both give
  the same bytes.
"""

from __future__ import annotations

import argparse
import glob
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("directory", nargs="?", help="a campaign directory (default: run the demo first)")
    ap.add_argument("--sample", type=int, default=200, help="traces timed for the pose-reading comparison")
    ap.add_argument("--phases", action="store_true", help="also write the report in this process, its parts timed")
    a = ap.parse_args()
    exe = str(Path(sys.executable).with_name("navstress"))
    with tempfile.TemporaryDirectory() as tmp:
        root = a.directory
        if root is None:
            subprocess.run([exe, "demo", "-o", tmp + "/demo"], check=True, stdout=subprocess.DEVNULL)
            root = tmp + "/demo/campaign"
        from navstress.campaign.store import Store
        with Store.open(root) as s:
            done, planned = s.progress()
        out = Path(tmp) / "report.html"
        t = time.perf_counter()
        subprocess.run([exe, "report", root, "-o", str(out)], check=True, stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - t
        peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        size_mb = out.stat().st_size / 1e6
        print(f"campaign {root}: {done}/{planned} runs; cores {os.cpu_count()}")
        print(f"navstress report: {wall:.1f} s, {size_mb:.1f} MB, peak memory {peak_mb:.0f} MB "
              f"(targets for 2,475 runs: < 60 s, < 20 MB)")

    from navstress.run.trace import TOPIC_TRUTH, read_poses
    traces = sorted(glob.glob(os.path.join(root, "traces", "**", "*.mcap"), recursive=True))[: a.sample]
    fast, slow, same = [], [], True
    for p in traces:
        t = time.perf_counter()
        x = read_poses(p, TOPIC_TRUTH)
        fast.append(time.perf_counter() - t)
        t = time.perf_counter()
        y = read_poses(p, TOPIC_TRUTH, indexed=False)
        slow.append(time.perf_counter() - t)
        same = same and x.tobytes() == y.tobytes()
    if traces:
        mf, ms = statistics.median(fast), statistics.median(slow)
        print(f"pose reading, {len(traces)} traces: indexed {1e3 * mf:.1f} ms, library {1e3 * ms:.1f} ms per trace, "
              f"{ms / mf:.1f}x; identical: {same}")
        if not same:
            sys.exit("the two readers disagree")
    if a.phases:
        if a.directory is None:
            sys.exit("--phases needs DIR (the demo's folder is gone by now)")
        phases(root)


def phases(root: str) -> None:
    """The report written again in this process, its parts timed (each wraps the function of
    that name: analysis, trajectory prefetches, run views, charts)."""
    from navstress.analysis import report as R
    from navstress.analysis import trajectories as T

    totals: dict[str, float] = {}

    def wrap(mod: object, name: str, label: str) -> None:
        orig = getattr(mod, name)

        def timed(*args: object, **kw: object) -> object:
            t = time.perf_counter()
            try:
                return orig(*args, **kw)
            finally:
                totals[label] = totals.get(label, 0.0) + time.perf_counter() - t
        setattr(mod, name, timed)

    for mod, name, label in ((R, "analyze", "analysis"), (T.TrajectoryCache, "prefetch", "trajectory prefetches"),
                             (T.TrajectoryCache, "wait", "waiting for trajectories"),
                             (R, "_run_view", "run views"), (R, "class_chart", "charts"),
                             (R, "verdict_chart", "charts"), (R, "indeterminism_chart", "charts"),
                             (R, "fault_power_chart", "charts")):
        wrap(mod, name, label)
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        R.build_report(root, Path(tmp) / "report.html")
        total = time.perf_counter() - t
    print(f"report in this process: {total:.1f} s; " + ", ".join(f"{k} {v:.1f} s" for k, v in totals.items()))


if __name__ == "__main__":
    main()
