"""``navstress run --live``: a real run served on a real Foxglove WebSocket server (foxglove-sdk)
on 127.0.0.1, watched by a real WebSocket client speaking Foxglove's protocol
(subprotocol ``foxglove.sdk.v1``, the one the SDK's server speaks): what it receives is the run, as it goes, and the run's trace is the
same as without ``--live``."""

from __future__ import annotations

import json
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from tests.support import loopback
import pytest

from tests.support.cli_run import cli
from navstress.run.live import _topics
from navstress.run.trace import TOPIC_MAP, read_debug, read_events, read_grid, read_poses

pytestmark = pytest.mark.slow
NAVSTRESS = [sys.executable, "-m", "navstress.cli"]
SPEED = 4.0
TOPICS = _topics()


def _classes() -> dict[str, Any]:
    """Protobuf classes by schema name (what a client does with the advertised schemas)."""
    import importlib
    import pkgutil

    import foxglove_schemas_protobuf as fsp

    from navstress.run.trace import command_class

    out: dict[str, Any] = {"navstress.VelocityCommand": command_class()}
    for mod in pkgutil.iter_modules(fsp.__path__):
        m = importlib.import_module(f"foxglove_schemas_protobuf.{mod.name}")
        name = mod.name.removesuffix("_pb2")
        if hasattr(m, name):
            out[f"foxglove.{name}"] = getattr(m, name)
    return out


def _watch(url: str, proc: subprocess.Popen[str]) -> tuple[dict[str, list[tuple[int, Any]]], list[str], float]:
    """Connect as Foxglove does, subscribe to every channel as it is advertised, and collect the
    decoded messages per topic until the server goes away; also the listening addresses seen
    and the wall time from the first subscription to the end."""
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    from tests.support.loopback import listening_addresses

    deadline = time.monotonic() + 120
    while True:  # the server starts when the run's process is up
        try:
            ws = connect(url, subprotocols=["foxglove.sdk.v1"], open_timeout=10, max_size=None)
            break
        except OSError:
            if time.monotonic() > deadline or proc.poll() is not None:
                raise
            time.sleep(0.2)
    listening = listening_addresses()
    classes = _classes()
    channels: dict[int, tuple[str, str]] = {}
    subs: dict[int, int] = {}
    got: dict[str, list[tuple[int, Any]]] = {}
    t0 = None
    with ws:
        while True:
            try:
                raw = ws.recv(timeout=120)
            except (ConnectionClosed, TimeoutError):
                break
            if isinstance(raw, str):
                msg = json.loads(raw)
                # the server refused nothing (foxglove-sdk's "Unknown channel ID" for a channel
                # advertised while we were connected: the run's channels exist before its server)
                assert msg["op"] != "status", msg
                if msg["op"] == "advertise":
                    for ch in msg["channels"]:
                        assert ch["encoding"] == "protobuf"
                        channels[ch["id"]] = (ch["topic"], ch["schemaName"])
                    if not subs and len(channels) == len(TOPICS):
                        # every channel known (the run advertises them all before it starts): one
                        # request for all, so that the run, which starts at the first
                        # subscription, finds them all subscribed
                        subs.update((i + 1, cid) for i, cid in enumerate(channels))
                        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                            {"id": sid, "channelId": cid} for sid, cid in subs.items()]}))
                        t0 = time.monotonic()
                continue
            assert raw[0] == 0x01  # MessageData: subscription id (u32), log time (u64), payload
            sid, log_time = struct.unpack_from("<IQ", raw, 1)
            topic, schema = channels[subs[sid]]
            got.setdefault(topic, []).append((log_time, classes[schema].FromString(raw[13:])))
    return got, listening, time.monotonic() - (t0 or time.monotonic())


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from navstress.world import generate, parse_spec

    w = generate(parse_spec({"size_m": [30, 30], "obstacles": {"obstruction": {"tree": 2}},
                             "ground": {"subdivisions": 3, "deformation": 0.4},
                             "movers": {"count": {"pedestrian": 1}}}), 11)
    d = tmp_path_factory.mktemp("live") / "w"
    w.save(d)
    return d


def test_a_live_run_is_watched_as_it_goes_and_is_the_same_run(world: Path, tmp_path: Path) -> None:
    port = loopback.free_port()
    out = tmp_path / "live"
    proc = subprocess.Popen([*NAVSTRESS, "run", str(world), "-o", str(out), "--timeout", "20", "--seed", "4",
                             "--live", "--live-port", str(port), "--live-wait", "120", "--speed", str(SPEED)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        got, listening, wall = _watch(f"ws://127.0.0.1:{port}", proc)
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        proc.kill()
    assert proc.returncode == 0, stderr
    assert f"ws://127.0.0.1:{port}" in stdout
    assert "live:" not in stderr, stderr  # the server had nothing to say about its client
    # the server listened on loopback only
    mine = [a for a in listening if a.endswith(f":{port}")]
    assert mine and all(a.startswith("127.0.0.1:") for a in mine), listening
    (rec,) = [json.loads(x) for x in (out / "runs.jsonl").read_text().splitlines()]
    trace = rec["trace"]
    # the same run as without --live (which it records with --navigator-view): the same trace bytes
    plain = tmp_path / "plain"
    r = subprocess.run([*NAVSTRESS, "run", str(world), "-o", str(plain), "--timeout", "20", "--seed", "4",
                        "--navigator-view"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert Path(trace).read_bytes() == (plain / "run-000.mcap").read_bytes()
    # paced: the run took at least its simulated time / speed on the wall clock
    assert wall >= rec["duration_s"] / SPEED * 0.95, (wall, rec["duration_s"])
    # the world and the robot came first, and the run step by step
    for topic in ("/world/scene", "/world/terrain_mesh", "/world/terrain", "/robot/body", "/world/movers",
                  "/nav/cmd", "/nav/debug", "/nav/map", "/lidar", "/events", "/truth/pose", "/perceived/pose"):
        assert topic in got, (topic, sorted(got))
    truth = read_poses(trace)
    live = np.array([[lt / 1e9, m.pose.position.x, m.pose.position.y] for lt, m in got["/truth/pose"]])
    assert len(live) >= 0.9 * rec["duration_s"] * 10 and (np.diff(live[:, 0]) > 0).all()
    # each live pose lies on the recorded trajectory at its time
    for t, x, y in live[:: max(1, len(live) // 20)]:
        assert np.interp(t, truth[:, 0], truth[:, 1]) == pytest.approx(x, abs=0.05)
        assert np.interp(t, truth[:, 0], truth[:, 2]) == pytest.approx(y, abs=0.05)
    tf = [m for _, m in got["/tf"]]
    assert {(m.parent_frame_id, m.child_frame_id) for m in tf} >= {
        ("map", "base_link"), ("map", "perceived/base_link"), ("base_link", "lidar")}
    # the navigator's drawings: the trace's, one by one
    drawn = read_debug(trace)
    assert [lt / 1e9 for lt, _ in got["/nav/debug"]] == pytest.approx([t for t, _ in drawn])
    assert sum(len(e.lines) for _, m in got["/nav/debug"] for e in m.entities) == sum(len(d.lines) for _, d in drawn)
    # the events, ending with the outcome; the final map last
    assert [m.message for _, m in got["/events"]] == [e.message for e in read_events(trace)]
    assert got["/events"][-1][1].message.startswith("end of run: ")
    final = read_grid(trace, TOPIC_MAP)
    assert final is not None
    assert np.frombuffer(got["/nav/map"][-1][1].data, "<f4").tobytes() == final[0].astype("<f4").tobytes()
    clouds = [m for _, m in got["/lidar"]]
    assert all(c.frame_id == "lidar" and len(c.data) > 12 * 1000 for c in clouds)
    assert 0.8 * rec["duration_s"] / 0.5 <= len(clouds) <= rec["duration_s"] / 0.5 + 2


@pytest.mark.parametrize("args,needle", [
    (("--speed", "0"), "--speed='0' is invalid"),
    (("--speed", "nan"), "--speed='nan' is invalid"),
    (("--live-port", "0"), "--live-port='0' is invalid"),
    (("--live-port", "70000"), "--live-port='70000' is invalid"),
    (("--live-port", "http"), "--live-port='http' is invalid"),
    (("--live-wait", "-1"), "--live-wait='-1' is invalid"),
    (("--live-host", "no such host.invalid"), "--live-host='no such host.invalid' is invalid"),
    (("--live-port", "BUSY"), "is invalid: expected a free port on 127.0.0.1"),
])
def test_bad_live_input_is_one_line_and_writes_nothing(world: Path, tmp_path: Path, args: tuple[str, ...],
                                                       needle: str) -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        argv = [a.replace("BUSY", str(busy.getsockname()[1])) for a in args]
        needle = needle.replace("BUSY", str(busy.getsockname()[1]))
        code, _out, err = cli("run", str(world), "--live", *argv, "-o", str(tmp_path / "out"))
    assert code == 2, err
    assert needle in err and err.strip().count("\n") == 0, err
    assert not (tmp_path / "out").exists()


def test_garbage_from_clients_reaches_stderr_escaped_bounded_and_counted(world: Path, tmp_path: Path) -> None:
    """``navstress run --live`` (its server in the run's worker process) while clients send escape
    sequences and a flood of bad connections: stderr holds only the ``live:`` lines of
    navstress.run.live.ClientLog, escaped, bounded and counted; the run itself ends as usual."""
    from tests.support.live_garbage import UNSAFE, attack

    from navstress.run.live import LOG_BURST, LOG_LINE_CHARS

    port = loopback.free_port()
    out = tmp_path / "live"
    proc = subprocess.Popen([*NAVSTRESS, "run", str(world), "-o", str(out), "--timeout", "2", "--live",
                             "--live-port", str(port), "--live-wait", "4", "--speed", "100"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        attack(port, 40)  # during the wait for a subscriber: nobody subscribes, the run starts anyway
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        proc.kill()
    assert proc.returncode == 0, stderr
    lines = stderr.splitlines()
    assert lines and all(ln.startswith("live: ") for ln in lines), lines
    assert all(not UNSAFE.search(ln) and len(ln) <= LOG_LINE_CHARS for ln in lines), lines
    assert len([ln for ln in lines if "not shown" not in ln]) <= LOG_BURST, lines
    assert any("\\x1b[2J" in ln for ln in lines) and "not shown" in lines[-1], lines
