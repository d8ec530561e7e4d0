"""Every ``--json`` of every command, on real campaign stores and a real world: what prints JSON
on standard output prints exactly one strict JSON document and nothing else (progress and
notes go to stderr); what takes a FILE still writes it, and ``-`` as FILE means stdout.

The table is checked against the commands themselves: a new command with a ``--json`` option
and no row here fails :func:`test_the_table_covers_every_json_option`."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer import _click as click

from tests.support.analysis_synth import make_store, record
from tests.support.cli_inputs import invoke
from navstress.cli import MOUNTS, mounted
from tests.support.strict_json import strict_loads
from tests.support.world_fixtures import small_world

ROOT = str(Path(__file__).resolve().parents[3])  # tests.support.navigators importable in a child

FAULT = "small-footprint"

#: (command path, argv after it, what the JSON holds) for every way a --json prints to stdout.
#: {c}: a campaign store; {w}: a world; {t}: a fresh folder.
STDOUT_JSON = [
    ("analyze", ["{c}", "--json", "-"], "difficulty"),
    ("compare", ["{c}", "--a", "reference-v1", "--b", f"reference-v1:{FAULT}", "--json", "-"], "overall"),
    ("campaign status", ["{c}", "--json"], "counts"),
    ("gate", ["{c}", "--min-success", "0.5", "--json"], "configurations"),
    ("gate", ["{c}", "--min-success", "0.5", "--junit", "{t}/gate.xml", "--json"], "configurations"),
    ("run", ["{w}", "-o", "{t}/run", "--timeout", "0.3", "--runs", "2", "--json"], "records"),
    ("robot show", ["{w}/robot.yaml", "--json"], "figures"),
    ("sensor list", ["{k}", "--json"], "lidar2d"),
    ("robot check", ["{w}/robot.yaml", "--quick", "--json"], "legs"),
]
#: (command path, argv after it) for every --json that takes a FILE: it is written, stdout is the text.
FILE_JSON = [
    ("analyze", ["{c}", "--json", "{t}/a.json"]),
    ("compare", ["{c}", "--a", "reference-v1", "--b", f"reference-v1:{FAULT}", "--json", "{t}/ab.json"]),
]


@pytest.fixture(scope="module")
def dirs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A real store with nominal and faulty runs (one with an unknown goal distance) and a world."""
    root = tmp_path_factory.mktemp("json")
    with make_store(root / "c", maps=2, runs=2, faults=[None, FAULT]) as s:
        for m in range(2):
            for r in range(2):
                s.add(record("trees", "tree=0", m, r))
                s.add(record("trees", "tree=0", m, r, "fail-collision", fault=FAULT, collisions=1))
                s.add(record("trees", "tree=4", m, r, "success" if r else "fail-other", goal=1.0 if r else math.nan))
    small_world(1, bumpy=False).save(root / "w")
    (root / "w" / "robot.yaml").write_text("base: jackal\n", encoding="utf-8")  # a robot file (robot show/check)
    return {"c": root / "c", "w": root / "w"}


def _argv(cmd: str, args: list[str], dirs: dict[str, Path], tmp: Path) -> list[str]:
    sub = {"{c}": str(dirs["c"]), "{w}": str(dirs["w"]), "{t}": str(tmp), "{k}": str(dirs.get("k", "lidar2d"))}
    out = []
    for a in args:
        for k, v in sub.items():
            a = a.replace(k, v)
        out.append(a)
    return [*cmd.split(), *out]


def _json_commands() -> set[str]:
    """Every command path (``campaign status``) that has a ``--json`` option."""
    found: set[str] = set()

    def walk(cmd: click.Command, path: str) -> None:
        subs = getattr(cmd, "commands", None)  # a group
        if subs is not None:
            for name, sub in subs.items():
                walk(sub, f"{path} {name}".strip())
        elif any("--json" in getattr(p, "opts", ()) for p in cmd.params):
            found.add(path)

    for name in MOUNTS:
        walk(mounted(name), name)
    return found


def test_the_table_covers_every_json_option() -> None:
    commands = _json_commands()
    assert {"run", "gate", "campaign status", "analyze", "compare"} <= commands  # the walk finds them
    assert commands == {c for c, _, _ in STDOUT_JSON}, "a --json option without a row in STDOUT_JSON"


@pytest.mark.parametrize(("cmd", "args", "key"), STDOUT_JSON, ids=[" ".join([c, *a]) for c, a, _ in STDOUT_JSON])
def test_stdout_holds_exactly_one_strict_json_document(cmd: str, args: list[str], key: str, dirs: dict[str, Path],
                                                       tmp_path: Path) -> None:
    argv = _argv(cmd, args, dirs, tmp_path)
    code, out, err = invoke(argv)
    assert code in (0, 1), (argv, code, out, err)  # gate: 1 when below the bar, the same JSON
    doc = strict_loads(out)  # the whole of stdout is one document: no table, no "wrote ...", no progress
    assert isinstance(doc, dict) and key in doc, sorted(doc)
    assert out.endswith("}\n") and out.lstrip().startswith("{")


@pytest.mark.parametrize(("cmd", "args"), FILE_JSON, ids=[" ".join([c, *a]) for c, a in FILE_JSON])
def test_a_json_file_is_written_and_stdout_keeps_the_text(cmd: str, args: list[str], dirs: dict[str, Path],
                                                          tmp_path: Path) -> None:
    argv = _argv(cmd, args, dirs, tmp_path)
    code, out, err = invoke(argv)
    assert code == 0, (argv, out, err)
    path = Path(argv[-1])
    assert isinstance(strict_loads(path.read_text(encoding="utf-8")), dict)
    assert out.splitlines()[-1] == f"wrote {path}"
    assert not out.lstrip().startswith("{")


@pytest.mark.slow
def test_run_json_stdout_stays_one_document_when_the_navigator_prints(dirs: dict[str, Path], tmp_path: Path) -> None:
    """A real ``navstress`` process whose navigator (in its worker process) prints on stdout at
    every call: the prints go to stderr, stdout is the JSON document alone."""
    cli = ("import sys; from navstress.nav.registry import register; "
           "register('prints-v1', 'tests.support.navigators.campaign_navs:Prints'); from navstress.cli import main; "
           "sys.argv = ['navstress', *sys.argv[1:]]; main()")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([ROOT, *sys.path])}
    argv = ["run", str(dirs["w"]), "-o", str(tmp_path / "r"), "--navigator", "prints-v1", "--timeout", "0.3",
            "--json"]
    p = subprocess.run([sys.executable, "-c", cli, *argv], capture_output=True, text=True, timeout=300, env=env)
    assert p.returncode == 0, p.stderr
    doc = strict_loads(p.stdout)
    assert doc["navigator"] == "prints-v1" and doc["runs"] == 1
    assert "Prints: step" in p.stderr and "Prints:" not in p.stdout


@pytest.mark.parametrize(("cmd", "args", "key"), STDOUT_JSON, ids=[" ".join([c, *a]) for c, a, _ in STDOUT_JSON])
def test_bad_input_leaves_stdout_empty(cmd: str, args: list[str], key: str, tmp_path: Path) -> None:
    """Exit 2 with the one error line on stderr: a CI step reading stdout gets no half document."""
    missing = {"c": tmp_path / "no-campaign", "w": tmp_path / "no-world", "k": Path("no-such-kind")}
    code, out, err = invoke(_argv(cmd, args, missing, tmp_path))
    assert code == 2 and out == "" and err.startswith("error: "), (code, out, err)
