"""One validation of a navigator's answers (navstress.nav.api.check_answer) for every path: the
same bad answer gets the same classification and reason in process and over the line protocol,
and the same verdict from the conformance checker."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.nav import wire
from navstress.nav.api import Command, InvalidAnswer, Observation, Status, check_answer
from navstress.nav.check import check_navigator
from navstress.nav.external import ExternalNavigator
from navstress.run.mission import run_mission
from navstress.world import Mission, World, WorldSpec

ECHO = Path(__file__).resolve().parents[2] / "support" / "navigators" / "echo_nav.py"

#: bad answers as (the in-process object, the same answer as a protocol reply)
BAD: list[tuple[Any, dict[str, Any]]] = [
    (Status("exploded"), {"type": "status", "kind": "exploded"}),  # type: ignore[arg-type]
    (Status("ARRIVED"), {"type": "status", "kind": "ARRIVED"}),  # type: ignore[arg-type]
    (Status(None), {"type": "status", "kind": None}),  # type: ignore[arg-type]
    (Status(3), {"type": "status", "kind": 3}),  # type: ignore[arg-type]
    (Status("error", 42), {"type": "status", "kind": "error", "message": 42}),  # type: ignore[arg-type]
    (Status("error", None), {"type": "status", "kind": "error", "message": None}),  # type: ignore[arg-type]
    (Status("arrived", ["ok"]), {"type": "status", "kind": "arrived", "message": ["ok"]}),  # type: ignore[arg-type]
    (Command("fast", 0.0), {"type": "command", "v": "fast", "omega": 0.0}),  # type: ignore[arg-type]
    (Command(True, 0.0), {"type": "command", "v": True, "omega": 0.0}),
    (Command(1.0, None), {"type": "command", "v": 1.0, "omega": None}),  # type: ignore[arg-type]
    (Command(1.0, [0.0]), {"type": "command", "v": 1.0, "omega": [0.0]}),  # type: ignore[arg-type]
]


class Answers:
    """An in-process navigator answering every step with ``answer``."""

    def __init__(self, answer: Any) -> None:
        self.answer = answer

    def reset(self, mission: Any, robot: Any, *, seed: int) -> None:
        pass

    def step(self, obs: Observation) -> Any:
        return self.answer

    def close(self) -> None:
        pass


def echo(reply: dict[str, Any]) -> ExternalNavigator:
    return ExternalNavigator([sys.executable, str(ECHO), json.dumps(reply)], step_budget_s=10.0)


def flat() -> World:
    return World.flat(WorldSpec(size_m=(20.0, 20.0)), mission=Mission((3.0, 3.0, 0.0), (15.0, 3.0), 1.0))


@pytest.mark.parametrize(("answer", "reply"), BAD, ids=[repr(b[1]) for b in BAD])
def test_same_bad_answer_same_classification_both_ways(answer: Any, reply: dict[str, Any]) -> None:
    with pytest.raises(InvalidAnswer) as info:
        check_answer(answer)
    detail = str(info.value)
    world = flat()
    local = run_mission(world, Answers(answer), run_seed=1, timeout_s=2.0).classification
    nav = echo(reply)
    try:
        remote = run_mission(world, nav, run_seed=1, timeout_s=2.0).classification
    finally:
        nav.close()
    assert local.outcome == remote.outcome
    assert local.outcome.value == "fail-other"
    assert detail in local.reason and detail in remote.reason, (local.reason, remote.reason)


@pytest.mark.parametrize(("answer", "reply"), BAD[:2] + BAD[4:5] + BAD[7:8])
def test_checker_judges_the_same_bad_answer_the_same_both_ways(answer: Any, reply: dict[str, Any]) -> None:
    detail = str(pytest.raises(InvalidAnswer, check_answer, answer).value)
    local = check_navigator(lambda *, config: Answers(answer), n_steps=2).result("valid-types")
    remote = check_navigator(lambda *, config: echo(reply), n_steps=2).result("valid-types")
    assert not local.passed and not remote.passed
    assert detail in local.detail and detail in remote.detail, (local.detail, remote.detail)


values = st.one_of(st.none(), st.booleans(), st.integers(-5, 5), st.floats(allow_nan=False, allow_infinity=False),
                   st.text(max_size=8), st.sampled_from(["arrived", "error"]), st.lists(st.integers(), max_size=2))


@settings(max_examples=300, deadline=None)
@given(kind=st.sampled_from(["status", "command"]), a=values, b=values)
def test_protocol_decoding_agrees_with_in_process_validation(kind: str, a: Any, b: Any) -> None:
    """For any field values: the wire accepts exactly what check_answer accepts, with its reason."""
    if kind == "status":
        obj: Any = Status(a, b)
        msg = {"type": "status", "kind": a, "message": b}
    else:
        obj = Command(a, b)
        msg = {"type": "command", "v": a, "omega": b}
    try:
        expected: Any = check_answer(obj)
    except InvalidAnswer as e:
        expected = str(e)
    try:
        got: Any = wire.decode_command_or_status(wire.loads(wire.dumps(msg)))
    except wire.WireError as e:
        got = str(e)
    assert got == expected
