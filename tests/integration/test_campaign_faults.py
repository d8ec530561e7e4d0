"""Campaigns under fire, with real processes, signals and filesystems (all slow):

- ``campaign run`` SIGKILLed at many moments of a big store's creation: every later run resumes;
- a worker SIGKILLed from outside is retried and ends with a real outcome; a navigator that
  segfaults on every attempt is recorded as its own crash after the bounded attempts;
- a world file corrupted between sessions is regenerated on resume;
- SIGTERM / SIGINT: one line saying how to resume, exit 143 / 130, no partial file;
- a full disk (a tiny tmpfs in a private mount namespace): one line, non-zero exit, and the
  campaign resumes once there is space, nothing lost or doubled.
"""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest
import yaml

from navstress.campaign.executors import run_campaign
from navstress.campaign.store import Store

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), str(ROOT), os.environ.get("PYTHONPATH", "")])}


def _spec(**over: Any) -> dict[str, Any]:
    d: dict[str, Any] = {
        "name": "small", "seed": 3, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
        "experiments": [{"name": "flat", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
        "maps_per_config": 1, "runs_per_map": 2, "navigators": [{"name": "reference-v1"}], "timeout_s": 4.0}
    d.update(over)
    return d


def _write(path: Path, data: dict[str, Any]) -> Path:
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _default_sigint() -> None:
    # a command started in the background of a script (`make test &`) inherits SIGINT ignored, and
    # Python then never turns Ctrl-C into KeyboardInterrupt: the CLI gets the disposition a
    # terminal gives it
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _cli(spec: Path, out: Path, *extra: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "navstress.cli", "campaign", "run", str(spec), "-o", str(out),
                             "-q", *extra], env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_default_sigint)


def _count(out: Path) -> int:
    try:
        con = sqlite3.connect(f"file:{out / 'campaign.sqlite'}?mode=ro", uri=True, timeout=1)
        try:
            return int(con.execute("SELECT COUNT(*) FROM runs").fetchone()[0])
        finally:
            con.close()
    except sqlite3.Error:
        return -1


def _leftovers(d: Path) -> list[Path]:
    return [p for p in d.rglob(".*") if p.name != ".lock"]


def _assert_complete(out: Path) -> None:
    with Store.open(out) as s:
        planned = s.planned_ids()
        rows = [r[0] for r in s.con.execute("SELECT run_id FROM runs")]
        assert sorted(rows) == sorted(planned) and len(rows) == len(set(rows))
        for r in s.records():
            assert r.trace is None or (out / r.trace).is_file()
    assert _leftovers(out) == []


def test_kill_during_store_creation_at_many_moments(tmp_path: Path) -> None:
    """A 10,000-run store takes a few seconds to create; SIGKILL lands in every phase of it."""
    spec = _write(tmp_path / "big.yaml", _spec(
        experiments=[{"name": "trees", "sweep": {"obstacles.obstruction.tree": {"values": list(range(10))}}}],
        maps_per_config=10, runs_per_map=100))
    out = tmp_path / "out"
    mid_creation = 0
    for delay in (0.0, 0.02, 0.06, 0.15, 0.3, 0.6, 1.0, 1.6):
        p = _cli(spec, out, "-j", "1")
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and p.poll() is None and not (
                (out / "spec.yaml").exists() or (out / ".spec.yaml.tmp").exists()):
            time.sleep(0.002)
        time.sleep(delay)
        creating = not (out / "campaign.sqlite").exists()
        p.send_signal(signal.SIGKILL)
        _o, err = p.communicate()
        assert p.returncode == -signal.SIGKILL, err
        mid_creation += creating
        time.sleep(0.3)  # orphaned workers (if any started) notice and exit
    assert mid_creation >= 4, "too few kills landed during creation to show anything"
    # every later `campaign run` resumes: it gets past creation and records runs
    before = _count(out)  # a kill may have landed after a record: wait for one of this run's own
    p = _cli(spec, out, "-j", "1")
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and p.poll() is None and _count(out) < max(before, 0) + 1:
        time.sleep(0.2)
    p.send_signal(signal.SIGTERM)
    _o, err = p.communicate(timeout=60)
    assert p.returncode == 143 and "resume with: navstress campaign run" in err, err
    with Store.open(out) as s:
        done, planned = s.progress()
    assert planned == 10_000 and done >= 1
    assert _leftovers(out) == []


def test_worker_killed_from_outside_is_retried(tmp_path: Path) -> None:
    marker = tmp_path / "pid"
    spec = _write(tmp_path / "s.yaml", _spec(runs_per_map=1, navigators=[
        {"name": "killed-v1", "target": "tests.support.navigators.campaign_navs:KilledOnce", "config": {"marker": str(marker), "after_s": 0.3}}]))
    killed: list[int] = []

    def killer() -> None:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not marker.exists():
            time.sleep(0.05)
        if marker.exists():
            pid = int(marker.read_text())
            os.kill(pid, signal.SIGKILL)  # the OOM killer, or a person
            killed.append(pid)

    th = threading.Thread(target=killer, daemon=True)
    th.start()
    res = run_campaign(spec, tmp_path / "out", workers=1, wall_limit_s=60)
    th.join(5)
    assert killed and res.recorded == 1 and not res.unfinished
    with Store.open(tmp_path / "out") as s:
        rec = s.records()[0]
        attempts = s.attempts(rec.run_id)
    assert "killed" not in rec.reason and rec.trace is not None and (tmp_path / "out" / rec.trace).is_file()
    assert rec.outcome in ("success", "fail-timeout", "fail-collision", "fail-error"), rec
    assert [(a[1], a[2]) for a in attempts] == [(1, "died")] and "SIGKILL" in attempts[0][3]


def test_navigator_crashing_every_attempt_is_its_own_result(tmp_path: Path) -> None:
    spec = _write(tmp_path / "s.yaml", _spec(runs_per_map=1, navigators=[
        {"name": "segfaults-v1", "target": "tests.support.navigators.campaign_navs:Segfaults", "config": {"after_s": 0.2}}]))
    res = run_campaign(spec, tmp_path / "out", workers=1, wall_limit_s=60)
    assert res.recorded == 1
    with Store.open(tmp_path / "out") as s:
        rec = s.records()[0]
        attempts = s.attempts(rec.run_id)
    assert rec.outcome == "fail-other" and "SIGSEGV" in rec.reason and "in 3 of 3 attempts" in rec.reason
    assert [a[2] for a in attempts] == ["died"] * 3
    assert _leftovers(tmp_path / "out") == []


def test_corrupt_world_is_regenerated_on_resume(tmp_path: Path) -> None:
    spec = _write(tmp_path / "s.yaml", _spec())
    out = tmp_path / "out"
    run_campaign(spec, out, workers=1)
    with Store.open(out) as s:
        first = s.records()
        victim = first[-1]
        world = Path(s.task(victim.run_id).world_dir)
    # the world file is damaged and one run is not recorded yet (the session was killed before it)
    terrain = next(p for p in world.iterdir() if p.suffix == ".npz")
    terrain.write_bytes(terrain.read_bytes()[:50])
    con = sqlite3.connect(out / "campaign.sqlite")
    con.execute("DELETE FROM runs WHERE run_id = ?", (victim.run_id,))
    con.commit()
    con.close()
    res = run_campaign(spec, out, workers=1)
    assert res.recorded == 1 and not res.unfinished
    with Store.open(out) as s:
        again = next(r for r in s.records() if r.run_id == victim.run_id)
        attempts = s.attempts(victim.run_id)
    assert again.outcome == victim.outcome and again.reason == victim.reason and again.trace is not None
    assert (out / again.trace).read_bytes() == (out / victim.trace).read_bytes() if victim.trace else True
    assert [a[2] for a in attempts] == ["world"] and "corrupt" in attempts[0][3]
    _assert_complete(out)


@pytest.mark.parametrize("sig,code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
@pytest.mark.parametrize("moment", ["store-created", "first-record"])
def test_signals_stop_with_a_resume_line(tmp_path: Path, sig: signal.Signals, code: int, moment: str) -> None:
    # a slow navigator (0.05 s of wall time per step, 40 steps a run): the campaign cannot end before
    # the signal however loaded the machine (a quick one sometimes did, and exited 0)
    spec = _write(tmp_path / "s.yaml", _spec(runs_per_map=3, timeout_s=4.0, navigators=[
        {"name": "slow-v1", "target": "tests.support.navigators.campaign_navs:Slow", "config": {"delay_s": 0.05}}]))
    out = tmp_path / "out"
    p = _cli(spec, out, "-j", "2")
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and p.poll() is None:
        if moment == "store-created" and (out / "campaign.sqlite").exists():
            time.sleep(0.5)
            break
        if moment == "first-record" and _count(out) >= 1:
            break
        time.sleep(0.05)
    assert p.poll() is None, "the campaign ended before the signal: nothing tested"
    p.send_signal(sig)
    _o, err = p.communicate(timeout=60)
    lines = err.strip().splitlines()
    assert p.returncode == code, err
    assert len(lines) == 1 and f"stopped by {sig.name}" in lines[0], err
    assert f"resume with: navstress campaign run {spec} -o {out}" in lines[0]
    assert _leftovers(out) == [] and "Traceback" not in err
    res = run_campaign(spec, out, workers=2)
    assert res.already_done + res.recorded == res.planned == 3
    _assert_complete(out)


def _can_mount() -> bool:
    try:
        return subprocess.run(["unshare", "-rm", "sh", "-c", "mount -t tmpfs -o size=1m tmpfs /mnt"],
                              capture_output=True, timeout=20).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def test_full_disk_stops_then_resumes(tmp_path: Path) -> None:
    if not _can_mount():
        pytest.skip("mounting a tmpfs in a private mount namespace (unshare -rm) is not permitted here")
    spec = _write(tmp_path / "s.yaml", _spec(runs_per_map=4, record_lidar=True, timeout_s=6.0))
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    after = tmp_path / "after"
    run = f"{sys.executable} -m navstress.cli campaign run {spec} -o {mnt}/out -q -j 1"
    script = (f"mount -t tmpfs -o size=600k tmpfs {mnt} || exit 90\n"
              f"{run} > {tmp_path}/full.out 2> {tmp_path}/full.err; echo $? > {tmp_path}/full.rc\n"
              f"mount -o remount,size=64m {mnt}\n"
              f"{run} > {tmp_path}/resume.out 2> {tmp_path}/resume.err; echo $? > {tmp_path}/resume.rc\n"
              f"cp -a {mnt}/out {after}\n")
    p = subprocess.run(["unshare", "-rm", "sh", "-c", script], env=ENV, capture_output=True, text=True, timeout=500)
    assert p.returncode == 0, p.stderr
    err = (tmp_path / "full.err").read_text()
    lines = err.strip().splitlines()
    assert (tmp_path / "full.rc").read_text().strip() == "2", err
    assert len(lines) == 1 and "disk is full" in lines[0] and "Traceback" not in err, err
    assert (tmp_path / "resume.rc").read_text().strip() == "0", (tmp_path / "resume.err").read_text()
    _assert_complete(after)
    with Store.open(after) as s:
        assert s.progress() == (4, 4)


# ---- Ray: one line when it cannot join the cluster given (that it never joins one by accident,
# RAY_ADDRESS set and no address given: test_executors' Ray contract runs so) ----------------------


def test_ray_address_that_cannot_be_joined_is_one_line(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason="ray is not installed (pip extra 'ray')")
    spec = _write(tmp_path / "s.yaml", _spec())
    p = _cli(spec, tmp_path / "out", "--executor", "ray", "--ray-address", "127.0.0.1:1")
    _o, err = p.communicate(timeout=240)
    lines = err.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1, err[-3000:]
    assert lines[0].startswith("error: --ray-address='127.0.0.1:1' is invalid") and "ray start --head" in lines[0]
    assert not (tmp_path / "out").exists()


def test_machinery_failures_stay_pending_then_resume(tmp_path: Path) -> None:
    """An OS error on every attempt (the trace folder's path is taken by a file) is not a result:
    after the bounded attempts the run stays pending, the CLI exits 1 saying so, and once the cause
    is gone the same command records it."""
    spec = _write(tmp_path / "s.yaml", _spec(runs_per_map=1))
    out = tmp_path / "out"
    with Store.create(out, *_load(spec)) as s:
        task = s.plan().tasks[0]
    blocker = Path(task.trace_path).parent
    blocker.parent.mkdir(parents=True)
    blocker.write_text("not a folder")
    p = _cli(spec, out, "-j", "1")
    o, err = p.communicate(timeout=300)
    assert p.returncode == 1, err
    assert "1 run(s) not recorded" in err and "resume with: navstress campaign run" in err, err
    with Store.open(out) as s:
        assert s.progress() == (0, 1)
        assert [a[2] for a in s.attempts(task.run_id)] == ["error"] * 3
    blocker.unlink()
    p = _cli(spec, out, "-j", "1")
    o, err = p.communicate(timeout=300)
    assert p.returncode == 0, err
    _assert_complete(out)


def _load(spec: Path) -> tuple[Any, str]:
    from navstress.campaign.spec import load_campaign

    s, text = load_campaign(spec)
    return s, text
