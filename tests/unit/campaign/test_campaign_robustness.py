"""Bad input around campaigns, each a one-line error (exit 2) that writes nothing:

- what a killed store creation leaves behind (every family of leftover files) is redone;
- navigator configs (every built-in navigator, a third-party hook) and ``sim:`` configs are
  validated before the directory is created, in ``campaign run``, ``run`` and ``nav check``;
- plans too big to run are refused from their size, before any sweep is expanded;
- damaged stores (missing tables, bad JSON, truncated or foreign files) x every command that
  opens a store.
"""

from __future__ import annotations

import json
import math
import sqlite3
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from navstress.run.batch import failure_record
from navstress.campaign.presets import demo, preset_yaml
from navstress.campaign.spec import MAX_PLANNED_RUNS, parse_campaign, parse_campaign_text, planned_runs
from navstress.campaign.plan import plan
from navstress.campaign.store import _CREATION_LEFTOVERS, Store
from navstress.cli import app
from navstress.errors import SpecError
from tests.support.world_fixtures import small_world

TEXT = preset_yaml("demo")
SPEC = parse_campaign(demo())


def cli(*args: str) -> tuple[int, str, str]:
    r = CliRunner().invoke(app, list(args))
    return r.exit_code, r.stdout, r.stderr


def assert_one_line_error(code: int, err: str, *needles: str) -> None:
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: "), (code, err)
    for n in needles:
        assert n in lines[0], (n, lines[0])


# ---- store creation killed at any moment ------------------------------------------------------


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(names=st.sets(st.sampled_from(_CREATION_LEFTOVERS)), junk=st.binary(max_size=2000),
       old_spec=st.booleans())
def test_creation_leftovers_are_redone(tmp_path_factory: pytest.TempPathFactory, names: set[str], junk: bytes,
                                       old_spec: bool) -> None:
    """Whatever a killed creation left (temp database and its journals, a stray WAL of the final
    name, the spec's temp file, an older spec.yaml), the next creation starts over and succeeds."""
    d = tmp_path_factory.mktemp("c")
    for n in names:
        (d / n).write_bytes(junk)
    if old_spec:
        (d / "spec.yaml").write_text("name: half-made\n")
    with Store.create(d, SPEC, TEXT) as s:
        assert s.progress() == (0, len(plan(SPEC, d).tasks))
        assert s.con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    assert (d / "spec.yaml").read_text() == TEXT
    left = {p.name for p in d.iterdir()} & set(_CREATION_LEFTOVERS)
    assert left <= {"campaign.sqlite-wal", "campaign.sqlite-shm"}  # only the live database's own
    with Store.create(d, SPEC, TEXT) as s:  # and it resumes
        assert s.progress()[0] == 0


def test_foreign_files_still_refused(tmp_path: Path) -> None:
    (tmp_path / ".campaign.sqlite.tmp-journal").write_bytes(b"x")
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(Exception, match="not a campaign"):
        Store.create(tmp_path, SPEC, TEXT)
    assert (tmp_path / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == [".campaign.sqlite.tmp-journal", "notes.txt"]  # no .lock


@pytest.mark.parametrize("workers", ["0", "-1", "1025", str(10**9)])
def test_campaign_run_workers_out_of_range_is_one_line(tmp_path: Path, workers: str) -> None:
    from typer.testing import CliRunner

    from navstress.cli import app

    spec = tmp_path / "s.yaml"
    spec.write_text(TEXT)
    res = CliRunner().invoke(app, ["campaign", "run", str(spec), "-o", str(tmp_path / "out"), "-j", workers])
    assert res.exit_code == 2 and "--workers" in res.output and "[1, 1024]" in res.output, res.output
    assert not (tmp_path / "out").exists()


# ---- configs validated before anything runs -----------------------------------------------------


def _spec(**over: Any) -> dict[str, Any]:
    d: dict[str, Any] = {
        "name": "v", "seed": 1, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
        "experiments": [{"name": "flat", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
        "maps_per_config": 1, "runs_per_map": 1, "navigators": [{"name": "reference-v1"}], "timeout_s": 5.0}
    d.update(over)
    return d


def _not_executable(tmp: Path) -> str:
    p = tmp / "nav.sh"
    p.write_text("#!/bin/sh\nexit 0\n")
    p.chmod(0o644)
    return str(p)


# (navigator entry, the field the error must name relative to navigators[1].config)
BAD_NAVIGATORS: list[tuple[dict[str, Any], str]] = [
    ({"name": "reference-v1", "config": {"bogus": 1}}, "bogus=1"),
    ({"name": "reference-v1", "config": {"max_slope_deg": "steep"}}, "max_slope_deg='steep' is invalid: expected a number"),
    ({"name": "reference-v1", "config": {"max_slope_deg": math.nan}}, "max_slope_deg=nan"),
    ({"name": "reference-v1", "config": {"n_arcs": 2.5}}, "n_arcs=2.5"),
    ({"name": "reference-v1", "config": {"n_arcs": 20, "turn_in_place": False}}, "n_arcs=20"),
    ({"name": "reference-v1", "config": {"cell_m": math.inf}}, "cell_m=inf"),
    ({"name": "reference-v1", "config": {"turn_in_place": "maybe"}}, "turn_in_place='maybe'"),
    ({"name": "reference-global-v1", "config": {"carrot_m": -1}}, "carrot_m=-1"),
    ({"name": "reference-global-v1", "config": {"bogus": [1]}}, "bogus=[1]"),
    ({"name": "external-v1", "config": {"command": ["/no/such/bin"]}}, "command=['/no/such/bin']"),
    ({"name": "external-v1", "config": {"command": "NOT_EXECUTABLE"}}, "command="),
    ({"name": "external-v1", "config": {}}, "command is missing"),
    ({"name": "external-v1", "config": {"command": []}}, "command=[]"),
    ({"name": "external-v1", "config": {"command": ["sleep", "1"], "step_budget_s": 0}}, "step_budget_s=0"),
    ({"name": "external-v1", "config": {"command": ["sleep", "1"], "reset_budget_s": math.nan}}, "reset_budget_s=nan"),
    ({"name": "external-v1", "config": {"command": ["sleep", "1"], "cwd": "/no/such/dir"}}, "cwd='/no/such/dir'"),
    ({"name": "external-v1", "config": {"command": ["sleep", "1"], "env": {"A": 1}}}, "env="),
    ({"name": "external-v1", "config": {"command": ["sleep"], "budget": 1}}, "budget=1"),
    ({"name": "validated-v1", "target": "tests.support.navigators.campaign_navs:Validated", "config": {"gain": 99}}, "gain=99"),
    ({"name": "validated-v1", "target": "tests.support.navigators.campaign_navs:Validated", "config": {"gian": 1}}, "gian=1"),
]

BAD_SIMS: list[tuple[dict[str, Any], str]] = [
    ({"bogus": 1}, "sim.bogus=1"),
    ({"timestep_s": 0}, "sim.timestep_s=0"),
    ({"timestep_s": math.nan}, "sim.timestep_s=nan"),
    ({"timestep_s": math.inf}, "sim.timestep_s=inf"),
    ({"timestep_s": -0.01}, "sim.timestep_s=-0.01"),
    ({"timestep_s": "fast"}, "sim.timestep_s='fast'"),
    ({"friction": -0.5}, "sim.friction=-0.5"),
    ({"noise": "yes"}, "sim.noise='yes'"),
    ({"solver_iterations": 2.5}, "sim.solver_iterations=2.5"),
    ({"obstacle_pool": True}, "sim.obstacle_pool=True"),
    ({"pose_rate_hz": [10]}, "sim.pose_rate_hz=[10]"),
    ({"lidar": {"channels": 0}}, "sim.lidar.channels=0"),
    ({"lidar": {"chanels": 8}}, "sim.lidar.chanels=8"),
    ({"lidar": 3}, "sim.lidar=3"),
]


def _fill(entry: dict[str, Any], tmp: Path) -> dict[str, Any]:
    e = json.loads(json.dumps(entry))
    if e.get("config", {}).get("command") == "NOT_EXECUTABLE":
        e["config"]["command"] = [_not_executable(tmp)]
    return e


def _refused_then_reusable(tmp: Path, bad: dict[str, Any], needle: str) -> None:
    spec = tmp / "spec.yaml"
    spec.write_text(yaml.safe_dump(bad))
    out = tmp / "out"
    code, _o, err = cli("campaign", "run", str(spec), "-o", str(out), "-q")
    assert_one_line_error(code, err, needle)
    assert not out.exists()  # nothing written: the directory takes a corrected spec
    good = parse_campaign(_spec())
    with Store.create(out, good, yaml.safe_dump(_spec())) as s:
        assert s.progress() == (0, 1)


@pytest.mark.parametrize("entry,field", BAD_NAVIGATORS, ids=[f"{e['name']}-{f.split('=')[0]}" for e, f in BAD_NAVIGATORS])
def test_campaign_run_validates_navigator_configs(tmp_path: Path, entry: dict[str, Any], field: str) -> None:
    bad = _spec(navigators=[{"name": "first-v1", "target": "tests.support.navigators.campaign_navs:Exits"}, _fill(entry, tmp_path)])
    _refused_then_reusable(tmp_path, bad, f"navigators[1].config.{field}")


@pytest.mark.parametrize("sim,field", BAD_SIMS, ids=[f.split("=")[0] for _s, f in BAD_SIMS])
def test_campaign_run_validates_sim_configs(tmp_path: Path, sim: dict[str, Any], field: str) -> None:
    _refused_then_reusable(tmp_path, _spec(sim=sim), field)


@pytest.mark.parametrize("entry,field", [b for b in BAD_NAVIGATORS if "target" not in b[0]],
                         ids=[f"{e['name']}-{f.split('=')[0]}" for e, f in BAD_NAVIGATORS if "target" not in e])
def test_run_and_nav_check_validate_the_same_way(tmp_path: Path, entry: dict[str, Any], field: str) -> None:
    e = _fill(entry, tmp_path)
    cfg = tmp_path / "nav.json"
    cfg.write_text(json.dumps(e["config"]))
    small_world().save(tmp_path / "w")
    code, _o, err = cli("run", str(tmp_path / "w"), "-o", str(tmp_path / "out"), "--navigator", e["name"],
                        "--navigator-config", str(cfg))
    assert_one_line_error(code, err, f"navigator-config.{field}")
    assert not (tmp_path / "out").exists()
    code, _o, err = cli("nav", "check", e["name"], "--navigator-config", str(cfg))
    assert_one_line_error(code, err, f"navigator-config.{field}")


def test_valid_configs_pass(tmp_path: Path) -> None:
    from navstress.campaign.executors import check_runnable

    check_runnable(parse_campaign(_spec(
        navigators=[{"name": "reference-v1", "config": {"max_slope_deg": 20}},
                    {"name": "reference-global-v1", "config": {"carrot_m": 3}},
                    {"name": "external-v1", "config": {"command": "sleep 1", "step_budget_s": 1}},
                    {"name": "validated-v1", "target": "tests.support.navigators.campaign_navs:Validated", "config": {"gain": 2}}],
        sim={"timestep_s": 0.005, "noise": False, "lidar": {"channels": 8}})))


# ---- plans too big ------------------------------------------------------------------------------

AXES = ["obstacles.obstruction.tree", "obstacles.obstruction.building", "ground.deformation", "ground.subdivisions"]


@settings(max_examples=30, deadline=None)
@given(sizes=st.lists(st.integers(2, 10_000), min_size=2, max_size=4), maps=st.integers(1, 10_000),
       runs=st.integers(1, 10_000), navs=st.integers(1, 3), faults=st.integers(1, 2), as_values=st.booleans())
def test_huge_sweeps_are_refused_fast(sizes: list[int], maps: int, runs: int, navs: int, faults: int,
                                      as_values: bool) -> None:
    sweep = {}
    for path, n in zip(AXES, sizes):
        sweep[path] = {"values": list(range(n))} if as_values else {"start": 0, "stop": n - 1, "step": 1}
    data = {"name": "huge", "experiments": [{"name": "e", "sweep": sweep}], "maps_per_config": maps,
            "runs_per_map": runs, "navigators": [{"name": f"reference-v{i + 1}"} for i in range(navs)],
            "faults": [None, "small-footprint"][:faults]}
    expected = math.prod(sizes) * maps * runs * navs * faults
    t0 = time.perf_counter()
    if expected <= MAX_PLANNED_RUNS:
        return
    with pytest.raises(SpecError, match=r"planned runs.*at most 100,000 runs.*h of single-worker time.*--yes"):
        parse_campaign(data)
    assert time.perf_counter() - t0 < 2.0


def test_huge_sweep_through_the_cli(tmp_path: Path) -> None:
    spec = tmp_path / "huge.yaml"
    spec.write_text(yaml.safe_dump({"name": "huge", "experiments": [{"name": "e", "sweep": {
        "obstacles.obstruction.tree": {"start": 0, "stop": 99, "step": 1},
        "obstacles.obstruction.building": {"start": 0, "stop": 99, "step": 1},
        "ground.deformation": {"start": 0, "stop": 9.9, "step": 0.1}}}], "maps_per_config": 1, "runs_per_map": 1}))
    t0 = time.perf_counter()
    code, _o, err = cli("campaign", "run", str(spec), "-o", str(tmp_path / "out"), "-q")
    assert_one_line_error(code, err, "1,000,000 planned runs", "--yes")
    assert time.perf_counter() - t0 < 5.0 and not (tmp_path / "out").exists()


def test_accepted_large_plan_and_fast_paper_plan() -> None:
    data = demo()
    data["maps_per_config"], data["runs_per_map"] = 100, 100  # 7 configs x 10^4 x faults
    data["experiments"][1].pop("runs_per_map")  # (the demo's adaptive class: the campaign's count)
    assert planned_runs(parse_campaign(data, max_runs=None)) > MAX_PLANNED_RUNS
    with pytest.raises(SpecError, match="--yes"):
        parse_campaign(data)
    t0 = time.perf_counter()
    paper = parse_campaign_text(preset_yaml("paper"))
    assert len(plan(paper, "/tmp/p").tasks) == planned_runs(paper) == 2375
    assert time.perf_counter() - t0 < 3.0


# ---- damaged stores x every command that opens one -----------------------------------------------


def _store(d: Path) -> str:
    with Store.create(d, SPEC, TEXT) as s:
        for t in s.plan().tasks[:2]:
            s.add(failure_record(t, "x"))
        return s.plan().tasks[0].run_id


def _sql(*stmts: str) -> Callable[[Path], None]:
    def f(d: Path) -> None:
        con = sqlite3.connect(d / "campaign.sqlite")
        for q in stmts:
            con.execute(q)
        con.commit()
        con.close()
    return f


def _truncate(d: Path) -> None:
    db = d / "campaign.sqlite"
    con = sqlite3.connect(db)
    con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    con.close()
    data = db.read_bytes()
    db.write_bytes(data[: len(data) // 3])


def _replace_with(content: bytes) -> Callable[[Path], None]:
    def f(d: Path) -> None:
        for side in ("-wal", "-shm"):
            (d / f"campaign.sqlite{side}").unlink(missing_ok=True)
        (d / "campaign.sqlite").write_bytes(content)
    return f


CORRUPTIONS: dict[str, Callable[[Path], None]] = {
    "no-runs-table": _sql("DROP TABLE runs"),
    "no-planned-table": _sql("DROP TABLE planned"),
    "no-meta-table": _sql("DROP TABLE meta"),
    "runs-without-column": _sql("ALTER TABLE runs DROP COLUMN outcome"),
    "bad-json-config": _sql("UPDATE runs SET config = '{not json' WHERE rowid = 1"),
    "bad-json-errors": _sql("UPDATE runs SET errors = '[1, ' WHERE rowid = 2"),
    "json-of-wrong-kind": _sql("UPDATE runs SET errors = '{\"a\": 1}' WHERE rowid = 1"),
    "bad-json-task": _sql("UPDATE planned SET task = 'nope' WHERE seq = 3"),
    "bad-spec-json": _sql("UPDATE meta SET value = '{\"name\": 3' WHERE key = 'spec_json'"),
    "other-schema": _sql("UPDATE meta SET value = '99' WHERE key = 'schema'"),
    "truncated": _truncate,
    "not-sqlite": _replace_with(b"this is not a database\n" * 200),
    "random-bytes": _replace_with(bytes(range(256)) * 64),
    "empty-file": _replace_with(b""),
}


def _commands(d: Path, tmp: Path, run_id: str) -> dict[str, list[str]]:
    return {
        "status": ["campaign", "status", str(d)],
        "export": ["campaign", "export", str(d), "-o", str(tmp / "x.csv")],
        "run": ["campaign", "run", str(d / "spec.yaml"), "-o", str(d), "-q", "-j", "1"],
        "replay": ["replay", str(d), run_id],
        "analyze": ["analyze", str(d)],
        "report": ["report", str(d), "-o", str(tmp / "r.html")],
    }


@pytest.mark.parametrize("corruption", list(CORRUPTIONS))
def test_damaged_store_is_one_line_in_every_command(tmp_path: Path, corruption: str) -> None:
    d = tmp_path / "c"
    run_id = _store(d)
    spec_copy = (d / "spec.yaml").read_bytes()
    CORRUPTIONS[corruption](d)
    for name, args in _commands(d, tmp_path, run_id).items():
        code, _o, err = cli(*args)
        assert_one_line_error(code, err, "campaign=")
        assert not (tmp_path / "x.csv").exists() and not (tmp_path / "r.html").exists(), name
    assert (d / "spec.yaml").read_bytes() == spec_copy
    assert not (d / "worlds").exists() and not (d / "traces").exists()  # `campaign run` started nothing


# ---- status per navigator and fault ---------------------------------------------------------------


def test_status_splits_by_navigator_and_fault(tmp_path: Path) -> None:
    data = demo()
    data["navigators"] = [{"name": "reference-v1"}, {"name": "reference-global-v1"}]
    spec = parse_campaign(data)
    with Store.create(tmp_path, spec, yaml.safe_dump(data)) as s:
        tasks = s.plan().tasks
        glob = [t for t in tasks if t.navigator == "reference-global-v1" and t.fault is None][:3]
        for t in glob:
            s.add(failure_record(t, "x"))
        groups = {(n, f): (d, p, c["fail-other"]) for n, f, d, p, c in s.per_navigator()}
    per = sum(1 for t in tasks if t.navigator == "reference-v1" and t.fault is None)
    assert groups[("reference-global-v1", "nominal")] == (3, per, 3)
    assert groups[("reference-v1", "nominal")] == (0, per, 0)
    assert groups[("reference-v1", "small-footprint")][:2] == (0, len(tasks) // 2 - per)
    code, out, _e = cli("campaign", "status", str(tmp_path))
    assert code == 0 and "per navigator and fault" in out
    rows = [ln for ln in out.splitlines() if "reference-global-v1" in ln and "nominal" in ln]
    assert len(rows) == 1 and f"3/{per}" in rows[0]


# ---- Ray connection errors ------------------------------------------------------------------------


class AuthenticationError(Exception):
    """Stands for ray.exceptions.AuthenticationError (matched by name, ray need not be imported)."""


@pytest.mark.parametrize("err,logs,needle", [
    (AuthenticationError("Authentication token is missing or incorrect"), "", "export RAY_AUTH_MODE=token"),
    (AuthenticationError("Token authentication is enabled but no authentication token was found"), "",
     "~/.ray/auth_token, RAY_AUTH_TOKEN_PATH=FILE or RAY_AUTH_TOKEN"),
    (ConnectionError("Failed to connect to Ray cluster at 10.0.0.2:6379"),
     "gcs_client.cc:210: Unauthenticated: RPC error: InvalidAuthToken", "export RAY_AUTH_MODE=token"),
    (ConnectionError("Ray: Failed to get cluster ID from GCS server: Unauthenticated: RPC error: InvalidAuthToken: "
                     "Authentication token is missing or incorrect"), "", "`ray get-auth-token` prints it"),
    (ConnectionError("Failed to connect to Ray cluster at 10.0.0.2:6379"), "", "ray start --head"),
    (ConnectionError("Ray: Failed to connect to GCS at address 10.0.0.2:6379 within 5 seconds."), "",
     "Ray: Failed to connect to GCS at address 10.0.0.2:6379 within 5 seconds; start one"),
    (RuntimeError("line one\nline two"), "", "RuntimeError: line one line two"),
    (RuntimeError("\x1b[31mred\x1b[0m " + "x" * 1000), "", "RuntimeError: ?[31mred?[0m xxx"),
])
def test_ray_init_errors_are_one_line_with_a_fix(err: Exception, logs: str, needle: str) -> None:
    from navstress.campaign.ray_executor import _init_error

    e = _init_error("10.0.0.2:6379", err, logs)
    assert isinstance(e, SpecError) and "\n" not in str(e) and "\x1b" not in str(e) and needle in str(e)
    assert str(e).startswith("--ray-address='10.0.0.2:6379' is invalid") and len(str(e)) < 1000


@pytest.mark.parametrize("line,said", [
    ("[2026-11-27 12:32:43,483 W 15771 15771] gcs_client.cc:210: Failed to get cluster ID from GCS server: "
     "Unauthenticated", "Failed to get cluster ID from GCS server: Unauthenticated"),
    ("[2026-11-27 12:28:56,267 W 10596 10596] rpc_client.h:153: Failed to connect to GCS at address "
     "192.0.2.2:46379 within 5 seconds.\r", "Failed to connect to GCS at address 192.0.2.2:46379 within 5 seconds"),
    ("navstress-probe-error ConnectionError: Could not find any running Ray instance.",
     "ConnectionError: Could not find any running Ray instance"),
])
def test_ray_log_lines_are_quoted_without_their_heads(line: str, said: str) -> None:
    from navstress.campaign.ray_executor import _ray_line

    assert _ray_line(line) == said


def test_a_cluster_that_ray_moved_off_loopback_says_what_to_set() -> None:
    from navstress.campaign.ray_executor import _init_error

    e = str(_init_error("127.0.0.1:6379", ConnectionError("nothing answers at 192.0.2.2:6379 (Connection refused)"),
                        dialled="192.0.2.2:6379"))
    assert "Ray connects to 192.0.2.2:6379 instead" in e and "set RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0" in e
    assert "nothing answers at 192.0.2.2:6379" in e
