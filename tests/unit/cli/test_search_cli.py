"""``navstress search init``: a ready spec per objective that the parser accepts, refusals on one
line (an unknown objective, an existing file), and the group's default command."""

from __future__ import annotations

from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from tests.support.cli_inputs import assert_one_line_error, invoke
from navstress.cli.search import DEFAULT_COMMAND, DefaultGroup
from navstress.search.presets import template_yaml
from navstress.search.spec import OBJECTIVES, load_search


@pytest.mark.parametrize("objective", OBJECTIVES)
def test_init_writes_a_spec_the_parser_accepts(tmp_path: Path, objective: str) -> None:
    out = tmp_path / "sub" / f"{objective}.yaml"
    code, stdout, stderr = invoke(["search", "init", "--objective", objective, "-o", str(out)])
    assert code == 0, stderr
    assert f"wrote {out}" in stdout
    spec, text = load_search(out)
    assert text == template_yaml(objective) and "#" in text  # commented
    assert spec.objective.name == objective and spec.name == objective
    if objective == "fault-revealing":
        assert spec.objective.fault in spec.faults and None in spec.faults
    if objective == "illumination":
        assert len(spec.archive_descriptors()) == 2
    assert [p.name for p in tmp_path.rglob("*") if p.is_file()] == [out.name]  # no temporary file left


@pytest.mark.parametrize("bad", ["nope", "Failure", "", "illumination ", "fault_revealing"])
def test_an_unknown_objective_is_one_line_and_writes_nothing(tmp_path: Path, bad: str) -> None:
    out = tmp_path / "s.yaml"
    argv = ["search", "init", "--objective", bad, "-o", str(out)]
    line = assert_one_line_error(*invoke(argv), argv)
    assert line.startswith("error: --objective=") and "failure" in line
    assert not any(tmp_path.iterdir())


def test_an_existing_file_is_refused_unless_forced(tmp_path: Path) -> None:
    out = tmp_path / "s.yaml"
    out.write_text("mine\n", encoding="utf-8")
    argv = ["search", "init", "-o", str(out)]
    line = assert_one_line_error(*invoke(argv), argv)
    assert "--force" in line and out.read_text(encoding="utf-8") == "mine\n"
    code, _, stderr = invoke([*argv, "--force", "--objective", "boundary"])
    assert code == 0, stderr
    assert load_search(out)[0].objective.name == "boundary"


def test_the_default_command_takes_a_first_argument_that_names_no_subcommand() -> None:
    group = typer.Typer(cls=DefaultGroup)
    seen: list[tuple[str, ...]] = []

    @group.command("init")
    def _init(out: str = typer.Option(..., "-o")) -> None:
        seen.append(("init", out))

    @group.command(DEFAULT_COMMAND)
    def _run(spec: str, out: str = typer.Option(..., "-o")) -> None:
        seen.append((DEFAULT_COMMAND, spec, out))

    runner = CliRunner()
    assert runner.invoke(group, ["s.yaml", "-o", "d"]).exit_code == 0
    assert runner.invoke(group, [DEFAULT_COMMAND, "t.yaml", "-o", "e"]).exit_code == 0
    assert runner.invoke(group, ["init", "-o", "f"]).exit_code == 0
    assert seen == [(DEFAULT_COMMAND, "s.yaml", "d"), (DEFAULT_COMMAND, "t.yaml", "e"), ("init", "f")]
    assert runner.invoke(group, ["--help"]).exit_code == 0
