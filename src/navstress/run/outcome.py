"""Run outcomes and their classification.

A run ends for one of a few reasons (the navigator said it arrived or gave up with an
error, the time ran out, the robot flipped or left the mission area, the infrastructure failed).
:func:`classify` turns what happened into one :class:`Outcome`.

Severity order (a run with several problems takes the most severe one)::

    fail-collision > fail-error > fail-timeout > fail-other > success

Collision first because it is a safety failure whatever else happened; "error" is a failure
of the stack itself: an error it reported, or leaving the mission area (the geofence given in
``NavMission.bounds``: the stack knew it and drove out); a timeout means no progress to the
goal; "other" gathers everything else (ended away from the goal, robot flipped, navigator
process died, hung or spoke garbage, simulation unstable). Success requires: the navigator ended
normally (said "arrived"), no timeout, no error, no collision, and the final *real*
position within the goal tolerance.

Fail-Collision has two reasons: the robot hit something (an obstacle or a mover: "N
collision(s) ..."), or every collision was a mover hitting the robot while it stood ("hit by a
mover while stationary ...", ``RunFacts.collisions_hit``): the stack did not drive into it,
but it did not get out of the way either.

    >>> classify(RunFacts(collisions=1, collisions_hit=1, first_collision_s=3.0)).reason
    'hit by a mover while stationary: 1 collision(s) (first at t=3.0 s)'

    >>> classify(RunFacts(arrived=True, goal_distance_m=0.8, goal_tolerance_m=2.0)).outcome
    <Outcome.SUCCESS: 'success'>
    >>> classify(RunFacts(arrived=True, goal_distance_m=0.8, goal_tolerance_m=2.0, collisions=1)).outcome
    <Outcome.FAIL_COLLISION: 'fail-collision'>
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field


class Outcome(str, enum.Enum):
    SUCCESS = "success"
    FAIL_COLLISION = "fail-collision"
    FAIL_ERROR = "fail-error"
    FAIL_TIMEOUT = "fail-timeout"
    FAIL_OTHER = "fail-other"

    @property
    def label(self) -> str:
        """The paper's spelling: Success, Fail-Collision, ..."""
        return "-".join(p.capitalize() for p in self.value.split("-")).replace("Timeout", "TimeOut")

    @property
    def severity(self) -> int:
        return SEVERITY.index(self)


#: Most severe first.
SEVERITY: tuple[Outcome, ...] = (
    Outcome.FAIL_COLLISION, Outcome.FAIL_ERROR, Outcome.FAIL_TIMEOUT, Outcome.FAIL_OTHER, Outcome.SUCCESS,
)


#: The reason of a Fail-Collision run whose every collision was a mover hitting the standing robot.
HIT_WHILE_STATIONARY = "hit by a mover while stationary"


@dataclass(frozen=True)
class RunFacts:
    """What happened in a run, as observed by the framework (never by the navigator)."""

    arrived: bool = False  # the navigator returned Status("arrived")
    goal_distance_m: float = float("inf")  # final real position to goal
    goal_tolerance_m: float = 2.0
    collisions: int = 0
    collisions_hit: int = 0  # of ``collisions``: a mover hit the robot while it stood
    first_collision_s: float | None = None
    error: str | None = None  # navigator Status("error", msg), or its exception / process failure
    navigator_failure: bool = False  # the error came from the navigator crashing/hanging, not its own verdict
    timed_out: bool = False
    other: tuple[str, ...] = field(default_factory=tuple)  # flipped, unstable, ...
    left_area: str | None = None  # the robot left the mission area (the geofence it was told): where and when


@dataclass(frozen=True)
class Classification:
    outcome: Outcome
    reason: str
    problems: tuple[Outcome, ...]  # every problem seen, most severe first


def classify(f: RunFacts) -> Classification:
    """The outcome of a run with the facts ``f`` (see module doc for the order)."""
    problems: list[tuple[Outcome, str]] = []
    if f.collisions > 0:
        when = f" (first at t={f.first_collision_s:.1f} s)" if f.first_collision_s is not None else ""
        if f.collisions_hit >= f.collisions:
            problems.append((Outcome.FAIL_COLLISION, f"{HIT_WHILE_STATIONARY}: {f.collisions} collision(s){when}"))
        else:
            hit = f", {f.collisions_hit} of them {HIT_WHILE_STATIONARY}" if f.collisions_hit else ""
            problems.append((Outcome.FAIL_COLLISION, f"{f.collisions} collision(s){when}{hit}"))
    if f.error is not None:
        # A crashed or hung navigator process is infrastructure: Fail-Other with its reason.
        kind = Outcome.FAIL_OTHER if f.navigator_failure else Outcome.FAIL_ERROR
        problems.append((kind, f.error))
    if f.left_area is not None:  # the stack drove out of the area it was told: its own failure
        problems.append((Outcome.FAIL_ERROR, f.left_area))
    if f.timed_out:
        problems.append((Outcome.FAIL_TIMEOUT, f"timeout, {f.goal_distance_m:.1f} m from goal"))
    for reason in f.other:
        problems.append((Outcome.FAIL_OTHER, reason))
    if not problems and not f.arrived:
        problems.append((Outcome.FAIL_OTHER, "run ended without the navigator arriving"))
    if not problems and f.goal_distance_m > f.goal_tolerance_m:
        problems.append((Outcome.FAIL_OTHER,
                         f"navigator said arrived but the robot is {f.goal_distance_m:.2f} m from the goal "
                         f"(tolerance {f.goal_tolerance_m:.2f} m)"))
    if not problems:
        return Classification(Outcome.SUCCESS, f"arrived {f.goal_distance_m:.2f} m from goal", ())
    problems.sort(key=lambda p: p[0].severity)
    worst = problems[0][0]
    reason = "; ".join(r for _, r in problems)
    return Classification(worst, reason, tuple(p for p, _ in problems))
