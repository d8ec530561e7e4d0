"""The registry's note for an unversioned navigator name reaches the user once, on one line
(``note: ...``), whatever the command and however many workers run it; the runs themselves stay
quiet. Real processes: a campaign's workers write to the same stderr as the command."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from navstress.world import Mission, World, WorldSpec

pytestmark = pytest.mark.slow

NOTE = "note: navigator 'reference' has no version; using the latest, 'reference-v1' (write 'reference-v1' to pin it)"


def _navstress(*argv: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONWARNINGS="")
    return subprocess.run([sys.executable, "-m", "navstress.cli", *argv], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


def _check(p: subprocess.CompletedProcess[str]) -> None:
    assert p.returncode == 0, p.stdout + p.stderr
    err = p.stderr.splitlines()
    assert err.count(NOTE) == 1, p.stderr  # once, not once per run or per worker
    assert not any("NavigatorNote" in ln or "make_navigator" in ln for ln in err), p.stderr  # no source lines


def test_run_notes_an_unversioned_name_once(tmp_path: Path) -> None:
    World.flat(WorldSpec(size_m=(10.0, 10.0)), mission=Mission((2.0, 2.0, 0.0), (8.0, 2.0), 1.0)).save(tmp_path / "w")
    _check(_navstress("run", "w", "--navigator", "reference", "--timeout", "0.5", "-o", "out", cwd=tmp_path))


def test_a_campaign_on_two_workers_notes_it_once(tmp_path: Path) -> None:
    spec = {"name": "notes", "seed": 1, "world": {"size_m": [12.0, 12.0], "cell_m": 0.5},
            "experiments": [{"name": "e", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
            "maps_per_config": 2, "runs_per_map": 2, "navigators": [{"name": "reference"}], "faults": [None],
            "timeout_s": 0.5}
    (tmp_path / "spec.yaml").write_text(yaml.safe_dump(spec))
    _check(_navstress("campaign", "run", "spec.yaml", "-o", "out", "-j", "2", "-q", cwd=tmp_path))
