"""Third-party navigators driving the REAL simulation: by entry point and out of process.

The example package (examples/straightline_nav) is installed by the ``example_package``
fixture as a user would; its navigator then runs real missions through ``execute``, the same
path campaigns use, and crashes of an external navigator end as classified runs.
"""

import json
import sys
from pathlib import Path

import pytest

from tests.support.nav_plugin_helpers import MISBEHAVING, STDIO
from navstress.run.mission import execute
from navstress.run.record import RunTask
from navstress.run.trace import read_poses
from navstress.world import Mission, World, WorldSpec

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def open_world(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A flat, empty 30 m world: a straight-line navigator can reach the goal."""
    w = World.flat(WorldSpec(size_m=(30.0, 30.0)), mission=Mission((5.0, 5.0, 0.3), (24.0, 22.0), 3.0))
    d = tmp_path_factory.mktemp("w") / "open"
    w.save(d)
    return d


def _task(world: Path, out: Path, navigator: str, config: dict, **kw: object) -> RunTask:
    return RunTask(run_id="plug/0", world_dir=str(world), run_seed=9, trace_path=str(out / "t.mcap"),
                   navigator=navigator, navigator_config=config, timeout_s=60.0, **kw)  # type: ignore[arg-type]


def test_entry_point_navigator_reaches_the_goal(example_package: Path, open_world: Path, tmp_path: Path) -> None:
    rec = execute(_task(open_world, tmp_path, "straightline-v1", {}))
    assert rec.outcome == "success", rec.reason
    truth = read_poses(rec.trace)
    assert truth[-1, 1] > 20 and truth[-1, 2] > 18


def test_out_of_process_navigator_reaches_the_goal(open_world: Path, tmp_path: Path) -> None:
    rec = execute(_task(open_world, tmp_path, "external-v1", {"command": [sys.executable, str(STDIO)]}))
    assert rec.outcome == "success", rec.reason


def test_out_of_process_and_in_process_give_the_same_trace(example_package: Path, open_world: Path,
                                                           tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a = execute(_task(open_world, tmp_path / "a", "straightline-v1", {}, ))
    b = execute(_task(open_world, tmp_path / "b", "external-v1", {"command": [sys.executable, str(STDIO)]}))
    ta, tb = read_poses(a.trace), read_poses(b.trace)
    assert ta.shape == tb.shape and (ta == tb).all()


def test_crashing_external_navigator_is_a_classified_run(open_world: Path, tmp_path: Path) -> None:
    cmd = [sys.executable, str(MISBEHAVING), "crash"]
    rec = execute(_task(open_world, tmp_path, "external-v1", {"command": cmd}))
    assert rec.outcome == "fail-other"
    assert "navigator process" in rec.reason
    assert Path(rec.trace).exists()
