"""What a navigator or a user wrote is printed literally by every command that echoes it:
no rich markup, no emoji codes, no terminal escapes interpreted."""

from __future__ import annotations

import io
import json
import sys
from pathlib import Path

import pytest

from tests.support.cli_inputs import invoke, prepare
from navstress._console import console, literal

HOSTILE = [
    "[debug] planning",
    "[bold]x[/]",
    "[/]",
    "[link=https://example.invalid]click[/link]",
    ":smile: :thumbs_up:",
    "\x1b[31mred\x1b[0m",
    "\x1b]0;title\x07",
    "a\rb",
    "[red on white]loud",
]

# a line-protocol navigator that answers hello and reset, then prints its argument as a step reply
NAV_SCRIPT = r"""
import json, sys
text = sys.argv[1]
for line in sys.stdin:
    kind = json.loads(line)["type"]
    if kind == "hello":
        print(json.dumps({"type": "hello", "protocol": 1, "name": "chatty"}), flush=True)
    elif kind == "reset":
        print(json.dumps({"type": "ok"}), flush=True)
    elif kind == "step":
        print(json.dumps({"type": "status", "kind": "error", "message": text}), flush=True)
    elif kind == "close":
        break
"""


def _visible(out: str) -> str:
    """Table cells may wrap: compare on the text with table borders and spacing removed."""
    return "".join(ch for ch in out if ch not in " \n│┃║|─━┏┓┗┛┡┩└┘├┤┬┴┼╇")


def _shows(out: str, text: str) -> bool:
    return _visible(literal(text)) in _visible(out)


@pytest.mark.parametrize("text", HOSTILE)
def test_console_prints_strings_literally(text: str) -> None:
    from rich.table import Table

    buf = io.StringIO()
    con = console(file=buf)
    con.print(text)
    t = Table(title=text)
    t.add_column(text)
    t.add_row(text)
    con.print(t)
    out = buf.getvalue()
    assert out.count(literal(text)) >= 3, out
    assert "\x1b" not in out and "\r" not in out and "\x07" not in out


@pytest.fixture(scope="module")
def root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    r = tmp_path_factory.mktemp("literal")
    prepare(r)
    (r / "nav.py").write_text(NAV_SCRIPT)
    return r


@pytest.mark.slow
@pytest.mark.parametrize("text", HOSTILE)
def test_navigator_messages_are_literal_in_run_and_nav_check(root: Path, text: str, tmp_path: Path) -> None:
    cfg = json.dumps({"command": [sys.executable, str(root / "nav.py"), text]})
    code, out, err = invoke(["run", str(root / "w"), "--navigator", "external-v1", "--navigator-config", cfg,
                             "--timeout", "2", "-o", str(tmp_path / "o")])
    assert code == 0, err
    rec = json.loads((tmp_path / "o" / "runs.jsonl").read_text().splitlines()[0])
    assert text in rec["reason"], rec["reason"]  # stored as written
    assert _shows(out, text), out  # shown as written (escaped control characters)
    assert "\x1b" not in out and "\x07" not in out
    code, out, err = invoke(["nav", "check", "external-v1", "--navigator-config", cfg])
    assert code in (0, 1), err
    assert _shows(out, text), out
    assert "\x1b" not in out and "\x07" not in out


@pytest.mark.parametrize("text", [t for t in HOSTILE if "/" not in t])
def test_user_paths_and_names_are_literal(root: Path, text: str, tmp_path: Path) -> None:
    out_dir = tmp_path / f"w{text}"
    code, out, err = invoke(["world", "generate", "--size", "20", "--cell", "0.5", "-o", str(out_dir)])
    assert code == 0, err
    assert _shows(out, str(out_dir)), out
    code, out, err = invoke(["world", "show", str(out_dir), "-o", str(tmp_path / f"p{text}.png")])
    assert code == 0, err
    assert _shows(out, str(out_dir)) and _shows(out, str(tmp_path / f"p{text}.png")), out
    assert "\x1b" not in out
    code, out, err = invoke(["world", "show", str(tmp_path / f"missing{text}")])
    assert code == 2 and "\x1b" not in err and "\x07" not in err


def test_echoed_lines_escape_control_characters(root: Path, tmp_path: Path) -> None:
    out = tmp_path / "x\x1b[31m.xml"
    code, so, err = invoke(["world", "export", str(root / "w"), "--format", "mjcf", "-o", str(out)])
    assert code == 0, err
    assert "\x1b" not in so and literal(str(out)) in so
    code, so, err = invoke(["report", str(root / "c"), "-o", str(tmp_path / "r\x07.html")])
    assert code == 0, err
    assert "\x07" not in so and "r\\x07.html" in so
