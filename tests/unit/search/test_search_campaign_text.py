"""The campaign a search runs is made in code (``CampaignSpec`` objects, never a text read back), and
its store's ``spec.yaml`` is that spec's own text (``spec_yaml``): byte for byte the text the search
wrote when it built its campaign as YAML (the formula of navstress 5193c0b, kept here as the
oracle), so that a search's store and spec.yaml are what they were, over a family of searches
(navigator and config, faults, fixed or adaptive repetition, simulation overrides, obstacle moves,
several generations and a confirmation)."""

from __future__ import annotations

import copy
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
import yaml

from navstress.campaign.spec import AdaptiveRuns, parse_campaign_text, spec_yaml
from navstress.search.driver import CONFIRM, _campaign, _experiment, generation_name
from navstress.search.space import Candidate, Space
from navstress.search.spec import SearchSpec, parse_search

PARAMETERS = [{"path": "obstacles.obstruction.tree", "low": 0, "high": 20},
              {"path": "ground.deformation", "low": 0.0, "high": 1.5},
              {"path": "ground.subdivisions", "low": 0, "high": 6, "kind": "int"}]


def old_text(spec: SearchSpec, experiments: list[dict[str, Any]]) -> str:
    """The text of a search's campaign as navstress 5193c0b wrote it (search/driver.py ``_campaign``)."""
    r = spec.runs_per_candidate
    data = {"name": spec.name, "seed": spec.seed, "world": copy.deepcopy(spec.world),
            "navigators": [spec.navigator.model_dump(mode="json", exclude_none=True)],
            "faults": list(spec.faults), "maps_per_config": 1,
            "runs_per_map": r.model_dump(mode="json") if isinstance(r, AdaptiveRuns) else r,
            "timeout_s": spec.timeout_s, "goal_tolerance_m": spec.goal_tolerance_m,
            "sim": copy.deepcopy(spec.sim), "experiments": experiments}
    return yaml.safe_dump(data, sort_keys=False)


def old_experiment(name: str, cands: list[Candidate], runs: int | None = None) -> dict[str, Any]:
    out: dict[str, Any] = {"name": name, "worlds": [{"key": c.key, "map_seed": c.map_seed, "world": c.world_overrides}
                                                    for c in cands]}
    if runs is not None:
        out["runs_per_map"] = runs
    return out


@st.composite
def searches(draw: st.DrawFn) -> SearchSpec:
    params = draw(st.lists(st.sampled_from(PARAMETERS), max_size=3, unique_by=lambda p: p["path"]))
    space: dict[str, Any] = {"parameters": params, "map_seed": draw(st.booleans()) or not params}
    if draw(st.booleans()):
        space["moves"] = {"count": draw(st.integers(1, 3)), "radius_m": draw(st.floats(0.1, 5.0))}
    revealing = draw(st.booleans())
    objective = {"name": "fault-revealing", "fault": "small-footprint"} if revealing else {"name": "failure"}
    navigator: dict[str, Any] = {"name": draw(st.sampled_from(["reference-v1", "mine-v2"]))}
    if draw(st.booleans()):
        navigator["config"] = draw(st.dictionaries(st.sampled_from(["n_arcs", "gain", "mode"]),
                                                   st.none() | st.integers(-5, 50) | st.floats(-1e3, 1e3)
                                                   | st.text(max_size=5), max_size=3))
    if draw(st.booleans()):
        navigator["target"] = "some_pkg.nav:Nav"
    runs: Any = draw(st.integers(1, 4) | st.builds(lambda lo, hi: {"adaptive": {"min": lo, "max": lo + hi}},
                                                   st.integers(1, 3), st.integers(0, 3)))
    data: dict[str, Any] = {"name": draw(st.sampled_from(["search", "s-1.x"])), "seed": draw(st.integers(0, 2**62)),
                            "world": {"size_m": [30.0, 30.0], "cell_m": 0.5}, "space": space, "navigator": navigator,
                            "objective": objective, "budget": {"runs": 10_000}, "runs_per_candidate": runs,
                            "algorithm": {"name": "random", "batch": draw(st.integers(1, 4))},
                            "timeout_s": draw(st.sampled_from([400.0, 12.5, 60.0])),
                            "goal_tolerance_m": draw(st.sampled_from([2.0, 0.75]))}
    if draw(st.booleans()):
        data["sim"] = {"lidar_hz": draw(st.sampled_from([5.0, 10.0]))}
    return parse_search(data)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(spec=searches(), data=st.data())
def test_the_search_campaign_text_is_the_one_it_always_was(spec: SearchSpec, data: st.DataObject) -> None:
    space = Space.from_spec(spec)
    new, old = [], []
    for g in range(data.draw(st.integers(1, 3))):
        points = data.draw(st.lists(st.lists(st.floats(0.0, 1.0), min_size=space.dimension,
                                             max_size=space.dimension), min_size=1, max_size=3))
        cands = list({c.key: c for c in (space.decode(x) for x in points)}.values())
        new.append(_experiment(generation_name(g), cands))
        old.append(old_experiment(generation_name(g), cands))
        text = spec_yaml(_campaign(spec, new))
        assert text == old_text(spec, old)
    if data.draw(st.booleans()):
        elite = [space.decode(data.draw(st.lists(st.floats(0.0, 1.0), min_size=space.dimension,
                                                 max_size=space.dimension)))]
        new.append(_experiment(CONFIRM, elite, spec.confirm_runs))
        old.append(old_experiment(CONFIRM, elite, spec.confirm_runs))
    campaign = _campaign(spec, new)
    text = spec_yaml(campaign)
    assert text == old_text(spec, old)
    assert parse_campaign_text(text, max_runs=None).digest() == campaign.digest()
