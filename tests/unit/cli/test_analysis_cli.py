"""The analyze/report commands as their module defines them (navstress.cli.analysis.app, which the
root CLI mounts), without the root's error handling."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import typer
from tests.support.analysis_synth import make_store, record
from typer.testing import CliRunner

from navstress.cli.analysis import app as analysis_app
from navstress.errors import SpecError, StoreError


def _app() -> typer.Typer:
    return analysis_app


def test_analyze_json_and_report(tmp_path: Path) -> None:
    with make_store(tmp_path / "c", defs=[]) as s:
        for r in range(2):
            s.add(record("trees", "tree=0", 0, r, duration=10.0 + r))
        s.add(record("trees", "tree=8", 0, 0, "fail-error"))
    res = CliRunner().invoke(_app(), ["analyze", str(tmp_path / "c"), "--json", str(tmp_path / "a.json")])
    assert res.exit_code == 0, res.output
    assert "3/12 runs recorded" in res.output
    data = json.loads((tmp_path / "a.json").read_text())
    got = {c["config"]: (c["runs"], c["median_duration_s"], c["level"]) for c in data["configurations"]}
    assert got == {"tree=0": (2, 10.5, "easy"), "tree=4": (0, None, "no data"), "tree=8": (1, None, "very difficult")}
    res = CliRunner().invoke(_app(), ["report", str(tmp_path / "c"), "-o", str(tmp_path / "r.html")])
    assert res.exit_code == 0 and "report: " in res.output and (tmp_path / "r.html").stat().st_size > 1000


def test_bad_inputs_raise_navstress_errors(tmp_path: Path) -> None:
    make_store(tmp_path / "c").close()
    app = _app()
    r = CliRunner().invoke(app, ["analyze", str(tmp_path / "c"), "--weights", "1,2"])
    assert isinstance(r.exception, SpecError) and "--weights" in str(r.exception)
    r = CliRunner().invoke(app, ["report", str(tmp_path / "nope"), "-o", str(tmp_path / "r.html")])
    assert isinstance(r.exception, StoreError) and "not a campaign directory" in str(r.exception)
    r = CliRunner().invoke(app, ["analyze", str(tmp_path / "c"), "--threshold", "2"])
    assert isinstance(r.exception, SpecError) and "threshold" in str(r.exception)
    assert not (tmp_path / "r.html").exists()
    with pytest.raises(SpecError, match="dt"):
        from navstress.cli.analysis import analyze_cmd
        analyze_cmd(tmp_path / "c", dt=0.0)
