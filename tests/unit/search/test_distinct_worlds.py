"""Different candidates can make the same world (obstacle moves that were not applied): the
world digest tells them apart from the generated content, and a suite lists each world once."""

from __future__ import annotations

from pathlib import Path

from navstress.search.driver import CONFIRM, Elite, distinct_worlds
from navstress.search.objectives import Confirmation
from navstress.search.space import Candidate
from navstress.world.generate import generate
from navstress.world.spec import parse_spec
from navstress.world.world import World

BASE = {"size_m": [20.0, 20.0], "obstacles": {"obstruction": {"tree": 6.0}}}


def _world(moves: list[dict], seed: int = 2) -> World:
    return generate(parse_spec({**BASE, "obstacles": {**BASE["obstacles"], "moves": moves}}), seed)


def test_the_digest_is_the_generated_content_not_the_spec(tmp_path: Path) -> None:
    plain = _world([])
    off_map = _world([{"at": [10, 10], "by": [50.0, 0.0]}])      # refused: the same world
    moved = _world([{"at": [10, 10], "by": [0.3, 0.0]}])
    assert off_map.spec != plain.spec and off_map.digest() == plain.digest()
    assert moved.digest() != plain.digest()
    assert _world([], seed=3).digest() != plain.digest()
    plain.save(tmp_path / "w")
    assert World.load(tmp_path / "w").digest() == plain.digest()  # saved and loaded: the same


def _elite(key: str) -> Elite:
    c = Candidate(key=key, map_seed=2, world_overrides={}, params={})
    return Elite(c, 1.0, (), 0, Confirmation("failing", True, 0.95, 5, 5, (0.5, 1.0), "confirmed"))


def test_distinct_worlds_keeps_the_first_of_each_world_in_order(tmp_path: Path) -> None:
    worlds = {"wa": _world([]), "wb": _world([{"at": [10, 10], "by": [0.3, 0.0]}]),
              "wc": _world([{"at": [10, 10], "by": [50.0, 0.0]}]), "wd": _world([{"at": [10, 10], "by": [0.3, 0.0]}])}
    for key, w in worlds.items():
        w.save(tmp_path / "worlds" / CONFIRM / key / "m0")
    elites = [_elite(k) for k in ("wa", "wb", "wc", "wd", "we")]  # we: no world on disk
    kept, same = distinct_worlds(elites, tmp_path)
    assert [e.candidate.key for e in kept] == ["wa", "wb", "we"]
    assert same == {"wc": "wa", "wd": "wb"}
