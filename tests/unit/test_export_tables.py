"""The exported tables line up: one vocabulary for keys across every table, format and reader.

A real small campaign (a store of two experiments, nominal and faulty runs, generated flat worlds)
is exported through the CLI as every table (runs, verdicts, configurations) in both formats, then:

- the docs' examples (every ``python`` block of docs/*.md that reads an export) run as written
  with pandas and DuckDB, on Parquet and on CSV: their joins give every run its world's verdict,
  nominal runs included, and their ``groupby`` keeps every run;
- the family: every key column (navstress._tables.KEYS) has the same name, dtype and vocabulary
  in every table, format and reader, is never empty (``fault`` is ``nominal``), every pair of
  tables joins on the keys they share with one partner per row, and no count column is a float;
- every JSON output (``analyze``, ``compare``, ``gate``, ``campaign status``, the search's
  candidates) spells the keys the same way and writes counts as integers.
"""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path
from typing import Any

import duckdb
import pandas as pd
import pytest
from typer.testing import CliRunner

from navstress._tables import KEYS
from navstress.campaign.store import Store
from navstress.cli import app
from navstress.run.batch import failure_record

from tests.support.analysis_synth import make_store, save_flat_worlds

UNIT = Path(__file__).resolve().parent

DOCS = UNIT.parents[1] / "docs"
TABLES = ("runs", "verdicts", "configurations")  # finest first: each row of one has one partner in the next
FORMATS = ("parquet", "csv")
#: Columns that count something: integers in every table and output.
COUNTS = {"runs", "successes", "worlds", "collisions", "planned", "recorded", "pending", "pairs", "n", "n_maps",
          "n_runs", "attempts", "events", "trials", "new_failures", "nominal_runs", "nominal_collisions", "configs",
          "done", "runs_with_collision_a", "runs_with_collision_b", "total_a", "total_b", "both_succeed",
          "only_a_succeeds", "only_b_succeeds", "both_fail", "map_seed", "run_seed", "runs_spent", "generation"}
#: JSON objects whose values are all counts.
COUNT_MAPS = {"outcomes", "counts", "world_verdicts", "unpaired_runs", "table"}
FAULT = "small-footprint"


@pytest.fixture(scope="module")
def root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding ``demo-campaign``: every planned run recorded, every table exported."""
    base = tmp_path_factory.mktemp("tables")
    d = base / "demo-campaign"
    with make_store(d, trees=[0, 4], defs=[0.5], maps=2, runs=2, faults=[None, FAULT]) as s:
        save_flat_worlds(s)
        for i, t in enumerate(s.plan().tasks):
            ok = (i * 7) % 5 < 3
            s.add(replace(failure_record(t, "synthetic"), outcome="success" if ok else "fail-collision",
                          collisions=0 if ok else 1, first_collision_s=None if ok else 1.5, duration_s=5.0 + i))
    for table in TABLES:
        for fmt in FORMATS:
            r = CliRunner().invoke(app, ["campaign", "export", str(d), "--table", table, "-f", fmt])
            assert r.exit_code == 0, r.output
    return base


@pytest.fixture(scope="module")
def store_runs(root: Path) -> list[Any]:
    with Store.open(root / "demo-campaign") as s:
        return s.records()


def _read(path: Path) -> pd.DataFrame:
    return pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)


# ---- the docs' examples ---------------------------------------------------------------------------


def doc_examples() -> list[tuple[str, str]]:
    """(file, code) of every ``python`` block of docs/*.md that reads an exported table."""
    out = []
    for md in sorted(DOCS.glob("*.md")):
        for code in re.findall(r"```python\n(.*?)```", md.read_text(encoding="utf-8"), flags=re.S):
            if re.search(r"demo-campaign/\w+\.(parquet|csv)", code):
                out.append((md.name, code))
    return out


def test_the_docs_have_pandas_and_duckdb_examples() -> None:
    codes = [c for _, c in doc_examples()]
    assert any("import pandas" in c for c in codes) and any("import duckdb" in c for c in codes)


@pytest.mark.parametrize("fmt", FORMATS)
def test_the_docs_examples_run_and_keep_every_run(root: Path, store_runs: list[Any], fmt: str,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """Each example as written (for CSV: read_csv and .csv for read_parquet and .parquet) against the
    exported campaign; what they compute keeps every run, nominal ones included."""
    monkeypatch.chdir(root)
    ns: dict[str, Any] = {}
    for name, code in doc_examples():
        if fmt == "csv":
            code = code.replace("read_parquet", "read_csv").replace(".parquet", ".csv")
        exec(compile(code, f"docs/{name}", "exec"), ns)  # noqa: S102 - the docs' own example
    nominal = sum(r.fault is None for r in store_runs)
    assert 0 < nominal < len(store_runs)
    # pandas: the success rate per stack keeps every group (the nominal ones too) ...
    groups = {(r.experiment, r.run_id.split("/")[1], r.navigator, r.fault or "nominal") for r in store_runs}
    assert set(ns["success"].index) == groups
    # ... and every run gets its world's verdict
    joined = ns["runs_and_verdicts"]
    assert sorted(joined.run_id) == sorted(r.run_id for r in store_runs)
    assert (joined.fault == "nominal").sum() == nominal and joined.verdict.notna().all()
    # DuckDB: the same
    per_stack = ns["per_stack"].fetchall()
    cols = ns["per_stack"].columns
    assert sum(row[cols.index("runs")] for row in per_stack) == len(store_runs)
    assert {row[cols.index("fault")] for row in per_stack} == {"nominal", FAULT}
    with_verdicts = ns["with_verdicts"].fetchall()
    assert sorted(r[0] for r in with_verdicts) == sorted(r.run_id for r in store_runs)


# ---- the family: keys and counts in every table, format and reader ---------------------------------


def _pandas_kind(s: pd.Series) -> str:
    if pd.api.types.is_bool_dtype(s):
        return "bool"
    if pd.api.types.is_integer_dtype(s):
        return "int"
    if pd.api.types.is_float_dtype(s):
        return "float"
    return "str" if pd.api.types.is_string_dtype(s) else str(s.dtype)


def _duck_kind(t: str) -> str:
    return {"BIGINT": "int", "VARCHAR": "str", "DOUBLE": "float", "BOOLEAN": "bool"}.get(t, t)


def test_every_table_spells_and_types_the_keys_the_same_way(root: Path) -> None:
    d = root / "demo-campaign"
    vocab: dict[str, dict[str, set[Any]]] = {}  # key -> table/format/reader -> values
    con = duckdb.connect()
    for table in TABLES:
        for fmt in FORMATS:
            path = d / f"{table}.{fmt}"
            df = _read(path)
            duck = {name: _duck_kind(t) for name, t, *_ in con.sql(f"DESCRIBE SELECT * FROM '{path}'").fetchall()}
            keys = [c for c in df.columns if c in KEYS]
            assert len(keys) >= 4, (table, keys)
            for c in keys:
                assert _pandas_kind(df[c]) == KEYS[c] == duck[c], (table, fmt, c, df[c].dtype, duck[c])
                assert df[c].notna().all() and (df[c] != "").all(), (table, fmt, c)  # never empty
                vocab.setdefault(c, {})[f"{table}.{fmt}.pandas"] = set(df[c])
                vocab[c][f"{table}.{fmt}.duckdb"] = {v for (v,) in con.sql(f"SELECT DISTINCT {c} FROM '{path}'").fetchall()}
            for c in df.columns:  # counts are integers; no other column is a float by accident
                if c in COUNTS:
                    assert _pandas_kind(df[c]) == "int" == duck[c], (table, fmt, c, df[c].dtype)
    for c, by in vocab.items():  # the same values everywhere (every table holds every stack that ran)
        assert len({frozenset(v) for v in by.values()}) == 1, (c, by)
    assert vocab["fault"]["runs.csv.pandas"] == {"nominal", FAULT}
    assert vocab["config"]["verdicts.parquet.duckdb"] == {"tree=0", "tree=4", "deformation=0.5"}


@pytest.mark.parametrize("fmt", FORMATS)
def test_every_pair_of_tables_joins_on_the_keys_they_share(root: Path, fmt: str) -> None:
    """Each row of the finer table has exactly one partner in the coarser one (pandas merge and a
    DuckDB join), and a groupby on the shared keys keeps every row."""
    d = root / "demo-campaign"
    con = duckdb.connect()
    for i, fine in enumerate(TABLES):
        for coarse in TABLES[i + 1:]:
            a, b = _read(d / f"{fine}.{fmt}"), _read(d / f"{coarse}.{fmt}")
            on = [c for c in KEYS if c in a.columns and c in b.columns]
            assert "fault" in on and "config" in on, on
            merged = a[on].merge(b[on], on=on, how="left", indicator=True)
            assert len(merged) == len(a) and (merged["_merge"] == "both").all(), (fine, coarse)
            assert a.groupby(on).size().sum() == len(a)  # pandas' default groupby drops no row
            n = con.sql(f"SELECT count(*) FROM '{d / f'{fine}.{fmt}'}' JOIN '{d / f'{coarse}.{fmt}'}' "
                        f"USING ({', '.join(on)})").fetchall()
            assert n == [(len(a),)], (fine, coarse)


# ---- the JSON outputs -----------------------------------------------------------------------------


def _walk(x: Any, path: str = "") -> list[tuple[str, str, Any]]:
    """Every (path, key, value) of every object in ``x``."""
    out: list[tuple[str, str, Any]] = []
    if isinstance(x, dict):
        for k, v in x.items():
            out.append((path, k, v))
            out += _walk(v, f"{path}.{k}")
    elif isinstance(x, list):
        for i, v in enumerate(x):
            out += _walk(v, f"{path}[{i}]")
    return out


def check_json_vocabulary(data: Any) -> int:
    """Assert the key vocabulary and integer counts on a JSON output; returns how many keys it holds."""
    found = 0
    for path, k, v in _walk(data):
        if k in KEYS:
            want = str if KEYS[k] == "str" else int
            assert isinstance(v, want) and not isinstance(v, bool) and v != "", (path, k, v)
            found += 1
        if k in COUNTS and not isinstance(v, (dict, list)):
            assert isinstance(v, int) and not isinstance(v, bool), (path, k, v)
        if k in COUNT_MAPS and isinstance(v, dict):
            assert all(isinstance(n, int) and not isinstance(n, bool) for n in v.values()), (path, k, v)
    return found


def test_every_json_output_spells_the_keys_the_same_way(root: Path) -> None:
    d = str(root / "demo-campaign")
    outputs = {"analyze": ["analyze", d, "--json", "-"],
               "compare": ["compare", d, "--a", "reference-v1", "--b", f"reference-v1:{FAULT}", "--json", "-"],
               "gate": ["gate", d, "--min-success", "0.1", "--fault", "nominal", "--fault", FAULT, "--json"],
               "status": ["campaign", "status", d, "--json"]}
    for name, args in outputs.items():
        r = CliRunner().invoke(app, args)
        assert r.exit_code in (0, 1), (name, r.output)
        data = json.loads(r.stdout)
        assert check_json_vocabulary(data) >= 3, name
        faults = {v for _, k, v in _walk(data) if k == "fault"}
        assert "nominal" in faults and None not in faults, (name, faults)
    gate = json.loads(CliRunner().invoke(app, outputs["gate"]).stdout)
    assert all(isinstance(w["map_index"], int) for c in gate["configurations"] for w in c["worlds"])


def test_the_search_names_its_candidates_with_the_same_keys() -> None:
    from navstress.search.driver import CONFIRM, Elite, Evaluated, generation_name
    from navstress.search.objectives import Confirmation
    from navstress.search.space import Candidate

    c = Candidate("k3", 11, {}, {"obstacles.obstruction.tree": 4})
    ev = Evaluated(3, c, 0.5, 0.5, 1, 2, (0.1,), 2, 10, True).to_json()
    el = Elite(c, 0.5, (0.1,), 3, Confirmation("failing", True, 0.95, 3, 4, (0.6, 1.0), "why")).to_json()
    for data, experiment in ((ev, generation_name(3)), (el, CONFIRM)):
        assert (data["experiment"], data["config"], data["key"]) == (experiment, "k3", "k3")
        check_json_vocabulary(data)


@pytest.mark.parametrize("fault", [None, FAULT])
@pytest.mark.parametrize("config", [{}, {"obstacles.tree": 4}, {"ground.s": 2, "ground.d": 1.5}])
def test_a_single_worlds_records_spell_the_keys_the_same_way(fault: str | None, config: dict[str, Any]) -> None:
    """``navstress run``'s runs.jsonl (and its --json records) use the tables' vocabulary too:
    ``config`` a key, ``params`` the parameters, ``fault`` "nominal" for the nominal stack."""
    from navstress.run.batch import failure_record, record_line
    from navstress.run.record import RunTask

    task = RunTask(run_id="run-002", experiment="single", world_dir="w", run_seed=1, trace_path="t.mcap", fault=fault, config=config)
    line = json.loads(record_line(failure_record(task, "died")))
    assert check_json_vocabulary(line) >= 4, line
    assert line["fault"] == (fault or "nominal") and line["params"] == config
    assert line["config"] == (",".join(f"{k.rsplit('.', 1)[-1]}={v}" for k, v in sorted(config.items())) or "base")
