"""Campaign spec validation (error table naming the field) and sweep expansion."""

from __future__ import annotations

import copy
import math
from typing import Any

import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from navstress.campaign.presets import PRESETS, demo, paper, preset, preset_yaml
from navstress.campaign.spec import Range, load_campaign, parse_campaign, parse_campaign_text
from navstress.errors import SpecError


def _base(**over: Any) -> dict[str, Any]:
    d: dict[str, Any] = {"name": "t", "seed": 1, "world": {"size_m": [30, 30]},
                         "experiments": [{"name": "trees",
                                          "sweep": {"obstacles.obstruction.tree": {"start": 0, "stop": 4, "step": 2}}}]}
    d.update(over)
    return d


def _exp(**over: Any) -> dict[str, Any]:
    e: dict[str, Any] = {"name": "e", "sweep": {"ground.deformation": {"values": [0, 1]}}}
    e.update(over)
    return e


BAD: list[tuple[dict[str, Any], str, str]] = [
    (_base(seed=-1), "seed", ">= 0"),
    (_base(maps_per_config=0), "maps_per_config", ">= 1"),
    (_base(runs_per_map="five"), "runs_per_map", "an integer"),
    (_base(timeout_s=0), "timeout_s", "> 0"),
    (_base(experiments=[]), "experiments", ""),
    (_base(colour="red"), "colour", "a known field"),
    (_base(world={"size_m": [30, 30], "cell_m": 7}), "world.cell_m", "<= 2"),
    (_base(experiments=[_exp(sweep={"ground.deformaton": {"values": [1]}})], ), "experiments[0].sweep", "WorldSpec parameter path"),
    (_base(experiments=[_exp(sweep={"ground": {"values": [1]}})]), "experiments[0].sweep", "WorldSpec parameter path"),
    (_base(experiments=[_exp(sweep={"ground.deformation": {"start": 3, "stop": 1, "step": 1}})]), "experiments[0].sweep.ground.deformation",
     "stop (1) must be >= start (3)"),
    (_base(experiments=[_exp(sweep={"ground.deformation": {"start": 0, "stop": 1}})]), "experiments[0].sweep.ground.deformation",
     "start, stop and step"),
    (_base(experiments=[_exp(sweep={"ground.deformation": {"start": 0, "stop": 1, "step": 0}})]), "experiments[0].sweep.ground.deformation.step", "> 0"),
    (_base(experiments=[_exp(sweep={"ground.deformation": {"start": 0, "stop": 1, "step": 1e-9}})]),
     "experiments[0].sweep.ground.deformation", "at most 10000"),
    (_base(experiments=[_exp(sweep={"ground.deformation": {"values": [0, 60]}})]),
     "experiments[0].sweep[deformation=60].ground.deformation", "<= 50"),
    (_base(experiments=[_exp(sweep={"obstacles.obstruction.tre": {"values": [1]}})]),
     "experiments[0].sweep[tre=1].obstacles.obstruction.tre", "obstacle types"),
    (_base(experiments=[_exp(overrides={"ground": {"subdivisions": -1}})]), "experiments[0].overrides.ground.subdivisions", ">= 0"),
    (_base(experiments=[_exp(), _exp()]), "experiments[1].name", "unique"),
    (_base(experiments=[_exp(name="a/b")]), "experiments[0].name", "directory name"),
    (_base(navigators=[{"name": "x-v1"}, {"name": "x-v1"}]), "navigators", "without duplicates"),
    (_base(faults=[None, None]), "faults", "without duplicates"),
    (_base(faults=["bad name!"]), "faults", "fault name"),
]


@pytest.mark.parametrize("data,field,expected", BAD)
def test_bad_spec_names_field(data: dict[str, Any], field: str, expected: str) -> None:
    with pytest.raises(SpecError) as ei:
        parse_campaign(data)
    assert ei.value.field == field, str(ei.value)
    assert expected in str(ei.value)


def test_not_a_mapping() -> None:
    with pytest.raises(SpecError, match="mapping"):
        parse_campaign_text("- 1\n- 2\n")
    with pytest.raises(SpecError, match="valid YAML"):
        parse_campaign_text("a: [1,\n")


def test_missing_file(tmp_path: Any) -> None:
    with pytest.raises(SpecError, match="readable"):
        load_campaign(tmp_path / "nope.yaml")


def test_configurations_cartesian_and_keys() -> None:
    spec = parse_campaign(_base(experiments=[_exp(
        overrides={"ground": {"subdivisions": 2}},
        sweep={"ground.subdivisions": {"values": [2, 4]}, "ground.deformation": {"start": 0.5, "stop": 1.5, "step": 0.5}})]))
    cfgs = spec.experiments[0].configurations(spec.world)
    assert [c.key for c in cfgs] == [f"subdivisions={s},deformation={d}" for s in (2, 4) for d in ("0.5", "1", "1.5")]
    assert cfgs[4].values == {"ground.subdivisions": 4, "ground.deformation": 1.0}
    ws = cfgs[4].world_spec()
    assert ws.ground.subdivisions == 4 and ws.ground.deformation == 1.0 and ws.size_m == (30.0, 30.0)


def test_duplicate_short_names_use_full_path() -> None:
    """obstruction.tree and mix.tree share the last component: the key spells both in full."""
    from navstress.campaign.spec import _short_names

    assert _short_names(["obstacles.obstruction.tree", "obstacles.mix.tree", "ground.deformation"]) == {
        "obstacles.obstruction.tree": "obstacles.obstruction.tree", "obstacles.mix.tree": "obstacles.mix.tree",
        "ground.deformation": "deformation"}


@given(start=st.integers(-50, 50).map(lambda x: x / 4), n=st.integers(0, 40),
       step=st.sampled_from([0.1, 0.25, 0.5, 1.0, 2.5, 3.0]), extra=st.floats(0, 0.99))
def test_range_expansion(start: float, n: int, step: float, extra: float) -> None:
    stop = start + n * step + extra * step
    vals = Range(start=start, stop=stop, step=step).expand()
    assert len(vals) == n + 1
    assert vals[0] == pytest.approx(start)
    assert all(math.isclose(b - a, step, rel_tol=1e-9, abs_tol=1e-9) for a, b in zip(vals, vals[1:]))
    assert vals[-1] <= stop + 1e-9


def test_integer_range_stays_integer() -> None:
    assert Range(start=0, stop=28, step=2).expand() == list(range(0, 29, 2))
    assert all(isinstance(v, int) for v in Range(start=0, stop=4, step=1).expand())


@pytest.mark.parametrize("name", PRESETS)
def test_presets_validate_and_roundtrip_yaml(name: str) -> None:
    spec = parse_campaign(preset(name))
    again = parse_campaign_text(preset_yaml(name))
    assert spec.digest() == again.digest()


def test_paper_preset_design() -> None:
    spec = parse_campaign(paper())
    assert [e.name for e in spec.experiments] == ["buildings", "trees", "smooth-s2", "smooth-s4", "smooth-s6"]
    assert spec.maps_per_config == 5 and spec.runs_per_map == 5
    n_cfg = {e.name: len(e.configurations(spec.world)) for e in spec.experiments}
    assert n_cfg == {"buildings": 15, "trees": 15, "smooth-s2": 15, "smooth-s4": 12, "smooth-s6": 8}
    # the paper's Table I: the ground classes on Blender's Subdivide, d from 0 in steps of 0.5
    for s, top in ((2, 7.0), (4, 5.5), (6, 3.5)):
        cfgs = spec.experiments[[e.name for e in spec.experiments].index(f"smooth-s{s}")].configurations(spec.world)
        grounds = [c.world_spec().ground for c in cfgs]
        assert {(g.model, g.subdivisions, g.plane_m) for g in grounds} == {("blender", s, 2.0)}
        assert [g.deformation for g in grounds] == [0.5 * k for k in range(int(top / 0.5) + 1)]
        assert len(cfgs) * 25 == {2: 375, 4: 300, 6: 200}[s]  # the paper's runs per ground class


def test_movers_in_the_demo_and_dynamic_presets() -> None:
    demo_spec = parse_campaign(demo())
    movers = demo_spec.experiments[[e.name for e in demo_spec.experiments].index("movers")]
    worlds = [c.world_spec() for c in movers.configurations(demo_spec.world)]
    assert [w.movers.counts(w.size_m) for w in worlds] == [{"pedestrian": 1}, {"pedestrian": 4}]
    assert not any(v for w in worlds for v in w.obstacles.obstruction.values())  # movers on open ground
    assert {(b.kind, b.aim, b.clearance_m) for w in worlds for b in [w.movers.behaviour_of("pedestrian")]} == \
        {("intercept", "clearance", 2.0)}
    dyn = parse_campaign(preset("dynamic"))
    cfgs = {e.name: [c.world_spec() for c in e.configurations(dyn.world)] for e in dyn.experiments}
    assert [w.movers.counts(w.size_m)["pedestrian"] for w in cfgs["count"]] == [0, 1, 2, 4, 8]
    assert [w.movers.behaviour_of("pedestrian").clearance_m for w in cfgs["aggressiveness"]] == [6.0, 4.0, 2.0, 1.0, 0.0]
    assert all(w.movers.counts(w.size_m)["pedestrian"] == 2 for w in cfgs["aggressiveness"])
    assert list(dyn.faults) == [None]
    # 10 configurations x 3 maps x 3 runs, one navigator
    assert sum(len(c) for c in cfgs.values()) * dyn.maps_per_config * dyn.runs_per_map == 90


def test_digest_ignores_formatting_but_not_content() -> None:
    d = demo()
    a = parse_campaign(d)
    b = parse_campaign(yaml.safe_load(yaml.safe_dump(d, default_flow_style=True)))
    d2 = copy.deepcopy(d)
    d2["seed"] += 1
    assert a.digest() == b.digest() != parse_campaign(d2).digest()
