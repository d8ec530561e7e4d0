"""``robot:`` in a search spec: one robot (a profile, a mapping with a base and overrides) that every
campaign the search builds runs (its generations, its confirmation and its suite), with its bad
input named by the search spec's field; a search without one is the search it always was."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from navstress.campaign.plan import plan
from navstress.campaign.spec import parse_campaign_text, spec_yaml
from navstress.errors import SpecError
from navstress.robot import PROFILES
from navstress.search.driver import _campaign, _experiment, generation_name
from navstress.search.space import Space
from navstress.search.spec import load_search, parse_search, with_budget


def _data(**extra: Any) -> dict[str, Any]:
    return {"name": "s", "seed": 4, "world": {"size_m": [30.0, 30.0], "cell_m": 0.5},
            "space": {"parameters": [{"path": "obstacles.obstruction.tree", "low": 0, "high": 20}]},
            "objective": {"name": "failure"}, "budget": {"runs": 100}, "runs_per_candidate": 2,
            "algorithm": {"name": "random", "batch": 2}, **extra}


@pytest.mark.parametrize("robot", [*sorted(PROFILES), {"base": "jackal", "name": "ours", "mass_kg": 21.0},
                                   {"base": "turtlebot4", "name": "tb", "caster_positions": [[0.1, 0.0]]}])
def test_the_robot_reaches_every_campaign_of_the_search(robot: Any) -> None:
    spec = parse_search(_data(robot=robot))
    assert spec.robot is not None
    space = Space.from_spec(spec)
    campaign = _campaign(spec, [_experiment(generation_name(0), [space.decode([0.5] * space.dimension)])])
    assert campaign.all_robots() == [spec.robot]
    assert {t.robot_spec().digest for t in plan(campaign, "/tmp/s").tasks} == {spec.robot.digest}
    # the campaign's text (its store's spec.yaml) reads back as the same campaign
    assert parse_campaign_text(spec_yaml(campaign), max_runs=None).digest() == campaign.digest()
    assert with_budget(spec, 200).robot == spec.robot
    if robot == "rmp400":  # the default robot named: the campaign of a search without one
        plain = _campaign(parse_search(_data()), [_experiment(generation_name(0), [space.decode([0.5] * space.dimension)])])
        assert spec_yaml(plain) != spec_yaml(campaign) and plain.digest() == campaign.digest()


def test_no_robot_is_the_search_it_always_was() -> None:
    spec = parse_search(_data())
    assert spec.robot is None and "robot" not in spec.campaign_fields()


@pytest.mark.parametrize("robot,field,words", [
    ("jackall", "robot", "did you mean jackal"),
    ({"base": "huskyy"}, "robot.base", "did you mean husky"),
    ({"base": "jackal", "mass_kg": -2}, "robot.mass_kg", "> 0"),
    ({"base": "jackal", "wheel_count": 4}, "robot.wheel_count", "expected a robot field"),
    ([1], "robot", "robot profile name"),
])
def test_bad_robot_names_its_field(robot: Any, field: str, words: str) -> None:
    with pytest.raises(SpecError) as info:
        parse_search(_data(robot=robot))
    assert info.value.field == field and words in str(info.value) and "\n" not in str(info.value)


def test_a_robot_too_big_for_the_free_areas() -> None:
    world = {"size_m": [30.0, 30.0], "cell_m": 0.5, "mission": {"free_radius_m": 0.5}}
    with pytest.raises(SpecError, match=r"^world\.mission\.free_radius_m=0\.5 is invalid: .*'husky'"):
        parse_search(_data(world=world, robot="husky"))
    parse_search(_data(world=world, robot="turtlebot4"))


def test_a_spec_file_and_its_robot(tmp_path: Path) -> None:
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(_data(robot={"base": "jackal", "name": "ours", "length_m": 0.6})))
    spec, _ = load_search(p)
    assert spec.robot is not None and (spec.robot.name, spec.robot.length_m) == ("ours", 0.6)
