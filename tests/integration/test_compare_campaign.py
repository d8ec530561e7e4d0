"""``navstress compare`` on real campaigns (MuJoCo runs): the nominal and the faulty navigator of one
campaign, and the same spec run twice into two directories (version 1 against itself: every pair
agrees, to the duration, because the runs are deterministic)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.support.built_once import built_once
from navstress.analysis.compare import Arm, compare
from navstress.campaign.executors import run_campaign

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]


def _spec() -> dict[str, Any]:
    return {"name": "ab", "seed": 5, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
            "experiments": [{"name": "flat", "sweep": {"obstacles.obstruction.tree": {"values": [0, 4]}}}],
            "maps_per_config": 1, "runs_per_map": 2, "navigators": [{"name": "reference-v1"}],
            "faults": [None, "small-footprint"], "timeout_s": 4.0}


def _campaigns(root: Path) -> list[str]:
    spec = root / "spec.yaml"
    spec.write_text(yaml.safe_dump(_spec(), sort_keys=False))
    for out in ("v1", "v2"):
        res = run_campaign(spec, root / out, workers=2)
        assert res.recorded == res.planned == 8
    return [str(root / "v1"), str(root / "v2")]


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Two campaigns of one spec, built once in the session (the tests only read them)."""
    v1, v2 = built_once(tmp_path_factory, "compare-campaigns", _campaigns)
    return Path(v1), Path(v2)


def test_nominal_against_fault_in_one_campaign(campaigns: tuple[Path, Path], tmp_path: Path) -> None:
    v1, _ = campaigns
    out = tmp_path / "ab.json"
    proc = subprocess.run([sys.executable, "-m", "navstress.cli", "compare", str(v1), "--a", "reference-v1",
                           "--b", "reference-v1:small-footprint", "--json", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[0].endswith("4 pairs of runs with the same map and run seeds"), proc.stdout
    data = json.loads(out.read_text())
    assert [c["config"] for c in data["configurations"]] == ["tree=0", "tree=4"]
    assert data["overall"]["pairs"] == 4 and data["unpaired_runs"] == {"a": 0, "b": 0}
    for c in data["configurations"]:
        t = c["table"]
        assert sum(t.values()) == 2 and 0.0 <= c["p_value"] <= c["p_holm"] <= 1.0
        assert c["ci"][0] <= c["diff"] <= c["ci"][1]


def test_the_same_spec_twice_pairs_every_run_and_agrees(campaigns: tuple[Path, Path]) -> None:
    v1, v2 = campaigns
    for arm in (Arm("reference-v1"), Arm("reference-v1", "small-footprint")):
        cmp = compare(v1, arm, arm, v2)
        o = cmp.overall
        assert o.pairs == 4 and o.a_only == o.b_only == 0 and o.p_value == 1.0
        assert o.collided_a == o.collided_b
        assert o.duration_s.diff in (None, 0.0)  # deterministic runs: the very same durations
        assert cmp.headline().startswith("no configuration differs")
