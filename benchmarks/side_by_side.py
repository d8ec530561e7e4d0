"""Run benchmarks of this tree and of an earlier git revision side by side, in one run.

A redesign must keep the speed: this script extracts revision ``--rev`` (its ``src/`` and
``benchmarks/``) into a temporary directory, then runs each named benchmark alternately with the
earlier tree and with this one (``--rounds`` times each, earlier first in odd rounds and last in
even ones, so that a machine that gets slower or faster during the run favours neither), each in
a fresh interpreter with ``PYTHONPATH`` pointing at that tree's ``src``. Every printed figure of
the form ``<number>x real time`` or ``<number> M rays/s`` is collected by its line's label, and
the table gives, per label, the median of each tree and the ratio this / earlier (1.00 = the
same speed; figures are higher-is-better). The first round compiles both trees' numba kernels
into their own caches and is not counted unless ``--rounds 1``.

    .venv/bin/python benchmarks/side_by_side.py --rev 05b4ab1 bench_sim.py bench_loop.py \\
        [--rounds 3] [--args "bench_loop.py=--seconds 60 --repeat 1"]
"""

from __future__ import annotations

import argparse
import io
import os
import re
import shlex
import statistics
import subprocess
import sys
import tarfile
import tempfile
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
FIGURE = re.compile(r"(\d+(?:\.\d+)?)\s*(x real time|M rays/s)")


def extract(rev: str, dest: Path) -> None:
    """``src/`` and ``benchmarks/`` of git revision ``rev`` under ``dest``."""
    data = subprocess.run(["git", "archive", "--format=tar", rev, "src", "benchmarks"], cwd=REPO,
                          capture_output=True, check=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        tar.extractall(dest, filter="data")


def figures(out: str) -> dict[str, float]:
    """Label -> value of every figure in a benchmark's output (the label: the line with its
    numbers replaced by '#', up to the figure, after the last section header '== name: ...' if
    any, plus the figure's unit and its rank on the line)."""
    found: dict[str, float] = {}
    section = ""
    for line in out.splitlines():
        if line.startswith("== "):  # a section header (bench_loop: one world): part of its lines' labels
            section = line[3:].split(":")[0].strip() + ": "
        for rank, m in enumerate(FIGURE.finditer(line)):
            label = section + re.sub(r"\d+(?:\.\d+)?", "#", line[: m.start()]).strip()
            found[f"{label} [{m.group(2)} #{rank}]"] = float(m.group(1))
    return found


def run(tree: Path, bench: str, args: list[str]) -> str:
    git_dir = subprocess.run(["git", "rev-parse", "--git-common-dir"], cwd=REPO, capture_output=True, text=True,
                             check=True).stdout.strip()
    # (GIT_DIR: a benchmark that loads its own baseline revision with `git show` finds the repository
    # from the extracted tree too)
    env = dict(os.environ, PYTHONPATH=str(tree / "src"), PYTHONDONTWRITEBYTECODE="1",
               GIT_DIR=str((REPO / git_dir).resolve()))
    p = subprocess.run([sys.executable, str(tree / "benchmarks" / bench), *args], cwd=REPO, env=env,
                       capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"error: {bench} failed in {tree} (exit {p.returncode}):\n{p.stdout[-2000:]}{p.stderr[-2000:]}")
    return p.stdout


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("benches", nargs="+", help="benchmark file names under benchmarks/")
    ap.add_argument("--rev", required=True, help="the earlier git revision")
    ap.add_argument("--rounds", type=int, default=3, help="runs of each tree per benchmark (first one not counted)")
    ap.add_argument("--args", action="append", default=[], metavar="BENCH=ARGS",
                    help="arguments for one benchmark, e.g. 'bench_loop.py=--seconds 60'")
    a = ap.parse_args()
    if a.rounds < 1:
        sys.exit("error: --rounds must be at least 1")
    bench_args = {}
    for spec in a.args:
        name, _, rest = spec.partition("=")
        bench_args[name] = shlex.split(rest)
    with tempfile.TemporaryDirectory(prefix="navstress-side-by-side-") as tmp:
        old = Path(tmp)
        extract(a.rev, old)
        trees = {f"{a.rev}": old, "this tree": REPO}
        for bench in a.benches:
            vals: dict[str, dict[str, list[float]]] = {k: defaultdict(list) for k in trees}
            for r in range(a.rounds):
                order = list(trees) if r % 2 == 0 else list(trees)[::-1]
                for k in order:
                    out = run(trees[k], bench, bench_args.get(bench, []))
                    print(f"--- {bench}, round {r + 1}, {k}\n{out}", flush=True)
                    if r > 0 or a.rounds == 1:
                        for label, v in figures(out).items():
                            vals[k][label].append(v)
            print(f"=== {bench}: median of {max(1, a.rounds - 1)} round(s); ratio = this tree / {a.rev}")
            for label in vals[a.rev]:
                before, after = vals[a.rev][label], vals["this tree"].get(label)
                if not after:
                    print(f"  {label}: only in {a.rev}")
                    continue
                b, c = statistics.median(before), statistics.median(after)
                print(f"  {label:90s} {b:8.2f} {c:8.2f}  {c / b:5.2f}")


if __name__ == "__main__":
    main()
