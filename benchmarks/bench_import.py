"""Import time of navstress and of its plug-in contract, in fresh interpreters.

    python benchmarks/bench_import.py [--n 15]

Prints the median wall time of ``python -c "import M"`` over N fresh interpreters for
``navstress``, ``navstress.nav.api`` and ``navstress.cli``, the time of ``navstress --help``, and
what every worker process and command pays before it works: the modules a campaign or ``run``
worker imports before it answers "ready", and the modules of the ``run`` and ``campaign``
commands, beside ``python -c pass`` (the interpreter's own start-up). Target: ``import
navstress`` < 0.2 s. Run it in two checkouts to compare revisions.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

CASES = [("python -c pass", ["-c", "pass"]),
         ("import navstress", ["-c", "import navstress"]),
         ("import navstress.nav.api", ["-c", "import navstress.nav.api"]),
         ("import navstress.cli", ["-c", "import navstress.cli"]),
         ("navstress --help", ["-m", "navstress.cli", "--help"]),
         ("a worker's imports", ["-c", "import navstress.campaign.work, navstress.run.mission, "
                                 "navstress.sim.simulation, navstress.nav.reference"]),
         ("navstress run's modules", ["-c", "import navstress.cli.run"]),
         ("navstress campaign's modules", ["-c", "import navstress.cli.campaign"])]


def median_s(args: list[str], n: int) -> float:
    times = []
    for _ in range(n):
        t = time.perf_counter()
        subprocess.run([sys.executable, *args], check=True, stdout=subprocess.DEVNULL)
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=15, help="fresh interpreters per case")
    n = ap.parse_args().n
    base = median_s(CASES[0][1], n)
    print(f"{'case':<28} {'median s':>9} {'minus baseline s':>17}")
    for name, args in CASES:
        t = base if args is CASES[0][1] else median_s(args, n)
        print(f"{name:<28} {t:>9.3f} {t - base:>17.3f}")


if __name__ == "__main__":
    main()
