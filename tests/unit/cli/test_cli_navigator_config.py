"""``--navigator-config`` takes a file path or inline JSON/YAML text in every command that has it
(found from the typer app, so a new command with the option is covered too)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import typer

from tests.support.cli_inputs import assert_one_line_error, invoke, snapshot
from tests.support.world_fixtures import small_world
from navstress.cli import app


def _commands_with(option: str) -> list[list[str]]:
    """Command paths (e.g. ["nav", "check"]) of every command that has ``option``."""
    root = typer.main.get_command(app)
    found: list[list[str]] = []

    def walk(cmd: object, path: list[str]) -> None:
        for name, sub in sorted(getattr(cmd, "commands", {}).items()):
            walk(sub, [*path, name])
        if not hasattr(cmd, "commands") and any(option in getattr(p, "opts", []) for p in getattr(cmd, "params", [])):
            found.append(path)

    walk(root, [])
    return found


COMMANDS = _commands_with("--navigator-config")


def test_the_option_exists_where_documented() -> None:
    assert ["run"] in COMMANDS and ["nav", "check"] in COMMANDS


@pytest.fixture(scope="module")
def world_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("navcfg")
    small_world().save(d / "w")
    return d / "w"


def _argv(cmd: list[str], cfg: str, world_dir: Path, out: Path) -> list[str]:
    if cmd == ["run"]:
        return ["run", str(world_dir), "--timeout", "0.3", "-o", str(out), "--navigator-config", cfg]
    if cmd == ["nav", "check"]:
        return ["nav", "check", "reference-v1", "--navigator-config", cfg]
    return [*cmd, "--navigator-config", cfg]


def _family(tmp: Path) -> list[tuple[str, str, str]]:
    """(label, option value, text the one error line must hold); every config names an unknown
    option, so a config that was parsed is refused naming it, before anything runs."""
    (tmp / "c.yaml").write_text("bogus_option: 1\n")
    (tmp / "c.yml").write_text("bogus_option: 1\n")
    (tmp / "c.json").write_text(json.dumps({"bogus_option": 1}))
    (tmp / "list.json").write_text("[1, 2]")
    (tmp / "bin.yaml").write_bytes(b"\xff\xfe\x00\x01")
    return [
        ("inline JSON", '{"bogus_option": 1}', "bogus_option"),
        ("inline JSON, spaced", '  { "bogus_option" : 1 }  ', "bogus_option"),
        ("inline YAML mapping", "bogus_option: 1", "bogus_option"),
        ("inline YAML flow", "{bogus_option: 1}", "bogus_option"),
        ("YAML file", str(tmp / "c.yaml"), "bogus_option"),
        ("YML file", str(tmp / "c.yml"), "bogus_option"),
        ("JSON file", str(tmp / "c.json"), "bogus_option"),
        ("missing file", str(tmp / "nope.yaml"), "--navigator-config="),
        ("a directory", str(tmp), "--navigator-config="),
        ("non-mapping JSON", "[1, 2]", "--navigator-config="),
        ("non-mapping JSON file", str(tmp / "list.json"), "--navigator-config="),
        ("a number", "42", "--navigator-config="),
        ("bad JSON", '{"command": [}', "--navigator-config="),
        ("bad JSON, unclosed", '{"a": 1', "--navigator-config="),
        ("binary file", str(tmp / "bin.yaml"), "UTF-8"),
        ("alias bomb", "a: &a [1,1,1,1,1,1,1,1,1,1]\n" + "".join(
            f"{c}: &{c} [*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p}]\n"
            for p, c in zip("abcdefgh", "bcdefghi")), "aliases"),
    ]


@pytest.mark.slow
@pytest.mark.parametrize("cmd", COMMANDS, ids=" ".join)
def test_every_form_of_the_option_is_parsed_or_refused_in_one_line(cmd: list[str], world_dir: Path,
                                                                      tmp_path: Path) -> None:
    for label, cfg, words in _family(tmp_path):
        out = tmp_path / "out"
        before = snapshot(tmp_path)
        argv = _argv(cmd, cfg, world_dir, out)
        code, so, se = invoke(argv)
        if cmd == ["nav", "check"] and code == 1 and words == "bogus_option":
            assert "bogus_option" in so and "FAIL" in so, (label, so)  # parsed: the build check names the key
            continue
        line = assert_one_line_error(code, so, se, argv)
        assert words in line, (label, line)
        assert "no such file" not in line or label in ("missing file",), (label, line)
        assert snapshot(tmp_path) == before, label


@pytest.mark.slow
def test_inline_json_config_reaches_the_navigator_of_a_run(world_dir: Path, tmp_path: Path) -> None:
    cfg = '{"max_speed_mps": 0.5, "n_arcs": 12}'
    argv = ["run", str(world_dir), "--timeout", "0.3", "-o", str(tmp_path / "o"), "--navigator-config", cfg]
    code, out, err = invoke(argv)
    assert code == 0, err
    rec = json.loads((tmp_path / "o" / "runs.jsonl").read_text().splitlines()[0])
    assert rec["outcome"] == "fail-timeout"
    task_cfg = rec.get("navigator_config")
    assert task_cfg in (None, {"max_speed_mps": 0.5, "n_arcs": 12})
