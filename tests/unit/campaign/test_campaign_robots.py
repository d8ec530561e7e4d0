"""The robot as a campaign dimension: ``robot:`` / ``robots:`` in campaign specs (profiles, mappings
with a base and overrides, bad input named by its field path), the plan (every run on each robot,
paired seeds, run ids naming the robot), the store (robot name and digest in every record, old
stores read as rmp400 and migrated when resumed, a changed robot refused on resume and extend) and
the exports."""

from __future__ import annotations

import csv
import sqlite3
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.campaign.plan import plan
from navstress.campaign.spec import parse_campaign, spec_yaml
from navstress.campaign.store import DB_NAME, Store, read_export
from navstress.errors import SpecError, StoreError
from navstress.robot import PROFILES, RobotSpec
from navstress.run.batch import failure_record

WORLD = {"size_m": [12.0, 12.0], "cell_m": 0.5,
         "mission": {"start": [5.0, 5.0, 0.0], "goal": [6.0, 5.0], "free_radius_m": 1.0}}


def _spec(**extra: Any) -> dict[str, Any]:
    return {"name": "robots", "seed": 3, "world": WORLD, "maps_per_config": 1, "runs_per_map": 2,
            "navigators": [{"name": "nav-a"}, {"name": "nav-b"}], "faults": [None, "small-footprint"],
            "timeout_s": 5.0, "experiments": [{"name": "trees", "sweep": {"obstacles.obstruction.tree": {"values": [0, 2]}}}],
            **extra}


def _error(data: dict[str, Any]) -> SpecError:
    with pytest.raises(SpecError) as info:
        parse_campaign(data)
    assert "\n" not in str(info.value)
    return info.value


# ---- parsing ------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(PROFILES))
@pytest.mark.parametrize("where", ["robot", "robots", "experiment-robot", "experiment-robots"])
def test_every_profile_in_every_place(name: str, where: str) -> None:
    data = _spec()
    if where == "robot":
        data["robot"] = name
    elif where == "robots":
        data["robots"] = [name]
    else:
        data["experiments"][0][where.split("-")[1]] = name if where == "experiment-robot" else [name]
    spec = parse_campaign(data)
    assert [r.name for r in spec.robots_of(spec.experiments[0])] == [name]
    assert spec.robots_of(spec.experiments[0])[0] == PROFILES[name]
    # the default robot named is no robot named (the digest of before robots existed)
    assert (spec.digest() == parse_campaign(_spec()).digest()) == (name == "rmp400")


@settings(max_examples=25, deadline=None)
@given(base=st.sampled_from(sorted(PROFILES)), length=st.floats(0.2, 0.9), mass=st.floats(1.0, 200.0))
def test_mapping_with_overrides(base: str, length: float, mass: float) -> None:
    b = PROFILES[base]
    over: dict[str, Any] = {"base": base, "name": f"my-{base}", "mass_kg": mass}
    if b.footprint.shape == "box":
        over["length_m"] = max(length, b.wheelbase_m + 2 * b.wheel_radius_m)
    spec = parse_campaign(_spec(robots=["rmp400", over]))
    r = spec.robots_of(spec.experiments[0])[1]
    assert r.name == f"my-{base}" and r.mass_kg == mass and r.drive == b.drive
    assert r.wheel_radius_m == b.wheel_radius_m  # the rest from the base
    # it reads back from the stored canonical text and from a spec made in code's text
    again = parse_campaign(yaml.safe_load(spec_yaml(spec)))
    assert again.digest() == spec.digest()
    assert parse_campaign(__import__("json").loads(spec.canonical_json())).digest() == spec.digest()


@pytest.mark.parametrize("data,field,words", [
    (_spec(robot="jackall"), "robot", "did you mean jackal"),
    (_spec(robots=["rmp400", "huskie"]), "robots[1]", "did you mean husky"),
    (_spec(robots=["turtlebot"]), "robots[0]", "did you mean turtlebot4"),
    (_spec(experiments=[{"name": "e", "robot": "f1tenh"}]), "experiments[0].robot", "did you mean f1tenth"),
    (_spec(experiments=[{"name": "e", "robots": ["rmp400", "zzz"]}]), "experiments[0].robots[1]", "robot profile"),
    (_spec(robots=[{"base": "jackl"}]), "robots[0].base", "did you mean jackal"),
    (_spec(robots=["rmp400", {"base": "jackal", "mass_kg": 0}]), "robots[1].mass_kg", "> 0"),
    (_spec(robot={"base": "jackal", "lenght_m": 0.6}), "robot.lenght_m", "did you mean length_m"),
    (_spec(robot={"base": "jackal", "footprint": {"shape": "circle"}}), "robot.footprint.radius_m", "radius"),
    (_spec(robot={"drive": "differential", "wheels_per_side": 2}), "robot.wheels_per_side", "1 for a differential"),
    (_spec(robot={"base": "jackal", "max_speed_mps": "fast"}), "robot.max_speed_mps", "a number"),
    (_spec(robots=[]), "robots", "non-empty list"),
    (_spec(robots="jackal"), "robots", "non-empty list"),
    (_spec(robot=3), "robot", "robot profile name"),
    (_spec(robot=["jackal"]), "robot", "robot profile name"),
    (_spec(robots=["jackal", "jackal"]), "robots[1].name", "unique"),
    (_spec(robot="jackal", robots=["husky"]), "robot", "not both"),
    (_spec(robots=["jackal"], experiments=[{"name": "d"}, {"name": "e", "robot": {"base": "husky", "name": "jackal"}}]),
     "experiments[1].robot", "one description per robot name"),
])
def test_bad_robots_name_their_field(data: dict[str, Any], field: str, words: str) -> None:
    err = _error(data)
    assert err.field == field, str(err)
    assert words in str(err)


@pytest.mark.parametrize("name", sorted(PROFILES))
@pytest.mark.parametrize("radius", [0.2, 0.4, 0.6, 1.0])
def test_a_robot_that_does_not_fit_the_free_areas_is_refused(name: str, radius: float) -> None:
    world = {**WORLD, "mission": {**WORLD["mission"], "free_radius_m": radius}}
    r = PROFILES[name]
    data = _spec(world=world, robots=[name])
    if r.half_diagonal_m <= radius:
        parse_campaign(data)
        return
    err = _error(data)
    assert err.field.endswith("mission.free_radius_m") and err.field.startswith("experiments[0].sweep[")
    assert f"{r.half_diagonal_m:.3g}" in str(err) and name in str(err)


def test_no_free_area_asked_for_is_no_refusal() -> None:
    parse_campaign(_spec(world={**WORLD, "mission": {**WORLD["mission"], "free_radius_m": 0.0}}, robot="husky"))


# ---- plan -----------------------------------------------------------------------------------------


def test_the_plan_runs_every_run_on_each_robot_paired() -> None:
    one = plan(parse_campaign(_spec()), "/tmp/c")
    spec = parse_campaign(_spec(robots=["rmp400", "jackal"]))
    two = plan(spec, "/tmp/c")
    assert len(two.tasks) == 2 * len(one.tasks) and len({t.run_id for t in two.tasks}) == len(two.tasks)
    assert len({t.trace_path for t in two.tasks}) == len(two.tasks)
    assert len(two.streams) == 2 * len(one.streams)
    by_robot: dict[str, dict[tuple[str, int, int, str, str | None], int]] = {}
    for t in two.tasks:
        name = t.robot_spec().name
        assert t.run_id.split("/")[-2] == f"{t.navigator}@{name}"
        assert (t.robot is None) == (name == "rmp400")  # the default travels as None
        by_robot.setdefault(name, {})[(t.world_dir, t.map_index, t.run_index, t.navigator, t.fault)] = t.run_seed
    assert by_robot["rmp400"] == by_robot["jackal"]  # same worlds, same seeds: paired
    assert {t.robot_spec().digest for t in two.tasks} == {PROFILES["rmp400"].digest, PROFILES["jackal"].digest}
    # one robot: the run ids and tasks of before robots existed
    assert [t.to_json() for t in one.tasks] == [t.to_json() for t in plan(parse_campaign(_spec(robot="rmp400")), "/tmp/c").tasks]
    jackal = plan(parse_campaign(_spec(robot="jackal")), "/tmp/c")
    assert [t.run_id for t in jackal.tasks] == [t.run_id for t in one.tasks]
    assert all(t.robot_spec() == PROFILES["jackal"] for t in jackal.tasks)


def test_per_experiment_robots() -> None:
    spec = parse_campaign(_spec(robot="jackal", experiments=[
        {"name": "a", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}},
        {"name": "b", "robots": ["husky", "jackal"], "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}]))
    assert spec.several_robots and [r.name for r in spec.all_robots()] == ["jackal", "husky"]
    names = {(t.experiment, t.robot_spec().name) for t in plan(spec, "/tmp/c").tasks}
    assert names == {("a", "jackal"), ("b", "husky"), ("b", "jackal")}


# ---- store ----------------------------------------------------------------------------------------


def _fill(store: Store, wrong_robot: bool = False) -> None:
    for i, t in enumerate(store.plan().tasks):
        rec = replace(failure_record(t, "synthetic"), outcome="success" if i % 3 else "fail-collision")
        if wrong_robot:  # what a worker says of the robot is not what the store keeps: the plan is
            rec = replace(rec, robot="somebody-else", robot_digest="0" * 16)
        assert store.add(rec)


def test_records_and_exports_carry_the_robot(tmp_path: Path) -> None:
    spec = parse_campaign(_spec(robots=["rmp400", "jackal"]))
    with Store.create(tmp_path / "c", spec, yaml.safe_dump(_spec(robots=["rmp400", "jackal"]))) as s:
        _fill(s, wrong_robot=True)
        recs = s.records()
        out = s.export("csv")
        per = s.per_navigator()
    want = {"rmp400": PROFILES["rmp400"].digest, "jackal": PROFILES["jackal"].digest}
    assert {r.robot for r in recs} == set(want)
    for r in recs:
        assert r.robot_digest == want[r.robot] and r.run_id.split("/")[-2].endswith("@" + r.robot)
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert {(row["robot"], row["robot_digest"]) for row in rows} == set(want.items())
    assert len(rows) == len(recs)
    assert [p[0] for p in per] == ["nav-a@rmp400"] * 2 + ["nav-a@jackal"] * 2 + ["nav-b@rmp400"] * 2 + ["nav-b@jackal"] * 2
    assert all(p[2] == p[3] == 4 for p in per)  # 2 configs x 2 runs, each row one robot


def test_damaged_robot_column_is_one_line(tmp_path: Path) -> None:
    d = tmp_path / "c"
    with Store.create(d, parse_campaign(_spec(robots=["rmp400", "jackal"]))) as s:
        _fill(s)
    con = sqlite3.connect(d / DB_NAME)
    con.execute("UPDATE runs SET robot = 'rmp400' WHERE run_id LIKE '%@jackal/%'")
    con.commit()
    con.close()
    with pytest.raises(StoreError, match=r"column 'robot' is not valid .*'rmp400' is not its planned run's 'jackal'"):
        Store.open(d)


def _make_old(d: Path) -> int:
    """A store as navstress wrote it before robots existed: its runs table without the robot columns."""
    with Store.create(d, parse_campaign(_spec())) as s:
        _fill(s)
        n = len(s.records())
    con = sqlite3.connect(d / DB_NAME)
    con.execute("ALTER TABLE runs DROP COLUMN robot_digest")
    con.execute("ALTER TABLE runs DROP COLUMN robot")
    con.commit()
    con.close()
    return n


def test_old_store_reads_back_as_rmp400_and_is_migrated_on_resume(tmp_path: Path) -> None:
    d = tmp_path / "old"
    n = _make_old(d)
    with Store.open(d) as s:  # read only: nothing written
        recs = s.records()
        s.export("csv", tmp_path / "runs.csv")
    assert len(recs) == n and {(r.robot, r.robot_digest) for r in recs} == {("rmp400", RobotSpec().digest)}
    with open(tmp_path / "runs.csv", newline="") as f:
        assert {row["robot"] for row in csv.DictReader(f)} == {"rmp400"}
    con = sqlite3.connect(d / DB_NAME)
    assert "robot" not in {r[1] for r in con.execute("PRAGMA table_info(runs)")}
    con.close()
    with Store.create(d, parse_campaign(_spec(robot="rmp400"))) as s:  # resumed: the same campaign
        assert {(r.robot, r.robot_digest) for r in s.records()} == {("rmp400", RobotSpec().digest)}
    con = sqlite3.connect(d / DB_NAME)
    assert {"robot", "robot_digest"} <= {r[1] for r in con.execute("PRAGMA table_info(runs)")}
    con.close()


def test_resume_refuses_a_changed_robot(tmp_path: Path) -> None:
    mine = {"base": "jackal", "name": "ours"}
    d = tmp_path / "c"
    with Store.create(d, parse_campaign(_spec(robots=["rmp400", mine]))) as s:
        _fill(s)
    with pytest.raises(StoreError) as info:
        Store.create(d, parse_campaign(_spec(robots=["rmp400", {**mine, "mass_kg": 20.0}])))
    msg = str(info.value)
    assert "\n" not in msg and "robot 'ours' is described otherwise" in msg
    with pytest.raises(StoreError, match="robot 'ours' is described otherwise"):
        Store.create(d, parse_campaign(_spec(robots=["rmp400", {**mine, "mass_kg": 20.0}])), extend=True)
    with Store.create(d, parse_campaign(_spec(robots=["rmp400", mine]))) as s:  # the same robot resumes
        assert len(s.records()) == len(s.plan().tasks)


def test_extend_keeps_the_robots(tmp_path: Path) -> None:
    d = tmp_path / "c"
    base = _spec(robot="jackal")
    with Store.create(d, parse_campaign(base)) as s:
        _fill(s)
        more = {**base, "experiments": [*base["experiments"], {"name": "more", "robots": ["jackal", "husky"]}]}
        with pytest.raises(StoreError, match="a campaign keeps its number of robots"):
            s.extend(parse_campaign(more))
        changed = {**base, "robot": {"base": "jackal", "mass_kg": 18.0},
                   "experiments": [*base["experiments"], {"name": "more"}]}
        with pytest.raises(StoreError, match="robot 'jackal' is described otherwise|its robot differs from the stored one"):
            s.extend(parse_campaign(changed))
        added = s.extend(parse_campaign({**base, "experiments": [*base["experiments"], {"name": "more"}]}))
        assert added == 2 * 2 * 2  # 2 navigators x 2 faults x 2 runs
        assert {t.robot_spec().name for t in s.plan().tasks} == {"jackal"}


def test_an_export_made_before_robots_reads_back_as_rmp400(tmp_path: Path) -> None:
    with Store.create(tmp_path / "c", parse_campaign(_spec())) as s:
        _fill(s)
        out = s.export("csv")
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    old = tmp_path / "old.csv"
    with open(old, "w", newline="") as f:  # the columns of an export of before robots existed
        w = csv.DictWriter(f, [c for c in rows[0] if c not in ("robot", "robot_digest")], extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    back = read_export(old)
    assert len(back) == len(rows) and {(r["robot"], r["robot_digest"]) for r in back} == {("rmp400", RobotSpec().digest)}
    assert [r["run_id"] for r in back] == [r["run_id"] for r in read_export(out)]
