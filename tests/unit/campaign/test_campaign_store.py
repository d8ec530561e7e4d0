"""The store: create/resume rules, one record per run_id, atomic records, export round trip."""

from __future__ import annotations

import math
import os
import signal
import sqlite3
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
import yaml

from navstress.run.batch import failure_record
from navstress.campaign.presets import demo, preset_yaml
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import COLUMNS, Store, read_export
from navstress.run.record import SOURCE_COLUMNS
from navstress.errors import StoreError
from navstress.run.record import RunRecord

TEXT = preset_yaml("demo")
SPEC = parse_campaign(demo())


def _record(store: Store, i: int, **over: object) -> RunRecord:
    t = store.plan().tasks[i]
    r = replace(failure_record(t, f"reason {i}"), outcome=["success", "fail-collision", "fail-timeout"][i % 3],
                duration_s=10.0 + i, wall_s=0.5 * i, goal_distance_m=1.25 * i, path_length_m=42.0,
                tortuousness=0.1, collisions=i % 2, first_collision_s=(3.0 if i % 2 else None),
                errors=["e1", "x,\"quoted\""] if i == 1 else [], trace=t.trace_path)
    return replace(r, **over)  # type: ignore[arg-type]


def test_create_then_resume_same_spec(tmp_path: Path) -> None:
    d = tmp_path / "c"
    with Store.create(d, SPEC, TEXT) as s:
        assert s.progress() == (0, 90)
        assert s.add(_record(s, 0))
    assert (d / "spec.yaml").read_text() == TEXT  # as given, byte for byte
    with Store.create(d, parse_campaign(yaml.safe_load(TEXT)), "# reformatted\n" + TEXT) as s:
        assert s.progress() == (1, 90)  # smooth-s4 is adaptive: up to 5 runs per map, 2 due at first
        assert len(s.pending()) == 48 + 6 * 2 + 12 - 1 and s.plan().tasks[0].run_id not in {t.run_id for t in s.pending()}


def test_refuses_different_spec(tmp_path: Path) -> None:
    with Store.create(tmp_path, SPEC, TEXT):
        pass
    other = demo()
    other["runs_per_map"] = SPEC.runs_per_map + 1
    with pytest.raises(StoreError, match="different spec"):
        Store.create(tmp_path, parse_campaign(other), "x")


def test_refuses_foreign_directory_and_file(tmp_path: Path) -> None:
    (tmp_path / "thesis.tex").write_text("x")
    with pytest.raises(StoreError, match="not a campaign"):
        Store.create(tmp_path, SPEC, TEXT)
    assert not (tmp_path / "campaign.sqlite").exists()
    with pytest.raises(StoreError, match="not a directory"):
        Store.create(tmp_path / "thesis.tex", SPEC, TEXT)
    with pytest.raises(StoreError, match="not a campaign directory"):
        Store.open(tmp_path)


def test_second_writer_is_refused(tmp_path: Path) -> None:
    with Store.create(tmp_path, SPEC, TEXT):
        code = ("import sys; from navstress.campaign.store import Store; from navstress.campaign.presets import demo;"
                "from navstress.campaign.spec import parse_campaign\n"
                "try:\n Store.create(sys.argv[1], parse_campaign(demo()), '')\nexcept Exception as e: print(e); sys.exit(3)")
        p = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True)
        assert p.returncode == 3 and "in use" in p.stdout
    with Store.create(tmp_path, SPEC, TEXT):  # lock released on close
        pass


def test_record_once_and_roundtrip(tmp_path: Path) -> None:
    with Store.create(tmp_path, SPEC, TEXT) as s:
        recs = [_record(s, i) for i in range(4)]
        recs[2] = replace(recs[2], goal_distance_m=math.inf, tortuousness=math.nan)
        for r in reversed(recs):
            assert s.add(r)
        assert not s.add(replace(recs[0], reason="again"))  # a run is recorded once
        got = s.records()
        assert [r.run_id for r in got] == [r.run_id for r in recs]  # plan order
        rel = [replace(r, trace=os.path.relpath(r.trace, tmp_path)) if r.trace else r for r in recs]
        assert got[0] == rel[0] and got[1] == rel[1] and got[3] == rel[3]
        assert got[2].goal_distance_m == math.inf and math.isnan(got[2].tortuousness)
        assert got[0].trace is not None and not os.path.isabs(got[0].trace)  # stored relative to DIR
        assert s.outcome_counts() == {"success": 2, "fail-collision": 1, "fail-error": 0, "fail-timeout": 1,
                                      "fail-other": 0}
        cols = [r[1] for r in s.con.execute("PRAGMA table_info(runs)")]
        # a campaign of generated worlds: every record column but the world source's (none)
        assert set(COLUMNS) - set(SOURCE_COLUMNS) <= set(cols) and not set(SOURCE_COLUMNS) & set(cols)
        assert s.con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_killed_mid_transaction_leaves_nothing(tmp_path: Path) -> None:
    """SIGKILL between INSERT and COMMIT: the record is absent, the database intact."""
    with Store.create(tmp_path, SPEC, TEXT) as s:
        s.add(_record(s, 0))
    code = (
        "import os, signal, sqlite3, sys\n"
        "con = sqlite3.connect(sys.argv[1], isolation_level=None)\n"
        "con.execute('BEGIN IMMEDIATE')\n"
        "con.execute(\"UPDATE runs SET reason = 'torn'\")\n"
        "con.execute(\"INSERT INTO runs (run_id, outcome) VALUES ('half', 'success')\")\n"
        "os.kill(os.getpid(), signal.SIGKILL)\n")
    p = subprocess.run([sys.executable, "-c", code, str(tmp_path / "campaign.sqlite")])
    assert p.returncode == -signal.SIGKILL
    with Store.open(tmp_path) as s:
        assert s.done_ids() == {s.plan().tasks[0].run_id}
        assert s.records()[0].reason == "reason 0"
        assert s.con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"


@pytest.mark.not_traces
def test_cleanup_partials(tmp_path: Path) -> None:
    with Store.create(tmp_path, SPEC, TEXT) as s:
        t = s.plan().tasks[0]
        trace = Path(t.trace_path)
        trace.parent.mkdir(parents=True)
        partial = trace.with_name(f".{trace.name}.partial")
        partial.write_bytes(b"half")
        trace.write_bytes(b"whole")
        wtmp = Path(t.world_dir).parent / ".m0.abc12_45"  # tempfile.mkdtemp's 8 characters
        wtmp.mkdir(parents=True)
        (wtmp / "world.json").write_text("{")
        removed = s.cleanup_partials()
        assert set(removed) == {partial, wtmp}
        assert trace.exists() and not partial.exists() and not wtmp.exists()


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_export_roundtrip(tmp_path: Path, fmt: str) -> None:
    with Store.create(tmp_path / "c", SPEC, TEXT) as s:
        recs = [_record(s, i) for i in range(5)]
        recs[4] = replace(recs[4], fault="small-footprint", trace=None)
        for r in recs:
            s.add(r)
        out = s.export(fmt, tmp_path / f"runs.{fmt}")  # type: ignore[arg-type]
    rows = read_export(out)
    params = list(dict.fromkeys(k for r in recs for k in r.config))
    # the record's columns (with params after config), then one typed column per swept parameter (no
    # world is generated here)
    columns = [c for name in COLUMNS if name not in SOURCE_COLUMNS
               for c in ((name, "params") if name == "config" else (name,))]
    assert [list(r) for r in rows] == [columns + [f"param.{k}" for k in params]] * 5
    # the keys are those of every table: config the configuration key, fault "nominal" for none
    assert [(r["config"], r["fault"]) for r in rows] == [(b.run_id.split("/")[1], b.fault or "nominal") for b in recs]
    back = [RunRecord.from_row({**r, "config": r["params"], "fault": None if r["fault"] == "nominal" else r["fault"]})
            for r in rows]
    for a, b, row in zip(back, recs, rows):
        assert a == replace(b, trace=(os.path.relpath(b.trace, tmp_path / "c") if b.trace else None))
        assert {k: row[f"param.{k}"] for k in b.config} == b.config
        assert row["errors"] == b.errors  # a list of strings, in both formats


def test_export_bad_format(tmp_path: Path) -> None:
    from navstress.errors import SpecError
    with Store.create(tmp_path, SPEC, TEXT) as s, pytest.raises(SpecError, match="csv or parquet"):
        s.export("xlsx")  # type: ignore[arg-type]


def test_corrupt_database(tmp_path: Path) -> None:
    with Store.create(tmp_path, SPEC, TEXT):
        pass
    con = sqlite3.connect(tmp_path / "campaign.sqlite")
    con.execute("DELETE FROM meta WHERE key = 'spec_json'")
    con.commit()
    con.close()
    with pytest.raises(StoreError, match="corrupt"):
        Store.open(tmp_path)
