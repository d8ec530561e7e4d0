"""Messages are bounded where a record is made: any reason or error in, at most the cap stored,
head and tail kept, the cut said; the store, the trace and exports get the bounded text."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.run.record import MAX_ERRORS, MAX_MESSAGE_CHARS, RunRecord, cap_errors, cap_message

CUT = re.compile(r"\.\.\.\[([\d,]+) characters cut\]\.\.\.")


def _record(reason: str, errors: list[str]) -> RunRecord:
    return RunRecord(run_id="e/c/m0/r0/reference-v1/nominal", experiment="e", config={}, map_index=0, run_index=0,
                     map_seed=1, run_seed=2, navigator="reference-v1", fault=None, outcome="fail-error",
                     reason=reason, duration_s=1.0, wall_s=1.0, goal_distance_m=1.0, path_length_m=0.0,
                     tortuousness=0.0, collisions=0, first_collision_s=None, errors=errors, trace=None)


@settings(max_examples=300, deadline=None)
@given(text=st.text(max_size=3000) | st.integers(0, 300_000).map(lambda n: "h" + "x" * n + "t"),
       limit=st.integers(40, 5000))
def test_any_message_in_is_bounded_with_head_and_tail_and_the_cut_said(text: str, limit: int) -> None:
    out = cap_message(text, limit)
    assert len(out) <= limit
    if len(text) <= limit:
        assert out == text
        return
    m = CUT.search(out)
    assert m is not None
    head, tail = out[:m.start()], out[m.end():]
    assert text.startswith(head) and text.endswith(tail)
    assert len(head) >= len(tail) >= 0 and len(head) > 0
    assert int(m.group(1).replace(",", "")) == len(text) - len(head) - len(tail)
    assert cap_message(out, limit) == out  # capping twice changes nothing


@settings(max_examples=100, deadline=None)
@given(n=st.integers(0, 300), size=st.integers(0, 5000))
def test_errors_are_bounded_in_count_and_size(n: int, size: int) -> None:
    errors = [f"{i}:" + "e" * size for i in range(n)]
    out = cap_errors(errors)
    assert len(out) <= MAX_ERRORS and all(len(e) <= MAX_MESSAGE_CHARS for e in out)
    if n <= MAX_ERRORS:
        assert [e.split(":")[0] for e in out] == [str(i) for i in range(n)]
    else:
        assert out[0].startswith("0:") and out[-1].startswith(f"{n - 1}:")
        assert any(f"{n - MAX_ERRORS + 1:,} errors cut" in e for e in out)
    assert cap_errors(out) == out


def test_a_20_mb_message_makes_a_small_record_store_row_and_export(tmp_path: Path) -> None:
    import yaml

    from navstress.campaign.spec import parse_campaign
    from navstress.campaign.store import Store

    big = "HEAD" + "x" * 20_000_000 + "TAIL"
    rec = _record(big, [big] * 1000)
    assert len(rec.reason) <= MAX_MESSAGE_CHARS and rec.reason.startswith("HEAD") and rec.reason.endswith("TAIL")
    m = CUT.search(rec.reason)
    assert m is not None and int(m.group(1).replace(",", "")) > 19_990_000
    assert RunRecord.from_row(rec.to_row()) == rec
    spec = {"name": "t", "experiments": [{"name": "e"}], "maps_per_config": 1, "runs_per_map": 1,
            "world": {"size_m": [20, 20], "cell_m": 0.5}}
    with Store.create(tmp_path / "c", parse_campaign(spec), yaml.safe_dump(spec)) as s:
        s.add(dataclasses.replace(_record(big, [big] * 1000), run_id=s.planned_ids()[0]))
        path = s.export("csv", tmp_path / "runs.csv")
    assert path.stat().st_size < 100_000
    assert sum(p.stat().st_size for p in (tmp_path / "c").rglob("*") if p.is_file()) < 2_000_000


def test_trace_events_are_bounded_too(tmp_path: Path) -> None:
    from navstress.run.trace import TraceWriter, read_events

    big = "HEAD" + "y" * 5_000_000 + "TAIL"
    with TraceWriter(tmp_path / "t.mcap") as w:
        w.event(1.0, "error", big)
    (ev,) = read_events(tmp_path / "t.mcap")
    msg = getattr(ev, "message", None) or str(ev)
    assert len(msg) <= MAX_MESSAGE_CHARS + 200 and "HEAD" in msg and "TAIL" in msg
    assert (tmp_path / "t.mcap").stat().st_size < 100_000
