"""Every option and argument of every CLI command (enumerated from the typer app, so a new command
or option is covered without editing this file) fed random text, huge and non-finite numbers,
deep nesting and bad paths: the command exits 0 or 2 (1 only where documented), prints at most
one ``error:`` line, never a traceback, and writes nothing.

Only cheap commands run to the end: each command gets base arguments (``BASE``) that let it
validate everything and then stop at its output check (an existing folder where a new one is
needed, a directory where a file is needed), so no world is generated and no run is made.
Commands not in ``BASE`` get cheap defaults by parameter name.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.support.cli_inputs import TRACEBACK, leaf_commands, prepare, snapshot
from navstress.cli import app

# ---- the commands, from the app --------------------------------------------------------


COMMANDS = leaf_commands()

# base values that stop each command at its last check ({root} is the prepared folder)
BASE: dict[str, dict[str, str]] = {
    "world generate": {"output": "{root}/notaworld", "size": "20", "cell": "0.5"},
    "world show": {"output": "{root}/adir"},
    "world export": {"fmt": "png", "output": "{root}/adir"},
    "world drive": {"output": "{root}/adir", "course": "0.5,0,0.5"},
    "run": {"output": "{root}/full", "timeout": "0.3"},
    "demo": {"output": "{root}/afile"},
    "campaign init": {"out": "{root}/afile"},
    "campaign run": {"out": "{root}/afile"},
    "search init": {"out": "{root}/afile", "objective": "failure"},
    "search run": {"spec": "{root}/search.yaml", "out": "{root}/afile"},
    "campaign export": {"out": "{root}/adir"},
    "report": {"out": "{root}/adir"},
    "nav check": {"name": "no-such-nav-v1"},
    "replay": {"run_id": "no/such/run"},
    "gate": {"min_success": "0.5"},
    "trace export": {"trace": "{root}/t.mcap", "output": "{root}/adir"},
}
# defaults by parameter name for required parameters
DEFAULTS = {"world_dir": "{root}/w", "directory": "{root}/c", "spec": "{root}/spec.yaml", "name": "no-such-nav-v1",
            "run_id": "no/such/run", "output": "{root}/adir", "out": "{root}/adir", "fmt": "png"}
# exit 1 is a documented result of these (a failed check, a differing replay, a gate not met)
EXIT_1_OK = {"nav check", "replay", "gate"}
# parameters that name files or folders to write: fuzzed only with paths that cannot be written
WRITES = {"output", "out", "json_out", "keep", "junit"}
PATHS = WRITES | {"world_dir", "directory", "spec"}
NUMERIC = {"size", "cell", "subdivisions", "deformation", "trees", "buildings", "obstruction", "seed", "runs",
           "timeout", "goal_tolerance", "workers", "wall_limit", "budget", "threshold", "k", "dt", "min_success",
           "confidence", "max_collisions"}

_text = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=40)
_huge = st.sampled_from(["9" * 5000, "1e309", "-1e309", "nan", "inf", "-inf", "1" * 30, "-" + "9" * 40,
                         "0x10", "1_000", "", " ", "1e-400", "2000", "0.05", "2000x2000"])
_deep = st.sampled_from(["[" * 100_000, "{" * 100_000, "a: " + "[" * 5000 + "]" * 5000, "{\"a\": " * 50_000,
                         "a: &a [1,1,1,1,1,1,1,1,1]\n" + "".join(
                             f"{c}: &{c} [*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p}]\n"
                             for p, c in zip("abcdefgh", "bcdefghi"))])
_numbers = (st.integers(-10**30, 10**30).map(str) | st.floats(allow_nan=True, allow_infinity=True).map(repr)
            | st.floats(-1e6, 1e6).map(lambda v: f"{v:g}"))
_bad_paths = st.sampled_from(["{root}/afile/x", "/proc/navstress-no-such/x", "/sys/navstress-x", "{root}/adir",
                              "{root}/afile", "{root}/bin.yaml", "{root}/bomb.yaml", "{root}/deep.json",
                              "{root}/nope/deeper/x"])


def _value(name: str) -> st.SearchStrategy[str]:
    if name in WRITES:  # always unwritable: nothing may be created by a fuzzed value
        return (st.sampled_from(["{root}/afile/x", "/proc/navstress-no-such/x", "/sys/navstress-x"])
                | _text.map(lambda t: "{root}/afile/x" + t))
    if name in PATHS or name == "navigator_config":
        return _bad_paths | _text | _deep | _huge
    if name in NUMERIC:
        return _numbers | _huge | _text
    return _text | _huge | _deep


def _argv(cmd_name: str, cmd: Any, root: Path, fuzzed: str | None, value: str | None) -> list[str]:
    base = {**BASE.get(cmd_name, {})}
    argv = cmd_name.split()
    for p in cmd.params:
        if getattr(p, "is_flag", False) or p.name == "quiet":
            continue
        if p.name == fuzzed:
            v = value
        elif p.name in base:
            v = base[p.name]
        elif p.required:
            v = DEFAULTS.get(p.name, "x")
        else:
            continue
        assert v is not None
        v = v.replace("{root}", str(root))
        argv += [v] if p.param_type_name == "argument" else [p.opts[0], v]
    return argv


@pytest.fixture(scope="module")
def root(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    r = tmp_path_factory.mktemp("fuzz")
    prepare(r)
    (r / "notaworld").mkdir()
    (r / "notaworld" / "keep.txt").write_text("mine")
    (r / "full").mkdir()
    (r / "full" / "keep.txt").write_text("mine")
    (r / "adir").mkdir()
    (r / "afile").write_text("a file")
    (r / "bin.yaml").write_bytes(bytes(range(256)))
    (r / "bomb.yaml").write_text("a: &a [1,1,1,1,1,1,1,1,1]\n" + "".join(
        f"{c}: &{c} [*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p}]\n" for p, c in zip("abcdefgh", "bcdefghi")))
    (r / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    cwd = os.getcwd()
    os.chdir(r / "adir")  # relative fuzzed paths resolve inside the snapshot
    try:
        yield r
    finally:
        os.chdir(cwd)


def _check(cmd_name: str, argv: list[str], root: Path) -> None:
    from typer.testing import CliRunner

    before = snapshot(root)
    r = CliRunner().invoke(app, argv)
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise AssertionError(f"{argv!r} raised {type(r.exception).__name__}: {r.exception}") from r.exception
    ok = {0, 2} | ({1} if cmd_name in EXIT_1_OK else set())
    assert r.exit_code in ok, f"{argv!r}: exit {r.exit_code}\n{r.stdout[-2000:]}\n{r.stderr[-2000:]}"
    errors = [ln for ln in r.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) <= 1, f"{argv!r}: {r.stderr[-2000:]}"
    if r.exit_code == 2:  # exactly one line: no blank line either
        assert len(errors) == 1 and len(r.stderr.splitlines()) == 1, f"{argv!r}: {r.stderr[-2000:]}"
    assert not TRACEBACK.search(r.stdout + r.stderr), f"{argv!r}: {r.stdout[-2000:]}\n{r.stderr[-2000:]}"
    after = snapshot(root)
    assert after == before, f"{argv!r} wrote {sorted(set(after) ^ set(before))[:5]}"


def test_every_command_is_enumerated_and_the_base_is_cheap() -> None:
    assert {"world generate", "run", "nav check", "campaign run", "report", "demo"} <= set(COMMANDS)
    assert set(BASE) <= set(COMMANDS), "BASE names a command that no longer exists"


@pytest.mark.parametrize("cmd_name", sorted(COMMANDS))
def test_base_arguments_alone_stop_cleanly(root: Path, cmd_name: str) -> None:
    _check(cmd_name, _argv(cmd_name, COMMANDS[cmd_name], root, None, None), root)


@pytest.mark.parametrize("cmd_name", sorted(COMMANDS))
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                 HealthCheck.too_slow])
@given(data=st.data())
def test_every_option_survives_hostile_values(root: Path, cmd_name: str, data: st.DataObject) -> None:
    cmd = COMMANDS[cmd_name]
    params = [p.name for p in cmd.params if not getattr(p, "is_flag", False)]
    if not params:
        _check(cmd_name, cmd_name.split(), root)
        return
    name = data.draw(st.sampled_from(params), label="param")
    value = data.draw(_value(name), label="value")
    _check(cmd_name, _argv(cmd_name, cmd, root, name, value), root)


@pytest.mark.parametrize("argv,flag", [
    (["run", "{root}/w", "--runs", "1000000000", "-o", "{root}/adir/new"], "--runs"),
    (["run", "{root}/w", "--seed", str(2**64), "-o", "{root}/adir/new"], "--seed"),
    (["world", "generate", "--size", "20", "--cell", "0.5", "--seed", "9" * 30, "-o", "{root}/adir/new"], "--seed"),
    (["world", "drive", "{root}/w", "--seed", str(2**63), "-o", "{root}/adir/d.png"], "--seed"),
    (["demo", "--workers", "1000000000", "-o", "{root}/adir/new"], "--workers"),
])
def test_huge_counts_and_seeds_are_refused_before_anything_starts(root: Path, argv: list[str], flag: str) -> None:
    import time

    from typer.testing import CliRunner

    before = snapshot(root)
    t0 = time.perf_counter()
    r = CliRunner().invoke(app, [a.replace("{root}", str(root)) for a in argv])
    assert r.exit_code == 2 and r.stderr.startswith(f"error: {flag}=") and "an integer in [" in r.stderr, r.stderr
    assert time.perf_counter() - t0 < 5.0
    assert snapshot(root) == before
