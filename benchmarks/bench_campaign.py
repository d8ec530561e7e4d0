"""Campaign throughput: runs per hour of the demo campaign with 1 and 2 workers (scaling ratio),
and the projected wall time of the ``paper`` preset on this machine.

The projection runs a sample of the paper design (one map, one run of the middle
configuration of each of the five classes, nominal, 100 m maps, default fidelity) with
``--workers`` workers and scales: ``paper runs x mean wall per sampled run / workers``. It is
approximate: runs that fail early are shorter than successes, so the mix of outcomes matters.

    .venv/bin/python benchmarks/bench_campaign.py [--skip-paper] [--workers 2]
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml

from navstress.campaign.executors import run_campaign
from navstress.campaign.plan import plan
from navstress.campaign.presets import demo, paper
from navstress.campaign.spec import parse_campaign
from navstress.campaign.progress import format_counts
from navstress.campaign.store import Store


def _run(spec: dict[str, Any], workers: int, root: Path, name: str) -> tuple[float, int, float]:
    """Run ``spec`` into ``root/name``; (wall s, runs, mean wall per run from the records)."""
    path = root / f"{name}.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    t0 = time.perf_counter()
    res = run_campaign(path, root / name, workers=workers)
    wall = time.perf_counter() - t0
    with Store.open(root / name) as s:
        mean = s.mean_wall_s() or 0.0
        print(f"  {name}: outcomes {format_counts(s.outcome_counts(), markup=False)}")
    return wall, res.recorded, mean


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--skip-paper", action="store_true")
    ap.add_argument("--workers", type=int, default=2, help="workers for the paper projection")
    a = ap.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}")
    with tempfile.TemporaryDirectory(prefix="bench-campaign-") as tmp:
        root = Path(tmp)
        rates: dict[int, float] = {}
        for w in (1, 2):
            wall, n, mean = _run(demo(), w, root, f"demo-{w}")
            rates[w] = n / wall * 3600
            print(f"demo campaign, {w} worker(s): {n} runs in {wall:.1f} s = {rates[w]:.0f} runs/h "
                  f"(mean wall per run {mean:.1f} s; the total includes worker start-up and world generation)")
        print(f"scaling 2 vs 1 worker: {rates[2] / rates[1]:.2f}x")
        if a.skip_paper:
            return
        p = paper()
        n_paper = len(plan(parse_campaign(p), root).tasks)
        sample = dict(p, maps_per_config=1, runs_per_map=1, faults=[None])
        exps = []
        for e in p["experiments"]:
            key, rng = next(iter(e["sweep"].items()))
            vals = parse_campaign(dict(p, experiments=[e])).experiments[0].sweep[key].expand()
            exps.append(dict(e, sweep={key: {"values": [vals[len(vals) // 2]]}}, faults=[None]))
        sample["experiments"] = exps
        wall, n, mean = _run(sample, a.workers, root, "paper-sample")
        proj = n_paper * mean / a.workers
        print(f"paper sample: {n} runs (middle config of each class, 100 m maps) in {wall:.1f} s, "
              f"mean wall per run {mean:.1f} s")
        print(f"paper preset: {n_paper} runs -> projected {proj / 3600:.1f} h with {a.workers} workers "
              f"(paper: 2,345 runs in about 112 h)")


if __name__ == "__main__":
    main()
