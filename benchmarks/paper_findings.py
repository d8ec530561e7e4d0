"""Which of the paper's qualitative findings hold, per stack, in campaigns' ``analyze --json`` output.

Reads the JSON that ``navstress analyze DIR --navigator NAV --json FILE`` writes (one file per
campaign and navigator) and prints, per navigator, a markdown table of the paper's findings with
the figures behind each verdict:

1. difficulty rises with each swept parameter (Spearman's rank correlation of the nominal success
   rate with the parameter, per class: negative, p < 0.05, holds);
2. many small trees are far harder than few large buildings at equal obstruction (mean nominal
   success over the obstruction values both classes sweep);
3. more subdivisions make a given deformation harder (classes named ``<prefix>-s<N>`` swept over
   ``ground.deformation``: at each d they share, the Spearman correlation of success with s);
4. the footprint fault is revealed more among trees (the faulty runs' collision share, trees
   against buildings; the nominal runs' share beside it);
5. indeterminism of meters to tens of meters at every level (per level, the range over its
   configurations of the indeterminism curve's peak: at each time the largest distance between
   runs on one map, averaged over the configuration's maps).

    .venv/bin/python benchmarks/paper_findings.py --navigator reference-v1 OBSTRUCTION.json GROUND.json
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
from collections import defaultdict
from typing import Any

from scipy import stats


def load(paths: list[str]) -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[dict[str, Any]]]:
    configs, fault_power, indet = [], [], []
    for p in paths:
        with open(p, encoding="utf-8") as fh:
            d = json.load(fh)
        nav = d["navigator"]
        configs += [c for c in d["configurations"] if c["navigator"] == nav]
        fault_power += [f for f in d["fault_power"] if f["navigator"] == nav]
        levels = {(c["experiment"], c["config"]): c.get("level") for c in d["configurations"]
                  if c["navigator"] == nav and c["fault"] == "nominal"}
        indet += [dict(i, level=levels.get((i["experiment"], i["config"]))) for i in d["indeterminism"]
                  if i["group"] == "all"]
    return configs, fault_power, indet


def param(c: dict[str, Any]) -> float:
    (value,) = c["params"].values()
    return float(value)


def nominal(configs: list[dict[str, Any]]) -> dict[str, list[tuple[float, float]]]:
    by_class: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for c in configs:
        if c["fault"] == "nominal" and c["success_rate"] is not None:
            by_class[c["experiment"]].append((param(c), c["success_rate"]))
    return {k: sorted(v) for k, v in by_class.items()}


def rises(classes: dict[str, list[tuple[float, float]]]) -> list[str]:
    out = []
    for name, pts in classes.items():
        xs, ys = zip(*pts)
        if len(set(ys)) < 2:
            out.append(f"{name}: success {ys[0]:.0%} everywhere (no trend)")
            continue
        r = stats.spearmanr(xs, ys)
        out.append(f"{name}: rho {r.statistic:+.2f} (p {r.pvalue:.2g}), success {ys[0]:.0%} -> {ys[-1]:.0%}")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--navigator", required=True)
    ap.add_argument("files", nargs="+")
    a = ap.parse_args()
    configs, fault_power, indet = load(a.files)
    classes = nominal(configs)
    print(f"### {a.navigator}\n")
    print("| finding | figures |\n|---|---|")
    print("| difficulty rises with each parameter | " + "; ".join(rises(classes)) + " |")
    if "trees" in classes and "buildings" in classes:
        b, t = dict(classes["buildings"]), dict(classes["trees"])
        common = sorted(set(b) & set(t))
        print(f"| trees harder than buildings at equal obstruction | at {', '.join(f'{x:g}' for x in common)} %: mean "
              f"success trees {statistics.fmean(t[x] for x in common):.0%}, buildings "
              f"{statistics.fmean(b[x] for x in common):.0%}; trees lower at {sum(t[x] < b[x] for x in common)} of "
              f"{len(common)}, higher at {sum(t[x] > b[x] for x in common)} |")
    groups: dict[str, dict[int, dict[float, float]]] = defaultdict(dict)
    for name, pts in classes.items():
        m = re.fullmatch(r"(.*)-s(\d+)", name)
        if m:
            groups[m.group(1)][int(m.group(2))] = dict(pts)
    for prefix, by_s in sorted(groups.items()):
        common = sorted(set.intersection(*(set(v) for v in by_s.values())))
        rhos = []
        harder = easier = 0
        for d in common:
            ss = sorted(by_s)
            ys = [by_s[s][d] for s in ss]
            harder += ys[-1] < ys[0]
            easier += ys[-1] > ys[0]
            if len(set(ys)) > 1:
                rhos.append(stats.spearmanr(ss, ys).statistic)
        mean = f"mean rho {statistics.fmean(rhos):+.2f} over {len(rhos)} d" if rhos else "success equal for every s at every d"
        print(f"| more subdivisions harder at equal deformation ({prefix}) | at d = {', '.join(f'{x:g}' for x in common)}: "
              f"s={max(by_s)} below s={min(by_s)} at {harder}, above at {easier}; {mean} |")
    per_class: dict[str, list[int]] = defaultdict(lambda: [0, 0, 0, 0])
    for f in fault_power:
        acc = per_class[f["experiment"]]
        acc[0] += f["collisions"]
        acc[1] += f["runs"]
        acc[2] += f["nominal_collisions"]
        acc[3] += f["nominal_runs"]
    if per_class:
        parts = [f"{k}: faulty {v[0]}/{v[1]} runs with a collision ({v[0] / max(v[1], 1):.0%}), nominal {v[2]}/{v[3]}"
                 for k, v in sorted(per_class.items())]
        print("| footprint fault revealed more among trees | " + "; ".join(parts) + " |")
    by_level: dict[str, list[float]] = defaultdict(list)
    for i in indet:
        if i["level"] is not None and i["mean_m"] is not None:
            by_level[i["level"]].append(i["peak_m"])
    parts = [f"{lv}: {min(v):.1f}-{max(v):.1f} m (median {statistics.median(v):.1f} m, {len(v)} configurations)"
             for lv, v in sorted(by_level.items())]
    print("| indeterminism per level (peak over time of the largest distance between runs on one map, averaged over the maps) | "
          + "; ".join(parts) + " |")


if __name__ == "__main__":
    main()
