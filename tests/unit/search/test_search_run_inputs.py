"""``navstress search SPEC -o DIR``: every bad input is one line ``error: ...``, exit 2, before
anything runs, and nothing is written. A table: the spec (an unknown parameter, an empty
range, a budget of 0, an unknown objective or algorithm), the options (--budget, --workers,
--executor, --wall-limit) and the output (a file, a campaign that is no search, a search made
from another spec, a confirmation planned with another confirm_runs)."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.support.cli_inputs import SEARCH, assert_one_line_error, invoke, prepare, snapshot
from navstress.campaign.store import Store
from navstress.search.driver import _campaign, _experiment, generation_name
from navstress.search.algorithms import make_algorithm
from navstress.search.space import Space
from navstress.search.spec import parse_search


def _with(**over: Any) -> dict[str, Any]:
    d = copy.deepcopy(SEARCH)
    for path, v in over.items():
        *head, last = path.split("__")
        node = d
        for k in head:
            node = node[k]
        node[last] = v
    return d


# (case, spec, extra argv, output: "new" | "file" | "campaign" | "other-search", what the line names)
CASES: list[tuple[str, dict[str, Any], list[str], str, str]] = [
    ("unknown parameter", _with(space__parameters=[{"path": "obstacles.nope", "low": 0, "high": 1}]), [], "new",
     "space.parameters[0].path"),
    ("unknown obstacle type", _with(space__parameters=[{"path": "obstacles.obstruction.castle", "low": 0, "high": 1}]),
     [], "new", "space.parameters[0].path"),
    ("empty range", _with(space__parameters=[{"path": "obstacles.obstruction.tree", "low": 5, "high": 5}]), [], "new",
     "space.parameters[0]="),
    ("reversed range", _with(space__parameters=[{"path": "ground.deformation", "low": 2, "high": 1}]), [], "new",
     "space.parameters[0]="),
    ("no obstacle moves", _with(space__moves={"count": 0, "radius_m": 1.0}), [], "new", "space.moves.count=0"),
    ("moves of radius 0", _with(space__moves={"count": 2, "radius_m": 0}), [], "new", "space.moves.radius_m=0"),
    ("bad move in the base world", _with(world={"obstacles": {"moves": [{"at": [1, 2], "by": [0, float("nan")]}]}}),
     [], "new", "world.obstacles.moves[0].by[1]=nan"),
    ("budget 0", _with(budget={"runs": 0}), [], "new", "budget.runs=0"),
    ("budget negative", _with(budget={"runs": -3}), [], "new", "budget.runs=-3"),
    ("unknown objective", _with(objective={"name": "nope"}), [], "new", "objective.name="),
    ("unknown algorithm", _with(algorithm={"name": "nope", "batch": 2}), [], "new", "algorithm.name="),
    ("--budget 0", SEARCH, ["--budget", "0"], "new", "--budget=0"),
    ("--budget under a generation", SEARCH, ["--budget", "1"], "new", "--budget=1"),
    ("--workers 0", SEARCH, ["--workers", "0"], "new", "--workers=0"),
    ("--executor foo", SEARCH, ["--executor", "foo"], "new", "--executor="),
    ("--wall-limit 0", SEARCH, ["--wall-limit", "0"], "new", "--wall-limit="),
    # the search spec's own names, never those of the campaign it runs (navigators[0], runs_per_map)
    ("unknown navigator", _with(navigator={"name": "no-such-nav-v1"}), [], "new", "error: navigator.name="),
    ("navigator config: text for an integer", _with(navigator={"name": "reference-v1", "config": {"n_arcs": "21"}}),
     [], "new", "error: navigator.config.n_arcs='21'"),
    ("navigator config: a boolean for an integer", _with(navigator={"name": "reference-v1",
                                                                    "config": {"n_arcs": True}}),
     [], "new", "error: navigator.config.n_arcs=True"),
    ("navigator config: unknown key", _with(navigator={"name": "reference-v1", "config": {"colour": 1}}), [], "new",
     "error: navigator.config.colour=1"),
    ("navigator target that cannot be imported", _with(navigator={"name": "mine-v1", "target": "no_such_mod:f"}), [],
     "new", "error: navigator.target="),
    ("unknown fault", _with(faults=[None, "no-such-fault"], budget={"runs": 4}), [], "new",
     "error: faults='no-such-fault'"),
    ("unknown fault to reveal, faults left out", _with(objective={"name": "fault-revealing", "fault": "nofault"},
                                                       budget={"runs": 4}), [], "new",
     "error: objective.fault='nofault'"),
    ("a bad sim override", _with(sim={"timestep_s": 0}), [], "new", "error: sim.timestep_s=0"),
    ("runs_per_candidate as text", _with(runs_per_candidate="2"), [], "new", "error: runs_per_candidate='2'"),
    ("budget as text", _with(budget={"runs": "10"}), [], "new", "error: budget.runs='10'"),
    ("seed true", _with(seed=True), [], "new", "error: seed=True"),
    ("seed over 2^63 - 1", _with(seed=2**63), [], "new", "error: seed=9223372036854775808"),
    ("output is a file", SEARCH, [], "file", "exists and is not a directory"),
    ("output holds a campaign", SEARCH, [], "campaign", "which is not a search"),
    ("output holds another search", _with(seed=2), [], "other-search", "different spec"),
    ("output holds another algorithm's search", _with(algorithm={"name": "ga", "batch": 2}), [], "other-search",
     "generation 0 of the stored search differs"),
    ("output holds its confirmation made with other confirm_runs", SEARCH, [], "confirmed",
     "run with confirm_runs=3, not 1"),
]


@pytest.fixture(scope="module")
def root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The prepared folder (``c``: a campaign store), ``afile``, ``s``: the search of
    :data:`SEARCH` with its first generation planned (nothing run), and ``sc``: the same with a
    confirmation planned with another ``confirm_runs``."""
    r = tmp_path_factory.mktemp("search-inputs")
    prepare(r)
    (r / "afile").write_text("a file")
    spec = parse_search(SEARCH)
    space = Space.from_spec(spec)
    first = [space.decode(x) for x in make_algorithm(spec, space).ask()]
    Store.create(r / "s", _campaign(spec, [_experiment(generation_name(0), first)])).close()
    conf = _experiment("confirm", first[:1], 3)
    Store.create(r / "sc", _campaign(spec, [_experiment(generation_name(0), first), conf])).close()
    return r


@pytest.mark.parametrize("case,spec,argv,output,names", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_exit_2_and_nothing_written(root: Path, tmp_path: Path, case: str,
                                                          spec: dict[str, Any], argv: list[str], output: str,
                                                          names: str) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(spec), encoding="utf-8")
    out = {"new": tmp_path / "new", "file": root / "afile", "campaign": root / "c", "other-search": root / "s",
           "confirmed": root / "sc"}[output]
    before, mine = snapshot(root), snapshot(tmp_path)
    full = ["search", str(path), "-o", str(out), "-q", *argv]
    line = assert_one_line_error(*invoke(full), full)
    assert names in line and "navigators[" not in line and "runs_per_map" not in line, line
    assert snapshot(root) == before and snapshot(tmp_path) == mine
    # the same through the subcommand's own name
    full = ["search", "run", str(path), "-o", str(out), "-q", *argv]
    assert assert_one_line_error(*invoke(full), full) == line
