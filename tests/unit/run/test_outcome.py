"""Run classification: each class, and the severity order when several problems coincide."""

import itertools

import pytest
from hypothesis import given
from hypothesis import strategies as st

from navstress.run.outcome import SEVERITY, Outcome, RunFacts, classify


def test_success_needs_arrival_within_tolerance() -> None:
    c = classify(RunFacts(arrived=True, goal_distance_m=1.2, goal_tolerance_m=2.0))
    assert c.outcome is Outcome.SUCCESS and c.problems == ()


@pytest.mark.parametrize("facts,expected,text", [
    (RunFacts(arrived=True, goal_distance_m=0.5, collisions=2, first_collision_s=12.0), Outcome.FAIL_COLLISION, "2 collision"),
    (RunFacts(error="no arc elected", goal_distance_m=40), Outcome.FAIL_ERROR, "no arc elected"),
    (RunFacts(timed_out=True, goal_distance_m=33.3), Outcome.FAIL_TIMEOUT, "33.3 m from goal"),
    (RunFacts(arrived=True, goal_distance_m=5.0, goal_tolerance_m=2.0), Outcome.FAIL_OTHER, "5.00 m from the goal"),
    (RunFacts(other=("robot flipped over at t=3.0 s",), goal_distance_m=80), Outcome.FAIL_OTHER, "flipped"),
    (RunFacts(error="navigator process exited with code -9", navigator_failure=True), Outcome.FAIL_OTHER, "code -9"),
    (RunFacts(goal_distance_m=3.0), Outcome.FAIL_OTHER, "without the navigator arriving"),
])
def test_each_class(facts: RunFacts, expected: Outcome, text: str) -> None:
    c = classify(facts)
    assert c.outcome is expected
    assert text in c.reason


def test_severity_order_is_documented_order() -> None:
    assert [o.value for o in SEVERITY] == ["fail-collision", "fail-error", "fail-timeout", "fail-other", "success"]
    assert Outcome.FAIL_TIMEOUT.label == "Fail-TimeOut" and Outcome.SUCCESS.label == "Success"


@given(st.booleans(), st.booleans(), st.booleans(), st.booleans())
def test_most_severe_problem_wins(collide: bool, error: bool, timeout: bool, other: bool) -> None:
    f = RunFacts(collisions=int(collide), error="boom" if error else None, timed_out=timeout,
                 other=("left the map",) if other else (), arrived=True, goal_distance_m=0.0)
    c = classify(f)
    present = [o for o, flag in zip(SEVERITY[:4], (collide, error, timeout, other)) if flag]
    assert c.outcome is (present[0] if present else Outcome.SUCCESS)
    assert list(c.problems) == present
    # every problem is named in the reason
    for word, flag in (("collision", collide), ("boom", error), ("timeout", timeout), ("left the map", other)):
        assert (word in c.reason) == flag
