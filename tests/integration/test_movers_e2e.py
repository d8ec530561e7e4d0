"""Movers end to end in the real simulation: an intercepting mover against a robot driving a
straight scripted line (far more meetings than a crossing one), a real mission with movers
(same seeds, same trace bytes; the movers in the trace, read back with the mcap reader, and in
the picture) and a small campaign sweeping the mover count."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from navstress.analysis import svgmap
from navstress.analysis.report import build_report
from navstress.campaign.executors import run_campaign
from navstress.campaign.store import Store
from navstress.nav.api import Command
from navstress.run.batch import batch_picture
from navstress.run.mission import execute
from navstress.run.record import RunTask
from navstress.run.figures import RunTrack
from navstress.run.trace import TOPIC_MOVERS, read_movers, read_poses
from navstress.sim.config import SimConfig
from navstress.sim.simulation import Simulation
from navstress.world import World, generate, parse_spec

pytestmark = pytest.mark.slow


def _meets(kind: str, seed: int, **behaviour: Any) -> bool:
    """Whether one pedestrian of ``kind`` touches the robot driving straight (1 m/s, open loop)
    across an empty 60 m map for 50 s (map and run seed ``seed``)."""
    spec = parse_spec({"size_m": [60, 60], "mission": {"start": [5, 30, 0], "goal": [55, 30]},
                       "movers": {"count": {"pedestrian": 1},
                                  "behaviour": {"pedestrian": {"kind": kind, **behaviour}}}})
    sim = Simulation(generate(spec, seed), config=SimConfig(lidar_enabled=False), seed=seed)
    sim.command(Command(1.0, 0.0))
    for _ in range(50):
        sim.advance(1.0)
        if sim.observer.collisions or sim.stopped:
            break
    return any(c.mover == 0 for c in sim.observer.collisions)


def test_an_intercepting_mover_meets_a_straight_driving_robot_far_more_often_than_a_crossing_one() -> None:
    seeds = range(30)
    intercept = sum(_meets("intercept", s, ttc_s=0.5) for s in seeds)
    crossing = sum(_meets("crossing", s) for s in seeds)
    # measured in the simulator: 30 of 30 against 2 of 30 (seeds 0-29)
    assert intercept >= 24 and crossing <= 8 and intercept - crossing >= 16, (intercept, crossing)


MOVERS_WORLD: dict[str, Any] = {
    "size_m": [40, 40], "obstacles": {"obstruction": {"tree": 2}},
    "movers": {"count": {"pedestrian": 5, "vehicle": 1},
               "behaviour": {"pedestrian": {"pause_max_s": 2.0}, "vehicle": {"kind": "patrol"}}}}


def test_a_mission_with_movers_same_seeds_same_trace(tmp_path: Path) -> None:
    w = generate(parse_spec(MOVERS_WORLD), 4)
    d = tmp_path / "w"
    w.save(d)

    def run(name: str, seed: int) -> Any:
        (tmp_path / name).mkdir()
        return execute(RunTask(run_id="movers/0", world_dir=str(d), run_seed=seed,
                               trace_path=str(tmp_path / name / "r.mcap"), timeout_s=30.0))

    a, b, c = run("a", 7), run("b", 7), run("c", 8)
    assert Path(a.trace).read_bytes() == Path(b.trace).read_bytes()
    ta, pa = read_movers(a.trace)
    tc, pc = read_movers(c.trace)
    assert pa.shape[1] == len(World.load(d).movers) == 6 and len(ta) >= 10 * min(a.duration_s, 29.0)
    assert np.allclose(pa[0, :, :2], [mv.start[:2] for mv in w.movers])  # where they were placed
    assert float(np.abs(pa[-1, :, :2] - pa[0, :, :2]).max()) > 3.0  # and they moved
    n = min(len(pa), len(pc))
    assert not np.array_equal(pa[:n], pc[:n])  # pauses come from the run seed
    png = batch_picture(d, [a], tmp_path / "a.png", "movers")
    assert png.stat().st_size > 10_000


def test_a_small_campaign_sweeping_the_mover_count(tmp_path: Path) -> None:
    spec = {"name": "movers", "seed": 5, "world": {"size_m": [30.0, 30.0], "cell_m": 0.4,
                                                   "movers": {"behaviour": {"pedestrian": {"kind": "intercept"}}}},
            "experiments": [{"name": "crowd", "sweep": {"movers.count.pedestrian": {"values": [0, 4]}}}],
            "maps_per_config": 1, "runs_per_map": 2, "navigators": [{"name": "reference-v1"}],
            "faults": [None], "timeout_s": 30.0, "goal_tolerance_m": 2.0}
    path = tmp_path / "spec.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    res = run_campaign(path, tmp_path / "out", workers=1)
    assert res.recorded == res.planned == 4
    with Store.open(tmp_path / "out") as s:
        recs = s.records()
    movers = sorted(read_movers(tmp_path / "out" / r.trace)[1].shape[1] for r in recs if r.trace)
    assert movers == [0, 0, 4, 4]
    assert all(r.outcome in ("success", "fail-collision", "fail-error", "fail-timeout") for r in recs)
    assert TOPIC_MOVERS == "/world/movers"
    # the report's configuration pages say which movers a world has and draw them (their paths in
    # the one-run picture, where they were at a collision in the all-runs picture)
    html = build_report(tmp_path / "out", tmp_path / "report.html").read_text(encoding="utf-8")
    crowd, empty = (html.split('data-config="pedestrian=4"><h3>')[1].split("</section>")[0],
                    html.split('data-config="pedestrian=0"><h3>')[1].split("</section>")[0])
    assert "movers: 4 pedestrian (intercept)" in crowd and "movers:" not in empty
    rec = next(r for r in recs if r.trace and "pedestrian=4" in r.trace)
    world = World.load(next((tmp_path / "out" / "worlds" / "crowd").glob("pedestrian=4/m0")))
    truth = read_poses(tmp_path / "out" / rec.trace)
    bare = RunTrack("r", rec.outcome, truth)
    moving = RunTrack("r", rec.outcome, truth, movers=read_movers(tmp_path / "out" / rec.trace),
                      collision_t=rec.first_collision_s)
    assert svgmap.runs_svg(world, "w", [("r", moving, "r")]) != svgmap.runs_svg(world, "w", [("r", bare, "r")])
    assert 'class="mvpath"' in svgmap.runs_svg(world, "w", [("r", moving, "r")])  # a one-run picture: their paths
    assert 'class="mvpath"' in crowd and 'class="mvpath"' not in empty


def test_navstress_run_on_a_world_with_intercepting_movers(tmp_path: Path) -> None:
    """As a user calls it: generate a world with movers from flags, run the reference stack on it;
    reference-v1 stands still for its first seconds, so intercepting pedestrians hit it there:
    Fail-Collision with the reason of a robot hit while stationary; the trace holds the movers."""
    import subprocess
    import sys

    def cli(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "navstress.cli", *args], capture_output=True, text=True,
                              timeout=600)

    w, out = tmp_path / "w", tmp_path / "out"
    r = cli("world", "generate", "-o", str(w), "--size", "60", "--movers", "pedestrian=8,vehicle=1",
            "--mover-behaviour", "pedestrian=intercept", "--seed", "3")
    assert r.returncode == 0, r.stderr
    r = cli("run", str(w), "-o", str(out), "--timeout", "40", "--json")
    assert r.returncode == 0, r.stderr
    (rec,) = [json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines()]
    assert rec["outcome"] == "fail-collision"
    assert rec["reason"].startswith("hit by a mover while stationary: 1 collision(s)")
    assert read_movers(out / "run-000.mcap")[1].shape[1] == 9
    assert (out / "trajectories.png").stat().st_size > 10_000
