"""docs/robots.md names the source of every profile's physical figures: the figures it cites are
the profiles' own (a figure changed in profiles.py without its source, or the other way round, fails)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from navstress.robot import PROFILES, RobotSpec

DOC = (Path(__file__).resolve().parents[3] / "docs" / "robots.md").read_text(encoding="utf-8")
FIGURES = ("mass_kg", "wheel_radius_m", "wheel_width_m", "track_m", "body_height_m", "ground_clearance_m",
           "max_speed_mps")


def _section(name: str) -> str:
    """The profile's section, without the old values it names ("was 0.555 m: corrected")."""
    m = re.search(rf"^### `{name}`.*?(?=^### |^## )", DOC, re.S | re.M)
    assert m, f"docs/robots.md has no section for {name}"
    return re.sub(r"\(?was [^:|)]*[:)]", "", m.group(0))


def _cited(value: float, text: str) -> bool:
    return re.search(rf"(?<![\d.]){re.escape(f'{value:g}')}(?![\d])", text) is not None


@pytest.mark.parametrize("name", sorted(n for n in PROFILES if n != "rmp400"))
def test_every_physical_figure_is_cited_with_its_value(name: str) -> None:
    r, text = PROFILES[name], _section(name)
    for f in FIGURES:
        assert _cited(getattr(r, f), text), f"{name}.{f} = {getattr(r, f):g} is not in its section of docs/robots.md"
    if r.wheelbase_m:
        assert _cited(r.wheelbase_m, text)
    for m in r.mounts.values():
        assert "(" + ", ".join(f"{v:g}" for v in m.xyz) + ")" in text
    assert "| source |" in text


def test_rmp400_is_the_default_robot() -> None:
    assert PROFILES["rmp400"] == RobotSpec() and "`RobotSpec()`" in _section("rmp400")
