"""What one run needs (RunTask) and what it leaves (RunRecord).

A RunTask is plain data (picklable, JSON-able): it travels to worker processes and Ray
workers, and it holds every seed, so any run can be replayed exactly from its record.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields
from typing import Any


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
    # campaign bookkeeping, carried through untouched
    experiment: str = ""
    config: dict[str, Any] = field(default_factory=dict)
    map_index: int = 0
    run_index: int = 0
    map_seed: int = 0
    sim_overrides: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, text: str) -> "RunTask":
        return cls(**json.loads(text))


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

    def to_row(self) -> dict[str, Any]:
        row = asdict(self)
        row["config"] = json.dumps(self.config, sort_keys=True)
        row["errors"] = json.dumps(self.errors)
        return row

    @classmethod
    def from_row(cls, row: dict[str, Any]) -> "RunRecord":
        names = {f.name for f in fields(cls)}
        d = {k: row[k] for k in names}
        d["config"] = json.loads(d["config"]) if isinstance(d["config"], str) else d["config"]
        d["errors"] = json.loads(d["errors"]) if isinstance(d["errors"], str) else d["errors"]
        return cls(**d)
