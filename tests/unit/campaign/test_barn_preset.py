"""``navstress campaign init --preset barn --barn DIR [--all]``: BARN's protocol as a campaign spec,
the folder's paths kept whatever their characters, and bad folders refused in one line with
nothing written (every way a BARN folder can be incomplete, and the flags' misuses)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress.campaign.presets import (ALL_PRESETS, BARN_ALL_WORLDS, BARN_GOAL, BARN_START, BARN_TEST_WORLDS, preset,
                                        preset_yaml)
from navstress.campaign.spec import parse_campaign, parse_campaign_text, planned_runs
from navstress.robot import PROFILES
from tests.support.cli_run import cli


def fake_barn(d: Path, worlds: tuple[int, ...] = BARN_ALL_WORLDS) -> Path:
    """A folder laid out as BARN's (empty world files, tiny path files): what init reads."""
    (d / "path_files").mkdir(parents=True)
    for n in worlds:
        (d / f"world_{n}.world").write_text("<sdf version='1.6'/>")
        np.save(d / "path_files" / f"path_{n}.npy", np.array([[15, 0], [15, 29]]))
    return d


@pytest.fixture(scope="module")
def barn_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return fake_barn(tmp_path_factory.mktemp("b") / "BARN")


def test_the_test_set_protocol(barn_dir: Path) -> None:
    spec = parse_campaign(preset("barn", folder=barn_dir))
    (exp,) = spec.experiments
    assert [w.key for w in exp.worlds or ()] == [f"world_{n}" for n in range(0, 300, 6)]
    assert len(BARN_TEST_WORLDS) == 50 and planned_runs(spec) == 500
    assert spec.runs_per_map == 10 and spec.timeout_s == 100.0 and spec.goal_tolerance_m == 1.0
    assert [n.name for n in spec.navigators] == ["reference-2d-v1"] and spec.faults == [None]
    robot = spec.robot
    assert robot is not None and robot.name == "jackal"
    assert robot.model_copy(update={"sensors": None}) == PROFILES["jackal"].model_copy(update={"sensors": None})
    (laser,) = robot.sensors or ()
    assert laser.kind == "lidar2d" and laser.profile == "ust10"
    assert laser.mount.xyz == pytest.approx((0.055, 0.0, 0.2069))  # BARN's mount (presets.BARN_SCANNER)
    assert laser.params["fov_deg"] == 270.0 and laser.params["beams"] == 721 and laser.params["rate_hz"] == 50.0
    for w, n in zip(exp.worlds or (), range(0, 300, 6)):
        assert w.map_seed == n
        assert w.world["source"] == {"path": str((barn_dir / f"world_{n}.world").resolve()), "margin_m": 5.0}
        assert Path(w.world["source"]["path"]).is_absolute()
        assert w.world["mission"] == {"start": list(BARN_START), "goal": list(BARN_GOAL)}


def test_all_300_worlds(barn_dir: Path) -> None:
    spec = parse_campaign(preset("barn", folder=barn_dir, all_worlds=True), max_runs=None)
    assert [w.map_seed for w in spec.experiments[0].worlds or ()] == list(range(300))
    assert planned_runs(spec) == 3000 and spec.name == "barn-all"


def test_cli_writes_the_preset(barn_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "barn.yaml"
    code, stdout, _ = cli("campaign", "init", "--preset", "barn", "--barn", str(barn_dir), "-o", str(out))
    assert code == 0 and "barn" in stdout
    text = out.read_text()
    assert text.startswith("# navstress campaign spec: preset 'barn'.")
    assert parse_campaign_text(text).digest() == parse_campaign(preset("barn", folder=barn_dir)).digest()
    assert "barn" in ALL_PRESETS


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc"), exclude_characters="/\\"),
                    min_size=1, max_size=12).filter(lambda s: s not in (".", "..")))
def test_folder_names_round_trip(tmp_path_factory: pytest.TempPathFactory, name: str) -> None:
    """Any folder name (quotes, colons, '#', spaces, non-ASCII ...) reads back as the same paths."""
    try:
        d = fake_barn(tmp_path_factory.mktemp("n") / name, BARN_TEST_WORLDS)
    except OSError:
        return  # a name this file system refuses
    spec = parse_campaign_text(preset_yaml("barn", folder=d))
    got = [w.world["source"]["path"] for w in spec.experiments[0].worlds or ()]
    assert got == [str(d.resolve() / f"world_{n}.world") for n in BARN_TEST_WORLDS]


def _break(root: Path, how: str) -> tuple[list[str], str]:
    """A bad BARN folder (or bad flags): the extra argv and what the one line must name."""
    if how == "missing":
        return ["--barn", str(root / "nope")], str(root / "nope")
    if how == "a-file":
        (root / "f.world").write_text("x")
        return ["--barn", str(root / "f.world")], str(root / "f.world")
    d = root / "BARN"
    if how == "no-path-files":
        d.mkdir()
        for n in BARN_ALL_WORLDS:
            (d / f"world_{n}.world").write_text("x")
        return ["--barn", str(d)], "path_files"
    fake_barn(d, BARN_TEST_WORLDS)
    if how == "no-world-file":
        (d / "world_6.world").unlink()
        return ["--barn", str(d)], "world_6.world"
    if how == "no-path-file":
        (d / "path_files" / "path_294.npy").unlink()
        return ["--barn", str(d)], "path_294.npy"
    if how == "all-of-a-test-set":
        return ["--barn", str(d), "--all"], "world_1.world"
    if how == "barn-without-folder":
        return [], "--barn"
    if how == "folder-for-demo":
        return ["--barn", str(d), "--preset", "demo"], "--barn"
    if how == "all-for-demo":
        return ["--all", "--preset", "demo"], "--all"
    raise AssertionError(how)


@pytest.mark.parametrize("how", ["missing", "a-file", "no-path-files", "no-world-file", "no-path-file",
                                 "all-of-a-test-set", "barn-without-folder", "folder-for-demo", "all-for-demo"])
def test_bad_folders_one_line_nothing_written(tmp_path: Path, how: str) -> None:
    extra, named = _break(tmp_path, how)
    out = tmp_path / "out" / "barn.yaml"
    out.parent.mkdir()
    argv = ["campaign", "init", "-o", str(out), *extra]
    if "--preset" not in extra:
        argv += ["--preset", "barn"]
    code, stdout, stderr = cli(*argv)
    assert code == 2, (stdout, stderr)
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and named in lines[0], stderr
    assert list(out.parent.iterdir()) == []  # nothing written
