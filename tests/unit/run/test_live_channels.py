"""The live view's channels exist before its server accepts a client, and a client's subscriptions
have all landed when the run starts: a real foxglove-sdk server (``LivePublisher``, port 0), a real
simulation, a real WebSocket client speaking Foxglove's protocol (subprotocol ``foxglove.sdk.v1``).

Why: foxglove-sdk (0.30.3) sends the advertisement of a channel made while a client is connected
BEFORE it records the channel as advertised to that client; a client that subscribes as soon as it
learns of a channel (the Foxglove app for its panels' topics, the integration test's watcher) can
be refused ("Unknown channel ID") and then never gets that topic. That was the flaky
``test_a_live_run_is_watched_as_it_goes_and_is_the_same_run`` (no ``/nav/cmd``, the last channel
made, at all). A channel made before the server starts is advertised to each client before the
server reads the client's first request, so it cannot be refused."""

from __future__ import annotations

import json
from typing import Any

import pytest

from navstress.robot import RobotSpec, profile
from navstress.robot.files import with_sensors
from navstress.run.live import LivePublisher, LiveSettings, _topics
from navstress.run.trace import SensorRecorder, sensor_topics
from tests.support.world_fixtures import small_world

LASER = {"name": "front_laser", "kind": "lidar2d", "profile": "ust10",
         "mount": {"xyz": [0.12, 0, 0.3], "rpy": [0, 0, 0]}}
CAM = {"name": "cam", "kind": "depth", "profile": "d435", "width": 32, "height": 24}

# no sensor list (the default lidar only), and both kinds of sensor that add topics
ROBOTS: dict[str, Any] = {
    "rmp400": lambda: RobotSpec(),
    "jackal+laser+cam": lambda: with_sensors(profile("jackal"), sensors=[LASER, CAM]),
}


def _expected(robot: RobotSpec) -> set[str]:
    """Every topic a live run of ``robot`` sends."""
    out = set(_topics())
    for sensor in SensorRecorder(robot.sensors or ()).sensors:
        out |= set(sensor_topics(sensor))
    return out


def _drain(ws: Any, quiet_s: float) -> list[dict[str, Any]]:
    """The JSON messages the server sends until it is quiet for ``quiet_s``."""
    out = []
    while True:
        try:
            raw = ws.recv(timeout=quiet_s)
        except TimeoutError:
            return out
        if isinstance(raw, str):
            out.append(json.loads(raw))


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_every_channel_is_advertised_before_a_client_can_connect_and_every_subscription_lands(name: str) -> None:
    pytest.importorskip("websockets")
    from websockets.sync.client import connect

    from navstress.sim.config import SimConfig
    from navstress.sim.simulation import Simulation

    robot = ROBOTS[name]()
    world = small_world(bumpy=False)
    sim = Simulation(world, robot, SimConfig(), seed=1)
    pub = LivePublisher(LiveSettings(port=0, wait_s=20.0, speed=50.0), robot)
    try:
        with connect(f"ws://127.0.0.1:{pub.port}", subprotocols=["foxglove.sdk.v1"], open_timeout=10,
                     max_size=None) as ws:
            first = _drain(ws, 0.5)
            advertised = {ch["id"]: ch["topic"] for m in first if m["op"] == "advertise" for ch in m["channels"]}
            # the whole run's channels, in the advertisements a client gets as it connects
            assert sorted(advertised.values()) == sorted(_expected(robot)), (name, first)
            # one request for them all (as a viewer's layout asks), before the run starts
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": i + 1, "channelId": cid} for i, cid in enumerate(advertised)]}))
            pub.start(world, robot, sim)
            # the run starts with every subscription in place: no message of its first step is lost
            assert [t for t, ch in sorted(pub._channels.items()) if not ch.has_sinks()] == []
            later = _drain(ws, 0.3)
        assert pub.late_topics == []
        # nothing refused (the SDK's "Unknown channel ID"), nothing advertised after the start
        assert [m for m in later if m["op"] in ("status", "advertise")] == [], later
    finally:
        pub.close()
