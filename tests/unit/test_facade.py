"""The public facade: ``navstress.run_mission`` (lazy: ``import navstress`` stays cheap)."""

from __future__ import annotations

import doctest
import subprocess
import sys
from pathlib import Path

import navstress
from navstress.nav.api import Command, Observation, Status
from navstress.run.trace import read_metadata, read_poses
from tests.support.world_fixtures import small_world


def test_import_navstress_does_not_import_the_simulation() -> None:
    code = ("import sys, navstress; assert callable(navstress.__dict__.get('cache_dir')); "
            "heavy = [m for m in ('mujoco', 'navstress.run.mission', 'navstress._facade') if m in sys.modules]; "
            "print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_run_mission_docstring_example_runs() -> None:
    finder = doctest.DocTestFinder()
    tests = finder.find(navstress.run_mission, "navstress.run_mission", globs={})
    assert tests and tests[0].examples
    runner = doctest.DocTestRunner()
    for t in tests:
        runner.run(t)
    assert runner.failures == 0 and runner.tries >= 4


class Creep:
    """A navigator written in the test: creeps forward, gives up after 1 s."""

    def reset(self, mission: object, robot: object, *, seed: int) -> None:
        self.seed = seed

    def step(self, obs: Observation) -> Command | Status:
        return Command(0.3, 0.0) if obs.t < 1.0 else Status("error", "tired")

    def close(self) -> None:
        pass


def test_run_mission_with_an_object_a_world_dir_and_a_trace(tmp_path: Path) -> None:
    w = small_world(9, bumpy=False)
    w.save(tmp_path / "w")
    a = navstress.run_mission(tmp_path / "w", Creep(), seed=4, trace=tmp_path / "t.mcap")
    b = navstress.run_mission(w, Creep(), seed=4)
    assert a.classification.outcome.value == "fail-error" and a.classification.reason == "tired"
    assert (a.truth == b.truth).all()
    assert read_metadata(tmp_path / "t.mcap")["map_seed"] == "9"
    assert len(read_poses(tmp_path / "t.mcap")) == len(a.truth)
    assert not list(tmp_path.glob(".*.partial"))
