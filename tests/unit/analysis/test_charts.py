"""The report's charts drawn by the real Vega renderer (the libraries the page embeds, run by
vl-convert) and read back mark by mark: every configuration's success rate is a point placed by
its value with its interval around it, coloured by its level; every world's verdict a point of its
colour; every indeterminism curve a line; every fault-power bar as tall as its count. And the page
side: a specification survives any text in its names, the same input gives the same text."""

from __future__ import annotations

import json
import re
from html.parser import HTMLParser
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.support.chart_render import all_marks, fields, marks, rgb
from navstress.analysis.charts import (LEVEL_STYLE, VERDICT_COLOURS, chart_html, class_chart,
                                       fault_power_chart, indeterminism_chart, verdict_chart)
from navstress.analysis.stats import ConfigStats, wilson
from navstress.analysis.verdicts import verdicts
from tests.support.analysis_synth import record

LEVELS = list(LEVEL_STYLE)


def stats(rows: list[tuple[float, int, int, str]]) -> tuple[list[ConfigStats], dict[tuple[str, str], str]]:
    out, levels = [], {}
    for v, runs, ok, level in rows:
        lo, hi = wilson(ok, runs) if runs else (0.0, 1.0)
        s = ConfigStats("trees", f"tree={v:g}", {"obstacles.obstruction.tree": v}, "reference-v1", "nominal", runs, ok,
                        lo, hi, {}, 20.0 + v if ok else None, 0.01 * (1 + v) if ok else None, None)
        out.append(s)
        levels[s.key] = level
    return out, levels


def affine(pixels: list[float], values: list[float]) -> tuple[float, float]:
    """(offset, slope) of pixel = offset + slope * value, checked to hold for every point."""
    slope, offset = np.polyfit(values, pixels, 1)
    assert np.allclose(offset + slope * np.asarray(values), pixels, atol=0.6), (pixels, values)
    return float(offset), float(slope)


config_rows = st.lists(st.tuples(st.integers(0, 40).map(float), st.integers(0, 12), st.integers(0, 12),
                                 st.sampled_from(LEVELS)), min_size=1, max_size=7, unique_by=lambda r: r[0]).map(
    lambda rs: [(v, n, min(k, n), lev) for v, n, k, lev in rs])


@settings(max_examples=8, deadline=None)
@given(rows=config_rows)
def test_class_chart_places_each_configuration_by_its_value_and_success_rate(
        rows: list[tuple[float, int, int, str]]) -> None:
    ss, levels = stats(rows)
    spec = class_chart("trees", ss, levels, navigator="reference-v1")
    pts = marks(spec, "rate_points")
    with_runs = [s for s in ss if s.runs]
    # one point per configuration with runs, none for one without
    assert sorted(fields(p)["configuration"] for p in pts) == sorted(s.config_key for s in with_runs)
    by_key = {s.config_key: s for s in with_runs}
    got = [(p, by_key[fields(p)["configuration"]]) for p in pts]
    # the vertical position is the success rate, the horizontal one the parameter's value
    if len({s.successes / s.runs for _, s in got}) > 1:
        _, slope = affine([p["y"] for p, _ in got], [100 * s.successes / s.runs for _, s in got])
        assert slope < 0  # up is more
    if len({s.params["obstacles.obstruction.tree"] for _, s in got}) > 1:
        _, slope = affine([p["x"] for p, _ in got], [s.params["obstacles.obstruction.tree"] for _, s in got])
        assert slope > 0
    for p, s in got:
        assert rgb(p["fill"]) == rgb(LEVEL_STYLE[levels[s.key]][1])
        assert float(fields(p)["success %"]) == pytest.approx(100 * s.successes / s.runs, abs=0.06)
        assert re.fullmatch(r"\d+\.\d", fields(p)["success %"])  # a rate as a person reads it: one decimal
    # the three panels share one x range: a configuration stands at the same place in each
    rate_x = {fields(p)["configuration"]: p["x"] for p in pts}
    if any(s.successes for s in with_runs):
        for d in marks(spec, "duration_points"):
            assert d["x"] == pytest.approx(rate_x[fields(d)["configuration"]], abs=0.6)
    # the durations panel: a point per configuration with successes; without any, a sentence
    if any(s.successes for s in with_runs):
        assert len(marks(spec, "duration_points")) == sum(1 for s in with_runs if s.successes)
    else:
        assert [t["text"] for t in marks(spec, "duration_none")] == ["no successful run yet"]


def test_class_chart_draws_the_interval_around_each_rate() -> None:
    ss, levels = stats([(0.0, 10, 10, "easy"), (2.0, 10, 6, "challenging"), (4.0, 10, 1, "very difficult")])
    spec = class_chart("trees", ss, levels, navigator="reference-v1")
    pts = {fields(p)["configuration"]: p for p in marks(spec, "rate_points")}
    offset, slope = affine([pts[s.config_key]["y"] for s in ss], [100 * s.successes / s.runs for s in ss])
    rules = [it for it in _unnamed_rules(spec) if "y2" in it]
    assert len(rules) == 3
    for s in ss:
        x = pts[s.config_key]["x"]
        r = min(rules, key=lambda it: abs(it["x"] - x))
        assert abs(r["x"] - x) < 1
        assert sorted((r["y"], r["y2"])) == pytest.approx(sorted((offset + slope * 100 * s.ci_low,
                                                                  offset + slope * 100 * s.ci_high)), abs=0.6)


def _unnamed_rules(spec: dict[str, Any]) -> list[dict[str, Any]]:
    """The vertical rules of the chart's data marks (the intervals; the 25 % line is horizontal)."""
    return [it for items in all_marks(spec).values() for it in items
            if it.get("y2") is not None and it.get("x2") is None]


def test_explicit_worlds_are_placed_by_their_keys_in_order() -> None:
    ss, levels = stats([(3.0, 4, 4, "easy"), (1.0, 4, 0, "very difficult")])
    spec = class_chart("trees", ss, levels, navigator="reference-v1", by_key=True)
    pts = marks(spec, "rate_points")
    xs = {fields(p)["configuration"]: p["x"] for p in pts}
    assert xs["tree=3"] < xs["tree=1"]  # the order of the configurations, not of their values


def _verdict_inputs() -> tuple[list[Any], list[Any]]:
    recs = []
    for key, per_map in (("tree=0", [[True] * 8, [True] * 8]), ("tree=4", [[True, False] * 4, [False] * 8])):
        for m, runs in enumerate(per_map):
            for r, ok in enumerate(runs):
                recs.append(record("trees", key, m, r, "success" if ok else "fail-collision"))
    v = verdicts(recs)
    return list(v.configurations), list(v.worlds)


def test_verdict_chart_draws_every_world_and_configuration_in_its_verdict_colour() -> None:
    cs, ws = _verdict_inputs()
    spec = verdict_chart("trees: verdicts", cs, ws, 0.8)
    pts = marks(spec, "points")
    assert len(pts) == len(ws) + len(cs)
    worlds = [p for p in pts if fields(p)["kind"] == "world"]
    pooled = [p for p in pts if fields(p)["kind"] != "world"]
    assert sorted((fields(p)["configuration"], fields(p)["map"]) for p in worlds) == \
        sorted((w.config_key, str(w.map_index)) for w in ws)
    want = {(w.config_key, str(w.map_index)): w for w in ws}
    for p in worlds:
        w = want[(fields(p)["configuration"], fields(p)["map"])]
        assert fields(p)["verdict"] == w.verdict and rgb(p["fill"]) == rgb(VERDICT_COLOURS[w.verdict])
    assert {fields(p)["configuration"]: fields(p)["verdict"] for p in pooled} == {c.config_key: c.verdict for c in cs}
    assert len({w.verdict for w in ws}) >= 2  # the input shows more than one colour
    # each configuration's worlds stand over its label, left of the next configuration's
    xs = {c.config_key: [p["x"] for p in pts if fields(p)["configuration"] == c.config_key] for c in cs}
    assert max(xs["tree=0"]) < min(xs["tree=4"])
    assert [t["text"] for t in marks(spec, "verdicts")] == [c.verdict for c in cs]


def test_indeterminism_chart_draws_a_line_per_configuration_and_says_when_a_panel_is_empty() -> None:
    t = np.arange(0.0, 1000.0, 0.5)
    curves = {"tree=0": {"success": SimpleNamespace(t=t, d=np.sqrt(t), n_maps=2)},
              "tree=4": {"success": SimpleNamespace(t=t[:50], d=t[:50] * 0.1, n_maps=1)}}
    spec = indeterminism_chart("trees", curves, max_points=400)
    vertices = marks(spec, "curves_success")
    lines: dict[str, list[dict[str, Any]]] = {}
    for v in vertices:
        lines.setdefault(fields(v)["configuration"], []).append(v)
    assert sorted(lines) == ["tree=0 (2 maps)", "tree=4 (1 map)"]  # a line per configuration, maps counted
    assert len({v["stroke"] for v in lines["tree=0 (2 maps)"]}) == 1
    assert lines["tree=0 (2 maps)"][0]["stroke"] != lines["tree=4 (1 map)"][0]["stroke"]
    long, short = lines["tree=0 (2 maps)"], lines["tree=4 (1 map)"]
    assert len(short) == 50 and 400 <= len(long) <= 402  # a long curve thinned, a short one whole
    ts = [float(fields(v)["t"]) for v in long]
    assert ts[0] == 0.0 and ts[-1] == float(t[-1]) and ts == sorted(ts)  # both ends kept, in order
    # drawn where its values are: x affine in t, y in d, on one pair of scales for both lines
    both = long + short
    affine([v["x"] for v in both], [float(fields(v)["t"]) for v in both])
    affine([v["y"] for v in both], [float(fields(v)["max distance between runs [m]"]) for v in both])
    empty = marks(spec, "empty_failure")
    assert [e["text"] for e in empty] == ["no map with 2+ such runs"]


def test_fault_power_bars_are_as_tall_as_their_counts() -> None:
    lp = [SimpleNamespace(level="easy", fault="small", collisions=3, runs=10, nominal_collisions=1, nominal_runs=10),
          SimpleNamespace(level="very difficult", fault="small", collisions=7, runs=9, nominal_collisions=2,
                          nominal_runs=9)]
    spec = fault_power_chart(lp, navigator="reference-v1")
    bars = marks(spec, "bars")
    assert len(bars) == 4
    heights = {(fields(b)["level / fault"], fields(b)["collisions"]): b["height"] for b in bars}
    per_run = heights[("very difficult / small", "7")] / 7
    assert per_run > 0
    for (_, n), h in heights.items():
        assert h == pytest.approx(per_run * int(n), abs=0.6)
    assert sorted(t["text"] for t in marks(spec, "labels")) == sorted(["3/10", "1/10", "7/9", "2/9"])
    faulty = [b for b in bars if "faulty" in fields(b)["runs of"]]
    assert all(rgb(b["fill"]) == rgb("#d7191c") for b in faulty) and len(faulty) == 2


class _Scripts(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.scripts: list[str] = []
        self.charts: list[dict[str, str]] = []
        self._in = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "div" and ("class", "chart") in attrs:
            self.charts.append({k: v or "" for k, v in attrs})
        if tag == "script":
            self._in = True
            self.scripts.append("")

    def handle_endtag(self, tag: str) -> None:
        if tag == "script":
            self._in = False

    def handle_data(self, data: str) -> None:
        if self._in:
            self.scripts[-1] += data


def _parsed(page: str) -> _Scripts:
    p = _Scripts()
    p.feed(page)
    p.close()
    return p


@settings(max_examples=100, deadline=None)
@given(name=st.text(min_size=1, max_size=30), text=st.text(max_size=40))
def test_a_chart_in_the_page_survives_any_text_in_it(name: str, text: str) -> None:
    spec = {"title": text, "data": {"values": [{"configuration": text + "</script><!--", "n": 1}]}, "mark": "point"}
    p = _parsed(chart_html(spec, name, f"alt {text}", navigator=text, fault="nominal"))
    assert len(p.scripts) == 1 and len(p.charts) == 1
    assert json.loads(p.scripts[0]) == spec
    assert p.charts[0]["data-figure"] == name and p.charts[0]["data-navigator"] == text


def test_names_flow_into_a_real_chart_and_out_again() -> None:
    ss, _ = stats([(1.0, 4, 2, "challenging")])
    k = 'x</script><script>alert("&")</script><!--'
    s = ConfigStats(k, k, ss[0].params, k, "nominal", 4, 2, ss[0].ci_low, ss[0].ci_high, {}, None, None, None)
    spec = class_chart(k, [s], {s.key: "challenging"}, navigator=k)
    p = _parsed(chart_html(spec, "class-" + k, "alt", navigator=k))
    assert len(p.scripts) == 1 and json.loads(p.scripts[0]) == spec
    assert [fields(it)["configuration"] for it in marks(spec, "rate_points")] == [k]


def test_the_same_input_gives_the_same_text() -> None:
    ss, levels = stats([(0.0, 3, 3, "easy"), (5.0, 3, 1, "challenging")])
    one = chart_html(class_chart("trees", ss, levels, navigator="reference-v1"), "class-trees", "x")
    two = chart_html(class_chart("trees", ss, levels, navigator="reference-v1"), "class-trees", "x")
    assert one == two


def test_the_libraries_are_made_once_and_kept(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from navstress.analysis import charts

    monkeypatch.setenv("NAVSTRESS_CACHE_DIR", str(tmp_path / "cache"))
    charts._bundle.cache_clear()
    try:
        made = charts.page_script()
        (kept,) = (tmp_path / "cache").glob("vega-bundle-*.js")
        assert kept.read_text(encoding="utf-8") in made and "window.vegaEmbed=" in made
        kept.write_text("damaged", encoding="utf-8")  # a damaged copy is made again, not used
        charts._bundle.cache_clear()
        assert charts.page_script() == made and kept.read_text(encoding="utf-8") in made
    finally:
        charts._bundle.cache_clear()
