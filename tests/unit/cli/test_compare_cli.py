"""``navstress compare`` on real campaign stores with hand-written records: the figures, the line a
person reads first, the JSON, two campaign directories, and every kind of bad input (one line, exit 2,
nothing written)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import pytest
import yaml
from tests.support.analysis_synth import make_store, record, spec_dict

from tests.support.cli_inputs import assert_one_line_error, invoke, snapshot

from navstress.analysis.compare import Arm, compare
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import Store

FAULT = "small-footprint"


def _fill(root: Path, *, worse_on: str | None = "tree=8", seed: int | None = None, b_delay: float = 2.0,
          faulty: bool = True, nominal: bool = True) -> Path:
    """trees 0/4/8, 2 maps x 5 runs, nominal and faulty runs; B (the fault) fails every run of
    ``worse_on`` where A succeeds, is ``b_delay`` s slower elsewhere, and collides where it fails."""
    d = spec_dict(trees=[0, 4, 8], defs=[], maps=2, runs=5, faults=[None, FAULT])
    if seed is not None:
        d["seed"] = seed
    with Store.create(root, parse_campaign(d), yaml.safe_dump(d)) as s:
        for key in ("tree=0", "tree=4", "tree=8"):
            for m in range(2):
                for r in range(5):
                    if nominal:
                        s.add(record("trees", key, m, r, duration=20.0 + r))
                    if faulty:
                        bad = key == worse_on
                        s.add(record("trees", key, m, r, "fail-collision" if bad else "success", fault=FAULT,
                                     duration=20.0 + r + b_delay, collisions=int(bad)))
    return root


def test_a_worse_b_is_found_and_said_first(tmp_path: Path) -> None:
    c = _fill(tmp_path / "c")
    code, out, err = invoke(["compare", str(c), "--a", "reference-v1", "--b", f"reference-v1:{FAULT}",
                             "--json", str(tmp_path / "ab.json")])
    assert code == 0, err
    lines = out.splitlines()
    assert lines[1].startswith("B is worse than A on trees tree=8: success 100% -> 0%, p = 0.006"), out
    assert "runs with a collision: A 0, B 10 of 30 pairs" in out
    data = json.loads((tmp_path / "ab.json").read_text())
    assert data["significant"] == ["trees tree=8"]
    by = {c["config"]: c for c in data["configurations"]}
    t8 = by["tree=8"]
    assert t8["pairs"] == 10 and t8["table"] == {"both_succeed": 0, "only_a_succeeds": 10, "only_b_succeeds": 0,
                                                  "both_fail": 0}
    assert t8["p_value"] == pytest.approx(2 / 1024) and t8["p_holm"] == pytest.approx(3 * 2 / 1024)
    assert t8["diff"] == -1.0 and t8["ci"][0] < -0.6 and t8["ci"][1] < 0
    assert by["tree=0"]["p_value"] == 1.0 and by["tree=0"]["p_holm"] == 1.0 and by["tree=0"]["diff"] == 0.0
    assert by["tree=0"]["duration_s"]["diff"] == pytest.approx(2.0) and by["tree=0"]["duration_s"]["n"] == 10
    assert t8["collisions"]["runs_with_collision_b"] == 10 and t8["collisions"]["mean_diff_per_run"] == 1.0
    o = data["overall"]
    assert o["pairs"] == 30 and o["success_rate_a"] == 1.0 and o["success_rate_b"] == pytest.approx(2 / 3)
    assert o["p_holm"] is None and data["unpaired_runs"] == {"a": 0, "b": 0}


def test_swapping_a_and_b_mirrors_every_figure(tmp_path: Path) -> None:
    c = _fill(tmp_path / "c")
    ab = compare(c, Arm("reference-v1"), Arm("reference-v1", FAULT))
    ba = compare(c, Arm("reference-v1", FAULT), Arm("reference-v1"))
    for x, y in zip(ab.configs + [ab.overall], ba.configs + [ba.overall]):
        assert x.diff == -y.diff and x.p_value == y.p_value and x.p_adjusted == y.p_adjusted
        assert x.ci == pytest.approx((-y.ci[1], -y.ci[0]))
    assert ba.headline().startswith("B is better than A on trees tree=8: success 0% -> 100%")


def test_no_difference_is_said_so(tmp_path: Path) -> None:
    c = _fill(tmp_path / "c", worse_on=None)
    code, out, err = invoke(["compare", str(c), "--a", "reference-v1", "--b", f"reference-v1:{FAULT}"])
    assert code == 0, err
    assert out.splitlines()[1].startswith(
        "no configuration differs at the 5% level after Holm correction (3 compared); overall success 100% -> 100%")
    assert "no run differs from another, so the gain cannot be measured" in out


def test_json_on_standard_output_alone(tmp_path: Path) -> None:
    c = _fill(tmp_path / "c")
    code, out, err = invoke(["compare", str(c), "--a", "reference-v1", "--b", f"reference-v1:{FAULT}", "--json", "-"])
    assert code == 0, err
    data = json.loads(out)
    assert data["correction"] == "Holm" and len(data["configurations"]) == 3


def test_two_campaign_directories_from_the_same_spec(tmp_path: Path) -> None:
    """Version 1 (nominal runs in one directory) against version 2 (the fault's runs in another)."""
    v1 = _fill(tmp_path / "v1", faulty=False)
    v2 = _fill(tmp_path / "v2", nominal=False)
    code, out, err = invoke(["compare", str(v1), str(v2), "--a", "reference-v1", "--b", f"reference-v1:{FAULT}"])
    assert code == 0, err
    assert "B is worse than A on trees tree=8" in out
    code, out, err = invoke(["compare", str(v1), str(v1)])  # --a: the first navigator; --b: as --a
    assert code == 2 and "another navigator or fault" in err


# ---- bad input -----------------------------------------------------------------------


def _seed_mismatch(root: Path) -> Path:
    c = _fill(root, nominal=False)
    d = spec_dict(trees=[0, 4, 8], defs=[], maps=2, runs=5, faults=[None, FAULT])
    with Store.create(c, parse_campaign(d), yaml.safe_dump(d)) as s:
        s.add(dataclasses.replace(record("trees", "tree=0", 0, 0), run_seed=999))
    return c


def _empty(root: Path) -> Path:
    make_store(root, faults=[None, FAULT]).close()
    return root


BAD: list[tuple[str, Any, list[str], str]] = [
    ("navigator not in the store", _fill, ["--a", "nope-v1", "--b", "reference-v1"], "--a='nope-v1'"),
    ("fault not in the store", _fill, ["--a", "reference-v1", "--b", "reference-v1:no-such-fault"],
     "--b='reference-v1:no-such-fault'"),
    ("empty store", _empty, ["--a", "reference-v1", "--b", f"reference-v1:{FAULT}"], "expected recorded runs"),
    ("no paired runs", lambda r: _fill(r, faulty=False), ["--a", "reference-v1", "--b", f"reference-v1:{FAULT}"],
     "pairs=0"),
    ("bad NAV:FAULT", _fill, ["--a", "reference-v1", "--b", "a:b:c"], "--b='a:b:c'"),
    ("empty NAV", _fill, ["--a", ":x", "--b", "reference-v1"], "--a=':x'"),
    ("same arm twice", _fill, ["--a", "reference-v1", "--b", "reference-v1:nominal"], "--b="),
    ("--b missing with one directory", _fill, ["--a", "reference-v1"], "--b="),
    ("run seeds differ", _seed_mismatch, ["--a", "reference-v1", "--b", f"reference-v1:{FAULT}"], "run_seed="),
    ("confidence 1.5", _fill, ["--a", "reference-v1", "--b", f"reference-v1:{FAULT}", "--confidence", "1.5"],
     "--confidence=1.5"),
    ("alpha 0", _fill, ["--a", "reference-v1", "--b", f"reference-v1:{FAULT}", "--alpha", "0"], "--alpha=0"),
]


@pytest.mark.parametrize("name,make,args,says", BAD, ids=[b[0] for b in BAD])
def test_bad_input_is_one_line_exit_2(tmp_path: Path, name: str, make: Any, args: list[str], says: str) -> None:
    c = make(tmp_path / "c")
    before = snapshot(tmp_path)
    argv = ["compare", str(c), *args, "--json", str(tmp_path / "out.json")]
    line = assert_one_line_error(*invoke(argv), argv)
    assert says in line, line
    assert snapshot(tmp_path) == before


def test_bad_directories_are_one_line_exit_2(tmp_path: Path) -> None:
    a = _fill(tmp_path / "a", faulty=False)
    (tmp_path / "adir").mkdir()
    cases = [
        (["compare", str(tmp_path / "nope"), "--a", "reference-v1", "--b", "reference-v1:x"], "not a campaign"),
        (["compare", str(a), str(tmp_path / "nope")], "not a campaign"),
        (["compare", str(a), str(a), str(a)], "DIR="),
        (["compare", str(a), "--a", "reference-v1", "--b", f"reference-v1:{FAULT}", "--json", str(tmp_path / "adir")],
         "--json="),
    ]
    other = spec_dict(trees=[0, 4, 8], defs=[], maps=2, runs=5, faults=[None, FAULT])
    for field, value in (("seed", 4), ("timeout_s", 50.0), ("world", {"size_m": [30.0, 30.0], "cell_m": 0.5})):
        d = {**other, field: value}
        b = tmp_path / f"b-{field}"
        with Store.create(b, parse_campaign(d), yaml.safe_dump(d)) as s:
            s.add(record("trees", "tree=0", 0, 0))
        cases.append((["compare", str(a), str(b)], "same spec and seed"))
    for argv, says in cases:
        before = snapshot(tmp_path)
        line = assert_one_line_error(*invoke(argv), argv)
        assert says in line, (argv, line)
        assert snapshot(tmp_path) == before


@pytest.mark.parametrize("out", ["{root}/afile/x.json", "/proc/navstress-no-such-dir/x.json", "/sys/navstress-x.json"])
def test_unwritable_json_is_one_line_exit_2_before_any_work(tmp_path: Path, out: str) -> None:
    c = _fill(tmp_path / "c")
    (tmp_path / "afile").write_text("a file")
    before = snapshot(tmp_path)
    path = out.replace("{root}", str(tmp_path))
    argv = ["compare", str(c), "--a", "reference-v1", "--b", f"reference-v1:{FAULT}", "--json", path]
    line = assert_one_line_error(*invoke(argv), argv)
    assert "path=" in line and path in line, line
    assert snapshot(tmp_path) == before and not Path(path).exists()


def _pairs_store(root: Path, kinds: str) -> Path:
    """tree=0, 2 maps x 5 runs; pair i is kinds[i]: 'b' both succeed, 'a' only A, 'B' only B, 'n' neither."""
    d = spec_dict(trees=[0], defs=[], maps=2, runs=5, faults=[None, FAULT])
    with Store.create(root, parse_campaign(d), yaml.safe_dump(d)) as s:
        for i, k in enumerate(kinds):
            m, r = divmod(i, 5)
            s.add(record("trees", "tree=0", m, r, "success" if k in "ba" else "fail-error"))
            s.add(record("trees", "tree=0", m, r, "success" if k in "bB" else "fail-timeout", fault=FAULT))
    return root


def test_pairing_gain_is_the_ratio_of_the_variances(tmp_path: Path) -> None:
    cmp = compare(_pairs_store(tmp_path / "c", "bbbbbaBnnn"), Arm("reference-v1"), Arm("reference-v1", FAULT))
    o = cmp.overall
    assert (o.both, o.a_only, o.b_only, o.neither) == (5, 1, 1, 3) and o.diff == 0.0
    assert o.var_paired == pytest.approx(0.2) and o.var_unpaired == pytest.approx(0.24 + 0.24)
    assert cmp.runs_factor == pytest.approx(0.48 / 0.2)
    assert cmp.width_ratio == pytest.approx(o.width / o.width_unpaired) and cmp.width_ratio < 1


def test_sides_that_agree_pair_by_pair_are_said_so(tmp_path: Path) -> None:
    c = _pairs_store(tmp_path / "c", "bbbbbnnnnn")
    code, out, err = invoke(["compare", str(c), "--a", "reference-v1", "--b", f"reference-v1:{FAULT}"])
    assert code == 0, err
    assert "A and B agree pair by pair: the paired variance of B - A is 0" in out
    assert compare(c, Arm("reference-v1"), Arm("reference-v1", FAULT)).runs_factor == float("inf")
