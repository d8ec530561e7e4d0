"""`navstress run`'s batch (navstress.run.batch): records and traces carry the world's seed."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from navstress.run.batch import plan_batch, run_batch
from navstress.run.trace import read_metadata
from tests.support.world_fixtures import small_world


@pytest.mark.parametrize("seeds", [(0, 7, 2**40 + 3)])
def test_every_record_and_trace_carries_the_worlds_seed(seeds: tuple[int, ...], tmp_path: Path) -> None:
    tasks = []
    for s in seeds:
        w = tmp_path / f"w{s}"
        small_world(s, bumpy=False).save(w)
        tasks += plan_batch(w, tmp_path / "out" / str(s), navigator="reference-v1", navigator_config={},
                            fault=None, runs=2, seed=1, timeout_s=0.5, goal_tolerance_m=1.0)
    records = run_batch(tasks, tmp_path / "out")
    assert [r.map_seed for r in records] == [s for s in seeds for _ in range(2)]
    lines = [json.loads(x) for x in (tmp_path / "out" / "runs.jsonl").read_text().splitlines()]
    assert [x["map_seed"] for x in lines] == [r.map_seed for r in records]
    for r in records:
        assert r.trace is not None
        meta = read_metadata(r.trace)
        assert meta["map_seed"] == str(r.map_seed) == meta["world_seed"]
