"""What a hostile WebSocket client sends a live view's server (tests of navstress.run.live's
client log: tests/unit/run/test_live_client_log.py, tests/integration/test_live.py)."""

from __future__ import annotations

import json
import re
import socket
import time

#: What no line may hold: escape, other controls (the line's own end aside), DEL, C1 controls,
#: bidirectional overrides and isolates, zero widths, line and paragraph separators.
UNSAFE = re.compile("[\x00-\x09\x0b-\x1f\x7f-\x9f\u200b-\u200f\u2028-\u202e\u2066-\u2069\ufeff]")
EVIL = "\x1b[2J\x1b[31mEVIL\x07\r\nline two\u202egnp.exe\x00\x9b31m"


def connect(port: int) -> object:
    """A Foxglove client's connection to the server on ``port`` (it may still be starting)."""
    from websockets.sync.client import connect as ws_connect

    deadline = time.monotonic() + 20
    while True:
        try:
            return ws_connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"], max_size=None,
                           open_timeout=5)
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)


def attack(port: int, connections: int) -> None:
    """A client speaking garbage, then ``connections`` raw sockets failing the handshake."""
    with connect(port) as ws:  # type: ignore[attr-defined]
        ws.send(json.dumps({"op": EVIL}))  # the SDK echoes an unknown op back in its log line
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": EVIL, "channelId": 1}]}))
        ws.send(json.dumps({"op": "x" * 1_000_000}))  # a huge frame
        ws.send(b"\x1b[31m" + bytes(range(256)) * 64)  # binary garbage
        ws.send(EVIL)  # not even JSON
        time.sleep(0.3)
    for _ in range(connections):
        try:
            s = socket.create_connection(("127.0.0.1", port), timeout=5)
        except ConnectionRefusedError:  # the server closed (its run started): the lines so far are the test's
            return
        with s:
            s.sendall(b"GET /\x1b[31mRED HTTP/1.1\r\nHost: \x07\r\n\r\n")
