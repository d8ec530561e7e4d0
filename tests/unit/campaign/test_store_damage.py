"""A damaged store is one line in every command that reads it, whatever the damage: every column
of every table (meta, planned, runs, attempts) of a real small campaign's SQLite file, tampered
with each kind of wrong value (a wrong type, NULL, NaN and infinite text, huge integers, a blob,
fractions and negatives where integers belong, bad JSON, JSON of the wrong kind, a planned task
with a wrong-typed, missing, unknown or inconsistent field), through the CLI: ``analyze``,
``compare``, ``gate``, ``report``, ``replay``, ``campaign status``, ``campaign export`` (both
tables) and ``campaign run``.

The oracle is independent of the store's own rules: :data:`ACCEPTED` lists the few tamperings
that leave a valid store (a number in a REAL column, NULL where a value may be unknown, any text
in a free-text column); every command then works as on an intact store (all of them, on all of
these tamperings at once, per kind of value). Every other case must be refused: exit 2, one line
on stderr naming the table, the row and the column, no traceback, nothing written. Each refused
case runs one command, the next case the next command (the store is checked where it is opened,
the same for all of them; every command still meets every table and every kind of damage), to
keep some 300 cases within seconds.
"""

from __future__ import annotations

import json
import shutil
import sqlite3
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
import yaml
from typer.testing import CliRunner

from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import DB_NAME, RULES, Store
from navstress.cli import app
from navstress.run.batch import failure_record

SPEC = {"name": "damage", "seed": 5, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
        "experiments": [{"name": "trees", "sweep": {"obstacles.obstruction.tree": {"values": [0, 4]}}}],
        "maps_per_config": 1, "runs_per_map": 2, "faults": [None, "small-footprint"], "timeout_s": 50.0}
#: The rows tampered with: each table's first (a nominal run), meta's rows by key.
ROW = {"runs": "rowid = 1", "planned": "seq = 0", "attempts": "rowid = 1"}
META_ROWS = {"spec_json": ("value",), "name": ("value", "key")}

# label -> (SQL literal, the columns it is tried on: every, number (int and real), int, real, json)
VALUES: dict[str, tuple[str, str]] = {
    "text": ("'abc'", "every"),
    "null": ("NULL", "every"),
    "huge-int": (str(2 ** 63), "every"),  # one past int64: SQLite keeps it as a REAL (as text in a TEXT column)
    "blob": ("X'00ff'", "every"),
    "nan-text": ("'NaN'", "number"),
    "inf-text": ("'-Infinity'", "number"),
    "huger-int": (str(10 ** 30), "int"),
    "fraction": ("1.5", "int"),
    "negative": ("-1", "int"),
    "overflow-text": ("'1e999'", "real"),  # a REAL column converts it to infinity
    "bad-json": ("'{\"a\": '", "json"),
    "json-array": ("'[1, 2]'", "json"),
    "json-object": ("'{\"x\": 1}'", "json"),
    "json-nan": ("'{\"x\": NaN}'", "json"),
    "json-strings-and-int": ("'[\"x\", 1]'", "json"),
    "json-null": ("'null'", "json"),
}
#: Tamperings that leave a valid store (see the module doc): (table, column, label).
_NUMBERS = ("null", "huge-int", "overflow-text")
_FREE_TEXT = ("text", "huge-int")
ACCEPTED: set[tuple[str, str, str]] = {
    *{("runs", c, v) for c in ("duration_s", "wall_s", "goal_distance_m", "path_length_m", "tortuousness",
                               "first_collision_s", "recorded_at") for v in _NUMBERS},
    *{("attempts", "at", v) for v in _NUMBERS},
    *{("runs", c, v) for c in ("reason", "trace") for v in _FREE_TEXT},
    *{("attempts", c, v) for c in ("run_id", "kind", "reason") for v in _FREE_TEXT},
    ("runs", "fault", "null"), ("planned", "fault", "null"),  # the tampered rows are nominal ones
    ("runs", "trace", "null"),
    *{("meta", "value@name", v) for v in _FREE_TEXT}, *{("meta", "key@name", v) for v in _FREE_TEXT},
}
INT_COLUMNS = {(t, c) for t, cols in RULES.items() for c, r in cols.items() if r.kind == "int"}
REAL_COLUMNS = {(t, c) for t, cols in RULES.items() for c, r in cols.items() if r.kind == "real"}
JSON_COLUMNS = {(t, c) for t, cols in RULES.items() for c, r in cols.items() if r.kind in ("object", "array")}


def _task_edits() -> dict[str, Any]:
    """label -> a change of the planned task's JSON object (a dict -> dict function)."""
    def setting(**kw: Any) -> Any:
        return lambda d: {**d, **kw}
    return {"task-seed-text": setting(run_seed="x"), "task-seed-float": setting(run_seed=1.5),
            "task-seed-negative": setting(run_seed=-3), "task-bool-as-int": setting(record_lidar=1),
            "task-fault-number": setting(fault=3), "task-unknown-field": setting(bogus=1),
            "task-missing-field": lambda d: {k: v for k, v in d.items() if k != "run_seed"},
            "task-other-map": setting(map_index=7), "task-other-run-id": setting(run_id="x/y/m0/r0/a/b"),
            "task-world-outside": setting(world_dir="../../elsewhere"),
            "task-world-absolute": setting(world_dir="/tmp"), "task-trace-outside": setting(trace_path="../t.mcap"),
            "task-other-world": setting(world_dir="worlds/trees/tree=4/m0"),
            "task-config-other": setting(config={"obstacles.obstruction.tree": "x"}),
            "task-navigator-config-list": setting(navigator_config=[1])}


TASK_EDITS = _task_edits()
#: runs.config: a JSON object whose swept value has another type than the planned one
CONFIG_EDITS = {"config-value-text": '{"obstacles.obstruction.tree": "x"}',
                "config-value-float": '{"obstacles.obstruction.tree": 0.5}', "config-empty": "{}"}


def _cases() -> list[tuple[str, str, str]]:
    """Every (table, column, label) tried (meta: ``column@key``, the row being the key's)."""
    def tried(table: str, column: str, where: str) -> bool:
        kind = RULES[table][column].kind
        return where == "every" or where == kind or (where == "number" and kind in ("int", "real")) or \
            (where == "json" and kind in ("object", "array"))

    out = [(t, c, label) for t, cols in RULES.items() if t != "meta" for c in cols
           for label, (_, where) in VALUES.items() if tried(t, c, where)]
    out += [("meta", f"{c}@{key}", label) for key, cols in META_ROWS.items() for c in cols
            for label, (_, where) in VALUES.items() if where == "every" or (where == "json" and key == "spec_json")]
    out += [("planned", "task", label) for label in TASK_EDITS]
    out += [("runs", "config", label) for label in CONFIG_EDITS]
    return out


CASES = _cases()
REFUSED = [c for c in CASES if c not in ACCEPTED]
RUN_ID = "trees/tree=0/m0/r0/reference-v1/nominal"


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A complete small campaign (every planned run recorded, one failed attempt kept)."""
    d = tmp_path_factory.mktemp("damage") / "c"
    with Store.create(d, parse_campaign(SPEC), yaml.safe_dump(SPEC)) as s:
        for i, t in enumerate(s.plan().tasks):
            ok = i % 3 != 2
            s.add(replace(failure_record(t, "synthetic"), outcome="success" if ok else "fail-collision",
                          collisions=0 if ok else 1, first_collision_s=None if ok else 2.0, duration_s=10.0 + i))
        s.add_attempt(RUN_ID, "died", "worker killed")
    con = sqlite3.connect(d / DB_NAME)
    con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    con.close()
    return d


@pytest.fixture(scope="module")
def scratch(template: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, bytes]:
    """A copy of the campaign (its database rewritten for each case), an output folder, the database's bytes."""
    root = tmp_path_factory.mktemp("scratch")
    shutil.copytree(template, root / "c")
    (root / "out").mkdir()
    return root / "c", root / "out", (template / DB_NAME).read_bytes()


def _fresh(d: Path, db: bytes) -> None:
    for side in ("-wal", "-shm"):
        (d / f"{DB_NAME}{side}").unlink(missing_ok=True)
    (d / DB_NAME).write_bytes(db)


def _tamper(d: Path, table: str, column: str, label: str) -> bool:
    """Apply one case to the store in ``d``; False when SQLite itself refuses it (NOT NULL)."""
    con = sqlite3.connect(d / DB_NAME)
    try:
        con.execute("PRAGMA synchronous=OFF")
        if label in TASK_EDITS:
            (task,) = con.execute(f"SELECT task FROM planned WHERE {ROW['planned']}").fetchone()
            con.execute(f"UPDATE planned SET task = ? WHERE {ROW['planned']}",
                        (json.dumps(TASK_EDITS[label](json.loads(task))),))
        elif label in CONFIG_EDITS:
            con.execute(f"UPDATE runs SET config = ? WHERE {ROW['runs']}", (CONFIG_EDITS[label],))
        elif table == "meta":
            col, key = column.split("@")
            con.execute(f"UPDATE meta SET {col} = {VALUES[label][0]} WHERE key = ?", (key,))
        else:
            con.execute(f"UPDATE {table} SET {column} = {VALUES[label][0]} WHERE {ROW[table]}")
        con.commit()
        return True
    except sqlite3.IntegrityError:
        return False
    finally:
        con.close()


def _commands(d: Path, out: Path) -> dict[str, list[str]]:
    return {
        "analyze": ["analyze", str(d)],
        "compare": ["compare", str(d), "--a", "reference-v1", "--b", "reference-v1:small-footprint"],
        "gate": ["gate", str(d), "--min-success", "0.1"],
        "report": ["report", str(d), "-o", str(out / "r.html")],
        "replay": ["replay", str(d), RUN_ID],
        "status": ["campaign", "status", str(d)],
        "export": ["campaign", "export", str(d), "-o", str(out / "x.csv")],
        "verdicts": ["campaign", "export", str(d), "--table", "verdicts", "-f", "parquet", "-o", str(out / "v.pq")],
        "run": ["campaign", "run", str(d / "spec.yaml"), "-o", str(d), "-q", "-j", "1"],
    }


COMMANDS = list(_commands(Path("."), Path(".")))
#: What each command does on a valid store (the runs have no trace to replay; a complete
#: campaign's resume runs nothing).
NORMAL = {"analyze": {0}, "compare": {0}, "gate": {0, 1}, "report": {0}, "replay": {2}, "status": {0},
          "export": {0}, "verdicts": {0}, "run": {0}}


def _invoke(args: list[str]) -> tuple[int, str, BaseException | None]:
    r = CliRunner().invoke(app, args)
    exc = None if r.exception is None or isinstance(r.exception, SystemExit) else r.exception
    return r.exit_code, r.stderr, exc


def test_the_cases_cover_every_column_of_every_table(template: Path) -> None:
    con = sqlite3.connect(template / DB_NAME)
    try:
        for table in ("meta", "planned", "runs", "attempts"):
            cols = [r[1] for r in con.execute(f"PRAGMA table_info({table})")]
            assert cols == list(RULES[table]), table  # every column has a rule
            tried = {c.split("@")[0] for t, c, _ in REFUSED if t == table}
            assert tried == set(cols), table  # and is damaged somehow
    finally:
        con.close()
    assert {label for _, _, label in CASES} >= set(VALUES) | set(TASK_EDITS) | set(CONFIG_EDITS)
    # every command meets every table's damage
    assert {(REFUSED[i][0], COMMANDS[i % len(COMMANDS)]) for i in range(len(REFUSED))} >= \
        {(t, c) for t in RULES for c in COMMANDS}


def test_valid_tamperings_work_in_every_command(scratch: tuple[Path, Path, bytes]) -> None:
    """Every column with accepted tamperings gets one of them, all in one store, the labels in turn
    (REAL columns: NULL, a huge number, infinity; free text: any text): every command works as on
    an intact store (nothing refused, no traceback)."""
    d, out, db = scratch
    _fresh(d, db)
    columns = sorted({(t, c) for t, c, _ in ACCEPTED})
    done = []
    for i, (table, column) in enumerate(columns):
        labels = sorted(lab for t, c, lab in ACCEPTED if (t, c) == (table, column))
        label = labels[i % len(labels)]
        assert _tamper(d, table, column, label)
        done.append(label)
    assert set(done) == {lab for _, _, lab in ACCEPTED}  # every kind of valid value is there
    try:
        for name, args in _commands(d, out).items():
            code, err, exc = _invoke(args)
            assert exc is None and code in NORMAL[name] and "corrupt" not in err, (name, code, err, exc)
            assert name != "replay" or "has no stored trace" in err or "is missing" in err, err  # (trace 'abc')
    finally:
        for p in out.iterdir():
            p.unlink()


def _not_null(d: Path, table: str, column: str) -> bool:
    """Whether ``table.column`` of the store in ``d`` is declared NOT NULL (or is its primary key)."""
    con = sqlite3.connect(d / DB_NAME)
    try:
        info = {r[1]: r for r in con.execute(f"PRAGMA table_info({table})")}
    finally:
        con.close()
    return bool(info[column][3] or info[column][5])


@pytest.mark.parametrize("table,column,label", REFUSED, ids=["/".join(c) for c in REFUSED])
def test_every_damage_is_one_line(scratch: tuple[Path, Path, bytes], table: str, column: str, label: str) -> None:
    d, out, db = scratch
    _fresh(d, db)
    if not _tamper(d, table, column, label):  # SQLite itself refuses it: that damage cannot be stored
        assert label == "null" and _not_null(d, table, column.split("@")[0]), (table, column, label)
        return
    name = COMMANDS[REFUSED.index((table, column, label)) % len(COMMANDS)]
    code, err, exc = _invoke(_commands(d, out)[name])
    assert exc is None, (name, exc)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: campaign="), (name, code, err)
    line = lines[0]
    assert f"table {table!r}" in line and ("run_id=" in line or "key=" in line or "rowid=" in line), (name, line)
    assert column.split("@")[0] in line, (name, line)  # the column, or the field of the task, that is damaged
    assert list(out.iterdir()) == [], name  # nothing written
    assert not (d / "worlds").exists() and not (d / "traces").exists()  # `campaign run` started nothing
