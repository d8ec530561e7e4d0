"""analyze(DIR) and the HTML report on small synthetic stores (records, traces, worlds by hand)."""

from __future__ import annotations

import json
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from tests.support.analysis_synth import line, make_store, record, save_flat_worlds, write_trace
from scipy import stats as sst

from navstress.analysis.analyze import analyze
from navstress.analysis.descriptors_corr import correlations, flatten, spearman
from navstress.analysis.report import build_report
from navstress.analysis.stats import wilson
from navstress.errors import StoreError


def test_spearman_and_flatten() -> None:
    x, y = [1.0, 2.0, 2.0, 5.0, 7.0], [3.0, 1.0, 4.0, 4.0, 9.0]
    assert spearman(x, y) == pytest.approx(sst.spearmanr(x, y).statistic)
    assert spearman([1, 1, 1], [1, 2, 3]) is None and spearman([1, 2], [1, 2]) is None
    assert flatten({"a": 1, "b": {"c": 2.5, "d": True, "e": "x", "f": None}}) == {"a": 1.0, "b.c": 2.5, "b.d": 1.0}
    desc = {("e", str(i)): {"good": float(i), "flat": 1.0, "anti": float(-i)} for i in range(4)}
    rank = {("e", "0"): 0, ("e", "1"): 0, ("e", "2"): 1, ("e", "3"): 2}
    cs = correlations(desc, rank, {k: 1 - v / 2 for k, v in rank.items()})
    assert [c.descriptor for c in cs][-1] == "flat" and cs[-1].rho_level is None
    assert {c.descriptor: round(c.rho_level or 0, 6) for c in cs[:2]} == {
        "good": round(sst.spearmanr([0, 1, 2, 3], [0, 0, 1, 2]).statistic, 6),
        "anti": -round(sst.spearmanr([0, 1, 2, 3], [0, 0, 1, 2]).statistic, 6)}


@pytest.fixture
def campaign(tmp_path: Path) -> Path:
    """trees 0/4/8 x 2 maps x 2 runs (+ a fault on trees), smooth d=0.5; partially recorded, with traces."""
    root = tmp_path / "c"
    with make_store(root, faults=[None, "small"]) as s:
        save_flat_worlds(s, trees_per_map=1)
        tdir = root / "traces"
        def tr(name: str, xyt: np.ndarray) -> str:
            return write_trace(tdir / f"{name}.mcap", xyt)
        # tree=0: 4/4 successes; map 0 runs end apart by 1 m at t=10
        s.add(record("trees", "tree=0", 0, 0, duration=10.0, tort=0.01, trace=tr("a", line(10, 0, 0, 10, 0))))
        s.add(record("trees", "tree=0", 0, 1, duration=11.0, tort=0.02, trace=tr("b", line(10, 0, 0, 10, 1))))
        s.add(record("trees", "tree=0", 1, 0, duration=11.0, tort=0.01))
        s.add(record("trees", "tree=0", 1, 1, duration=12.0, tort=0.03))
        # tree=4: 2 of 4
        s.add(record("trees", "tree=4", 0, 0, duration=20.0, tort=0.2))
        s.add(record("trees", "tree=4", 0, 1, "fail-error", duration=5.0, goal=8.0))
        s.add(record("trees", "tree=4", 1, 0, duration=30.0, tort=0.3))
        s.add(record("trees", "tree=4", 1, 1, "fail-timeout", duration=100.0, goal=6.0))
        # tree=8: all failures on an all-failure map; map 1 not run yet (partial)
        s.add(record("trees", "tree=8", 0, 0, "fail-error", goal=15.0))
        s.add(record("trees", "tree=8", 0, 1, "fail-error", goal=17.0))
        # faulty runs on tree=4
        s.add(record("trees", "tree=4", 0, 0, "fail-collision", fault="small", collisions=1, goal=9.0))
        s.add(record("trees", "tree=4", 0, 1, "fail-error", fault="small", goal=9.0))
        # smooth: nothing recorded (an empty configuration)
    return root


def test_analyze_synthetic_campaign(campaign: Path) -> None:
    a = analyze(campaign)
    assert (a.done, a.planned) == (12, 2 * 3 * 4 + 4)
    nom = {s.config_key: s for s in a.nominal}
    assert (nom["tree=0"].successes, nom["tree=0"].median_duration_s) == (4, 11.0)
    assert nom["tree=4"].median_tortuousness == pytest.approx(0.25)
    assert nom["deformation=0.5"].runs == 0
    assert a.level("trees", "tree=8") == "very difficult"
    assert a.level("smooth", "deformation=0.5") == "no data"
    assert a.level("trees", "tree=0") == "easy" and a.level("trees", "tree=4") == "challenging"
    curves = a.indeterminism[("trees", "tree=0")]
    np.testing.assert_allclose(curves["success"].d, np.arange(11) / 10)  # the two traced runs drift 0.1 m/s
    assert curves["success"].n_maps == 1
    (p,) = a.power
    assert (p.config_key, p.runs, p.collisions, p.new_failures, p.nominal_runs) == ("tree=4", 2, 1, 1, 2)
    miss = {(e, k): (d, n) for e, k, d, n in a.missing}
    assert miss[("trees", "tree=8")] == (2, 8) and miss[("trees", "tree=4")] == (6, 8) and miss[("smooth", "deformation=0.5")] == (0, 4)
    assert miss[("trees", "tree=0")] == (4, 8)  # its faulty runs are still missing
    json.dumps(a.to_json())  # serialisable


class _Cells(HTMLParser):
    """Collects data-field/data-value per table row and every img src."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[dict[str, str]] = []
        self.imgs: list[str] = []
        self.charts: list[str] = []
        self.ids: dict[str, str] = {}
        self.srcs: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        d = {k: v or "" for k, v in attrs}
        if tag == "tr" and "data-config" in d:
            self.rows.append(dict(d))
        if tag == "td" and "data-field" in d and self.rows:
            self.rows[-1]["f:" + d["data-field"]] = d.get("data-value", "")
        if tag == "img":
            self.imgs.append(d.get("src", ""))
        if tag == "div" and d.get("class") == "chart":
            self.charts.append(d["data-figure"])
        if "id" in d and "data-value" in d:
            self.ids[d["id"]] = d["data-value"]
        for k in ("src", "href"):
            if k in d:
                self.srcs.append(d[k])


def test_report_numbers_match_the_store(campaign: Path, tmp_path: Path) -> None:
    out = build_report(campaign, tmp_path / "r" / "report.html")
    text = out.read_text()
    p = _Cells()
    p.feed(text)
    assert p.ids["runs-done"] == "12" and p.ids["runs-planned"] == "28"
    assert p.ids["outcome-success"] == "6" and p.ids["outcome-fail-error"] == "4"
    rows = {(r["data-config"], r["data-fault"]): r for r in p.rows if "f:success-rate" in r}
    r4 = rows[("tree=4", "nominal")]
    assert float(r4["f:success-rate"]) == 0.5 and float(r4["f:ci-low"]) == pytest.approx(wilson(2, 4)[0])
    assert float(r4["f:median-duration"]) == 25.0 and r4["f:level"] == "challenging"
    assert rows[("tree=8", "nominal")]["f:median-duration"] == ""  # undefined, not 0
    assert rows[("deformation=0.5", "nominal")]["f:runs"] == "0"
    assert "partial-campaign" in text and "figure" in text
    assert all(s.startswith("data:image/png;base64,") for s in p.imgs)
    assert {"class-trees", "indeterminism-trees", "fault-power"} <= set(p.charts), p.charts  # smooth: no run yet
    assert not any(s.startswith(("http:", "https:", "//")) for s in p.srcs)  # self-contained


def test_a_report_says_how_far_it_is_step_by_step(campaign: Path, tmp_path: Path) -> None:
    """The progress callback: the analysis, the first sections, one step per configuration (each
    named in the page), then done; never backwards; the last step is the whole."""
    seen: list[tuple[str, int, int]] = []
    out = build_report(campaign, tmp_path / "p.html", progress=lambda what, done, total: seen.append((what, done, total)))
    text = out.read_text()
    n = text.count("<section id=")
    assert n > 3 and seen[0] == ("analysing the campaign", 0, 2)
    assert [w for w, _d, _t in seen[1:]] == ["writing the summary and the charts"] + ["drawing the configurations"] * n \
        + ["written"]
    assert [d for _w, d, _t in seen[1:]] == list(range(1, n + 3)) and {t for _w, _d, t in seen[1:]} == {n + 2}
    empty: list[tuple[str, int, int]] = []
    make_store(tmp_path / "e").close()
    build_report(tmp_path / "e", tmp_path / "e.html", progress=lambda *a: empty.append(a))
    assert empty[-1] == ("written", 2, 2)


@pytest.mark.slow
def test_the_report_command_shows_its_progress_on_a_terminal_only(campaign: Path, tmp_path: Path) -> None:
    """``navstress report``: with standard error a terminal, a progress bar names each step (and is
    gone at the end); piped, standard error stays empty; standard output is the one result line
    either way."""
    import os
    import pty
    import subprocess
    import sys
    exe = str(Path(sys.executable).with_name("navstress"))
    piped = subprocess.run([exe, "report", str(campaign), "-o", str(tmp_path / "a.html")], capture_output=True,
                           text=True, timeout=300)
    assert piped.returncode == 0 and piped.stderr == ""
    assert piped.stdout == f"report: {(tmp_path / 'a.html').resolve()}\n"
    main, sub = pty.openpty()
    p = subprocess.Popen([exe, "report", str(campaign), "-o", str(tmp_path / "b.html")], stdout=subprocess.PIPE,
                         stderr=sub, text=True, env={**os.environ, "COLUMNS": "120"})
    os.close(sub)
    seen = b""
    while True:
        try:
            chunk = os.read(main, 65536)
        except OSError:  # the terminal's other end is closed: the command has ended
            break
        if not chunk:
            break
        seen += chunk
    out, _ = p.communicate(timeout=300)
    os.close(main)
    assert p.returncode == 0 and out == f"report: {(tmp_path / 'b.html').resolve()}\n"
    import re
    text = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", seen.decode(errors="replace"))
    # (drawn at 10 Hz: a fast report may skip steps, never the first and the last)
    assert re.search(r"report: reading the campaign \S+ 0/2", text), text[-500:]
    assert re.search(r"report: written \S+ (\d+)/\1 ", text), text[-500:]


def test_empty_campaign_report_says_so(tmp_path: Path) -> None:
    make_store(tmp_path / "e").close()
    text = build_report(tmp_path / "e", tmp_path / "e.html").read_text()
    assert 'id="empty-campaign"' in text and 'data-value="0"' in text
    a = analyze(tmp_path / "e")
    assert a.done == 0 and set(a.difficulty.levels.values()) == {"no data"} and a.indeterminism == {}


def test_not_a_campaign_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(StoreError, match="not a campaign directory"):
        analyze(tmp_path)


def test_infeasible_maps_counts_the_generators_verdict(tmp_path: Path) -> None:
    from dataclasses import replace

    from navstress.analysis.analyze import infeasible_maps
    from navstress.world.spec import WorldSpec
    from navstress.world.world import World

    w = World.flat(WorldSpec(size_m=(20.0, 20.0), cell_m=0.5))
    replace(w, descriptors={"feasible": True, "path_length_m": 21.0}).save(tmp_path / "ok")
    replace(w, descriptors={"feasible": False, "path_length_m": None}).save(tmp_path / "walled")
    replace(w, descriptors={}).save(tmp_path / "unknown")  # no verdict recorded: not counted as infeasible
    dirs = [tmp_path / n for n in ("ok", "walled", "unknown", "not-generated-yet")]
    assert infeasible_maps(dirs) == (1, 3)
    assert infeasible_maps([]) == (0, 0)


def test_report_shows_infeasible_maps_per_configuration(campaign: Path, tmp_path: Path) -> None:
    from navstress.analysis.report import build_report

    html = build_report(campaign, tmp_path / "r.html").read_text()
    assert "maps infeasible a priori" in html
    assert html.count('data-field="infeasible-maps"') >= 1


@pytest.mark.not_traces
def test_trajectory_prefetch_in_worker_processes_reads_what_get_reads(tmp_path: Path) -> None:
    """Many traces are read in worker processes; the cache then holds, byte for byte, what a
    sequential get() reads; a missing trace and an unreadable one are None, as with get()."""
    from navstress.analysis.trajectories import TrajectoryCache
    paths: list[Path | None] = []
    for i in range(6):
        paths.append(Path(write_trace(tmp_path / f"{i}.mcap", line(10 + i, 0, i, 20, 5 + i))))
    (tmp_path / "junk.mcap").write_bytes(b"not an mcap file")
    paths += [tmp_path / "missing.mcap", tmp_path / "junk.mcap", None, paths[0]]
    par, seq = TrajectoryCache(), TrajectoryCache()
    par.prefetch(paths, workers=2)
    for p in paths:
        a, b = par.get(p), seq.get(p)
        assert (a is None) == (b is None)
        if a is not None and b is not None:
            assert a.tobytes() == b.tobytes() and len(a) > 10
    assert par.get(tmp_path / "junk.mcap") is None and par.get(tmp_path / "missing.mcap") is None
    par.close()


def test_trajectories_read_in_the_background_are_those_get_reads(tmp_path: Path) -> None:
    """prefetch(wait=False) returns while the workers read; after wait() the cache holds what
    get() reads (truth and perceived read together from each trace), nothing asked twice is read
    twice, and close() stops the workers (the cache keeps its arrays)."""
    from navstress.analysis.trajectories import TrajectoryCache
    from navstress.run.trace import TOPIC_PERCEIVED, TOPIC_TRUTH
    paths = [Path(write_trace(tmp_path / f"{i}.mcap", line(10 + i, 0, i, 20, 5 + i))) for i in range(8)]
    seq = TrajectoryCache()
    with TrajectoryCache() as par:
        par.prefetch(paths[:5], (TOPIC_TRUTH, TOPIC_PERCEIVED), workers=2, wait=False)
        par.prefetch(paths, workers=2, wait=False)  # the first five's truth is already asked for
        par.wait()
        assert len(par._c) == 5 * 2 + 3 and not par._pending
        for p in paths:
            for topic in (TOPIC_TRUTH, TOPIC_PERCEIVED):
                a, b = par.get(p, topic), seq.get(p, topic)
                assert a is not None and b is not None and a.tobytes() == b.tobytes()
        procs = [w._child.proc for w in par._workers if w._child is not None]
        assert len(procs) == 2 and all(p.is_alive() for p in procs)
    assert not par._workers and not any(p.is_alive() for p in procs)
    assert par.get(paths[0]) is not None
