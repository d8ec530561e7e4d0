"""Fault-revealing power (the paper's Q3): what a faulty navigator's runs reveal.

For each configuration, navigator and fault, against the nominal runs of the same navigator
on the **same maps** (same map index, hence the same world):

- ``collisions``: runs with a collision (``collisions > 0`` or outcome Fail-Collision),
  and their share of the runs;
- ``new_failures``: failed runs whose outcome the nominal navigator did not show on that
  map (a collision counts when no nominal run collided on that map; a Fail-TimeOut counts
  when no nominal run timed out there; ...), and their share;
- the nominal figures beside them (runs, collisions, share) over the maps the faulty runs used.

Runs on maps the world generator refused (:func:`navstress.run.record.ungenerated`) are left out
on both sides: ``refused`` counts the faulty ones; a configuration whose every faulty run is on a
refused map has no entry (nothing ran to reveal anything; the difficulty table counts its maps).

:func:`by_level` sums these per difficulty level (levels from the nominal analysis).
"""

from __future__ import annotations

from dataclasses import dataclass

from navstress.analysis.stats import NOMINAL, config_key, fault_name
from navstress.run.outcome import Outcome
from navstress.run.record import RunRecord, ungenerated


def collided(r: RunRecord) -> bool:
    return r.collisions > 0 or r.outcome == Outcome.FAIL_COLLISION.value


@dataclass(frozen=True)
class FaultPower:
    """One configuration's faulty-vs-nominal figures (see module doc)."""

    experiment: str
    config_key: str
    navigator: str
    fault: str
    runs: int
    collisions: int
    new_failures: int
    nominal_runs: int
    nominal_collisions: int
    level: str = ""
    refused: int = 0  # faulty runs on refused maps, left out

    @property
    def collision_share(self) -> float | None:
        return self.collisions / self.runs if self.runs else None

    @property
    def new_failure_share(self) -> float | None:
        return self.new_failures / self.runs if self.runs else None

    @property
    def nominal_collision_share(self) -> float | None:
        return self.nominal_collisions / self.nominal_runs if self.nominal_runs else None

    def to_json(self) -> dict[str, object]:
        return {"experiment": self.experiment, "config": self.config_key, "navigator": self.navigator,
                "fault": self.fault, "level": self.level, "runs": self.runs, "collisions": self.collisions,
                "collision_share": self.collision_share, "new_failures": self.new_failures,
                "new_failure_share": self.new_failure_share, "nominal_runs": self.nominal_runs,
                "nominal_collisions": self.nominal_collisions,
                "nominal_collision_share": self.nominal_collision_share, "refused_runs": self.refused}


def fault_power(records: list[RunRecord], levels: dict[tuple[str, str], str] | None = None) -> list[FaultPower]:
    """One :class:`FaultPower` per (configuration, navigator, fault != nominal), in first-seen order."""
    nominal: dict[tuple[str, str, str, int], list[RunRecord]] = {}
    faulty: dict[tuple[str, str, str, str], list[RunRecord]] = {}
    refused: dict[tuple[str, str, str, str], int] = {}
    for r in records:
        key = config_key(r)
        if fault_name(r.fault) == NOMINAL:
            if not ungenerated(r):
                nominal.setdefault((r.experiment, key, r.navigator, r.map_index), []).append(r)
        elif ungenerated(r):
            g = (r.experiment, key, r.navigator, fault_name(r.fault))
            refused[g] = refused.get(g, 0) + 1
        else:
            faulty.setdefault((r.experiment, key, r.navigator, fault_name(r.fault)), []).append(r)
    out: list[FaultPower] = []
    for (exp, key, nav, fault), runs in faulty.items():
        maps = sorted({r.map_index for r in runs})
        nom = [n for m in maps for n in nominal.get((exp, key, nav, m), [])]
        new = 0
        for r in runs:
            if r.outcome == Outcome.SUCCESS.value and not collided(r):
                continue
            seen = nominal.get((exp, key, nav, r.map_index), [])
            if collided(r):
                new += not any(collided(n) for n in seen)
            else:
                new += not any(n.outcome == r.outcome for n in seen)
        out.append(FaultPower(exp, key, nav, fault, len(runs), sum(collided(r) for r in runs), new,
                              len(nom), sum(collided(n) for n in nom),
                              (levels or {}).get((exp, key), ""), refused.get((exp, key, nav, fault), 0)))
    return out


@dataclass(frozen=True)
class LevelPower:
    """Fault power summed over the configurations of one difficulty level (one fault)."""

    level: str
    fault: str
    configs: int
    runs: int
    collisions: int
    new_failures: int
    nominal_runs: int
    nominal_collisions: int

    @property
    def collision_share(self) -> float | None:
        return self.collisions / self.runs if self.runs else None

    @property
    def nominal_collision_share(self) -> float | None:
        return self.nominal_collisions / self.nominal_runs if self.nominal_runs else None


def by_level(powers: list[FaultPower], level_order: tuple[str, ...]) -> list[LevelPower]:
    """Sum ``powers`` per (level, fault), levels in ``level_order`` (others after, by name)."""
    acc: dict[tuple[str, str], list[FaultPower]] = {}
    for p in powers:
        acc.setdefault((p.level, p.fault), []).append(p)
    rank = {lv: i for i, lv in enumerate(level_order)}
    keys = sorted(acc, key=lambda k: (rank.get(k[0], len(rank)), k[0], k[1]))
    return [LevelPower(lv, f, len(acc[(lv, f)]), sum(p.runs for p in acc[(lv, f)]),
                       sum(p.collisions for p in acc[(lv, f)]), sum(p.new_failures for p in acc[(lv, f)]),
                       sum(p.nominal_runs for p in acc[(lv, f)]), sum(p.nominal_collisions for p in acc[(lv, f)]))
            for lv, f in keys]
