"""The report's per-run views: every failing run with a trace gets one (its real and perceived
trajectories and its coarsened final perceived map, inert in a ``<template>`` until its row or line
is clicked), within a per-report cap that says how many it left out; the coarsening keeps, per
block, the highest known height and leaves a block unknown only when all of it is."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from tests.support.analysis_synth import line, make_store, record, save_flat_worlds, write_trace
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from navstress.analysis import report
from navstress.analysis.report import build_report, coarse_grid


@settings(max_examples=150, deadline=None)
@given(g=arrays(np.float32, st.tuples(st.integers(1, 40), st.integers(1, 40)),
                elements=st.one_of(st.just(np.nan), st.floats(-5, 5, width=32))),
       cells=st.integers(1, 45))
def test_a_coarse_grid_keeps_the_highest_known_height_of_each_block(g: np.ndarray, cells: int) -> None:
    out, origin, cell = coarse_grid(g, (1.5, -2.0), 0.25, cells)
    rows, cols = g.shape
    k = max(1, -(-max(rows, cols) // cells))
    assert max(out.shape) <= max(cells, 1) and origin == (1.5, -2.0) and cell == pytest.approx(0.25 * k)
    assert out.shape == (-(-rows // k), -(-cols // k))
    for i in range(out.shape[0]):
        for j in range(out.shape[1]):
            block = g[i * k:(i + 1) * k, j * k:(j + 1) * k].astype(np.float64)
            known = block[np.isfinite(block)]
            if known.size:
                assert out[i, j] == known.max()
            else:
                assert np.isnan(out[i, j])


def _campaign(root: Path, failing: int) -> Path:
    with make_store(root, trees=[0, 4], defs=[], maps=2, runs=4) as s:
        save_flat_worlds(s, trees_per_map=1)
        n = 0
        for key in ("tree=0", "tree=4"):
            for m in range(2):
                for r in range(4):
                    fail = n < failing
                    t = write_trace(root / "traces" / f"{n}.mcap", line(10 + r, 2, 2, 12, 12 - r))
                    s.add(record("trees", key, m, r, "fail-error" if fail else "success", trace=t))
                    n += 1
    return root


def test_every_failing_run_gets_its_view_within_the_cap(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = _campaign(tmp_path / "c", failing=6)
    text = build_report(root, tmp_path / "all.html").read_text(encoding="utf-8")
    views = re.findall(r'<template data-run-view="([^"]+)">(.*?)</template>', text, re.S)
    assert len(views) == 6 and all("/reference-v1/" in v for v, _ in views)
    for run_id, body in views:  # both pictures, named by the run, for its navigator
        assert f'data-figure="run-{run_id}"' in body and f'data-figure="runmap-{run_id}"' in body
        assert 'class="perceived"' in body and "data:image/png;base64," in body
    assert 'id="run-views-skipped"' not in text
    monkeypatch.setattr(report, "MAX_RUN_VIEWS", 4)
    text = build_report(root, tmp_path / "capped.html").read_text(encoding="utf-8")
    assert len(re.findall(r"<template data-run-view=", text)) == 4
    m = re.search(r'<p class="note" id="run-views-skipped">(\d+) failing runs', text)
    assert m and int(m.group(1)) == 2
