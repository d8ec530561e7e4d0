"""Adaptive repetition against the fixed design, side by side in one run.

The ``paper`` preset's ``trees`` (tree obstruction 0..14 %, nominal and the small-footprint
fault) and ``smooth-s4`` (s = 4, deformation 0..3 m, nominal) classes, every configuration,
``--maps`` maps each (the preset has 5; 2 by default to fit a few minutes), run twice through
the real campaign machinery:

- **fixed**: the preset's design, ``runs_per_map: 5``;
- **adaptive**: the same spec with ``runs_per_map: {adaptive: RULE}`` (``--rule``).

Both campaigns share every seed (maps and runs), so the adaptive campaign's runs are the first
runs of each fixed stream: the benchmark checks that each of them has the same outcome, duration
and trace bytes as the fixed run with the same id. It then prints, for each design: runs and
simulated hours spent, wall time, the difficulty level of every configuration (the analysis of
``navstress analyze``: nominal runs, the paper's rule) and the per-world verdicts under RULE's
threshold and confidence; and their agreement. Last, a table of other rules replayed on the
fixed campaign's runs (a stream stopped where the rule stops it: exact, since the same seeds
give the same outcomes, as checked above) shows the trade-off between runs saved and
confidence.

    .venv/bin/python benchmarks/bench_adaptive.py [--maps 2] [--workers 2]
        [--rule 2,5,0.5,0.8,0.25] [--keep DIR]

The default rule asks whether a world passes at least 75 % of the time or at most 25 % of the
time (threshold 0.5, indifference 0.25; docs/statistics.md), with 80 % confidence.

``--keep DIR`` keeps both campaigns in DIR (a later call with the same DIR resumes them: only
what is missing runs, and the wall times then count only that).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import platform
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

import yaml

from navstress.analysis.analyze import trace_path
from navstress.analysis.difficulty import assign_levels, reference_keys
from navstress.analysis.stats import config_key, config_stats, planned_configs
from navstress.analysis.verdicts import VerdictRule, verdicts
from navstress.campaign.executors import run_campaign
from navstress.campaign.presets import paper
from navstress.campaign.store import Store
from navstress.errors import SpecError
from navstress.run.record import RunRecord
from navstress.sequential import AdaptiveRule, should_continue

CLASSES = ("trees", "smooth-s4")
FIXED_RUNS = 5
#: (threshold, indifference, confidence) of the rules replayed on the fixed runs
REPLAYED = [(0.8, 0.0, c) for c in (0.75, 0.9, 0.95)] + [(0.5, 0.0, c) for c in (0.5, 0.75, 0.9)] + \
    [(0.25, 0.0, c) for c in (0.75, 0.9)] + [(0.5, d, c) for d in (0.2, 0.25) for c in (0.75, 0.8, 0.9, 0.95)]


def specs(maps: int, rule: AdaptiveRule) -> tuple[dict[str, Any], dict[str, Any]]:
    """(fixed, adaptive) campaign specs: the paper preset's two classes at ``maps`` maps."""
    p = paper()
    p["experiments"] = [e for e in p["experiments"] if e["name"] in CLASSES]
    p["maps_per_config"] = maps
    p["runs_per_map"] = FIXED_RUNS
    fixed = dict(p, name="fixed")
    name = f"adaptive-{rule.min_runs}-{rule.max_runs}-{rule.threshold:g}-{rule.confidence:g}-{rule.indifference:g}"
    adaptive = dict(p, name=name, runs_per_map={"adaptive": {
        "min": rule.min_runs, "max": rule.max_runs, "threshold": rule.threshold, "confidence": rule.confidence,
        "indifference": rule.indifference}})
    return fixed, adaptive


class Campaign:
    """A finished campaign's records and what the benchmark measures of them."""

    def __init__(self, directory: Path, wall_s: float) -> None:
        with Store.open(directory) as s:
            self.spec = s.spec
            self.records = s.records()
            self.planned = s.planned_by_config()
        self.root = directory
        self.wall_s = wall_s

    @property
    def sim_hours(self) -> float:
        return sum(r.duration_s for r in self.records) / 3600.0

    def levels(self, records: list[RunRecord] | None = None) -> dict[tuple[str, str], str]:
        """Difficulty level per configuration, as ``navstress analyze`` assigns them."""
        st = config_stats(self.records if records is None else records, planned_configs(self.spec, self.planned))
        nav = self.spec.navigators[0].name
        nominal = [s for s in st if s.navigator == nav and s.fault == "nominal"]
        refs = reference_keys(self.spec)
        return assign_levels(nominal, lambda c: c.key in refs).levels

    def verdicts(self, rule: VerdictRule, records: list[RunRecord] | None = None) -> dict[tuple[Any, ...], str]:
        v = verdicts(self.records if records is None else records, rule)
        return {(w.experiment, w.config_key, w.map_index, w.navigator, w.fault): w.verdict for w in v.worlds}

    def streams(self) -> dict[tuple[Any, ...], list[RunRecord]]:
        out: dict[tuple[Any, ...], list[RunRecord]] = defaultdict(list)
        for r in self.records:
            out[(r.experiment, config_key(r), r.map_index, r.navigator, r.fault)].append(r)
        return {k: sorted(v, key=lambda r: r.run_index) for k, v in out.items()}


def run(spec: dict[str, Any], root: Path, workers: int) -> Campaign:
    path = root / f"{spec['name']}.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    t0 = time.perf_counter()
    res = run_campaign(path, root / spec["name"], workers=workers)
    wall = time.perf_counter() - t0
    print(f"  {spec['name']}: {res.recorded} runs recorded now ({res.already_done} before) in {wall:.0f} s")
    return Campaign(root / spec["name"], wall)


def _sha(path: Path | None) -> str | None:
    return None if path is None else hashlib.sha256(path.read_bytes()).hexdigest()


def check_prefixes(fixed: Campaign, adaptive: Campaign) -> int:
    """Every adaptive run equals the fixed run of the same id (outcome, duration, trace bytes)."""
    by_id = {r.run_id: r for r in fixed.records}
    checked = 0
    for r in adaptive.records:
        f = by_id.get(r.run_id)
        if f is None:
            continue
        same = (f.outcome, f.duration_s) == (r.outcome, r.duration_s) and \
            _sha(trace_path(fixed.root, f)) == _sha(trace_path(adaptive.root, r))
        if not same:
            raise SystemExit(f"run {r.run_id} differs between the designs: {f.outcome} {f.duration_s} s "
                             f"against {r.outcome} {r.duration_s} s (or its trace)")
        checked += 1
    return checked


def replay(fixed: Campaign, rule: AdaptiveRule) -> list[RunRecord]:
    """The runs ``rule`` would have made, cut from the fixed streams (exact: same seeds, same outcomes)."""
    out: list[RunRecord] = []
    for rs in fixed.streams().values():
        n = s = 0
        while n < len(rs) and (n < rule.min_runs or should_continue(s, n, rule)):
            s += rs[n].outcome == "success"
            n += 1
        out += rs[:n]
    return out


def agreement(a: dict[Any, str], b: dict[Any, str]) -> tuple[int, int]:
    keys = [k for k in a if k in b]
    return sum(a[k] == b[k] for k in keys), len(keys)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, default=2, help="maps per configuration (the preset has 5)")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--rule", default="2,5,0.5,0.8,0.25",
                    help="adaptive rule: min,max,threshold,confidence[,indifference]")
    ap.add_argument("--keep", type=Path, help="keep (and resume) both campaigns in this directory")
    a = ap.parse_args()
    parts = a.rule.split(",")
    if len(parts) not in (4, 5):
        raise SystemExit(f"--rule={a.rule!r} is invalid: expected min,max,threshold,confidence[,indifference]")
    try:
        rule = AdaptiveRule(int(parts[0]), int(parts[1]), float(parts[2]), float(parts[3]),
                            float(parts[4]) if len(parts) == 5 else 0.0)
    except (ValueError, SpecError) as err:
        raise SystemExit(f"--rule={a.rule!r}: {err}") from None
    vrule = VerdictRule(rule.threshold, rule.confidence, indifference=rule.indifference)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"python {platform.python_version()}; {a.workers} workers")
    print(f"paper preset, classes {', '.join(CLASSES)}, {a.maps} maps per configuration; fixed {FIXED_RUNS} runs "
          f"per map against adaptive {{min {rule.min_runs}, max {rule.max_runs}, threshold {rule.threshold}, "
          f"confidence {rule.confidence}, indifference {rule.indifference}}}")
    with tempfile.TemporaryDirectory(prefix="bench-adaptive-") as tmp:
        root = a.keep or Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        fspec, aspec = specs(a.maps, rule)
        fixed = run(fspec, root, a.workers)
        adaptive = run(aspec, root, a.workers)
        checked = check_prefixes(fixed, adaptive)
        print(f"same seeds, same runs: {checked} adaptive runs identical to the fixed runs of the same id "
              f"(outcome, duration, trace bytes)")

        lf, la = fixed.levels(), adaptive.levels()
        vf, va = fixed.verdicts(vrule), adaptive.verdicts(vrule)
        nf, na = len(fixed.records), len(adaptive.records)
        lev, nlev = agreement(lf, la)
        ver, nver = agreement(vf, va)
        print()
        print(f"| design | runs | simulated hours | wall s | levels (easy/challenging/very difficult) |")
        print(f"|---|---|---|---|---|")
        for name, c, lv in (("fixed", fixed, lf), ("adaptive", adaptive, la)):
            cnt = Counter(lv.values())
            print(f"| {name} | {len(c.records)} | {c.sim_hours:.2f} | {c.wall_s:.0f} | "
                  f"{cnt['easy']} / {cnt['challenging']} / {cnt['very difficult']} |")
        print()
        print(f"adaptive / fixed: runs {na / nf:.2f} ({1 - na / nf:.0%} fewer), simulated hours "
              f"{adaptive.sim_hours / fixed.sim_hours:.2f} ({1 - adaptive.sim_hours / fixed.sim_hours:.0%} fewer)")
        print(f"difficulty levels identical: {lev} of {nlev} configurations ({lev / nlev:.0%})")
        for k in lf:
            if la.get(k) != lf[k]:
                print(f"  {k[0]} {k[1]}: fixed {lf[k]}, adaptive {la.get(k)}")
        print(f"per-world verdicts (threshold {rule.threshold}, confidence {rule.confidence}) identical: "
              f"{ver} of {nver} worlds ({ver / nver:.0%})")
        pairs = Counter((vf[k], va[k]) for k in vf if k in va)
        print("  fixed -> adaptive: " + ", ".join(f"{x} -> {y}: {n}" for (x, y), n in sorted(pairs.items())))

        print()
        print("other rules (min 2, max 5), replayed on the fixed campaign's runs; verdicts compared with the "
              "fixed design's under the same rule:")
        print("| threshold | indifference | confidence | runs | fewer | levels identical | verdicts identical |")
        print("|---|---|---|---|---|---|---|")
        for t, d, c in REPLAYED:
            r2 = AdaptiveRule(2, FIXED_RUNS, t, c, d)
            rr = replay(fixed, r2)
            ok, n = agreement(lf, fixed.levels(rr))
            v2 = VerdictRule(t, c, indifference=d)
            vok, vn = agreement(fixed.verdicts(v2), fixed.verdicts(v2, rr))
            print(f"| {t} | {d} | {c} | {len(rr)} | {1 - len(rr) / nf:.0%} | {ok / n:.0%} | {vok / vn:.0%} |")


if __name__ == "__main__":
    main()
