"""A campaign with two navigators (real runs on a tiny world): every figure and table of the
report says which navigator (and fault) it shows, no picture mixes two navigators' runs, and
``report --navigator X`` changes the figures, not only the tables."""

from __future__ import annotations

import re
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import pytest
import yaml
from typer.testing import CliRunner

from tests.support.built_once import built_once
from navstress.analysis.report import build_report
from navstress.campaign.executors import run_campaign
from navstress.campaign.store import Store
from navstress.cli import app
from navstress.run.record import RunRecord

pytestmark = pytest.mark.slow

NAVS = ("reference-v1", "raises-v1")
SPEC: dict[str, Any] = {
    "name": "two-navigators", "seed": 5, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
    "experiments": [{"name": "trees", "sweep": {"obstacles.obstruction.tree": {"values": [0, 2]}}}],
    "maps_per_config": 1, "runs_per_map": 2,
    "navigators": [{"name": "reference-v1"},
                   {"name": "raises-v1", "target": "tests.support.navigators.campaign_navs:Raises", "config": {"after_s": 0.5}}],
    "faults": [None], "timeout_s": 4.0, "goal_tolerance_m": 2.0}


def _campaign(root: Path) -> str:
    (root / "spec.yaml").write_text(yaml.safe_dump(SPEC, sort_keys=False))
    res = run_campaign(root / "spec.yaml", root / "c", workers=1)
    assert res.recorded == res.planned == 8
    return str(root / "c")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[RunRecord]]:
    """The campaign, built once in the session (the tests only read it), and its records."""
    c = Path(built_once(tmp_path_factory, "two-navigators-campaign", _campaign))
    with Store.open(c) as s:
        recs = s.records()
    # the two navigators end differently: a caption that credits one with the other's runs shows
    ends = {n: {r.outcome for r in recs if r.navigator == n} for n in NAVS}
    assert len(ends["raises-v1"]) == 1 and not ends["raises-v1"] & ends["reference-v1"], ends
    return c, recs


class _Page(HTMLParser):
    """Figures (attributes, image attributes, caption text) and table rows of a report."""

    def __init__(self) -> None:
        super().__init__()
        self.figures: list[dict[str, Any]] = []
        self.images: list[dict[str, str]] = []
        self.rows: dict[str, list[dict[str, str]]] = {}
        self._table: str | None = None
        self._fig: dict[str, Any] | None = None
        self._caption = False
        self._svg: dict[str, str] | None = None
        self._chart: dict[str, str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        if tag == "table":
            self._table = a.get("id")
        elif tag == "tr" and self._table:
            self.rows.setdefault(self._table, []).append(a)
        elif tag == "figure":
            self._fig = {"attrs": a, "img": None, "caption": ""}
            self.figures.append(self._fig)
        elif tag == "img" or (tag == "svg" and "map" in a.get("class", "").split()) or \
                (tag == "div" and a.get("class") == "chart"):
            # a picture: a PNG, an SVG map whose identity ("src") is the runs drawn in it, or a chart
            # whose identity is its specification (the JSON in it)
            if tag in ("svg", "div"):
                a["src"] = ""
            if tag == "svg":
                self._svg = a
            if tag == "div":
                self._chart = a
            self.images.append(a)
            if self._fig is not None:
                self._fig["img"] = a
        elif tag == "g" and self._svg is not None and "data-run" in a:
            self._svg["src"] += a["data-run"] + ";"
        elif tag == "figcaption":
            self._caption = True

    def handle_endtag(self, tag: str) -> None:
        if tag == "table":
            self._table = None
        elif tag == "figure":
            self._fig = None
        elif tag == "figcaption":
            self._caption = False
        elif tag == "svg":
            self._svg = None
        elif tag == "script":  # a chart's specification is its one script
            self._chart = None

    def handle_data(self, data: str) -> None:
        if self._chart is not None:
            self._chart["src"] += data
        if self._caption and self._fig is not None:
            self._fig["caption"] += data


def _page(path: Path) -> _Page:
    p = _Page()
    p.feed(path.read_text(encoding="utf-8"))
    return p


def _counts(recs: list[RunRecord]) -> dict[str, int]:
    labels = {"success": "Success", "fail-collision": "Fail-Collision", "fail-error": "Fail-Error",
              "fail-timeout": "Fail-TimeOut", "fail-other": "Fail-Other"}
    out: dict[str, int] = {}
    for r in recs:
        out[labels[r.outcome]] = out.get(labels[r.outcome], 0) + 1
    return out


def test_every_figure_names_its_navigator_and_no_picture_mixes_them(
        campaign: tuple[Path, list[RunRecord]], tmp_path: Path) -> None:
    root, recs = campaign
    page = _page(build_report(root, tmp_path / "r.html"))
    assert page.images and all(img.get("data-navigator") in NAVS for img in page.images), \
        [img.get("data-figure") for img in page.images if img.get("data-navigator") not in NAVS]
    map_figs = [f for f in page.figures if f["img"]["data-figure"].startswith("map-")]
    # one picture per (configuration, map, navigator): 2 configurations x 1 map x 2 navigators
    assert sorted((f["attrs"]["data-navigator"], f["img"]["data-figure"].split("-m0-")[0]) for f in map_figs) == \
        sorted((n, f"map-trees-{k}") for n in NAVS for k in ("tree=0", "tree=2"))
    for f in map_figs:
        nav, m = f["attrs"]["data-navigator"], int(f["attrs"]["data-map"])
        cfg = f["img"]["data-figure"][len("map-trees-"):].split("-m")[0]
        mine = [r for r in recs if r.navigator == nav and r.map_index == m and f"tree={r.config['obstacles.obstruction.tree']:g}" == cfg]
        assert len(mine) == 2, (nav, cfg, m)
        assert nav in f["caption"] and [n for n in NAVS if n != nav][0] not in f["caption"]
        shown = {lab: int(n) for n, lab in re.findall(r"(\d+) (Success|Fail-\w+)", f["caption"])}
        assert shown == _counts(mine), (f["caption"], _counts(mine))
    # the detailed run of each navigator is that navigator's, and its caption says so
    detail = [f for f in page.figures if f["img"]["data-figure"].startswith("perceived-")]
    assert sorted(f["attrs"]["data-navigator"] for f in detail) == sorted(NAVS * 2)
    for f in detail:
        nav = f["attrs"]["data-navigator"]
        assert nav in f["caption"]
        m, r = re.match(r"m(\d+) r(\d+) ", f["caption"]).groups()  # type: ignore[union-attr]
        rec = next(x for x in recs if x.navigator == nav and (x.map_index, x.run_index) == (int(m), int(r))
                   and f"tree={x.config['obstacles.obstruction.tree']:g}" in f["img"]["data-figure"])
        label = {"success": "Success", "fail-collision": "Fail-Collision", "fail-error": "Fail-Error",
                 "fail-timeout": "Fail-TimeOut", "fail-other": "Fail-Other"}[rec.outcome]
        assert re.findall(r"Success|Fail-\w+", f["caption"].split(" \u2013 ")[0]) == [label], f["caption"]
    # tables: every difficulty row names its navigator; both navigators are listed
    diff = page.rows["difficulty-table"][1:]
    assert sorted({r["data-navigator"] for r in diff}) == sorted(NAVS)
    # outcome counts split by navigator (and fault), matching the store
    html = (tmp_path / "r.html").read_text(encoding="utf-8")
    for nav in NAVS:
        for outcome, n in {r.outcome: sum(x.outcome == r.outcome for x in recs if x.navigator == nav)
                           for r in recs if r.navigator == nav}.items():
            assert re.search(rf'<tr data-navigator="{nav}" data-fault="nominal">.*?data-field="{outcome}" '
                             rf'data-value="{n}"', html), (nav, outcome, n)


@pytest.mark.parametrize("nav", NAVS)
def test_report_navigator_filters_figures_and_tables(campaign: tuple[Path, list[RunRecord]], tmp_path: Path,
                                                     nav: str) -> None:
    root, _recs = campaign
    res = CliRunner().invoke(app, ["report", str(root), "-o", str(tmp_path / "one.html"), "--navigator", nav])
    assert res.exit_code == 0, res.output
    one = _page(tmp_path / "one.html")
    assert {img["data-navigator"] for img in one.images} == {nav}
    assert {r["data-navigator"] for r in one.rows["difficulty-table"][1:]} == {nav}
    assert {r["data-navigator"] for r in one.rows["outcome-counts-by-navigator"][1:]} == {nav}
    assert all(nav in f["caption"] for f in one.figures)
    other = [n for n in NAVS if n != nav][0]
    CliRunner().invoke(app, ["report", str(root), "-o", str(tmp_path / "other.html"), "--navigator", other])
    two = _page(tmp_path / "other.html")
    srcs = {img["data-figure"]: img["src"] for img in one.images}
    srcs2 = {img["data-figure"]: img["src"] for img in two.images}
    # the per-class figure (same name) shows other runs; the map pictures are other pictures
    assert srcs["class-trees"] != srcs2["class-trees"]
    assert not set(srcs.values()) & set(srcs2.values())


def test_analyze_names_the_navigator_of_each_table(campaign: tuple[Path, list[RunRecord]]) -> None:
    root, _recs = campaign
    for nav in NAVS:
        res = CliRunner().invoke(app, ["analyze", str(root), "--navigator", nav])
        assert res.exit_code == 0, res.output
        assert f"nominal runs of {nav}" in res.output
        assert f"Indeterminism of {nav}" in res.output
