"""Durations and ranges at the edge of what a float or a system call takes: every one is a
one-line error or works, never an OverflowError (found by the property tests)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from tests.support.cli_inputs import assert_one_line_error, invoke
from navstress.campaign.presets import demo
from navstress.campaign.spec import parse_campaign
from navstress.errors import SpecError
from navstress.isolate import Worker
from tests.support.world_fixtures import small_world


@pytest.mark.parametrize("flag, value", [("--timeout", "1073682"), ("--timeout", "1e300"), ("--timeout", "86401"),
                                         ("--wall-limit", "1e12"), ("--wall-limit", "2592001")])
def test_run_durations_past_their_bounds_are_one_line(tmp_path: Path, flag: str, value: str) -> None:
    small_world().save(tmp_path / "w")
    argv = ["run", str(tmp_path / "w"), "-o", str(tmp_path / "out"), flag, value]
    line = assert_one_line_error(*invoke(argv), argv)
    assert flag in line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("stop, step", [(8.98846567431158e307, 0.5), (1e308, 1e-300), (5.0, 1e-320)])
def test_sweep_ranges_too_large_to_count_are_spec_errors(stop: float, step: float) -> None:
    data = demo()
    data["experiments"][0]["sweep"] = {"cell_m": {"start": 0.5, "stop": stop, "step": step}}
    with pytest.raises(SpecError, match="sweep"):
        parse_campaign(data)


def test_a_worker_with_a_limit_past_what_poll_takes_still_answers() -> None:
    with Worker(1e9) as w:  # 1e9 s: poll() would overflow on one wait of that length
        assert w.call(math.sqrt, 16.0) == ("ok", 4.0)
