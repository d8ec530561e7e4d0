"""The report's Search section on real search directories (tests/support/search_dirs.py: a tiny MAP-Elites
search whose map has a space path as an axis, and a random baseline): every number it shows is
search.json's, its charts are read back mark by mark as the real Vega renderer draws them (its
picture of the best worlds pixel by pixel), and a bad ``--baseline`` is one line and exit 2 with no
report written."""

from __future__ import annotations

import base64
import io
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from matplotlib.colors import to_rgb
from matplotlib.image import imread

from tests.support.cli_inputs import assert_one_line_error, invoke, prepare
from navstress.analysis.report import Section, build_report
from navstress.campaign.store import Store
from navstress.errors import SpecError
from navstress.run.figures import OUTCOME_COLOURS
from navstress.search.driver import CONFIRM
from tests.support.chart_render import fields, marks
from tests.support.chart_render import rgb as css_rgb
from navstress.analysis.charts import METHOD_COLOURS
from navstress.search.figures import illumination_grid, illumination_map
from test_search_figures import check_map
from navstress.search.report import STOPPED, search_section, search_sections
from tests.support.search_dirs import SEARCH, SearchDirs


def result(d: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((d / "search.json").read_text(encoding="utf-8"))
    return data


def png_of(html: str, name: str) -> np.ndarray:
    m = re.search(rf'data-figure="{re.escape(name)}"[^>]*src="data:image/png;base64,([^"]+)"', html)
    assert m, f"figure {name} not in the section"
    img = imread(io.BytesIO(base64.b64decode(m.group(1))), format="png")
    return np.asarray(img[..., :3], np.float64)


def spec_of(html: str, name: str) -> dict[str, Any]:
    """The specification of the chart ``name`` as the page holds it."""
    m = re.search(rf'<div class="chart" data-figure="{re.escape(name)}"[^>]*><div class="vl"></div>'
                  r'<script type="application/json">(.*?)</script>', html, re.S)
    assert m, f"chart {name} not in the section"
    spec: dict[str, Any] = json.loads(m.group(1))
    return spec


def near(px: np.ndarray, colour: str, tol: float = 0.08) -> np.ndarray:
    return np.abs(px - np.array(to_rgb(colour))).max(axis=-1) < tol


def rows(html: str, table: str) -> list[str]:
    m = re.search(rf'<table id="{table}"[^>]*>(.*?)</table>', html, re.S)
    assert m, f"table {table} not in the section"
    return re.findall(r"<tr (?:data-[^>]*)>.*?</tr>", m.group(1), re.S)


def field(row: str, name: str) -> str:
    m = re.search(rf'data-field="{name}" data-value="([^"]*)"', row)
    assert m, (name, row)
    return m.group(1)


@pytest.fixture(scope="module")
def section(tiny_searches: SearchDirs) -> str:
    s = search_section(tiny_searches.search)
    assert s is not None and s.id == "search" and s.title == "Search"
    return s.html


@pytest.fixture(scope="module")
def with_baseline(tiny_searches: SearchDirs) -> str:
    s = search_section(tiny_searches.search, baseline=tiny_searches.baseline)
    assert s is not None
    return s.html


def test_the_fixture_is_a_real_search_with_confirmed_and_unconfirmed_outcomes(tiny_searches: SearchDirs) -> None:
    d, b = result(tiny_searches.search), result(tiny_searches.baseline)
    assert d["runs"] == 8 and d["algorithm"] == "map-elites" and b["algorithm"] == "random"
    assert d["confirmed"] >= 1 and d["suite"] == "suite/suite.yaml"  # the suite path is exercised
    assert b["confirmed"] == 0 and b["suite"] is None  # and the no-suite one
    with Store.open(tiny_searches.search) as s:
        assert len([r for r in s.records() if r.experiment == CONFIRM]) == d["confirm_runs"] > 0


def test_it_says_what_was_searched(section: str, tiny_searches: SearchDirs) -> None:
    d = result(tiny_searches.search)
    what = dict(re.findall(r'<tr data-field="([^"]+)"><th class="l">[^<]*</th><td class="l">([^<]*)</td>', section))
    assert what["objective"] == "failure (outcome any)"
    assert what["algorithm"] == "map-elites, 4 candidates per generation"
    assert what["budget"] == "8 runs" and what["runs"] == f"{d['runs']} in {d['generations']} generations"
    assert what["stopped"] == STOPPED[d["stopped"]]
    assert what["confirm-runs"] == str(d["confirm_runs"]) and what["runs-per-candidate"] == "2"
    assert what["evaluated"].startswith(f"{len(d['evaluated'])} (")
    params = {re.search(r'data-parameter="([^"]+)"', r).group(1): r for r in rows(section, "search-space")}  # type: ignore[union-attr]
    assert list(params) == [p["path"] for p in SEARCH["space"]["parameters"]] + ["map_seed"]
    for p in SEARCH["space"]["parameters"]:
        assert float(field(params[p["path"]], "low")) == p["low"] and float(field(params[p["path"]], "high")) == p["high"]
    seen = len({e["key"] for e in d["evaluated"] if e["found"]})
    assert f'id="search-seen" data-value="{seen}"' in section
    assert f'id="search-confirmed" data-value="{d["confirmed"]}"' in section


def test_the_illumination_map_holds_every_evaluated_candidate_on_a_space_path_axis(
        section: str, tiny_searches: SearchDirs) -> None:
    d = result(tiny_searches.search)
    (dx, dy) = d["descriptors"]
    assert dy["name"] == "ground.deformation"  # a path of the space, not a registry descriptor
    bins = (dx["cells"], dy["cells"])
    pts = [{"x": e["descriptors"][0], "y": e["descriptors"][1], "fitness": e["fitness"], "key": e["key"]}
           for e in d["evaluated"]]
    # the y value of a path axis is the candidate's parameter value
    assert [p["y"] for p in pts] == [e["params"]["ground.deformation"] for e in d["evaluated"]]
    fit, keys = illumination_grid(pts, (dx["low"], dx["high"]), (dy["low"], dy["high"]), bins)
    table = rows(section, "search-cells")
    assert len(table) == int(np.isfinite(fit).sum()) >= 1
    for r in table:
        i, j = map(int, re.search(r'data-cell="(\d+),(\d+)"', r).groups())  # type: ignore[union-attr]
        assert f'data-key="{keys[i][j]}"' in r and float(field(r, "fitness")) == fit[i, j]
    check_map(spec_of(section, "search-illumination"), fit, keys, (dx["low"], dx["high"]), (dy["low"], dy["high"]))


def test_a_space_path_axis_needs_its_range_and_an_unknown_name_is_refused() -> None:
    pts = [{"x": 10.0, "y": 0.5, "fitness": 1.0}]
    labelled = illumination_map(pts, x="obstruction", y="ground.deformation", y_range=(0.0, 1.5))
    relabelled = illumination_map(pts, x="obstruction", y="ground.deformation", y_range=(0.0, 1.5),
                                  y_label="deformation d [m]")
    assert labelled["encoding"]["y"]["title"] == "ground.deformation"  # named by its path
    assert relabelled["encoding"]["y"]["title"] == "deformation d [m]"
    with pytest.raises(SpecError, match="^y="):
        illumination_map(pts, x="obstruction", y="ground.deformation")  # no range: no natural one to take
    with pytest.raises(SpecError, match="^x="):
        illumination_map(pts, x="obstructoin", y="roughness")


def test_found_against_runs_shows_seen_and_confirmed_for_search_and_baseline(
        section: str, with_baseline: str, tiny_searches: SearchDirs) -> None:
    d, b = result(tiny_searches.search), result(tiny_searches.baseline)
    for html, methods in ((section, [("search", d)]), (with_baseline, [("search", d), ("random", b)])):
        table = rows(html, "search-found")
        assert [re.search(r'data-method="([^"]+)"', r).group(1) for r in table] == [m for m, _ in methods]  # type: ignore[union-attr]
        for r, (_, data) in zip(table, methods):
            assert int(field(r, "runs")) == data["runs"] and int(field(r, "seen")) == data["found"]
            assert int(field(r, "confirmed")) == data["confirmed"] and int(field(r, "elites")) == len(data["elites"])
    alone, both = spec_of(section, "search-found"), spec_of(with_baseline, "search-found")
    for spec, methods_drawn in ((alone, ["search"]), (both, ["random", "search"])):
        lines: dict[str, list[dict[str, Any]]] = {}
        for v in marks(spec, "lines"):
            lines.setdefault(fields(v)["method"], []).append(v)
        assert sorted(lines) == methods_drawn
        for m in methods_drawn:
            assert {css_rgb(v["stroke"]) for v in lines[m]} == {css_rgb(METHOD_COLOURS[m])}
    assert "--baseline DIR2" in section and "--baseline DIR2" not in with_baseline
    # the confirmed count is drawn as the search's star at its runs and count
    stars = {fields(x)["confirmed"] for x in marks(alone, "confirmed")}
    assert stars == {f"search: {d['confirmed']} confirmed"}


def test_the_best_worlds_are_the_elites_confirmed_first_with_their_confirmation_runs(
        section: str, tiny_searches: SearchDirs) -> None:
    d = result(tiny_searches.search)
    table = rows(section, "search-elites")
    want = sorted(d["elites"], key=lambda e: not e["confirmed"])
    assert [re.search(r'data-key="([^"]+)"', r).group(1) for r in table] == [e["key"] for e in want]  # type: ignore[union-attr]
    for r, e in zip(table, want):
        c = e["confirmation"]
        assert field(r, "verdict") == ("confirmed" if c["confirmed"] else "not confirmed")
        assert int(field(r, "events")) == c["events"] and int(field(r, "trials")) == c["trials"]
        assert [float(v) for v in field(r, "interval").split(",")] == c["interval"]
        assert c["reason"] in r
    img = png_of(section, "search-best-worlds")
    with Store.open(tiny_searches.search) as s:
        outcomes = {r.outcome for r in s.records() if r.experiment == CONFIRM}
    for o in outcomes:  # every confirmation outcome's colour is drawn
        assert near(img, OUTCOME_COLOURS[o]).sum() > 40, o


def test_the_suite_and_its_commands_or_why_there_is_none(section: str, tiny_searches: SearchDirs) -> None:
    suite = tiny_searches.search / "suite" / "suite.yaml"
    assert suite.is_file()
    m = re.search(r'<div id="search-suite">(.*?)</div>', section, re.S)
    assert m and str(suite) in m.group(1)
    assert f"navstress campaign run {suite} -o RUN\nnavstress gate RUN" in m.group(1)
    none = search_section(tiny_searches.baseline)
    assert none is not None and 'id="search-suite"' in none.html and "No elite was confirmed" in none.html


def test_a_campaign_that_is_no_search_has_no_search_section_and_a_section_goes_after_the_summary(
        tmp_path: Path) -> None:
    prepare(tmp_path)
    assert search_sections(tmp_path / "c") == [] and search_sections(tmp_path / "nothing") == []
    plain = build_report(tmp_path / "c", tmp_path / "r.html", sections=search_sections(tmp_path / "c"))
    assert 'id="search"' not in plain.read_text(encoding="utf-8")
    extra = Section("search", "Search", '<section id="search"><h2>Search</h2></section>')
    text = build_report(tmp_path / "c", tmp_path / "s.html", sections=[extra]).read_text(encoding="utf-8")
    assert text.index('id="summary"') < text.index('<section id="search">') < text.index('id="difficulty"')
    assert text.index('<a href="#summary">') < text.index('<a href="#search">Search</a>') < \
        text.index('<a href="#difficulty">')
    # (the whole report of a search, through `navstress report DIR --baseline DIR2`, is opened in
    # Chromium by tests/integration/test_report_browser.py)


def _bad_baselines(root: Path, good: Path) -> dict[str, tuple[str, str]]:
    """name -> (DIR, --baseline): each refused with one line naming the field."""
    prepare(root)  # root/c: a campaign that is no search; root/w: a world
    (root / "other").mkdir()
    (root / "other" / "search.json").write_text('{"format": "something-else/1"}', encoding="utf-8")
    (root / "f.txt").write_text("x", encoding="utf-8")
    return {"missing": (str(good), str(root / "nope")), "campaign": (str(good), str(root / "c")),
            "world": (str(good), str(root / "w")), "file": (str(good), str(root / "f.txt")),
            "other-format": (str(good), str(root / "other")), "dir-no-search": (str(root / "c"), str(good))}


@pytest.mark.parametrize("case", ["missing", "campaign", "world", "file", "other-format", "dir-no-search"])
def test_a_bad_baseline_is_one_line_exit_2_and_writes_nothing(case: str, tiny_searches: SearchDirs,
                                                              tmp_path: Path) -> None:
    directory, baseline = _bad_baselines(tmp_path / "in", tiny_searches.search)[case]
    out = tmp_path / "out" / "r.html"
    argv = ["report", directory, "-o", str(out), "--baseline", baseline]
    line = assert_one_line_error(*invoke(argv), argv)
    want = "directory=" if case == "dir-no-search" else ("search.json" if case == "other-format" else "--baseline=")
    assert want in line, line
    assert not out.exists() and not out.parent.exists()


def test_searched_obstacle_moves_have_their_row_in_the_space_table(tiny_searches: SearchDirs) -> None:
    from navstress.search.report import _what
    data = result(tiny_searches.search)
    spec = yaml.safe_load((tiny_searches.search / "search.yaml").read_text(encoding="utf-8"))
    spec["space"]["moves"] = {"count": 3, "radius_m": 1.5}
    html = _what(data, spec)
    row = re.search(r'<tr data-parameter="moves">(.*?)</tr>', html)
    assert row is not None and "3 moves" in row.group(1) and "1.5 m" in row.group(1)
    del spec["space"]["moves"]
    assert 'data-parameter="moves"' not in _what(data, spec)
