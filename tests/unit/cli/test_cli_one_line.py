"""Every error of every command is exactly one line on standard error, whatever standard error is:
a file, a pseudo-terminal (what an interactive shell gives), or a pipe; with and without ``-q``
where a command has it; and a progress bar shown before an error leaves nothing behind.

The commands come from the typer app (:func:`cli_inputs.leaf_commands`): each needs a bad input in
:data:`BAD_INPUT` (a test fails for a command without one), and each also gets an option it does
not have. The file and pseudo-terminal cases run in one child process (``stderr_lines.py``) whose
file descriptor 2 is the file or the terminal itself; ``campaign run`` and ``search``, whose
progress bar once left a blank line before every error, also run as a user runs them (``python
-m navstress.cli`` with standard error on a file).
"""

from __future__ import annotations

import io
import json
import os
import pty
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.support import loopback
from tests.support.cli_inputs import CAMPAIGN, SEARCH, TRACEBACK, assert_one_line_error, invoke, leaf_commands

SUPPORT = Path(__file__).resolve().parents[2] / "support"
COMMANDS = leaf_commands()

#: A bad input per command ({root}: a folder holding bad.yaml, badsearch.yaml and afile).
BAD_INPUT: dict[str, list[str]] = {
    "analyze": ["analyze", "{root}/nope"],
    "campaign export": ["campaign", "export", "{root}/nope"],
    "campaign init": ["campaign", "init", "--preset", "nope", "-o", "{root}/x.yaml"],
    "campaign run": ["campaign", "run", "{root}/bad.yaml", "-o", "{root}/out"],
    "campaign status": ["campaign", "status", "{root}/nope"],
    "compare": ["compare", "{root}/nope"],
    "demo": ["demo", "-o", "{root}/afile"],
    "gate": ["gate", "{root}/nope", "--min-success", "2"],
    "nav check": ["nav", "check", "no-such-nav-v1"],
    "nav faults": ["nav", "faults", "extra"],
    "nav list": ["nav", "list", "extra"],
    "replay": ["replay", "{root}/nope", "a/b"],
    "robot check": ["robot", "check", "no-such-robot"],
    "robot list": ["robot", "list", "extra"],
    "sensor list": ["sensor", "list", "extra"],
    "robot show": ["robot", "show", "{root}/nope.yaml"],
    "report": ["report", "{root}/nope", "-o", "{root}/r.html"],
    "run": ["run", "{root}/nope", "-o", "{root}/runout"],
    "search init": ["search", "init", "--objective", "nope", "-o", "{root}/s.yaml"],
    "search run": ["search", "{root}/badsearch.yaml", "-o", "{root}/sout"],
    "trace export": ["trace", "export", "{root}/nope.mcap", "-o", "{root}/tout"],
    "world drive": ["world", "drive", "{root}/nope", "-o", "{root}/d.png"],
    "world export": ["world", "export", "{root}/nope", "-o", "{root}/e.sdf"],
    "world generate": ["world", "generate", "--size", "5", "-o", "{root}/wout"],
    "world show": ["world", "show", "{root}/nope"],
    "world import": ["world", "import", "{root}/nope.yaml", "-o", "{root}/wimp"],
}
#: Bad inputs with the live view asked for (its banner must not be a line before the error).
LIVE = {"replay --live": ["replay", "{root}/nope", "a/b", "--live", "--live-port", "{port}"],
        "run --live": ["run", "{root}/nope", "-o", "{root}/liveout", "--live", "--live-port", "{port}"]}
_CSI = re.compile(r"\x1b\[[0-?]*[ -/]*[@-~]")


def _quiet(cmd: Any) -> bool:
    return any(p.name == "quiet" for p in cmd.params)


def _cases() -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for name, cmd in COMMANDS.items():
        bad = BAD_INPUT.get(name)
        if bad is not None:
            out[name] = bad
            if _quiet(cmd):
                out[f"{name} -q"] = [*bad, "-q"]
        out[f"{name} --no-such-option"] = [*name.split(), "--no-such-option", "1"]
    out.update(LIVE)
    return out


@pytest.fixture(scope="module")
def root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    r = tmp_path_factory.mktemp("oneline")
    (r / "bad.yaml").write_text(yaml.safe_dump({k: v for k, v in CAMPAIGN.items() if k != "experiments"}))
    (r / "badsearch.yaml").write_text(yaml.safe_dump({k: v for k, v in SEARCH.items() if k != "objective"}))
    (r / "afile").write_text("a file")
    return r


def _argv(argv: list[str], root: Path, port: int) -> list[str]:
    return [a.replace("{root}", str(root)).replace("{port}", str(port)) for a in argv]


def test_every_command_has_a_bad_input() -> None:
    assert set(BAD_INPUT) == set(COMMANDS), sorted(set(COMMANDS) ^ set(BAD_INPUT))


@pytest.fixture(scope="module")
def on_fd2(root: Path) -> dict[tuple[str, str], dict[str, Any]]:
    """Every case run with standard error on a real file and on a real pseudo-terminal."""
    port = loopback.free_port()
    cases = [{"argv": _argv(argv, root, port), "mode": mode, "name": name}
             for name, argv in _cases().items() for mode in ("file", "pty")]
    env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": "120"}
    env.pop("NO_COLOR", None)
    env.pop("FORCE_COLOR", None)
    r = subprocess.run([sys.executable, str(SUPPORT / "stderr_lines.py")], input=json.dumps(cases), text=True,
                       capture_output=True, env=env, timeout=300, cwd=root)
    assert r.returncode == 0, r.stderr[-3000:]
    results = json.loads(r.stdout)
    return {(c["name"], c["mode"]): res for c, res in zip(cases, results)}


def _one_line(res: dict[str, Any]) -> None:
    """Exit 2 and one line: in a file, exactly ``error: ...\\n``; on a terminal, one line shown (a
    progress bar drawn while the command worked is erased before the error line)."""
    err = res["stderr"]
    assert res["code"] == 2, res
    assert not TRACEBACK.search(err + res["stdout"]), err
    if res["mode"] == "file":
        assert re.fullmatch(r"error: [^\n]*\n", err), f"{res['argv']}: {err!r}"
        return
    text = err.encode("latin-1").decode("utf-8")
    shown = _screen(text)
    assert len(shown) == 1 and shown[0].startswith("error: "), f"{res['argv']}: {shown} from {text!r}"
    assert text.replace("\r\n", "\n").endswith("\n") and not text.endswith("\n\n"), repr(text)


@pytest.mark.parametrize("mode", ["file", "pty"])
@pytest.mark.parametrize("name", sorted(_cases()))
def test_an_error_is_one_line_on_a_file_and_on_a_terminal(on_fd2: dict[tuple[str, str], dict[str, Any]],
                                                          name: str, mode: str) -> None:
    _one_line(on_fd2[(name, mode)])


@pytest.mark.parametrize("name", sorted(_cases()))
def test_an_error_is_one_line_on_a_pipe(root: Path, name: str) -> None:
    argv = _argv(_cases()[name], root, loopback.free_port())
    assert_one_line_error(*invoke(argv), argv)


@pytest.mark.parametrize("argv", [["campaign", "run", "{root}/bad.yaml", "-o", "{root}/out"],
                                  ["search", "{root}/badsearch.yaml", "-o", "{root}/sout"]],
                         ids=["campaign run", "search"])
def test_as_a_user_runs_it_stderr_in_a_file_holds_one_line(root: Path, argv: list[str], tmp_path: Path) -> None:
    err = tmp_path / "err.txt"
    with open(err, "wb") as f:
        p = subprocess.run([sys.executable, "-m", "navstress.cli", *_argv(argv, root, 0)], stderr=f,
                           stdout=subprocess.PIPE, timeout=120)
    text = err.read_text()
    assert p.returncode == 2 and re.fullmatch(r"error: [^\n]*\n", text), repr(text)


# ---- a progress bar shown, then an error ------------------------------------------------------


def _screen(raw: str) -> list[str]:
    """The lines a terminal shows after ``raw`` (blank lines kept, up to the last one written):
    printable text, CR, LF, cursor up (ESC[nA), erase line (ESC[2K); other escape sequences
    (colours, cursor visibility) change nothing shown."""
    lines = [""]
    row = col = 0
    i = 0
    while i < len(raw):
        m = _CSI.match(raw, i)
        if m:
            seq = m.group()
            if seq.endswith("A"):
                row = max(0, row - int(seq[2:-1] or 1))
            elif seq.endswith("K"):
                lines[row] = ""  # the whole line (2K), or what remains of it: not used otherwise
            i = m.end()
            continue
        c = raw[i]
        if c == "\r":
            col = 0
        elif c == "\n":
            row += 1
            col = 0
            if row == len(lines):
                lines.append("")
        else:
            line = lines[row].ljust(col)
            lines[row] = line[:col] + c + line[col + 1:]
            col += 1
        i += 1
    shown = [ln.rstrip() for ln in lines]
    while shown and not shown[-1]:  # below the last line written: the rest of the screen
        shown.pop()
    return shown


def _pty_read(master: int) -> str:
    """Everything written to a pseudo-terminal whose other end is closed."""
    raw = b""
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:  # EIO: the other end is closed and everything was read
            break
        if not chunk:
            break
        raw += chunk
    os.close(master)
    return raw.decode()


def _stream(mode: str) -> tuple[Any, int, int]:
    """Where a bar draws: a pseudo-terminal's writing end (with its reading end), or a file."""
    if mode == "pty":
        master, slave = pty.openpty()
        return open(slave, "w", encoding="utf-8", closefd=False), master, slave
    return io.StringIO(), -1, -1


@pytest.mark.parametrize("kind", ["campaign", "search"])
@pytest.mark.parametrize("mode", ["file", "pty"])
def test_a_bar_shown_before_an_error_leaves_nothing_behind(kind: str, mode: str,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    from navstress._console import console
    from navstress.campaign.progress import CampaignProgress
    from navstress.search.progress import SearchProgress

    monkeypatch.setenv("COLUMNS", "200")
    stream, master, slave = _stream(mode)
    con = console(file=stream)
    assert con.is_terminal == (mode == "pty")
    bar: Any = CampaignProgress(console=con) if kind == "campaign" else SearchProgress(console=con)
    with pytest.raises(OSError):
        with bar:
            bar.on_start(0, 10, {}) if kind == "campaign" else bar.on_start(0, 10)
            bar._progress.refresh()  # drawn on the terminal, as a long command's bar is
            raise OSError(28, "No space left on device")
    stream.flush()
    if mode == "pty":
        os.close(slave)
        text = _pty_read(master)
        assert "0/10" in text, "the bar was never drawn: nothing tested"
        assert _screen(text) == [], repr(text)
    else:
        assert stream.getvalue() == ""


@pytest.mark.parametrize("mode", ["file", "pty"])
def test_a_bar_that_ends_normally_keeps_its_last_frame(mode: str, monkeypatch: pytest.MonkeyPatch) -> None:
    from navstress._console import console
    from navstress.campaign.progress import CampaignProgress
    from navstress.run.record import RunRecord

    monkeypatch.setenv("COLUMNS", "200")
    stream, master, slave = _stream(mode)
    bar = CampaignProgress(console=console(file=stream))
    rec = RunRecord(run_id="r", experiment="e", config={}, map_index=0, run_index=0, map_seed=1, run_seed=2,
                    navigator="n", fault=None, outcome="success", reason="", duration_s=1.0, wall_s=1.0,
                    goal_distance_m=0.0, path_length_m=1.0, tortuousness=0.0, collisions=0, first_collision_s=None,
                    errors=[], trace=None)
    with bar:
        bar.on_start(0, 1, {})
        bar.on_record(rec)
    stream.flush()
    if mode == "pty":
        os.close(slave)
        shown = _screen(_pty_read(master))
    else:
        shown = _screen(stream.getvalue())
    assert len(shown) == 1 and "1/1" in shown[0] and "ok 1" in shown[0], shown
