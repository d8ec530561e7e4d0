"""The BARN benchmark end to end (issue 37's done-when): ``campaign init --preset barn`` on the
shared BARN worlds, a tiny campaign of it (2 worlds x 1 run: each world imported from its Gazebo
file, the Jackal with its scanner, reference-2d-v1), then ``analyze --json`` and ``report`` show
BARN's score beside navstress's own analysis, and the score is the formula's on the runs' own
records and path files."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from navstress.analysis.barn import load_path, path_length
from navstress.campaign.presets import BARN_TEST_WORLDS
from navstress.campaign.store import Store
from tests.support.barn import barn_dir
from tests.support.cli_run import cli

pytestmark = pytest.mark.slow


def test_barn_preset_campaign_and_report(tmp_path_factory: pytest.TempPathFactory, tmp_path: Path) -> None:
    folder = barn_dir(tmp_path_factory, BARN_TEST_WORLDS)  # what the preset checks: the test set's files
    spec = tmp_path / "barn.yaml"
    code, out, err = cli("campaign", "init", "--preset", "barn", "--barn", str(folder), "-o", str(spec))
    assert code == 0, (out, err)
    data = yaml.safe_load(spec.read_text())
    exp = data["experiments"][0]
    exp["worlds"] = [w for w in exp["worlds"] if w["key"] in ("world_0", "world_150")]
    data["runs_per_map"] = 1
    spec.write_text(yaml.safe_dump(data, sort_keys=False))
    camp = tmp_path / "c"
    code, out, err = cli("campaign", "run", str(spec), "-o", str(camp), "-q", "-j", "2")
    assert code == 0 and out.startswith(f"{camp}: 2/2 runs recorded"), (out, err)
    with Store.open(camp) as st:
        recs = {r.run_id.split("/")[1]: r for r in st.records()}
    assert set(recs) == {"world_0", "world_150"}
    code, out, err = cli("analyze", str(camp), "--json", str(tmp_path / "a.json"))
    assert code == 0, (out, err)
    js = json.loads((tmp_path / "a.json").read_text())
    (g,) = js["barn"]["groups"]
    assert g["navigator"] == "reference-2d-v1" and g["runs"] == 2
    by_world = {w["world"]: w for w in g["per_world"]}
    for n in (0, 150):
        w = by_world[n]
        L = path_length(load_path(folder / "path_files" / f"path_{n}.npy"))
        assert w["path_length_m"] == pytest.approx(L) and w["t_opt_s"] == pytest.approx(L / 2)
        (run,) = w["run_scores"]
        rec = recs[f"world_{n}"]
        assert run["success"] == (rec.outcome == "success")
        if run["success"]:
            assert run["t_from"] == "trace" and 0 < run["t_s"] <= rec.duration_s
            t = min(max(run["t_s"], L), 4 * L)  # clip(t, 2 t_opt, 8 t_opt) with t_opt = L / 2
            assert run["score"] == pytest.approx((L / 2) / t)
        else:
            assert run["score"] == 0.0
    assert g["score"] == pytest.approx(sum(by_world[n]["score"] for n in (0, 150)) / 2)
    assert 0.0 <= g["score"] <= 0.5
    assert "difficulty" in js and "verdicts" in js  # navstress's own analysis beside it
    report = tmp_path / "report.html"
    code, out, err = cli("report", str(camp), "-o", str(report))
    assert code == 0, (out, err)
    html = report.read_text()
    assert '<h2 id="barn">BARN score</h2>' in html and 'id="barn-overall"' in html
    assert f"{g['score']:.4f}" in html
    assert 'id="verdicts"' in html  # beside navstress's sections
