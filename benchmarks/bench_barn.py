"""The BARN benchmark's protocol in navstress: wall time of its test set (50 worlds x 10 runs), or of
all 300 worlds x 10 runs (``--all``), with ``reference-2d-v1`` on 2 workers (targets: 3 and 15 min).

It does what a user does: ``navstress campaign init --preset barn --barn DIR [--all]``, then
``navstress campaign run SPEC -o OUT --workers 2`` (a fresh campaign directory: every world imported
from its Gazebo file, every run simulated and traced), then the BARN score (``navstress analyze``'s
``barn`` key); it prints the wall time of each step, the machine's load average before and after
(the figure depends on what else runs), the outcome counts, BARN's overall score, and where a
run's time goes (the runs' mean wall and simulated seconds).

    .venv/bin/python benchmarks/bench_barn.py [--barn DIR] [--all] [--workers 2] [--runs 10] [--worlds N]

``--barn``: a BARN worlds folder (default: extract shared/barn/BARN.tar.xz beside the checkout into
a temporary folder). ``--worlds N``: only the first N worlds of the set (a quick look); ``--runs``:
runs per world (BARN's 10). The numba kernels are compiled once per tree, on disk: run it twice, or
once before, for the steady-state figure (the first run's compile is printed apart when it happens).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def _tar() -> Path:
    for d in (ROOT / "tests" / "data", ROOT, *ROOT.parents):  # the repository's copy, or shared/ beside the checkout
        p = d / "barn" / "BARN.tar.xz" if d.name == "data" else d / "shared" / "barn" / "BARN.tar.xz"
        if p.is_file():
            return p
    raise SystemExit("no shared/barn/BARN.tar.xz beside the checkout: pass --barn DIR")


def _cli(*args: str) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-W", "ignore", "-m", "navstress.cli", *args], check=True,
                   stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--barn", type=Path, default=None)
    ap.add_argument("--all", action="store_true", help="all 300 worlds (target 15 min) instead of the test set's 50")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--worlds", type=int, default=None)
    ap.add_argument("--keep", type=Path, default=None, help="keep the campaign in this folder")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-barn-") as tmp:
        tmpd = Path(tmp)
        folder = a.barn
        if folder is None:
            t0 = time.perf_counter()
            with tarfile.open(_tar()) as tf:
                tf.extractall(tmpd, filter="data")
            folder = tmpd / "BARN"
            print(f"extracted the BARN worlds: {time.perf_counter() - t0:.1f} s")
        spec = tmpd / "barn.yaml"
        _cli("campaign", "init", "--preset", "barn", "--barn", str(folder), "-o", str(spec),
             *(["--all"] if a.all else []))
        if a.worlds is not None or a.runs != 10:
            data = yaml.safe_load(spec.read_text())
            exp = data["experiments"][0]
            exp["worlds"] = exp["worlds"][: a.worlds]
            data["runs_per_map"] = a.runs
            spec.write_text(yaml.safe_dump(data, sort_keys=False))
        n_worlds = len(yaml.safe_load(spec.read_text())["experiments"][0]["worlds"])
        out = a.keep if a.keep is not None else tmpd / "campaign"
        load0 = os.getloadavg()
        wall = _cli("campaign", "run", str(spec), "-o", str(out), "--workers", str(a.workers), "--quiet")
        load1 = os.getloadavg()
        t0 = time.perf_counter()
        js = tmpd / "analysis.json"
        _cli("analyze", str(out), "--json", str(js))
        analyse = time.perf_counter() - t0
        import json

        from navstress.campaign.store import Store

        with Store.open(out) as st:
            recs = st.records()
            counts = st.outcome_counts()
        barn = json.loads(js.read_text()).get("barn", {})
        groups = barn.get("groups", [])
        target = 15 * 60 if a.all else 3 * 60
        print(f"BARN {'all' if a.all else 'test set'}: {n_worlds} worlds x {a.runs} runs = {len(recs)} runs, "
              f"{a.workers} workers, {os.cpu_count()} CPUs")
        print(f"  load average before {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}, "
              f"after {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f}")
        print(f"  campaign run: {wall:.1f} s wall (target for the full set: {target / 60:.0f} min); analyze: {analyse:.1f} s")
        print(f"  outcomes: {counts}")
        if recs:
            walls = [r.wall_s for r in recs]
            sims = [r.duration_s for r in recs]
            print(f"  per run: wall mean {statistics.fmean(walls):.2f} s (median {statistics.median(walls):.2f}, "
                  f"max {max(walls):.1f}), simulated mean {statistics.fmean(sims):.1f} s; "
                  f"{sum(walls) / max(wall * a.workers, 1e-9):.0%} of the workers' time in runs")
        for g in groups:
            print(f"  BARN score {g['navigator']} {g['fault']}: {g['score']:.4f} over {g['runs']} runs "
                  f"({g['successes']} successes, {g['worlds']} worlds)")


if __name__ == "__main__":
    main()
