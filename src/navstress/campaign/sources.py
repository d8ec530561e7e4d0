"""The world sources of a campaign (docs/worlds.md, "Any world in campaigns, searches, compare and
gate"): each source's digest pinned into the stored spec when the campaign is planned, and checked
before a campaign resumes.

A campaign whose worlds name a ``source`` (an occupancy-grid map, a Gazebo world, a world
directory) stores, in its spec, the sha256 of each source as it was when the campaign was planned
(``source.sha256``). Resuming gives the spec as the user wrote it (no digest): :func:`pin_sources`
gives it the stored digests, so that it is the stored spec again, and :func:`check_sources` loads
every source (:func:`~navstress.world.sources.load_source`), which refuses a file whose digest is
no longer the pinned one: one line naming the file, before anything is written or run. A campaign
of generated worlds has no source: its spec, plan and store are those of before sources existed."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from navstress.campaign.spec import CampaignSpec
from navstress.errors import SpecError
from navstress.world.spec import SourceSpec, WorldSpec


def _owners(spec: CampaignSpec) -> Iterator[tuple[str, dict[str, Any]]]:
    """(where, WorldSpec mapping) of every world mapping of ``spec`` that may name a source."""
    yield "world", spec.world
    for i, e in enumerate(spec.experiments):
        yield f"experiments[{i}].overrides", e.overrides
        for j, w in enumerate(e.worlds or ()):
            yield f"experiments[{i}].worlds[{j}].world", w.world


def has_sources(spec: CampaignSpec) -> bool:
    """Whether any world of ``spec`` names a source."""
    return any(isinstance(m.get("source"), dict) for _, m in _owners(spec))


def sources_of(spec: CampaignSpec) -> list[tuple[str, SourceSpec]]:
    """(where, SourceSpec) of every configuration's source (its merged world mapping), once per distinct source."""
    out: dict[str, tuple[str, SourceSpec]] = {}
    for i, e in enumerate(spec.experiments):
        for cfg in e.configurations(spec.world):
            src = cfg.world.get("source")
            if isinstance(src, dict):
                s = WorldSpec.model_validate({"source": src}).source
                assert s is not None
                out.setdefault(s.model_dump_json(), (f"experiments[{i}]", s))
    return list(out.values())


def _pins(spec: CampaignSpec) -> dict[str, str]:
    return {str(m["source"]["path"]): str(m["source"]["sha256"]) for _, m in _owners(spec)
            if isinstance(m.get("source"), dict) and m["source"].get("sha256")}


def pin_sources(spec: CampaignSpec, stored: CampaignSpec | None = None) -> CampaignSpec:
    """``spec`` with a ``sha256`` in each source that has none: the ``stored`` spec's pin of the
    same path (a campaign resumed or extended), else the source's digest now (a new campaign).
    A spec without sources is returned as it is (the same object)."""
    if not has_sources(spec):
        return spec
    from navstress.world.sources import load_source  # here: importing a source (numba, scipy) only where a world names one

    known = _pins(stored) if stored is not None else {}

    def pinned(m: dict[str, Any]) -> dict[str, Any]:
        src = m.get("source")
        if not isinstance(src, dict) or src.get("sha256"):
            return m
        path = str(src["path"])
        if path not in known:
            options = WorldSpec.model_validate({"source": src}).source
            assert options is not None
            world = load_source(options)
            known[path] = world.source.sha256 if world.source is not None else ""
        return {**m, "source": {**src, "sha256": known[path]}} if known[path] else m

    exps = []
    for e in spec.experiments:
        upd: dict[str, Any] = {}
        if isinstance(e.overrides.get("source"), dict):
            upd["overrides"] = pinned(e.overrides)
        if e.worlds is not None and any(isinstance(w.world.get("source"), dict) for w in e.worlds):
            upd["worlds"] = [w.model_copy(update={"world": pinned(w.world)}) for w in e.worlds]
        exps.append(e.model_copy(update=upd) if upd else e)
    return spec.model_copy(update={"world": pinned(spec.world), "experiments": exps})


def check_sources(spec: CampaignSpec) -> None:
    """Load every source of ``spec`` (:func:`~navstress.world.sources.load_source`): SpecError
    (one line naming the file) for a source that cannot be imported or whose digest is not its
    pin. (A given start or goal outside the map or inside an obstacle is the map's world
    generation failure, recorded as such: a search's candidates may put it there.)"""
    from navstress.world.sources import load_source  # here: importing a source (numba, scipy) only where a world names one

    for where, options in sources_of(spec):
        try:
            world = load_source(options)
        except SpecError as err:
            raise SpecError(f"{where}.world.{err.field}", err.value, err.expected, err.fix) from None
        assert world.source is not None
