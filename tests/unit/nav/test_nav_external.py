"""ExternalNavigator: drives the stdio example; crash, hang and garbage end the run precisely."""

from __future__ import annotations

import math
import subprocess
import sys
import time
from pathlib import Path

import pytest

from navstress.errors import NavigatorError, SpecError
from navstress.nav.api import Command, Imu, LidarScan, NavMission, Observation, Odometry, PoseReading, Status
from navstress.nav.check import flat_ground_scan
from navstress.nav.external import ExternalNavigator
from navstress.nav.registry import make_navigator
from navstress.robot import RobotSpec

from tests.support.nav_plugin_helpers import MISBEHAVING, STDIO

ROBOT = RobotSpec()
MISSION = NavMission((0.0, 0.0, 0.0), (5.0, 2.0), 1.0)


def approach(n: int = 40, azimuth_steps: int = 90) -> list[Observation]:
    """The robot creeps along a curve toward the goal; pose every 3rd cycle, scans every cycle."""
    scan = flat_ground_scan(ROBOT, 0.0, azimuth_steps=azimuth_steps)
    out = []
    for k in range(1, n + 1):
        t = 0.1 * k
        s = k / n
        x, y, yaw = 5.0 * s, 2.0 * s * s, math.atan2(4.0 * s, 5.0)
        pose = PoseReading(t, x + 0.01, y - 0.02, 0.0, yaw, 0.0, 0.0) if k % 3 == 0 else None
        out.append(Observation(t, Odometry(t, x, y, yaw, 0.5, 0.1), Imu(t, 0, 0, yaw, (0, 0, 0.1)),
                               pose, (LidarScan(t, scan.points, scan.mount),)))
    return out


def misbehaving(mode: str, **kw: float) -> ExternalNavigator:
    return ExternalNavigator([sys.executable, str(MISBEHAVING), mode], **kw)


def run_one_step(nav: ExternalNavigator, groups: list[int]) -> tuple[Command | Status, float]:
    nav.reset(MISSION, ROBOT, seed=1)
    assert nav.last_pid is not None
    groups.append(nav.last_pid)
    t0 = time.monotonic()
    out = nav.step(approach(1)[0])
    return out, time.monotonic() - t0


def test_stdio_example_matches_in_process_bit_for_bit(example_package: Path,
                                                      no_leftover_process: list[int]) -> None:
    from navstress_example_straightline import StraightLineNavigator

    local = StraightLineNavigator()
    remote = ExternalNavigator([sys.executable, str(STDIO)], step_budget_s=5.0)
    try:
        for seed in (3, 4):  # a second reset on the same process
            local.reset(MISSION, ROBOT, seed=seed)
            remote.reset(MISSION, ROBOT, seed=seed)
            no_leftover_process.append(remote.pid)  # type: ignore[arg-type]
            a = [local.step(o) for o in approach()]
            b = [remote.step(o) for o in approach()]
            assert a == b
            assert isinstance(a[0], Command) and a[0].v > 0
            assert a[-1] == Status("arrived", a[-1].message)  # type: ignore[union-attr]
        assert remote.remote_name == "straightline-stdio"
        assert remote.failure is None
    finally:
        remote.close()
        remote.close()  # idempotent
    assert remote.pid is None


def test_large_scans_do_not_deadlock_the_pipes(example_package: Path,
                                               no_leftover_process: list[int]) -> None:
    """32 x 1024 points (~450 KB per line) is far more than a pipe buffer holds."""
    big = flat_ground_scan(ROBOT, 0.0, azimuth_steps=1024)
    assert big.points.nbytes > 200_000
    with ExternalNavigator([sys.executable, str(STDIO)], step_budget_s=10.0) as nav:
        nav.reset(MISSION, ROBOT, seed=0)
        no_leftover_process.append(nav.pid)  # type: ignore[arg-type]
        obs = approach(1)[0]
        out = nav.step(Observation(obs.t, obs.odom, obs.imu, obs.pose, (big, big)))
        assert isinstance(out, Command), out


def test_crash_gives_exit_code_and_last_stderr_lines(no_leftover_process: list[int]) -> None:
    nav = misbehaving("crash", step_budget_s=5.0)
    out, _ = run_one_step(nav, no_leftover_process)
    nav.close()
    assert isinstance(out, Status) and out.kind == "error" and out.infrastructure
    assert out.message.startswith("navigator process exited with code 3 during step")
    assert "fatal: simulated crash in planner" in out.message
    assert "planner: loading map" in out.message
    assert nav.failure is not None and nav.failure.kind == "exit"
    assert nav.step(approach(1)[0]) == out  # the run stays ended


def test_killed_by_signal_is_named(no_leftover_process: list[int]) -> None:
    nav = misbehaving("segv", step_budget_s=5.0)
    out, _ = run_one_step(nav, no_leftover_process)
    nav.close()
    assert isinstance(out, Status) and "was killed by SIGSEGV" in out.message


@pytest.mark.parametrize("budget", [0.3, 0.6])
def test_hang_on_step_ends_within_budget(budget: float, no_leftover_process: list[int]) -> None:
    nav = misbehaving("hang", step_budget_s=budget)
    out, elapsed = run_one_step(nav, no_leftover_process)
    nav.close()
    assert isinstance(out, Status) and out.kind == "error"
    assert f"gave no answer within {budget} s to step" in out.message
    assert nav.failure is not None and nav.failure.kind == "timeout"
    assert budget <= elapsed < budget + 1.0


def test_hanging_command_never_answering_hello(no_leftover_process: list[int]) -> None:
    nav = ExternalNavigator(["sleep", "120"], reset_budget_s=0.4)
    t0 = time.monotonic()
    nav.reset(MISSION, ROBOT, seed=0)  # does not raise: the run is classified, not crashed
    assert time.monotonic() - t0 < 1.5
    assert nav.pid is None and nav.last_pid is not None  # killed at the failure already
    no_leftover_process.append(nav.last_pid)
    out = nav.step(approach(1)[0])
    nav.close()
    assert isinstance(out, Status) and out.message == \
        "navigator process gave no answer within 0.4 s to hello (budget exceeded; the run ends, the process is killed)"


def test_grandchildren_are_killed_with_the_group(no_leftover_process: list[int]) -> None:
    nav = misbehaving("hang-child", step_budget_s=0.5)
    out, _ = run_one_step(nav, no_leftover_process)
    nav.close()
    assert isinstance(out, Status) and "no answer within 0.5 s" in out.message
    # the fixture checks that the group (leader + its `sleep 120`) has no live member


@pytest.mark.parametrize(("mode", "expected"), [
    ("garbage", "navigator process sent an invalid message in reply to step: not JSON"),
    ("nan", "navigator process sent an invalid message in reply to step: non-finite number NaN"),
    ("wrong-type", "expected a 'command' or 'status' message, got type 'ok'"),
    ("garbage-hello", "invalid message in reply to hello: not JSON"),
    ("old-protocol", "navigator process speaks protocol 99, navstress speaks 1 or 2"),
    ("refuse-reset", "navigator process refused the reset: mission too long"),
])
def test_garbage_and_protocol_violations(mode: str, expected: str,
                                         no_leftover_process: list[int]) -> None:
    nav = misbehaving(mode, step_budget_s=5.0, reset_budget_s=5.0)
    out, elapsed = run_one_step(nav, no_leftover_process)
    nav.close()
    assert isinstance(out, Status) and out.kind == "error" and out.infrastructure
    assert expected in out.message, out.message
    assert elapsed < 2.0


def test_reset_after_failure_starts_a_fresh_process(example_package: Path,
                                                    no_leftover_process: list[int]) -> None:
    nav = ExternalNavigator([sys.executable, str(STDIO)])
    try:
        nav.reset(MISSION, ROBOT, seed=0)
        first = nav.pid
        no_leftover_process.append(first)  # type: ignore[arg-type]
        nav._fail("protocol", "test-injected failure")  # as if it had sent garbage
        assert nav.step(approach(1)[0]).kind == "error"  # type: ignore[union-attr]
        nav.reset(MISSION, ROBOT, seed=0)
        no_leftover_process.append(nav.pid)  # type: ignore[arg-type]
        assert nav.pid != first and nav.failure is None
        assert isinstance(nav.step(approach(1)[0]), Command)
    finally:
        nav.close()


def test_step_before_reset_is_an_error() -> None:
    nav = misbehaving("slow")
    out = nav.step(approach(1)[0])
    assert isinstance(out, Status) and "stepped before reset" in out.message
    nav.close()


def test_unstartable_command_is_a_config_error() -> None:
    with pytest.raises(NavigatorError, match=r"'/nonexistent/nav' is not an executable.*'command'"):
        ExternalNavigator(["/nonexistent/nav"])
    with pytest.raises(SpecError, match=r"step_budget_s=0 is invalid"):
        ExternalNavigator(["sleep", "1"], step_budget_s=0)
    with pytest.raises(SpecError, match=r"command=\[\] is invalid"):
        ExternalNavigator([])


def test_registered_as_external_v1(example_package: Path, no_leftover_process: list[int]) -> None:
    nav = make_navigator("external-v1", {"command": [sys.executable, str(STDIO)],
                                         "step_budget_s": 3.0})
    assert isinstance(nav, ExternalNavigator) and nav.step_budget_s == 3.0
    nav.reset(MISSION, ROBOT, seed=0)
    no_leftover_process.append(nav.pid)  # type: ignore[arg-type]
    assert isinstance(nav.step(approach(1)[0]), Command)
    nav.close()
    assert isinstance(make_navigator("external-v1", {"command": "sleep 5"}), ExternalNavigator)
    with pytest.raises(SpecError, match=r"navigator-config.command is missing: expected the command"):
        make_navigator("external-v1", {})
    with pytest.raises(SpecError, match=r"navigator-config.budget=1 is invalid: expected one of the keys"):
        make_navigator("external-v1", {"command": ["sleep"], "budget": 1})
    nav = make_navigator("straightline-stdio-v1", {"step_budget_s": 1.5})
    assert isinstance(nav, ExternalNavigator) and nav.step_budget_s == 1.5


def test_serve_runs_a_registered_navigator_out_of_process(example_package: Path,
                                                          no_leftover_process: list[int]) -> None:
    """``python -m navstress.nav.external NAME`` answers exactly as the in-process navigator."""
    from navstress_example_straightline import StraightLineNavigator

    remote = ExternalNavigator([sys.executable, "-m", "navstress.nav.external", "straightline-v1",
                                '{"heading_gain": 2.0}'], reset_budget_s=60.0)
    local = StraightLineNavigator({"heading_gain": 2.0})
    try:
        remote.reset(MISSION, ROBOT, seed=5)
        no_leftover_process.append(remote.pid)  # type: ignore[arg-type]
        local.reset(MISSION, ROBOT, seed=5)
        obs = approach(12)
        assert [remote.step(o) for o in obs] == [local.step(o) for o in obs]
        assert remote.remote_name == "straightline-v1"
    finally:
        remote.close()


def test_stdio_example_is_standard_library_only() -> None:
    """The out-of-process example speaks the protocol where navstress/numpy cannot be imported."""
    from navstress.nav import wire

    lines = b"".join(wire.dumps(m) for m in (
        wire.hello_message(), wire.reset_message(MISSION, ROBOT, 0),
        wire.step_message(approach(1)[0]), wire.close_message()))
    code = ("import sys, runpy; sys.modules['numpy'] = None; sys.modules['navstress'] = None; "
            f"sys.argv = [{str(STDIO)!r}]; runpy.run_path(sys.argv[0], run_name='__main__')")
    proc = subprocess.run([sys.executable, "-I", "-c", code], input=lines, capture_output=True,
                          timeout=30)
    assert proc.returncode == 0, proc.stderr.decode()
    replies = [wire.loads(line) for line in proc.stdout.splitlines()]
    assert [r["type"] for r in replies] == ["hello", "ok", "command"]
    assert replies[0]["protocol"] == wire.PROTOCOL_VERSION
    assert isinstance(wire.decode_command_or_status(replies[2]), Command)


CHATTY = Path(__file__).resolve().parents[2] / "support" / "navigators" / "chatty_nav.py"


def test_chatty_stderr_costs_little_and_keeps_a_bounded_tail(no_leftover_process: list[int]) -> None:
    """200 KB of stderr per step: the run ends with its real outcome, within a small factor of a
    quiet navigator's wall time (stderr is read in blocks, not a byte per system call)."""
    from navstress.nav.external import STDERR_TAIL_BYTES
    from navstress.run.mission import run_mission
    from navstress.world import Mission, World, WorldSpec

    world = World.flat(WorldSpec(size_m=(20.0, 20.0)), mission=Mission((3.0, 3.0, 0.0), (15.0, 3.0), 1.0))
    results = {}
    for mode in ("quiet", "chatty", "quiet", "chatty"):  # twice each: the first run also warms up
        nav = ExternalNavigator([sys.executable, str(CHATTY), mode], step_budget_s=5.0)
        t0 = time.monotonic()
        try:
            r = run_mission(world, nav, run_seed=1, timeout_s=3.0)
            no_leftover_process.append(nav.last_pid)  # type: ignore[arg-type]
            assert len(nav._stderr) <= STDERR_TAIL_BYTES
            assert (len(nav._stderr) > 0) == (mode == "chatty")
        finally:
            nav.close()
        results[mode] = (r, time.monotonic() - t0)
    for mode in ("quiet", "chatty"):
        r = results[mode][0]
        assert r.classification.outcome.value == "fail-timeout", r.classification.reason  # drove, never arrived
    # generous (a loaded machine), and with a floor: a quiet run may take only a tenth of a second
    assert results["chatty"][1] < 5.0 * max(results["quiet"][1], 0.2), results


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
@pytest.mark.parametrize(("mode", "dies"), [("setsid-child", False), ("setsid-child-pdeathsig", True)])
def test_what_a_group_kill_reaches_as_documented(mode: str, dies: bool, tmp_path: Path,
                                                no_leftover_process: list[int]) -> None:
    """docs/plugins.md: a helper that leaves the process group (setsid) survives the run unless it
    uses PR_SET_PDEATHSIG, as recommended."""
    import os
    import signal

    pid_file = tmp_path / "helper.pid"
    nav = ExternalNavigator([sys.executable, str(MISBEHAVING), mode], step_budget_s=1.0,
                            env={"HELPER_PID_FILE": str(pid_file)})
    out, _ = run_one_step(nav, no_leftover_process)
    nav.close()
    assert isinstance(out, Status) and "no answer within" in out.message
    pid = int(pid_file.read_text())
    try:
        deadline = time.monotonic() + 3.0
        while _alive(pid) and time.monotonic() < deadline:
            time.sleep(0.02)
        assert _alive(pid) is not dies
    finally:
        if _alive(pid):
            os.kill(pid, signal.SIGKILL)  # the escaped helper this test started
