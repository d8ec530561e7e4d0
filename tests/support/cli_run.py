"""Run the navstress CLI in-process for a test: (exit code, stdout, stderr); an exception other
than SystemExit is a failure of the test, not a result."""

from __future__ import annotations

from typer.testing import CliRunner

from navstress.cli import app


def cli(*argv: str) -> tuple[int, str, str]:
    r = CliRunner().invoke(app, list(argv))
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise AssertionError(f"{argv} raised {r.exception!r}") from r.exception
    return r.exit_code, r.stdout, r.stderr
