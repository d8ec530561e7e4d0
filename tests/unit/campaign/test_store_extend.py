"""``Store.extend``: a spec whose experiments extend the stored ones adds their planned runs and
becomes the stored spec in one transaction; anything else is refused and changes nothing; a
SIGKILL at any moment of an extension leaves a consistent store (real subprocesses, real SQLite)."""

from __future__ import annotations

import copy
import json
import signal
import subprocess
import sys
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
import yaml

from navstress.campaign.plan import plan
from navstress.campaign.spec import CampaignSpec, load_campaign, parse_campaign
from navstress.campaign.store import Store, read_export
from navstress.errors import SpecError, StoreError
from navstress.run.batch import failure_record


def gen(g: int, n: int = 2) -> dict[str, Any]:
    """Generation ``g``: an experiment of ``n`` explicit worlds."""
    return {"name": f"g{g:04d}", "worlds": [{"key": f"c{i}", "map_seed": 100 * g + i,
                                             "world": {"obstacles": {"obstruction": {"tree": i}}}}
                                            for i in range(n)]}


def spec_data(generations: int, **over: Any) -> dict[str, Any]:
    d: dict[str, Any] = {
        "name": "grow", "seed": 4, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
        "experiments": [{"name": "base", "sweep": {"obstacles.obstruction.tree": {"values": [0, 2]}}}]
        + [gen(g) for g in range(generations)],
        "maps_per_config": 2, "runs_per_map": 2, "faults": [None, "small-footprint"]}
    d.update(over)
    return d


def spec_of(data: dict[str, Any]) -> tuple[CampaignSpec, str]:
    text = yaml.safe_dump(data, sort_keys=False)
    return parse_campaign(data), text


def _meta(s: Store) -> dict[str, str]:
    return {r[0]: r[1] for r in s.con.execute("SELECT key, value FROM meta")}


def test_extend_adds_the_new_runs_and_becomes_the_stored_spec(tmp_path: Path) -> None:
    a, ta = spec_of(spec_data(1))
    b, tb = spec_of(spec_data(3))
    with Store.create(tmp_path, a, ta) as s:
        before = s.planned_ids()
        s.add(failure_record(s.task(before[0]), "recorded before the extension"))
        added = s.extend(b, tb)
        assert added == 2 * 2 * 2 * 2  # two generations x 2 worlds x 2 runs x 2 faults
        assert s.planned_ids() == [t.run_id for t in plan(b, tmp_path).tasks]  # plan order = seq order
        assert s.planned_ids()[:len(before)] == before and s.spec == b
        assert s.progress() == (1, len(before) + added)
        pending = {t.run_id for t in s.pending()}
        assert {t.run_id for t in plan(b, tmp_path).tasks if t.experiment in ("g0001", "g0002")} <= pending
        t = s.task("g0002/c1/m0/r1/reference-v1/small-footprint")
        assert (t.map_seed, t.config) == (201, {"obstacles.obstruction.tree": 1})
        assert _meta(s)["spec_digest"] == b.digest() and _meta(s)["spec_json"] == b.canonical_json()
        assert s.extend(b, tb) == 0  # the stored spec again: nothing to add
    assert (tmp_path / "spec.yaml").read_text() == tb
    with Store.open(tmp_path) as s:  # a reader sees the grown campaign
        assert s.spec == b and s.progress() == (1, len(s.planned_ids()))
    spec, _ = load_campaign(tmp_path / "spec.yaml")
    with Store.create(tmp_path, spec, tb) as s:  # and the CLI's resume with spec.yaml works
        assert s.spec.digest() == b.digest()


def test_extend_works_through_several_generations_with_adaptive_runs(tmp_path: Path) -> None:
    d = spec_data(0, runs_per_map={"adaptive": {"min": 2, "max": 4}})
    spec, text = spec_of(d)
    with Store.create(tmp_path, spec, text) as s:
        for g in range(4):
            d = copy.deepcopy(d)
            d["experiments"].append(gen(g, n=g + 1))
            spec, text = spec_of(d)
            assert s.extend(spec, text) == (g + 1) * 4 * 2
        assert s.planned_ids() == [t.run_id for t in plan(spec, tmp_path).tasks]
        assert len(s.pending()) == sum(2 * 2 * 2 for _ in range(2)) + sum((g + 1) * 2 * 2 for g in range(4))


def _refused(base: dict[str, Any]) -> list[tuple[str, dict[str, Any], str]]:
    out: list[tuple[str, dict[str, Any], str]] = []

    def case(name: str, words: str, change: Any) -> None:
        d = copy.deepcopy(base)
        change(d)
        out.append((name, d, words))

    case("seed", "its seed differs", lambda d: d.update(seed=5))
    case("name", "its name differs", lambda d: d.update(name="other"))
    case("navigators", "its navigators differ", lambda d: d.update(navigators=[{"name": "other-v1"}]))
    case("faults", "its faults differ", lambda d: d.update(faults=[None]))
    case("runs_per_map", "its runs_per_map differs", lambda d: d.update(runs_per_map=3))
    case("maps_per_config", "its maps_per_config differs", lambda d: d.update(maps_per_config=1))
    case("world", "its world differs", lambda d: d["world"].update(cell_m=0.4))
    case("timeout", "its timeout_s differs", lambda d: d.update(timeout_s=10.0))
    case("sim", "its sim differs", lambda d: d.update(sim={"physics_hz": 500}))
    case("stored experiment changed", "experiments[1] ('g0000') is changed",
         lambda d: d["experiments"][1]["worlds"][0].update(map_seed=7))
    case("stored experiment replaced", "experiments[1] ('g0009') is another experiment",
         lambda d: d["experiments"].__setitem__(1, gen(9)))
    case("stored experiment dropped", "experiments[1] ('g0001') is another experiment",
         lambda d: d["experiments"].pop(1))
    case("stored experiments reordered", "experiments[0] ('g0001') is another experiment",
         lambda d: d["experiments"].reverse())
    case("new experiment first", "experiments[0] ('g0005') is another experiment",
         lambda d: d["experiments"].insert(0, gen(5)))
    return out


REFUSED = _refused(spec_data(2))


@pytest.mark.parametrize("data,words", [c[1:] for c in REFUSED], ids=[c[0] for c in REFUSED])
def test_extend_refuses_a_spec_that_does_not_extend_and_changes_nothing(tmp_path: Path, data: dict[str, Any],
                                                                        words: str) -> None:
    a, ta = spec_of(spec_data(2))
    data = copy.deepcopy(data)
    data["experiments"].append(gen(7))  # every refused spec also adds an experiment
    b, tb = spec_of(data)
    with Store.create(tmp_path, a, ta) as s:
        ids, meta = s.planned_ids(), _meta(s)
        with pytest.raises(StoreError) as ei:
            s.extend(b, tb)
        msg = str(ei.value)
        assert words in msg and "\n" not in msg and "adding experiments at the end" in msg, msg
        assert s.planned_ids() == ids and _meta(s) == meta and s.spec == a
    assert (tmp_path / "spec.yaml").read_text() == ta
    with pytest.raises(StoreError):  # Store.create's opt-in refuses the same way
        Store.create(tmp_path, b, tb, extend=True)
    with Store.open(tmp_path) as s:
        assert s.planned_ids() == ids and s.spec == a


def test_extend_refuses_a_spec_with_fewer_experiments(tmp_path: Path) -> None:
    a, ta = spec_of(spec_data(3))
    b, tb = spec_of(spec_data(1))
    with Store.create(tmp_path, a, ta) as s:
        with pytest.raises(StoreError, match=r"it has 2 experiments, fewer than the stored 4 \('g0001', 'g0002' "
                                             r"missing\)"):
            s.extend(b, tb)
        assert s.spec == a


def test_create_refuses_an_extending_spec_unless_asked_to_extend(tmp_path: Path) -> None:
    a, ta = spec_of(spec_data(1))
    b, tb = spec_of(spec_data(2))
    with Store.create(tmp_path, a, ta):
        pass
    with pytest.raises(StoreError, match="different spec"):
        Store.create(tmp_path, b, tb)
    with Store.create(tmp_path, b, tb, extend=True) as s:
        assert s.spec == b and s.planned_ids() == [t.run_id for t in plan(b, tmp_path).tasks]
    assert (tmp_path / "spec.yaml").read_text() == tb


def test_extend_needs_the_write_lock_and_the_matching_text(tmp_path: Path) -> None:
    a, ta = spec_of(spec_data(1))
    b, tb = spec_of(spec_data(2))
    with Store.create(tmp_path, a, ta) as s:
        with pytest.raises(SpecError, match="spec_text"):
            s.extend(b, ta)
        assert s.spec == a
    with Store.open(tmp_path) as s, pytest.raises(StoreError, match="reading only"):
        s.extend(b, tb)


def test_a_kill_between_the_transaction_and_the_file_is_repaired(tmp_path: Path) -> None:
    """The state a SIGKILL right after the commit leaves (database extended, spec.yaml the old
    copy): the next write-open restores spec.yaml from the database, so resuming with it works."""
    a, ta = spec_of(spec_data(1))
    b, tb = spec_of(spec_data(2))
    with Store.create(tmp_path, a, ta) as s:
        s.extend(b, tb)
    (tmp_path / "spec.yaml").write_text(ta)  # the old copy, as a kill before the rename leaves it
    with Store.open(tmp_path) as s:
        assert s.spec == b  # the database is the truth
    with pytest.raises(StoreError, match="different spec"):
        Store.create(tmp_path, a, ta)  # resuming with the old spec is refused ...
    assert (tmp_path / "spec.yaml").read_text() == tb  # ... and spec.yaml holds the stored spec again
    spec, text = load_campaign(tmp_path / "spec.yaml")
    with Store.create(tmp_path, spec, text) as s:
        assert s.spec == b
    (tmp_path / "spec.yaml").write_text(ta)
    with Store.create(tmp_path, b, tb, extend=True) as s:  # extending again with the stored spec repairs it too
        assert s.extend(b, tb) == 0
    assert (tmp_path / "spec.yaml").read_text() == tb


EXTENDER = r"""
import sys, yaml
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import Store
sys.path.insert(0, sys.argv[2])
from test_store_extend import spec_data
root = sys.argv[1]
g = 0
try:
    with Store.open(root) as r:
        g = len(r.spec.experiments) - 1
except Exception:
    pass
d = spec_data(g)
with Store.create(root, parse_campaign(d), yaml.safe_dump(d, sort_keys=False)) as s:
    print("ready", flush=True)
    while True:
        d = spec_data(g + 1)
        s.extend(parse_campaign(d), yaml.safe_dump(d, sort_keys=False))
        g += 1
"""


def _consistent(root: Path) -> int:
    """The store after a kill: its planned runs are exactly its stored spec's plan, and the
    next write-open leaves a spec.yaml that resumes it. Returns the stored generations."""
    with Store.open(root) as s:
        spec = s.spec
        assert s.planned_ids() == [t.run_id for t in plan(spec, root).tasks]
        assert s.con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        assert {r[0] for r in s.con.execute("SELECT DISTINCT experiment FROM planned")} == \
            {e.name for e in spec.experiments}
    with Store.create(root, spec, "ignored: the store exists") as s:
        assert s.spec == spec
    on_disk, _ = load_campaign(root / "spec.yaml")
    assert on_disk == spec
    return len(spec.experiments) - 1


def test_sigkill_at_any_moment_of_extensions_leaves_a_consistent_store(tmp_path: Path) -> None:
    """A process extends a store generation after generation; SIGKILL it at several moments
    (each kill's store resumed by the next process): every time, the planned table is exactly
    the stored spec's plan, and spec.yaml is (or is made) that spec's text."""
    here = str(Path(__file__).resolve().parent)
    seen = [0]
    for delay_s in (0.0, 0.1, 0.3):
        proc = subprocess.Popen([sys.executable, "-c", EXTENDER, str(tmp_path), here], stdout=subprocess.PIPE)
        assert proc.stdout is not None and proc.stdout.readline() == b"ready\n"
        time.sleep(delay_s)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        assert proc.returncode == -signal.SIGKILL
        seen.append(_consistent(tmp_path))
    assert seen == sorted(seen) and seen[-1] > 1, seen  # it grew, and no kill lost a committed generation


def test_extended_records_and_export_keep_plan_order(tmp_path: Path) -> None:
    a, ta = spec_of(spec_data(1))
    b, tb = spec_of(spec_data(2))
    with Store.create(tmp_path, a, ta) as s:
        s.extend(b, tb)
        ids = s.planned_ids()
        for rid in reversed([ids[0], ids[-1], ids[len(ids) // 2]]):
            s.add(replace(failure_record(s.task(rid), "x"), outcome="success"))
        assert [r.run_id for r in s.records()] == [ids[0], ids[len(ids) // 2], ids[-1]]
        out = s.export("csv", tmp_path / "runs.csv")
    rows = read_export(out)
    assert [r["run_id"] for r in rows] == [ids[0], ids[len(ids) // 2], ids[-1]]
    assert json.loads(rows[2]["params"]) == {"obstacles.obstruction.tree": 1} and rows[2]["config"] == "c1"


def test_records_of_one_experiment_are_that_experiments_records_in_plan_order(tmp_path: Path) -> None:
    a, ta = spec_of(spec_data(3))
    with Store.create(tmp_path, a, ta) as s:
        ids = s.planned_ids()
        for rid in reversed(ids[::3]):  # recorded out of plan order, every experiment touched
            s.add(failure_record(s.task(rid), "x"))
        every = s.records()
        exps = {r.experiment for r in every}
        assert exps == {"base", "g0000", "g0001", "g0002"}
        for e in sorted(exps) + ["none-such"]:
            assert [r.run_id for r in s.records(e)] == [r.run_id for r in every if r.experiment == e]
        assert s.recorded_by_experiment() == Counter(r.experiment for r in every)
