"""Inputs shared by the CLI bad-input tests: a prepared folder (a world, a campaign store with one
record, a campaign spec), every command that writes a file or folder, and helpers to run the
CLI in process and check the one-line-error contract."""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from typer.testing import CliRunner

from tests.support.world_fixtures import small_world
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import Store
from navstress.cli import app
from navstress.run.record import RunRecord
from navstress.run.trace import TOPIC_TRUTH, TraceWriter

CAMPAIGN = {"name": "tiny", "seed": 1, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
            "experiments": [{"name": "flat", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
            "maps_per_config": 1, "runs_per_map": 1, "timeout_s": 5.0}
#: A search of one generation of two worlds, one run each, on the campaign's small world.
SEARCH = {"name": "tiny-search", "seed": 1, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
          "space": {"parameters": [{"path": "obstacles.obstruction.tree", "low": 0, "high": 10}]},
          "objective": {"name": "failure"}, "budget": {"runs": 2}, "runs_per_candidate": 1,
          "algorithm": {"name": "random", "batch": 2}, "confirm_runs": 1, "elites": 1, "timeout_s": 5.0}
TRACEBACK = re.compile(r"Traceback|^\s+File \"", re.M)


def prepare(root: Path) -> None:
    """``root/w`` a world, ``root/c`` a campaign store holding one record, ``root/spec.yaml``,
    ``root/search.yaml`` (a search spec), ``root/t.mcap`` (a run's trace)."""
    root.mkdir(parents=True, exist_ok=True)
    small_world().save(root / "w")
    with TraceWriter(root / "t.mcap") as tw:
        tw.poses(TOPIC_TRUTH, np.array([[0.0, 1, 1, 0, 0, 0, 0], [0.1, 1.1, 1, 0, 0, 0, 0]]))
        tw.transforms("map", "base_link", np.array([[0.0, 1, 1, 0, 0, 0, 0], [0.1, 1.1, 1, 0, 0, 0, 0]]))
        tw.robot((1.0, 0.6, 0.4), (0.3, 0.0, 0.7), belief=False)
        tw.event(0.1, "info", "end")
    (root / "spec.yaml").write_text(yaml.safe_dump(CAMPAIGN), encoding="utf-8")
    (root / "search.yaml").write_text(yaml.safe_dump(SEARCH), encoding="utf-8")
    with Store.create(root / "c", parse_campaign(CAMPAIGN), yaml.safe_dump(CAMPAIGN)) as s:
        s.add(RunRecord(run_id=s.planned_ids()[0], experiment="flat", config={"obstacles.obstruction.tree": 0}, map_index=0,
                        run_index=0, map_seed=1, run_seed=2, navigator="reference-v1", fault=None,
                        outcome="fail-error", reason="[debug] planning", duration_s=1.0, wall_s=1.0,
                        goal_distance_m=3.0, path_length_m=1.0, tortuousness=0.0, collisions=0,
                        first_collision_s=None, errors=["[bold]x[/]"], trace=None))


@dataclass(frozen=True)
class OutputCommand:
    """A command line that writes ``{out}``; ``kind`` is "file" or "dir" (what {out} must be)."""

    name: str
    args: tuple[str, ...]
    kind: str
    suffix: str = ".x"  # of the file names the link tests give it (a picture command needs its own)

    def argv(self, root: Path, out: str) -> list[str]:
        return [a.replace("{root}", str(root)).replace("{out}", out) for a in self.args]


OUTPUT_COMMANDS = [
    OutputCommand("world generate", ("world", "generate", "--size", "20", "--cell", "0.5", "-o", "{out}"), "dir"),
    OutputCommand("world show", ("world", "show", "{root}/w", "-o", "{out}"), "file"),
    *[OutputCommand(f"world export {f}", ("world", "export", "{root}/w", "--format", f, "-o", "{out}"), "file")
      for f in ("mjcf", "sdf", "gltf", "glb", "obj", "png")],
    OutputCommand("world drive", ("world", "drive", "{root}/w", "--course", "0.5,0,0.5", "-o", "{out}"), "file"),
    OutputCommand("robot show", ("robot", "show", "jackal", "-o", "{out}"), "file", ".svg"),
    OutputCommand("run", ("run", "{root}/w", "--timeout", "0.5", "-o", "{out}"), "dir"),
    OutputCommand("demo", ("demo", "-o", "{out}"), "dir"),
    OutputCommand("campaign init", ("campaign", "init", "-o", "{out}"), "file"),
    OutputCommand("search init", ("search", "init", "--objective", "illumination", "-o", "{out}"), "file"),
    OutputCommand("campaign run", ("campaign", "run", "{root}/spec.yaml", "-q", "-o", "{out}"), "dir"),
    OutputCommand("search", ("search", "{root}/search.yaml", "-q", "-o", "{out}"), "dir"),
    OutputCommand("campaign export csv", ("campaign", "export", "{root}/c", "-o", "{out}"), "file"),
    OutputCommand("campaign export parquet", ("campaign", "export", "{root}/c", "-f", "parquet", "-o", "{out}"),
                  "file"),
    *[OutputCommand(f"campaign export {t} {f}", ("campaign", "export", "{root}/c", "--table", t, "-f", f,
                                                 "-o", "{out}"), "file")
      for t in ("verdicts", "configurations") for f in ("csv", "parquet")],
    OutputCommand("report", ("report", "{root}/c", "-o", "{out}"), "file"),
    OutputCommand("analyze --json", ("analyze", "{root}/c", "--json", "{out}"), "file"),
    OutputCommand("gate --junit", ("gate", "{root}/c", "--min-success", "0", "--junit", "{out}"), "file"),
    OutputCommand("trace export ros2", ("trace", "export", "{root}/t.mcap", "-o", "{out}"), "dir"),
]


def leaf_commands() -> dict[str, Any]:
    """Every command of the CLI (``"campaign run"``: its click command), from the typer app: a new
    command is covered by the tests that iterate over them without editing them."""
    import typer

    def walk(cmd: Any, path: list[str]) -> Iterator[tuple[str, Any]]:
        subs = getattr(cmd, "commands", None)
        if subs is None:
            yield " ".join(path), cmd
            return
        for name, sub in sorted(subs.items()):
            yield from walk(sub, [*path, name])

    return dict(walk(typer.main.get_command(app), []))


def invoke(argv: list[str]) -> tuple[int, str, str]:
    r = CliRunner().invoke(app, argv)
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise AssertionError(f"{argv} raised {type(r.exception).__name__}: {r.exception}") from r.exception
    return r.exit_code, r.stdout, r.stderr


def assert_one_line_error(code: int, out: str, err: str, argv: list[str]) -> str:
    """Exit 2, exactly one stderr line starting with ``error:`` (no blank line either), no
    traceback anywhere."""
    lines = err.splitlines()
    assert code == 2, f"{argv}: exit {code}\nstdout: {out}\nstderr: {err}"
    assert len(lines) == 1 and lines[0].startswith("error: ") and err.endswith("\n"), f"{argv}: stderr {err!r}"
    assert not TRACEBACK.search(out + err), f"{argv}: traceback\n{out}\n{err}"
    return lines[0]


def snapshot(root: Path) -> dict[str, bytes]:
    """Every file and folder under ``root`` (contents of files)."""
    return {str(p.relative_to(root)): p.read_bytes() if p.is_file() else b"<dir>" for p in sorted(root.rglob("*"))}
