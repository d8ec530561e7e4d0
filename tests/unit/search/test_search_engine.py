"""A search runs through the campaign engine, as ``campaign run`` does: the executor comes from the
registry by name (here a plug-in's, found through its entry point: a distribution's metadata put on
``sys.path``, nothing installed), the search asks it to keep its workers (one pool for every
generation and the confirmation, ended once at the end), and ``campaign run`` on the campaign the
search wrote gives the same records and byte-identical traces through the same executor."""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from navstress.campaign.executors import run_campaign
from navstress.campaign.registry import ENTRY_POINT_GROUP
from navstress.campaign.store import Store
from navstress.search.driver import SearchResult, run_search

#: The plug-in: a local pool (no warm-up mission) that logs what the engine asks of it.
RECORDER = '''
from navstress.campaign.local import LocalExecutor

EVENTS = []


class Recording(LocalExecutor):
    def _spawn(self):
        EVENTS.append("spawn")
        return super()._spawn()

    def start(self, jobs):
        EVENTS.append("start")
        return super().start(jobs)

    def close(self):
        EVENTS.append("close")
        super().close()


def open_recording(options):
    EVENTS.append(("open", options.keep, options.workers))
    return Recording(options.workers or 1, options.targets, warm=False, keep=options.keep)
'''
#: Two generations of two worlds, one run each (budget 4), then the confirmation of one elite.
SEARCH: dict[str, Any] = {
    "name": "engine", "seed": 5,
    "world": {"size_m": [14.0, 14.0], "cell_m": 0.5,
              "mission": {"start": [3, 3, 0.785], "goal": [11, 11], "free_radius_m": 1.2}},
    "space": {"parameters": [{"path": "obstacles.obstruction.tree", "low": 5, "high": 30}]},
    "objective": {"name": "failure"}, "budget": {"runs": 4}, "runs_per_candidate": 1,
    "algorithm": {"name": "random", "batch": 2}, "confirm_runs": 1, "elites": 1, "timeout_s": 10.0,
}


@dataclasses.dataclass
class Ran:
    search: Path
    result: SearchResult
    search_events: list[Any]
    campaign: Path
    campaign_events: list[Any]


@pytest.fixture(scope="module")
def ran(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Ran]:
    root = tmp_path_factory.mktemp("engine")
    plugin = root / "plugin"
    plugin.mkdir()
    (plugin / "recording_executor.py").write_text(RECORDER, encoding="utf-8")
    info = plugin / "recording_executor-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: recording-executor\nVersion: 0.1\n", encoding="utf-8")
    (info / "entry_points.txt").write_text(f"[{ENTRY_POINT_GROUP}]\nrecording = recording_executor:open_recording\n",
                                           encoding="utf-8")
    spec = root / "search.yaml"
    spec.write_text(yaml.safe_dump(SEARCH, sort_keys=False), encoding="utf-8")
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(plugin))
        import recording_executor  # type: ignore[import-not-found]

        events: list[Any] = recording_executor.EVENTS
        result = run_search(spec, root / "search", workers=1, executor="recording")
        search_events = list(events)
        events.clear()
        run_campaign(root / "search" / "spec.yaml", root / "campaign", workers=1, executor="recording")
        yield Ran(root / "search", result, search_events, root / "campaign", list(events))
    sys.modules.pop("recording_executor", None)


def test_the_search_keeps_one_pool_of_the_named_executor_for_all_its_sessions(ran: Ran) -> None:
    r = ran.result
    assert r.generations == 2 and r.runs == 4 and r.confirm_runs == 1 and not r.unfinished
    # three sessions (two generations, the confirmation) on the one worker started for the first
    assert ran.search_events == [("open", True, 1), "start", "spawn", "start", "start", "close"]


def test_campaign_run_goes_through_the_same_executor_without_keeping_it(ran: Ran) -> None:
    assert ran.campaign_events == [("open", False, 1), "start", "spawn", "close"]


def _records(d: Path) -> list[dict[str, Any]]:
    with Store.open(d) as s:
        rows = [dataclasses.asdict(r) for r in s.records()]
    for row in rows:
        del row["wall_s"]
        if math.isnan(row["goal_distance_m"]):
            row["goal_distance_m"] = None
    return rows


def test_campaign_run_of_the_search_campaign_gives_its_records_and_traces(ran: Ran) -> None:
    """The search's campaign (its spec.yaml, written from the CampaignSpec the search made) is an
    ordinary campaign: the same planned runs, the same records, byte-identical traces."""
    with Store.open(ran.search) as a, Store.open(ran.campaign) as b:
        assert a.planned_ids() == b.planned_ids() and a.spec.digest() == b.spec.digest()
    assert (ran.search / "spec.yaml").read_text() == (ran.campaign / "spec.yaml").read_text()
    recs = _records(ran.search)
    assert len(recs) == ran.result.runs + ran.result.confirm_runs and recs == _records(ran.campaign)
    traces = sorted(p.relative_to(ran.search) for p in (ran.search / "traces").rglob("*.mcap"))
    assert len(traces) == len(recs)
    for t in traces:
        assert (ran.search / t).read_bytes() == (ran.campaign / t).read_bytes(), t
