"""`navstress nav list/faults/check` through the real CLI."""

from typer.testing import CliRunner

from navstress.cli import app


def run(*args: str) -> tuple[int, str]:
    r = CliRunner().invoke(app, list(args))
    return r.exit_code, r.output


def test_nav_list_shows_the_built_ins() -> None:
    code, out = run("nav", "list")
    assert code == 0
    for name in ("reference-v1", "reference-global-v1", "external-v1"):
        assert name in out


def test_nav_faults_lists_the_papers_fault_first() -> None:
    code, out = run("nav", "faults")
    assert code == 0
    lines = [ln.split()[0] for ln in out.splitlines() if ln.strip() and not ln.startswith(" " * 10)]
    assert lines[0] == "small-footprint"
    assert {"odometry-scale", "dropped-scans", "delayed-scans", "unknown-as-free", "permissive-slope"} <= set(lines)


def test_nav_check_passes_the_reference_stack() -> None:
    code, out = run("nav", "check", "reference-v1")
    assert code == 0, out
    assert "PASS" in out or "pass" in out


def test_nav_check_unknown_name_is_one_line_exit_2() -> None:
    code, out = run("nav", "check", "nosuch-v1")
    assert code == 2
    assert "unknown navigator 'nosuch-v1'" in out
