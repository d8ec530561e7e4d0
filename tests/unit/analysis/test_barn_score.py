"""BARN's score (navstress.analysis.barn): the formula against hand-computed values and by
hypothesis over t (its clip bounds, 0 for a failure, at most 0.5), the path length of a known
path file, BARN's clock on a trajectory, bad path files, and the score in ``analyze`` and the
report of a real campaign store on BARN worlds (hand-written records and traces: no simulation)."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.analysis.analyze import analyze
from navstress.analysis.barn import barn_time, barn_worlds, cells_xy, load_path, path_length, score
from navstress.analysis.report import build_report
from navstress.campaign.plan import run_id
from navstress.campaign.presets import BARN_GOAL, BARN_START, barn_world_file
from navstress.campaign.spec import parse_campaign, parse_campaign_text
import yaml
from navstress.campaign.store import Store
from navstress.errors import SpecError
from navstress.run.record import RunRecord
from navstress.run.trace import TOPIC_TRUTH, TraceWriter
from tests.support.analysis_synth import make_store, record
from tests.support.barn import barn_dir



# ---- the formula ----------------------------------------------------------------------------------


@pytest.mark.parametrize(("success", "t", "t_opt", "want"), [
    (True, 30.0, 6.0, 6.0 / 30.0),      # inside the clip: t_opt / t
    (True, 12.0, 6.0, 0.5),             # exactly 2 t_opt
    (True, 5.0, 6.0, 0.5),              # faster than 2 t_opt: clipped up to 2 t_opt
    (True, 48.0, 6.0, 0.125),           # exactly 8 t_opt
    (True, 100.0, 6.0, 0.125),          # slower than 8 t_opt: clipped down
    (True, 20.0, 6.796, 6.796 / 20.0),
    (False, 30.0, 6.0, 0.0),
    (False, 5.0, 6.0, 0.0),
])
def test_score_hand_computed(success: bool, t: float, t_opt: float, want: float) -> None:
    assert score(success, t, t_opt) == pytest.approx(want, rel=1e-12)


@settings(max_examples=300, deadline=None)
@given(t=st.floats(0.0, 1e4, allow_nan=False), t_opt=st.floats(0.05, 100.0), success=st.booleans())
def test_score_bounds_by_hypothesis(t: float, t_opt: float, success: bool) -> None:
    s = score(success, t, t_opt)
    if not success:
        assert s == 0.0
        return
    assert 0.125 - 1e-12 <= s <= 0.5 + 1e-12  # the clip: between t_opt/(8 t_opt) and t_opt/(2 t_opt)
    if t <= 2 * t_opt:
        assert s == pytest.approx(0.5)
    elif t >= 8 * t_opt:
        assert s == pytest.approx(0.125)
    else:
        assert s == pytest.approx(t_opt / t)
    # never better for a slower run
    assert score(True, t + 1.0, t_opt) <= s + 1e-12


@pytest.mark.parametrize(("t", "t_opt"), [(1.0, 0.0), (1.0, -2.0), (1.0, math.inf), (math.nan, 3.0), (1.0, math.nan)])
def test_score_refuses_nonsense(t: float, t_opt: float) -> None:
    with pytest.raises(SpecError):
        score(True, t, t_opt)


# ---- the path ---------------------------------------------------------------------------------------


def test_path_length_of_a_known_path_file(tmp_path: Path) -> None:
    f = tmp_path / "path_7.npy"
    np.save(f, np.array([[0, 0], [0, 1], [1, 1]], dtype=np.int64))
    cells = load_path(f)
    # cells -> (x, y) = (i * 0.15 - 4.575, j * 0.15 + 5.075), by hand
    assert cells_xy(cells).ravel().tolist() == pytest.approx([-4.575, 5.075, -4.575, 5.225, -4.425, 5.225])
    # start (-2.25, 3) -> (-4.575, 5.075): dx 2.325, dy 2.075; two lattice steps of 0.15;
    # (-4.425, 5.225) -> goal (-2.25, 13): dx 2.175, dy 7.775
    want = math.sqrt(2.325 ** 2 + 2.075 ** 2) + 0.15 + 0.15 + math.sqrt(2.175 ** 2 + 7.775 ** 2)
    assert path_length(cells) == pytest.approx(want, abs=1e-12)
    assert path_length(cells, (0.0, 0.0), (0.0, 0.0)) > 0  # another start and goal change it
    # cell column 15 is x = 15 * 0.15 - 4.575 = -2.325
    assert cells_xy(np.array([[15, j] for j in range(30)]))[:, 0].tolist() == pytest.approx([-2.325] * 30)


def test_path_length_of_barn_files(tmp_path_factory: pytest.TempPathFactory) -> None:
    """The shared BARN path files: every length at least the straight 10 m, at most a few times it."""
    folder = barn_dir(tmp_path_factory, (0, 6, 294))
    for n in (0, 6, 294):
        cells = load_path(folder / "path_files" / f"path_{n}.npy")
        assert cells.shape[1] == 2 and len(cells) >= 30  # the field is 30 cells deep
        assert 10.0 < path_length(cells) < 30.0


@pytest.mark.parametrize("content", ["missing", "text", "shape3", "empty", "nan", "pickle"])
def test_bad_path_files(tmp_path: Path, content: str) -> None:
    f = tmp_path / "path_1.npy"
    if content == "text":
        f.write_text("not an array")
    elif content == "shape3":
        np.save(f, np.zeros((4, 3)))
    elif content == "empty":
        np.save(f, np.zeros((0, 2)))
    elif content == "nan":
        np.save(f, np.array([[0.0, math.nan]]))
    elif content == "pickle":
        np.save(f, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(SpecError) as err:
        load_path(f)
    assert str(f) in str(err.value) and "\n" not in str(err.value)


# ---- BARN's clock -----------------------------------------------------------------------------------


def _walk(wait_s: float, speed: float, length: float, dt: float = 0.1) -> np.ndarray:
    """Stand still ``wait_s`` at (0, 0), then drive along +y at ``speed`` for ``length`` m."""
    t = np.arange(0.0, wait_s + length / speed + 1e-9, dt)
    y = np.clip((t - wait_s) * speed, 0.0, length)
    rows = np.zeros((len(t), 7))
    rows[:, 0], rows[:, 2] = t, y
    return rows


@pytest.mark.parametrize(("wait", "speed"), [(0.0, 1.0), (2.0, 1.0), (3.3, 0.5), (0.7, 2.0)])
def test_barn_time_starts_at_01_m_and_stops_1_m_from_the_goal(wait: float, speed: float) -> None:
    rows = _walk(wait, speed, 9.5)
    # moved 0.1 m at wait + 0.1 / speed; within 1 m of the goal (10 m ahead) at y = 9
    assert barn_time(rows, (0.0, 10.0)) == pytest.approx((9.0 - 0.1) / speed, abs=1e-6)


def test_barn_time_none_when_the_goal_is_never_reached() -> None:
    assert barn_time(_walk(0.0, 1.0, 8.5), (0.0, 10.0)) is None
    assert barn_time(np.zeros((0, 7)), (0.0, 10.0)) is None


# ---- in a campaign's analysis and report -----------------------------------------------------------


def small_barn_spec(folder: Path, worlds: tuple[int, ...], runs: int) -> dict:
    """The barn preset's spec on ``worlds`` only (the preset itself checks the whole test set)."""
    full = {"name": "barn", "seed": 2020, "robot": "jackal"}
    entries = [{"key": f"world_{n}", "map_seed": n,
                "world": {"source": {"path": str(barn_world_file(folder.resolve(), n))},
                          "mission": {"start": list(BARN_START), "goal": list(BARN_GOAL)}}} for n in worlds]
    return {**full, "experiments": [{"name": "barn", "worlds": entries}], "runs_per_map": runs,
            "navigators": [{"name": "reference-2d-v1"}], "faults": [None], "timeout_s": 100.0, "goal_tolerance_m": 1.0}


def _record(store: Store, n: int, r: int, outcome: str, duration: float, rows: np.ndarray | None) -> RunRecord:
    root = store.root
    task = store.task(run_id("barn", f"world_{n}", 0, r, "reference-2d-v1", None))
    trace = None
    if rows is not None:
        p = root / "traces" / f"w{n}r{r}.mcap"
        p.parent.mkdir(parents=True, exist_ok=True)
        with TraceWriter(p) as w:
            w.poses(TOPIC_TRUTH, rows)
        trace = str(p.relative_to(root))
    return RunRecord(run_id=task.run_id, experiment="barn", config=task.config, map_index=0, run_index=r,
                     map_seed=task.map_seed, run_seed=task.run_seed, navigator="reference-2d-v1", fault=None, outcome=outcome, reason="synthetic", duration_s=duration,
                     wall_s=1.0, goal_distance_m=0.5, path_length_m=10.0, tortuousness=0.0, collisions=0,
                     first_collision_s=None, errors=[], trace=trace)


def test_barn_score_in_analyze_and_report(tmp_path_factory: pytest.TempPathFactory, tmp_path: Path) -> None:
    folder = barn_dir(tmp_path_factory, (0, 6))
    spec_d = small_barn_spec(folder, (0, 6), 2)
    text = yaml.safe_dump(spec_d)
    root = tmp_path / "camp"
    store = Store.create(root, parse_campaign_text(text), text)
    L0 = path_length(load_path(folder / "path_files" / "path_0.npy"))
    L6 = path_length(load_path(folder / "path_files" / "path_6.npy"))
    t_opt0, t_opt6 = L0 / 2, L6 / 2
    # world 0: a success waiting 1 s then 0.5 m/s (BARN's t = 8.9 / 0.5 = 17.8 s), and a collision;
    # world 6: a success at 2 m/s (t = 4.45 s: below 2 t_opt, 0.5) and one without a trace (duration 40 s)
    recs = [_record(store, 0, 0, "success", 20.0, _walk(1.0, 0.5, 9.5)),
            _record(store, 0, 1, "fail-collision", 3.0, _walk(0.0, 1.0, 2.0)),
            _record(store, 6, 0, "success", 6.0, _walk(0.0, 2.0, 9.5)),
            _record(store, 6, 1, "success", 40.0, None)]
    for rec in recs:
        store.add(rec)
    store.close()
    want0 = [t_opt0 / min(max(17.8, 2 * t_opt0), 8 * t_opt0), 0.0]
    want6 = [0.5, t_opt6 / min(max(40.0, 2 * t_opt6), 8 * t_opt6)]
    a = analyze(root)
    assert a.barn is not None and len(a.barn.groups) == 1
    g = a.barn.groups[0]
    assert [w.world.index for w in g.worlds] == [0, 6]
    assert [r.score for r in g.worlds[0].runs] == pytest.approx(want0, rel=1e-6)
    assert [r.score for r in g.worlds[1].runs] == pytest.approx(want6, rel=1e-6)
    assert g.worlds[0].score == pytest.approx(sum(want0) / 2, rel=1e-6)
    assert g.score == pytest.approx((sum(want0) + sum(want6)) / 4, rel=1e-6)
    assert [r.t_from for r in g.worlds[1].runs] == ["trace", "duration"]
    assert any("without a readable trace" in n for n in a.barn.notes)
    js = json.loads(json.dumps(a.to_json()))
    assert js["barn"]["groups"][0]["score"] == pytest.approx(g.score)
    assert js["barn"]["groups"][0]["per_world"][0]["path_length_m"] == pytest.approx(L0)
    html = build_report(root, tmp_path / "report.html").read_text()
    assert 'id="barn"' in html and 'href="#barn"' in html
    assert f'data-field="barn_score" data-value="{g.score!r}"' in html or f"{g.score:.4f}" in html
    assert 'data-world="6"' in html


def test_no_barn_key_for_other_campaigns(tmp_path: Path) -> None:
    """A campaign without BARN worlds: no ``barn`` key, no section (its outputs keep their bytes)."""
    store = make_store(tmp_path / "c", trees=[0], defs=[], maps=1, runs=1)
    store.add(record("trees", "tree=0", 0, 0))
    store.close()
    a = analyze(tmp_path / "c")
    assert a.barn is None and "barn" not in a.to_json()


def test_barn_worlds_need_barns_mission_and_path_files(tmp_path_factory: pytest.TempPathFactory,
                                                      tmp_path: Path) -> None:
    folder = tmp_path / "BARN"  # a copy: this test breaks a path file
    shutil.copytree(barn_dir(tmp_path_factory, (0,)), folder)
    good = small_barn_spec(folder, (0,), 1)
    assert [w.index for w in barn_worlds(parse_campaign(good))] == [0]
    other = small_barn_spec(folder, (0,), 1)
    other["experiments"][0]["worlds"][0]["world"]["mission"]["goal"] = [-2.25, 12.0]
    assert barn_worlds(parse_campaign(other)) == []  # another mission: BARN's t_opt does not apply
    (folder / "path_files" / "path_0.npy").write_bytes(b"garbage")
    (w,) = barn_worlds(parse_campaign(good))
    assert w.t_opt_s is None and w.problem is not None and "path_0.npy" in w.problem
