"""The HTML report in a real headless Chromium (Debian ``chromium`` driven by Playwright).

Checks that the page renders, that every picture loads (decoded, non-zero size) and every chart
is drawn by the embedded Vega libraries, that a chart zooms with the wheel, pans by dragging and
resets on a double click, that nothing is fetched from outside the file, and that the numbers
shown match the store; a search directory's report (``navstress report DIR --baseline DIR2``)
shows its Search section, charts drawn, without a script error. At a phone's width (390 px) and
a laptop's (1,280 px) the page never scrolls sideways and the header cells of the columns a person
came for (``th.key``: level, success, verdict, ...) are in view at load. Fails (does not skip)
when chromium or playwright is missing under CI (``CI=true``)."""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import replace
from pathlib import Path

import pytest
import yaml

from tests.support.analysis_synth import line, make_store, record, save_flat_worlds, spec_dict, write_trace

from tests.support.cli_run import cli
from navstress._percent import percent
from navstress.analysis.report import build_report
from navstress.analysis.stats import wilson
from navstress.campaign.plan import run_id
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import Store
from tests.support.required import need as _need
from tests.support.search_dirs import SearchDirs

pytestmark = pytest.mark.slow  # a real browser, and the report of the session's tiny real searches

CHROMIUM = os.environ.get("NAVSTRESS_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"


@pytest.fixture
def page():  # type: ignore[no-untyped-def]
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _need(False, "playwright is not installed (pip install -e '.[test]')")
    _need(Path(CHROMIUM).exists(), f"chromium not found at {CHROMIUM} (apt-get install chromium)")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox", "--disable-gpu"])
        try:
            yield browser.new_page(viewport={"width": 1300, "height": 900})
        finally:
            browser.close()


def _campaign(root: Path) -> Path:
    with make_store(root, trees=[0, 4], defs=[], faults=[None, "small"]) as s:
        save_flat_worlds(s, trees_per_map=2)
        n = 0
        for key, outcomes in (("tree=0", ["success"] * 4), ("tree=4", ["success", "fail-error", "fail-timeout"])):
            for i, o in enumerate(outcomes):
                m, r = divmod(i, 2)
                t = write_trace(root / "traces" / f"{n}.mcap", line(20 + i, 5, 5, 15 - i, 15))
                s.add(record("trees", key, m, r, o, duration=20.0 + i, tort=0.01 * (i + 1), goal=1.0 + i, trace=t))
                n += 1
        s.add(record("trees", "tree=4", 0, 0, "fail-collision", fault="small", collisions=1))
    return root


def drawn(page) -> list[str]:  # type: ignore[no-untyped-def]
    """Waits until every chart of the page is drawn (or failed); the names of those drawn, and none failed."""
    page.wait_for_function("Array.from(document.querySelectorAll('div.chart'))"
                           ".every(e => e.hasAttribute('data-rendered'))", timeout=60_000)
    states = page.evaluate("Array.from(document.querySelectorAll('div.chart'))"
                           ".map(e => [e.dataset.figure, e.dataset.rendered])")
    assert states and all(r == "1" for _, r in states), states
    return [n for n, _ in states]


def _ticks(page, name: str) -> list[str]:  # type: ignore[no-untyped-def]
    """The labels of the first horizontal axis of chart ``name``, as drawn, left to right (Vega
    keeps the label elements it reuses, so their document order is not the axis order)."""
    labels: list[str] = page.evaluate("""n => {
        const svg = document.querySelector(`div.chart[data-figure='${n}'] svg.marks`);
        const axes = Array.from(svg.querySelectorAll('.role-axis'))
            .filter(a => (a.getAttribute('aria-label') || '').startsWith('X-axis'));
        return Array.from(axes[0].querySelectorAll('.role-axis-label text'))
            .map(t => [t.getBoundingClientRect().x, t.textContent]).sort((a, b) => a[0] - b[0]).map(p => p[1]);
    }""", name)
    return labels


def test_charts_zoom_pan_and_reset(page, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    root = _campaign(tmp_path / "camp")
    out = build_report(root, tmp_path / "report.html")
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    # errors, and the chart libraries' warnings (an empty extent, a bad encoding) too
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" or "WARN" in m.text else None)
    page.goto(out.resolve().as_uri())
    drawn(page)
    name = "indeterminism-trees"
    chart = page.locator(f"div.chart[data-figure='{name}']")
    chart.scroll_into_view_if_needed()
    before = _ticks(page, name)
    plot = chart.locator("svg.marks .role-mark").first.bounding_box()
    cx, cy = plot["x"] + plot["width"] / 2, plot["y"] + plot["height"] / 2
    page.mouse.move(cx, cy)
    page.mouse.wheel(0, -400)  # zoom in
    page.wait_for_timeout(300)
    zoomed = _ticks(page, name)
    assert zoomed != before, (before, zoomed)
    page.mouse.move(cx, cy)
    page.mouse.down()
    page.mouse.move(cx + 120, cy, steps=5)  # pan
    page.mouse.up()
    page.wait_for_timeout(300)
    assert _ticks(page, name) != zoomed
    page.mouse.dblclick(cx, cy)  # reset
    page.wait_for_timeout(300)
    assert _ticks(page, name) == before
    # hovering a configuration's point shows its numbers
    point = page.locator("div.chart[data-figure='class-trees'] svg.marks g.rate_points_0_marks path")
    assert point.count() == 2
    point.first.scroll_into_view_if_needed()
    point.first.hover()
    tip = page.locator("#vg-tooltip-element")
    tip.wait_for(state="visible", timeout=5000)
    assert "success %" in tip.inner_text() and "tree=" in tip.inner_text()
    assert errors == []


def test_report_renders_in_chromium(page, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    root = _campaign(tmp_path / "camp")
    out = build_report(root, tmp_path / "report.html")
    outside: list[str] = []
    page.on("request", lambda req: outside.append(req.url) if not req.url.startswith(("file:", "data:")) else None)
    page.goto(out.resolve().as_uri())
    assert page.title() == "navstress report: synth"
    # charts: every one drawn by the embedded libraries, as SVG with its marks
    names = drawn(page)
    assert {"class-trees", "verdicts-trees-reference-v1-nominal", "indeterminism-trees", "fault-power"} <= set(names)
    assert all(page.locator(f"div.chart[data-figure='{n}'] svg.marks .role-mark").count() >= 1 for n in names)
    # the maps' embedded rasters (terrain, perceived maps) decode
    sizes = page.evaluate("""Promise.all(Array.from(document.querySelectorAll('svg image')).map(e => {
        const i = new Image(); i.src = e.getAttribute('href');
        return i.decode().then(() => i.naturalWidth, () => 0); }))""")
    assert len(sizes) >= 3 and min(sizes) > 10, sizes
    assert page.locator("div.chart[data-figure='class-trees'] svg.marks").bounding_box()["width"] > 300  # laid out, visible
    assert outside == []
    # numbers against the store
    with Store.open(root) as s:
        done, planned = s.progress()
        counts = s.outcome_counts()
        recs = s.records()
    assert page.inner_text("#runs-done") == str(done) and page.inner_text("#runs-planned") == str(planned)
    for o, c in counts.items():
        assert page.inner_text(f"#outcome-{o}") == str(c)
    for key in ("tree=0", "tree=4"):
        mine = [r for r in recs if r.run_id.startswith(f"trees/{key}/") and r.fault is None]
        ok = sum(r.outcome == "success" for r in mine)
        row = page.locator(f"#difficulty-table tr[data-config='{key}'][data-fault='nominal']")
        assert row.locator("td[data-field='runs']").inner_text() == f"{len(mine)}/4"
        # the cells read as every rate a person reads (navstress._percent); the data-value holds the number
        assert row.locator("td[data-field='success-rate']").inner_text() == percent(ok / len(mine))
        assert row.locator("td[data-field='ci-low']").inner_text() == percent(wilson(ok, len(mine))[0])
        assert float(row.locator("td[data-field='success-rate']").get_attribute("data-value") or "nan") == \
            pytest.approx(ok / len(mine))
    assert page.locator("#difficulty-table tr[data-config='tree=0'][data-fault='nominal'] "
                        "td[data-field='level']").inner_text() == "easy"
    # the per-configuration sections link from the table and hold map pictures
    # map pictures (SVG: the world once per map, the runs as vectors over it): one per map and
    # (navigator, fault), the detailed run and its perceived map
    assert page.locator("section#cfg-trees--tree-4 svg.map").count() >= 3
    assert page.locator("section#cfg-trees--tree-4 svg.map").first.bounding_box()["width"] > 300
    assert page.locator("#partial-campaign").is_visible()
    # verdicts: a row per configuration whose counts are the store's, and the strip of worlds drawn
    from navstress.analysis.verdicts import verdicts
    for c in verdicts(recs).configurations:
        row = page.locator(f"#verdicts-configurations tr[data-config='{c.config_key}'][data-fault='{c.fault}']")
        assert row.is_visible()
        assert row.locator("td[data-field='runs']").inner_text() == str(c.runs)
        assert row.locator("td[data-field='verdict']").inner_text() == c.verdict
    assert page.locator("div.chart[data-figure='verdicts-trees-reference-v1-nominal'] svg.marks").bounding_box()["width"] > 300


def test_empty_campaign_renders(page, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    make_store(tmp_path / "e").close()
    out = build_report(tmp_path / "e", tmp_path / "e.html")
    page.goto(out.resolve().as_uri())
    assert page.locator("#empty-campaign").is_visible()
    assert page.inner_text("#runs-done") == "0"


def test_a_search_report_renders_its_search_section(page, tiny_searches: SearchDirs,  # type: ignore[no-untyped-def]
                                                    tmp_path: Path) -> None:
    out = tmp_path / "search.html"
    code, _, err = cli("report", str(tiny_searches.search), "-o", str(out), "--baseline", str(tiny_searches.baseline))
    assert code == 0, err
    errors: list[str] = []
    outside: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("request", lambda req: outside.append(req.url) if not req.url.startswith(("file:", "data:")) else None)
    page.goto(out.resolve().as_uri())
    section = page.locator("section#search")
    assert section.is_visible()
    # after the summary, before the campaign's own sections, and linked from the navigation bar
    order = page.evaluate("['summary', 'search', 'difficulty'].map(i => document.getElementById(i))"
                          ".map((e, _, a) => a[0].compareDocumentPosition(e))")
    assert order[1] & 4 and order[2] & 4  # DOCUMENT_POSITION_FOLLOWING
    assert page.evaluate("document.getElementById('search').compareDocumentPosition("
                         "document.getElementById('difficulty'))") & 4
    page.locator("nav a[href='#search']").click()
    assert {"search-illumination", "search-found"} <= set(drawn(page))
    for fig in ("search-illumination", "search-found"):
        assert page.locator(f"section#search div.chart[data-figure='{fig}'] svg.marks").bounding_box()["width"] > 300, fig
    img = page.locator("section#search img[data-figure='search-best-worlds']")
    assert img.evaluate("i => i.complete && i.naturalWidth > 300")
    assert img.bounding_box()["width"] > 300  # laid out, visible
    d = json.loads((tiny_searches.search / "search.json").read_text(encoding="utf-8"))
    assert page.inner_text("#search-confirmed") == str(d["confirmed"])
    assert page.locator("#search-found tr[data-method]").count() == 2
    assert page.locator("#search-elites tr[data-key]").count() == len(d["elites"])
    assert str(tiny_searches.search / "suite" / "suite.yaml") in page.inner_text("#search-suite")
    assert errors == [] and outside == []


def test_report_tables_sort_filter_and_link_runs_to_their_traces(page, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    root = _campaign(tmp_path / "camp")
    out = build_report(root, tmp_path / "out" / "report.html")
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.set_viewport_size({"width": 1280, "height": 900})
    page.goto(out.resolve().as_uri())
    # readable at 1,280 px: the page itself never scrolls sideways (a wide table scrolls in its box)
    assert page.evaluate("document.documentElement.scrollWidth") <= 1280
    # every table of the analysis that a reader ranks by is sortable
    from navstress.analysis.report import SORTABLE
    present = page.evaluate("ids => ids.filter(i => document.getElementById(i))", list(SORTABLE))
    assert "difficulty-table" in present and "verdicts-configurations" in present
    assert all(page.locator(f"table#{i}.sortable").count() == 1 for i in present)
    # sorting the difficulty table by its success-rate column, both ways
    table = page.locator("#difficulty-table")
    col = page.evaluate("Array.from(document.querySelectorAll('#difficulty-table tr:first-child th'))"
                        ".map(th => th.textContent.trim())").index("success")

    def rates() -> list[float]:
        return [float(v) for v in table.locator("td[data-field='success-rate']").evaluate_all(
            "tds => tds.map(td => td.getAttribute('data-value'))") if v not in (None, "")]

    header = table.locator("tr").first.locator("th").nth(col)
    header.click()
    assert header.get_attribute("aria-sort") == "ascending"
    assert rates() == sorted(rates()) and len(rates()) >= 2
    header.click()
    assert header.get_attribute("aria-sort") == "descending"
    assert rates() == sorted(rates(), reverse=True)
    # the runs of a configuration: one row each, its outcome and a trace link that resolves
    with Store.open(root) as s:
        mine = [r for r in s.records() if r.run_id.startswith("trees/tree=4/")]
    section = page.locator("section#cfg-trees--tree-4")
    section.locator("details.runs summary").click()
    assert section.locator("table#runs-trees--tree-4").count() == 1
    runs = section.locator("table.runs tr[data-run]")
    assert runs.count() == len(mine)
    for r in mine:
        row = section.locator(f"table.runs tr[data-run='{r.run_id}']")
        assert row.is_visible()
        assert row.get_attribute("data-outcome") == r.outcome
        href = row.locator("a[data-trace]").get_attribute("href") if r.trace else None
        if href is not None:
            assert not href.startswith("file:")  # relative: the report moves with its campaign
            assert (out.parent / href).resolve() == (root / r.trace).resolve()
            assert (out.parent / href).is_file()
    # the per-run view: clicking a run's line finds its row; clicking a row marks its line
    failing = next(r for r in mine if r.outcome == "fail-timeout")
    line = section.locator(f"svg.map g[data-run='{failing.run_id}']").first
    assert line.locator("polyline").count() == 1
    assert f"m{failing.map_index} r{failing.run_index} " in (line.locator("title").text_content() or "")
    line.locator("polyline").dispatch_event("click")
    assert section.locator(f"table.runs tr.hl[data-run='{failing.run_id}']").count() == 1
    # its own view opens with its row's facts, its trajectories and its perceived map
    panel = section.locator(".runview")
    assert panel.is_visible() and panel.get_attribute("data-run") == failing.run_id
    facts = dict(zip(panel.locator("dt").all_inner_texts(), panel.locator("dd").all_inner_texts()))
    assert facts["reason"] == failing.reason and facts["run seed"] == str(failing.run_seed)
    assert facts["outcome"] == "Fail-TimeOut" and facts["map seed"] == str(failing.map_seed)
    href = panel.locator("a[data-trace]").get_attribute("href")
    assert href is not None and (out.parent / href).resolve() == (root / failing.trace).resolve()  # type: ignore[operator]
    for kind in ("run", "runmap"):
        pic = panel.locator(f"svg.map[data-figure='{kind}-{failing.run_id}']")
        assert pic.count() == 1 and pic.bounding_box()["width"] > 200, kind
    assert panel.locator(f"svg.map[data-figure='run-{failing.run_id}'] polyline.perceived").count() == 1
    # the perceived map's picture decodes
    assert panel.locator("svg.map image").evaluate(
        "e => { const i = new Image(); i.src = e.getAttribute('href'); return i.decode().then(() => i.naturalWidth); }") > 10
    panel.locator("button.close").click()
    assert not panel.is_visible()
    other = next(r for r in mine if r.outcome == "success")
    section.locator(f"table.runs tr[data-run='{other.run_id}'] td").first.click()
    # a successful run's view: its facts, no embedded picture
    assert panel.is_visible() and panel.get_attribute("data-run") == other.run_id
    assert panel.locator("svg.map").count() == 0 and "successful run" in panel.inner_text()
    marked = page.evaluate("Array.from(document.querySelectorAll('svg.map g.hl')).map(g => g.dataset.run)")
    assert marked and set(marked) == {other.run_id}
    assert section.locator(f"table.runs tr.hl").count() == 1
    # a click on a picture enlarges it, another shrinks it back
    pic = section.locator("svg.map").first
    w0 = pic.bounding_box()["width"]
    pic.locator("use").dispatch_event("click")
    assert pic.bounding_box()["width"] > 1.5 * w0
    pic.locator("use").dispatch_event("click")
    assert pic.bounding_box()["width"] == pytest.approx(w0)
    # filtering: typing an outcome hides the other rows
    box = section.locator("input.filter")
    box.fill("timeout")
    visible = runs.evaluate_all("rs => rs.filter(r => r.offsetParent !== null).map(r => r.dataset.outcome)")
    assert visible == ["fail-timeout"]
    box.fill("")
    assert runs.evaluate_all("rs => rs.filter(r => r.offsetParent !== null).length") == len(mine)
    assert errors == []


# ---- the page at a phone's and a laptop's width ----------------------------------------------

#: The widths a report must read at without sideways scrolling: a phone's, a laptop's.
WIDTHS = (390, 1280)
#: The navigators of the wide campaign (two built-in ones: the report's every table names them).
NAVIGATORS = ("reference-v1", "reference-global-v1")
#: Per table, the header cells that must be in view at load (the columns a person came for).
KEYS = {"difficulty-table": {"level", "success"},
        "verdicts-configurations": {"verdict", "pass probability"},
        "verdicts-worlds": {"verdict", "pass probability"},
        "fault-power-table": {"fault", "share with collision", "new failures"},
        "indeterminism-table": {"peak [m]"},
        "search-found": {"seen", "confirmed"},
        "search-elites": {"confirmation", "fitness"}}


def _wide_campaign(root: Path) -> Path:
    """A demo-like campaign, wider than ``_campaign``: two classes, seven configurations, two
    navigators, a faulty stack beside the nominal one, every outcome, long reasons."""
    reason = "the navigator raised RuntimeError: " + "planner/global/costmap-inflation " * 6
    d = spec_dict(trees=[0, 4, 8, 16], defs=[0.5, 1.0, 1.5], faults=[None, "small-footprint"])
    d["navigators"] = [{"name": n} for n in NAVIGATORS]
    with Store.create(root, parse_campaign(d), yaml.safe_dump(d)) as s:
        save_flat_worlds(s, trees_per_map=2)
        outcomes = ["success", "fail-collision", "fail-error", "fail-timeout"]
        n = 0
        for exp, keys in (("trees", ["tree=0", "tree=4", "tree=8", "tree=16"]),
                          ("smooth", ["deformation=0.5", "deformation=1", "deformation=1.5"])):
            for j, key in enumerate(keys):
                for fault in (None, "small-footprint") if exp == "trees" else (None,):
                    for i in range(4):
                        m, r = divmod(i, 2)
                        o = outcomes[(i * j + (fault is not None)) % 4] if j else "success"
                        t = write_trace(root / "traces" / f"{n}.mcap", line(20 + i, 5, 5, 15 - i, 15))
                        rec = record(exp, key, m, r, o, fault=fault, duration=20.0 + i, tort=0.01 * (i + 1),
                                     goal=1.0 + i, collisions=int(o == "fail-collision"), trace=t)
                        for nav in NAVIGATORS:
                            s.add(replace(rec, navigator=nav, run_id=run_id(exp, key, m, r, nav, fault),
                                          reason=reason if o != "success" else "goal"))
                        n += 1
    return root


def _fits(page, url: str, width: int, tables: set[str]) -> None:  # type: ignore[no-untyped-def]
    """The report at ``url`` in a ``width`` px wide window: the page does not scroll sideways,
    every key column's header cell of every table shown is in view at load (and once every
    folded part is opened), ``tables`` among them; a table's first column stays in view when
    its box is scrolled to its end."""
    page.set_viewport_size({"width": width, "height": 900})
    page.goto(url)
    drawn(page)
    assert page.evaluate("document.documentElement.scrollWidth") <= width
    # the header cells shown: (table, text, left, right, marked as a key column)
    heads = """() => Array.from(document.querySelectorAll('table tr:first-child > th')).filter(th => th.offsetParent !== null)
        .map(th => { const r = th.getBoundingClientRect();
                     return [th.closest('table').id, th.textContent.trim(), r.left, r.right, th.classList.contains('key')]; })"""
    for opened in (False, True):
        if opened:
            page.evaluate("document.querySelectorAll('details').forEach(d => d.open = true)")
            assert page.evaluate("document.documentElement.scrollWidth") <= width
        cells = page.evaluate(heads)
        # the named key columns (by their header's text) and every column marked as one
        keys = [c for c in cells if c[4] or c[1] in KEYS.get(c[0], ())]
        assert not [k for k in keys if k[2] < 0 or k[3] > width], (width, keys)
        shown: dict[str, set[str]] = {}
        for t, text, _l, _r, _k in keys:
            shown.setdefault(t, set()).add(text)
        for t in tables:
            assert KEYS[t] <= shown.get(t, set()), (t, shown.get(t))
        if opened:  # every runs table has its outcome column in view
            runs = page.evaluate("Array.from(document.querySelectorAll('table.runs')).map(t => t.id)")
            assert runs and all("outcome" in shown.get(t, set()) for t in runs), (runs, shown)
    # a keyed table scrolled to its end in its box: its first column is still at the box's left
    for t in page.evaluate("Array.from(document.querySelectorAll('table.keyed')).map(t => t.id)"):
        box = page.evaluate("""id => { const t = document.getElementById(id), b = t.closest('.scroll');
            b.scrollLeft = b.scrollWidth; const c = t.rows[t.rows.length - 1].cells[0];
            return [b.getBoundingClientRect().left, c.getBoundingClientRect().left, b.scrollWidth > b.clientWidth]; }""", t)
        assert abs(box[0] - box[1]) < 1.5, (t, box)


@pytest.mark.parametrize("width", WIDTHS)
def test_a_campaign_report_reads_at_a_phone_and_a_laptop_width(page, tmp_path: Path,  # type: ignore[no-untyped-def]
                                                               width: int) -> None:
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    for make in (_campaign, _wide_campaign):
        root = make(tmp_path / make.__name__)
        out = build_report(root, tmp_path / f"{make.__name__}.html")
        _fits(page, out.resolve().as_uri(), width, {"difficulty-table", "verdicts-configurations", "verdicts-worlds",
                                                    "fault-power-table", "indeterminism-table"})
    assert errors == []


@pytest.mark.parametrize("width", WIDTHS)
def test_a_search_report_reads_at_a_phone_and_a_laptop_width(page, tiny_searches: SearchDirs,  # type: ignore[no-untyped-def]
                                                             tmp_path: Path, width: int) -> None:
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    for base in ((), ("--baseline", str(tiny_searches.baseline))):
        out = tmp_path / f"search{len(base)}.html"
        code, _, err = cli("report", str(tiny_searches.search), "-o", str(out), *base)
        assert code == 0, err
        _fits(page, out.resolve().as_uri(), width, {"search-found", "search-elites", "difficulty-table"})
    assert errors == []
