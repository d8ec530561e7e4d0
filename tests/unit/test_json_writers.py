"""Every JSON text navstress writes is strict JSON: a non-finite number is ``null``, never the
bare ``NaN`` / ``Infinity`` that Python's ``json`` writes by default and other parsers refuse.

Three layers: the writer helper (``navstress._json``) by property; a static check that no
writer in ``src/`` calls ``json.dump``/``json.dumps`` without ``allow_nan=False`` (the helper
does); and each writer fed non-finite values, its output read back with a strict parser."""

from __future__ import annotations

import ast
import math
import sqlite3
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress import _json
from navstress.analysis.stats import dumps as analysis_dumps
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import DB_NAME, Store
from navstress.errors import SpecError
from navstress.run.batch import failure_record, record_line
from navstress.run.record import RunRecord, RunTask
from tests.support.strict_json import strict_lines, strict_loads

SRC = Path(__file__).resolve().parents[2] / "src" / "navstress"
NON_FINITE = (math.nan, math.inf, -math.inf)

# ---- the helper -------------------------------------------------------------------------------

_scalars = st.one_of(st.none(), st.booleans(), st.integers(-2**63, 2**63), st.text(max_size=8),
                     st.floats(allow_nan=True, allow_infinity=True))
_values = st.recursive(_scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.tuples(inner, inner), st.dictionaries(st.text(max_size=5), inner, max_size=4)),
    max_leaves=20)


def _same(parsed: Any, original: Any) -> bool:
    """``parsed`` is ``original`` with non-finite floats as None and tuples as lists."""
    if isinstance(original, float):
        return parsed is None if not math.isfinite(original) else parsed == original
    if isinstance(original, dict):
        return isinstance(parsed, dict) and parsed.keys() == original.keys() and all(
            _same(parsed[k], v) for k, v in original.items())
    if isinstance(original, (list, tuple)):
        return isinstance(parsed, list) and len(parsed) == len(original) and all(
            _same(p, o) for p, o in zip(parsed, original))
    return bool(parsed == original)


@settings(max_examples=300, deadline=None)
@given(_values, st.sampled_from([{}, {"indent": 2}, {"sort_keys": True, "separators": (",", ":")}]))
def test_dumps_writes_strict_json_with_every_non_finite_number_as_null(value: Any, kw: dict[str, Any]) -> None:
    text = _json.dumps(value, **kw)
    assert _same(strict_loads(text), value), text


# ---- no other writer --------------------------------------------------------------------------


def _json_writes() -> list[tuple[str, int, bool]]:
    """(file, line, passes allow_nan=False) for every ``json.dump(s)`` call under src/navstress."""
    out = []
    for p in sorted(SRC.rglob("*.py")):
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr in ("dump", "dumps") and isinstance(node.func.value, ast.Name)
                    and node.func.value.id == "json"):
                strict = any(k.arg == "allow_nan" and isinstance(k.value, ast.Constant) and k.value.value is False
                             for k in node.keywords)
                out.append((str(p.relative_to(SRC)), node.lineno, strict))
    return out


def test_every_json_writer_of_the_package_refuses_nan() -> None:
    writes = _json_writes()
    assert ("_json.py", writes[[w[0] for w in writes].index("_json.py")][1], True) in writes  # the check sees calls
    lax = [f"{f}:{n}" for f, n, strict in writes if not strict]
    assert not lax, f"json.dump(s) without allow_nan=False (use navstress._json.dumps): {lax}"


# ---- each writer, fed non-finite numbers ------------------------------------------------------

SPEC = {"name": "nan", "seed": 1, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
        "experiments": [{"name": "flat", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
        "navigators": [{"name": "reference-v1", "config": {"gain": math.nan, "far": math.inf}}],
        "maps_per_config": 1, "runs_per_map": 2, "timeout_s": 5.0}


def _task() -> RunTask:
    return RunTask(run_id="run-000", world_dir="w", run_seed=1, trace_path="t.mcap",
                   navigator_config={"gain": math.nan, "far": [math.inf, -math.inf]}, config={"x": math.nan})


def _record(x: float, **kw: Any) -> RunRecord:
    base = failure_record(_task(), "it died", wall_s=x if math.isfinite(x) else 1.0)
    return RunRecord(**{**base.__dict__, "goal_distance_m": x, "tortuousness": x, "path_length_m": x,
                        "duration_s": x, "first_collision_s": x, **kw})


@pytest.mark.parametrize("x", NON_FINITE)
def test_runs_jsonl_line_is_strict_json(x: float) -> None:
    line = record_line(_record(x))
    assert line.endswith("\n") and line.count("\n") == 1
    rec = strict_loads(line)
    assert [rec[k] for k in ("goal_distance_m", "tortuousness", "duration_s", "first_collision_s")] == [None] * 4
    assert rec["params"] == {"x": None} and rec["config"] == "x=nan" and rec["fault"] == "nominal"
    assert strict_lines(record_line(failure_record(_task(), "died")))[0]["goal_distance_m"] is None


@pytest.mark.parametrize("x", NON_FINITE)
def test_record_row_and_task_json_are_strict_json(x: float) -> None:
    row = _record(x, config={"a": x, "b": [1.0, x]}).to_row()
    assert strict_loads(row["config"]) == {"a": None, "b": [1.0, None]}
    assert strict_loads(row["errors"]) == ["it died"]
    task = strict_loads(_task().to_json())
    assert task["navigator_config"] == {"gain": None, "far": [None, None]} and task["config"] == {"x": None}


def test_every_json_column_of_the_store_is_strict_json(tmp_path: Path) -> None:
    """The spec, the planned tasks and the records of a real store with non-finite values in a
    navigator's config and in its records: every JSON text in the SQLite file parses strictly."""
    with Store.create(tmp_path / "c", parse_campaign(SPEC), yaml.safe_dump(SPEC)) as s:
        for i, t in enumerate(s.plan().tasks):  # (a record repeats its planned run's keys: the store checks it)
            x = NON_FINITE[i]
            s.add(RunRecord(**{**failure_record(t, "it died").__dict__, "goal_distance_m": x, "tortuousness": x,
                               "path_length_m": x, "duration_s": x, "first_collision_s": x}))
    con = sqlite3.connect(tmp_path / "c" / DB_NAME)
    try:
        texts = [v for (v,) in con.execute("SELECT value FROM meta WHERE key = 'spec_json'")]
        texts += [v for row in con.execute("SELECT config, task FROM planned") for v in row]
        texts += [v for row in con.execute("SELECT config, errors FROM runs") for v in row]
    finally:
        con.close()
    assert len(texts) == 1 + 2 * 2 + 2 * 2
    parsed = [strict_loads(t) for t in texts]
    assert parsed[0]["navigators"][0]["config"] == {"gain": None, "far": None}
    assert all(p["navigator_config"] == {"gain": None, "far": None} for p in parsed[2:5:2])  # the tasks
    with Store.open(tmp_path / "c") as s:  # the store reads its own text back
        assert sorted(r.run_index for r in s.records()) == [0, 1]


def test_analysis_json_is_strict_json() -> None:
    text = analysis_dumps({"rate": math.nan, ("trees", "tree=0"): [math.inf, 0.5], 3: {"lo": -math.inf}})
    assert strict_loads(text) == {"rate": None, "('trees', 'tree=0')": [None, 0.5], "3": {"lo": None}}


@pytest.mark.parametrize("value", ["inf", ".inf", ".nan"])
def test_a_spec_with_a_non_finite_goal_tolerance_is_refused(value: str) -> None:
    """Its canonical JSON would hold Infinity (and every run would count as arrived)."""
    text = yaml.safe_dump({**SPEC, "navigators": [{"name": "reference-v1"}]}) + f"goal_tolerance_m: {value}\n"
    with pytest.raises(SpecError, match="goal_tolerance_m"):
        parse_campaign(yaml.safe_load(text))
