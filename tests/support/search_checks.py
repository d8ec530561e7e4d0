"""What every finished search directory must satisfy, checked against its campaign store: the
search's ``search.json`` says what the store holds (each evaluated world is a world of its
generation's experiment, the runs it counts are the store's records, the budget holds, the
found curve is monotone, each fitness and each confirmation is what the records give) and
the elites were confirmed with runs of experiment ``confirm`` on fresh run seeds."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml

from navstress.campaign.store import Store
from navstress.search.driver import CONFIRM, CONFIRM_KIND, generation_name
from navstress.search.objectives import by_world, confirm, evaluate, world_feasible
from navstress.search.spec import load_search


def result(out: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((out / "search.json").read_text(encoding="utf-8"))
    return data


def traces(out: Path) -> dict[str, bytes]:
    """Every run's trace bytes, by run id."""
    with Store.open(out) as s:
        return {r.run_id: (out / r.trace).read_bytes() for r in s.records() if r.trace is not None}


def check_search(out: Path) -> dict[str, Any]:
    """Assert that ``out`` is a finished search consistent with its store; returns search.json."""
    data = result(out)
    spec, _ = load_search(out / "search.yaml")
    fault = data["objective"].get("fault") if data["objective"]["name"] == "fault-revealing" else data["faults"][0]
    with Store.open(out) as s:
        done, planned = s.progress()
        assert done == planned, f"{out}: {done} of {planned} planned runs recorded"
        ids = [r[0] for r in s.con.execute("SELECT run_id FROM runs")]
        assert len(ids) == len(set(ids)) == planned and sorted(ids) == sorted(s.planned_ids())
        exps = s.spec.experiments
        records = s.records()
    gens = [e for e in exps if e.name != CONFIRM]
    assert [e.name for e in gens] == [generation_name(g) for g in range(data["generations"])]
    assert [e.name for e in exps[len(gens):]] == ([CONFIRM] if data["elites"] else [])
    groups = by_world(records)
    per_gen = {e.name: [r for r in records if r.experiment == e.name] for e in exps}
    # every evaluated candidate is one world of its generation's experiment, and the reverse
    spent = 0
    for g, e in enumerate(gens):
        evs = [v for v in data["evaluated"] if v["generation"] == g]
        worlds = {w.key: w for w in e.worlds or []}
        assert [v["key"] for v in evs] == list(worlds), f"generation {g}"
        spent += len(per_gen[e.name])
        for v in evs:
            w = worlds[v["key"]]
            assert v["map_seed"] == w.map_seed
            rs = groups.get((e.name, v["key"], 0), [])
            assert v["runs"] == len(rs) and v["runs_spent"] == spent
            assert {r.map_seed for r in rs} <= {w.map_seed}
            wdir = out / "worlds" / e.name / v["key"] / "m0"
            ev = evaluate(spec.objective.name, rs, fault=fault, failure_class=spec.objective.outcome,
                          target=spec.objective.target, feasible=world_feasible(wdir) if wdir.exists() else None)
            assert (v["fitness"], v["events"], v["trials"]) == (ev.fitness, ev.events, ev.trials), v["key"]
    # runs counted = the store's records; the budget holds
    assert data["runs"] == spent == sum(v["runs"] for v in data["evaluated"])
    assert data["confirm_runs"] == len(per_gen.get(CONFIRM, []))
    assert data["runs"] <= data["budget"]["runs"]
    if data["stopped"] == "budget.runs":  # one more generation would not have fitted
        assert data["runs"] + spec.generation_runs() > data["budget"]["runs"]
    # the found curve: from (0, 0), one point per generation, runs increasing, found never lower
    curve = data["found_curve"]
    assert curve[0] == [0, 0] and len(curve) == data["generations"] + 1
    assert all(a[0] < b[0] and a[1] <= b[1] for a, b in zip(curve, curve[1:])), curve
    assert curve[-1] == [data["runs"], data["found"]]
    assert data["found"] == len({v["key"] for v in data["evaluated"] if v["found"]})
    # elites: worlds whose runs showed the event, re-run in `confirm` with fresh run seeds
    found = {v["key"] for v in data["evaluated"] if v["found"]}
    assert len(data["elites"]) <= spec.elites and len({e["key"] for e in data["elites"]}) == len(data["elites"])
    for el in data["elites"]:
        assert el["key"] in found
        conf = groups.get((CONFIRM, el["key"], 0), [])
        assert len(conf) == spec.confirm_runs * len(spec.faults), el["key"]
        seen = {r.run_seed for (x, k, _), rs in groups.items() if x != CONFIRM and k == el["key"] for r in rs}
        assert seen and not seen & {r.run_seed for r in conf}, f"{el['key']}: a confirmation run seed was seen before"
        k = confirm(conf, CONFIRM_KIND[spec.objective.name], fault=fault, failure_class=spec.objective.outcome,
                    target=spec.objective.target)
        assert el["confirmed"] == k.confirmed and el["confirmation"] == json.loads(json.dumps(k.to_json()))
    assert data["confirmed"] == sum(e["confirmed"] for e in data["elites"])
    check_suite(out, data)
    return data


def check_suite(out: Path, data: dict[str, Any]) -> None:
    """suite/: suite.json lists every elite and its verdict; suite.yaml (only when some elite is
    confirmed) is a campaign of exactly the confirmed worlds, each world copied into worlds/KEY."""
    suite = out / "suite"
    info = json.loads((suite / "suite.json").read_text(encoding="utf-8"))
    assert [(w["key"], w["confirmed"]) for w in info["worlds"]] == [(e["key"], e["confirmed"]) for e in data["elites"]]
    confirmed = [e for e in data["elites"] if e["confirmed"]]
    assert data["suite"] == ("suite/suite.yaml" if confirmed else None)
    if not confirmed:
        assert sorted(p.name for p in suite.iterdir()) == ["suite.json"]
        return
    camp = yaml.safe_load((suite / "suite.yaml").read_text(encoding="utf-8"))
    assert [e["name"] for e in camp["experiments"]] == ["suite"]
    assert camp["experiments"][0]["worlds"] == [{"key": e["key"], "map_seed": e["map_seed"], "world": e["world"]}
                                               for e in confirmed]
    assert sorted(p.name for p in (suite / "worlds").iterdir()) == sorted(e["key"] for e in confirmed)
    for e in confirmed:
        assert (suite / "worlds" / e["key"] / "world.json").read_bytes() == \
            (out / "worlds" / CONFIRM / e["key"] / "m0" / "world.json").read_bytes()
