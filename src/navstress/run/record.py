"""What one run needs (RunTask) and what it leaves (RunRecord).

A RunTask is plain data (picklable, JSON-able): it travels to worker processes and Ray
workers, and it holds every seed, so any run can be replayed exactly from its record.

Messages are bounded where a record is made: ``reason`` and each of ``errors`` keep at most
:data:`MAX_MESSAGE_CHARS` characters (head and tail, the cut said in the middle) and ``errors``
keeps at most :data:`MAX_ERRORS` items, so a navigator's 20 MB message cannot swell the store,
the exports or the report.

    >>> cap_message("x" * 10 + "y" * 5000 + "z" * 10, 60)
    'xxxxxxxxxxyyyyyy...[4,988 characters cut]...yyyyyyzzzzzzzzzz'
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields
from typing import Any

from navstress import _json
from pydantic import ValidationError

from navstress._models import spec_error
from navstress.robot import RobotSpec
from navstress.run.outcome import Outcome

#: The default robot (``rmp400``, the paper's): its name and description digest, what every record
#: made before robots existed is of.
DEFAULT_ROBOT = "rmp400"
DEFAULT_ROBOT_DIGEST = RobotSpec().digest


#: The start of the reason of every record of a run whose world could not be generated: the world
#: generator refused the map's spec (:func:`ungenerated`).
GENERATION_FAILED = "world generation failed"


@dataclass(frozen=True)
class RunTask:
    """One planned run. ``run_id`` is unique and stable within a campaign (resume key)."""

    run_id: str
    world_dir: str
    run_seed: int
    trace_path: str
    navigator: str = "reference-v1"
    navigator_config: dict[str, Any] = field(default_factory=dict)
    fault: str | None = None
    timeout_s: float = 400.0
    goal_tolerance_m: float = 2.0
    record_lidar: bool = False
    record_navigator: bool = False  # the navigator's debug drawings and its map at 1 Hz in the trace
    # campaign bookkeeping, carried through untouched
    experiment: str = ""
    config: dict[str, Any] = field(default_factory=dict)
    map_index: int = 0
    run_index: int = 0
    map_seed: int = 0
    sim_overrides: dict[str, Any] = field(default_factory=dict)
    #: the simulated robot, a RobotSpec's JSON mapping (None: the default ``RobotSpec()``, rmp400)
    robot: dict[str, Any] | None = None

    def robot_spec(self) -> RobotSpec:
        """The robot of this run (the default ``RobotSpec()`` when ``robot`` is None)."""
        if self.robot is None:
            return RobotSpec()
        try:  # JSON mode: the lists of the JSON text stand for the description's tuples
            return RobotSpec.model_validate_json(_json.dumps(self.robot))
        except ValidationError as err:
            raise spec_error(err, self.robot, model=RobotSpec, prefix="robot") from None

    def to_json(self) -> str:
        """JSON text of the task (a task of the default robot leaves ``robot`` out: the text of
        before robots existed)."""
        d = asdict(self)
        if d["robot"] is None:
            del d["robot"]
        return _json.dumps(d, sort_keys=True)

    @classmethod
    def from_json(cls, text: str) -> "RunTask":
        return cls(**json.loads(text))


#: Most characters kept of one message (a record's reason, each error, each trace event).
MAX_MESSAGE_CHARS = 2000
#: Most error messages a record keeps (the first and the last ones, the cut said between them).
MAX_ERRORS = 20


def _cut_marker(n: int) -> str:
    return f"...[{n:,} characters cut]..."


def cap_message(text: str, limit: int = MAX_MESSAGE_CHARS) -> str:
    """``text`` if it has at most ``limit`` characters, else its head and tail around a marker
    saying how many characters were cut; the result never exceeds ``limit`` (``limit`` >= 40)."""
    if len(text) <= limit:
        return text
    keep = max(limit - len(_cut_marker(len(text))), 0)
    marker = _cut_marker(len(text) - keep)
    tail = keep // 2
    return text[:keep - tail] + marker + (text[len(text) - tail:] if tail else "")


def cap_errors(errors: list[str], limit: int = MAX_ERRORS, chars: int = MAX_MESSAGE_CHARS) -> list[str]:
    """At most ``limit`` messages, each capped: the first and last ones, and between them one
    entry saying how many were cut."""
    out = [cap_message(str(e), chars) for e in errors]
    if len(out) <= limit:
        return out
    head = (limit - 1) - (limit - 1) // 2
    tail = (limit - 1) // 2
    return out[:head] + [f"...[{len(out) - head - tail:,} errors cut]..."] + (out[len(out) - tail:] if tail else [])


@dataclass(frozen=True)
class RunRecord:
    """The classified result of one run (one row of the campaign's ``runs`` table)."""

    run_id: str
    experiment: str
    config: dict[str, Any]
    map_index: int
    run_index: int
    map_seed: int
    run_seed: int
    navigator: str
    fault: str | None
    outcome: str  # success | fail-collision | fail-error | fail-timeout | fail-other
    reason: str
    duration_s: float  # simulated seconds
    wall_s: float
    goal_distance_m: float  # final real position to goal; NaN when unknown (the run never simulated)
    path_length_m: float
    tortuousness: float
    collisions: int
    first_collision_s: float | None
    errors: list[str]
    trace: str | None  # path of the MCAP trace relative to the campaign dir (or absolute), None if none
    robot: str = DEFAULT_ROBOT  # the simulated robot's name
    robot_digest: str = DEFAULT_ROBOT_DIGEST  # its description's digest (RobotSpec.digest)
    #: an imported world's source (World.source: kind, absolute path, sha256); None for a generated
    #: world, whose record, row and line have no such keys (their text of before sources existed)
    source_kind: str | None = None
    source_path: str | None = None
    source_sha256: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "reason", cap_message(str(self.reason)))
        object.__setattr__(self, "errors", cap_errors(list(self.errors)))

    def to_row(self) -> dict[str, Any]:
        row = without_source(asdict(self))
        row["config"] = _json.dumps(self.config, sort_keys=True)
        row["errors"] = _json.dumps(self.errors)
        return row

    @classmethod
    def from_row(cls, row: dict[str, Any]) -> "RunRecord":
        names = {f.name for f in fields(cls)}
        # (old rows: the default robot; a generated world's: no source)
        d = {k: row[k] for k in names if k in row or k not in (*_ROBOT_COLUMNS, *SOURCE_COLUMNS)}
        d["config"] = json.loads(d["config"]) if isinstance(d["config"], str) else d["config"]
        d["errors"] = json.loads(d["errors"]) if isinstance(d["errors"], str) else d["errors"]
        return cls(**d)


#: The record's robot columns (absent from rows made before robots existed: the default robot's).
_ROBOT_COLUMNS = ("robot", "robot_digest")
#: The record's world source columns (only in the rows of a run on an imported world).
SOURCE_COLUMNS = ("source_kind", "source_path", "source_sha256")


def without_source(d: dict[str, Any]) -> dict[str, Any]:
    """``d`` (a record's mapping) without its source keys when the record has no source (a
    generated world's: the keys of before sources existed)."""
    if d.get("source_kind") is None and d.get("source_path") is None and d.get("source_sha256") is None:
        for c in SOURCE_COLUMNS:
            d.pop(c, None)
    return d


def ungenerated(r: RunRecord) -> bool:
    """Whether ``r`` is the record of a run that never ran because the world generator refused its
    map (a :class:`~navstress.errors.GenerationError`: an obstruction target with no room, a start
    or goal that cannot be made drivable): Fail-Other with a reason starting with
    :data:`GENERATION_FAILED`, recorded for each run of the map. Such a record says something about
    the world spec, not about the stack: every statistic of the navigation (success rates, levels,
    indeterminism, fault power, verdicts, comparisons, the gate, the search's objectives) leaves it
    out and counts it apart; the per-run tables and exports keep it as recorded.

        >>> r = RunRecord("e/k/m0/r0/nav/nominal", "e", {}, 0, 0, 1, 2, "nav", None, "fail-other",
        ...               GENERATION_FAILED + ": obstruction of 'building' reached 9.00% of the map", 0.0, 0.0,
        ...               float("nan"), 0.0, 0.0, 0, None, [], None)
        >>> ungenerated(r), ungenerated(RunRecord(**{**r.__dict__, "reason": "robot flipped"}))
        (True, False)
    """
    return r.outcome == Outcome.FAIL_OTHER.value and r.reason.startswith(GENERATION_FAILED)
