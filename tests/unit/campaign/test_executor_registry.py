"""The executor registry (``navstress.campaign.registry``): navstress's own executors known with or
without the installed entry-point metadata, a plug-in's found through the entry-point group
``navstress.executors`` (a distribution's metadata put on ``sys.path`` here: nothing is installed),
the command line's ``--executor`` and its help read from it, and an unknown name refused in one
line naming the known ones, by every command and function that runs a campaign's runs."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from navstress.campaign.executors import open_runner, run_campaign
from navstress.campaign.local import LocalExecutor
from navstress.campaign.registry import (BUILTIN, ENTRY_POINT_GROUP, ExecutorOptions, check_executor, executor_help,
                                         executor_names, make_executor)
from navstress.campaign.spec import parse_campaign
from navstress.cli import app
from navstress.errors import SpecError
from navstress.search.driver import run_search

ROOT = Path(__file__).resolve().parents[3]
#: A plug-in's executor module: a local pool that says it was made (imported from the plug-in's folder).
PLUGIN = '''
from navstress.campaign.local import LocalExecutor

MADE = []


def open_inline(options):
    MADE.append(options)
    return LocalExecutor(options.workers or 1, options.targets, warm=False, keep=options.keep)
'''
#: Its distribution's metadata: the executor, a built-in's name it may not take, a malformed entry,
#: and one whose module is not there.
ENTRY_POINTS = f"""[{ENTRY_POINT_GROUP}]
inline = inline_executor:open_inline
local = inline_executor:open_inline
bad name = inline_executor:open_inline
gone = no_such_module_here:open
"""
CAMPAIGN = {"name": "tiny", "seed": 1, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
            "experiments": [{"name": "flat", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
            "maps_per_config": 1, "runs_per_map": 1, "timeout_s": 5.0}
SEARCH = {"name": "tiny-search", "seed": 1, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
          "space": {"parameters": [{"path": "obstacles.obstruction.tree", "low": 0, "high": 10}]},
          "objective": {"name": "failure"}, "budget": {"runs": 2}, "runs_per_candidate": 1,
          "algorithm": {"name": "random", "batch": 2}, "timeout_s": 5.0}
#: Names that are no executor: near misses, case, spaces, a look-alike letter, control characters, long.
UNKNOWN = ["", "nope", "Local", "RAY", "local ", " ray", "loca", "rаy", "local\nray", "ray:local", "x" * 500,
           "navstress.campaign.local:open_local"]


def plugin_dir(root: Path) -> Path:
    """A folder holding the plug-in's module and its distribution's metadata (a .dist-info, as pip
    leaves it): on ``sys.path`` it is an installed distribution for importlib.metadata."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "inline_executor.py").write_text(PLUGIN, encoding="utf-8")
    info = root / "inline_executor-0.1.dist-info"
    info.mkdir(exist_ok=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: inline-executor\nVersion: 0.1\n", encoding="utf-8")
    (info / "entry_points.txt").write_text(ENTRY_POINTS, encoding="utf-8")
    return root


@pytest.fixture
def plugin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    d = plugin_dir(tmp_path / "plugin")
    monkeypatch.syspath_prepend(str(d))
    yield d
    sys.modules.pop("inline_executor", None)


def one_line(err: BaseException) -> str:
    text = str(err)
    assert "\n" not in text and text, repr(text)
    return text


def test_the_built_in_executors_are_listed_first_and_load() -> None:
    assert executor_names()[:2] == ["local", "ray"] == list(BUILTIN)
    for name in ("local", "ray"):
        assert check_executor(name) == name
    ex = make_executor("local", ExecutorOptions(workers=3, keep=True))
    assert isinstance(ex, LocalExecutor) and ex.workers == 3 and ex.keep
    ex.close()
    assert make_executor("local", ExecutorOptions()).workers == (os.cpu_count() or 1)


def test_the_project_declares_its_executors_as_entry_points() -> None:
    """pyproject.toml declares the built-ins under the group, with the registry's targets; the
    installed metadata, when it already declares the group (a checkout reinstalled since), says the
    same: a stale install (metadata without the group) still finds them (the test above)."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    declared = project["project"]["entry-points"][ENTRY_POINT_GROUP]
    assert declared == {name: b.target for name, b in BUILTIN.items()}
    installed = {ep.name: ep.value for ep in metadata.distribution("navstress").entry_points
                 if ep.group == ENTRY_POINT_GROUP}
    assert installed in ({}, declared)


def test_a_plug_in_executor_is_found_through_its_entry_point(plugin: Path) -> None:
    assert executor_names() == ["local", "ray", "gone", "inline"]  # not the malformed one
    assert "inline" in executor_help()
    opts = ExecutorOptions(workers=2, targets={"x-v1": "m:f"}, keep=True)
    ex = make_executor("inline", opts)
    import inline_executor  # type: ignore[import-not-found]

    assert inline_executor.MADE == [opts] and isinstance(ex, LocalExecutor) and not ex.warm
    # a built-in's name stays navstress's, whatever another distribution declares
    assert make_executor("local", ExecutorOptions(workers=1)).warm and len(inline_executor.MADE) == 1
    with pytest.raises(SpecError) as info:
        make_executor("gone", ExecutorOptions())
    line = one_line(info.value)
    assert line.startswith("--executor='gone' is invalid: expected an executor whose factory") and \
        "no_such_module_here" in line


@pytest.mark.parametrize("name", UNKNOWN, ids=range(len(UNKNOWN)))
def test_an_unknown_executor_is_refused_in_one_line_naming_the_known_ones(name: str) -> None:
    with pytest.raises(SpecError) as info:
        check_executor(name)
    line = one_line(info.value)
    assert line.startswith("--executor=") and line.endswith("expected one of the executors: local, ray"), line
    with pytest.raises(SpecError) as again:
        make_executor(name, ExecutorOptions())
    assert str(again.value) == line


@pytest.mark.parametrize("name", ["nope", "rаy", "x" * 500], ids=["nope", "lookalike", "long"])
def test_every_runner_refuses_an_unknown_executor_before_writing(tmp_path: Path, name: str) -> None:
    spec_path = tmp_path / "c.yaml"
    spec_path.write_text(yaml.safe_dump(CAMPAIGN), encoding="utf-8")
    search_path = tmp_path / "s.yaml"
    search_path.write_text(yaml.safe_dump(SEARCH), encoding="utf-8")
    calls = [lambda: run_campaign(spec_path, tmp_path / "out", executor=name),
             lambda: run_search(search_path, tmp_path / "out", executor=name),
             lambda: open_runner(parse_campaign(CAMPAIGN), tmp_path / "out", executor=name).__enter__()]
    for call in calls:
        with pytest.raises(SpecError) as info:
            call()
        assert one_line(info.value).endswith("expected one of the executors: local, ray")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", [["campaign", "run"], ["search", "run"], ["search"]])
@pytest.mark.parametrize("name", ["nope", "Local", "local\nray"], ids=["nope", "case", "newline"])
def test_the_commands_refuse_an_unknown_executor_in_one_line(tmp_path: Path, command: list[str], name: str) -> None:
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump(SEARCH if command[0] == "search" else CAMPAIGN), encoding="utf-8")
    argv = [*command, str(spec), "-o", str(tmp_path / "out"), "-q", "--executor", name]
    r = CliRunner().invoke(app, argv)
    assert r.exit_code == 2, (argv, r.stdout, r.stderr)
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --executor=") and \
        lines[0].endswith("expected one of the executors: local, ray"), r.stderr
    assert "Traceback" not in r.stdout + r.stderr and not (tmp_path / "out").exists()


def _help(argv: list[str], env: dict[str, str] | None = None) -> str:
    """The help of a command, in a fresh interpreter (the options' help is read when the command's
    module is imported)."""
    r = subprocess.run([sys.executable, "-m", "navstress.cli", *argv, "--help"], capture_output=True, text=True,
                       env={**os.environ, "COLUMNS": "400", **(env or {})}, timeout=120)
    assert r.returncode == 0, r.stderr
    return " ".join(r.stdout.split())


def test_the_help_of_executor_options_shows_the_registry_names(tmp_path: Path) -> None:
    """`campaign run` and `search run` show every registered name, the built-ins' and a plug-in's
    (its distribution on PYTHONPATH: found in the fresh interpreter by its entry point alone)."""
    d = plugin_dir(tmp_path / "plugin")
    env = {"PYTHONPATH": os.pathsep.join([str(d), os.environ.get("PYTHONPATH", "")])}
    for argv in (["campaign", "run"], ["search", "run"]):
        plain, more = _help(argv), _help(argv, env)
        assert "local (a process pool on this machine), ray (Ray tasks; pip extra ray). [default: local]" in plain
        assert "inline" not in plain
        assert "local (a process pool on this machine), ray (Ray tasks; pip extra ray), gone, inline. " \
               "[default: local]" in more, more
