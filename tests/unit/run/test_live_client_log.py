"""What a WebSocket client sends never reaches standard error raw: the live view's server (a real
foxglove-sdk server in a child process, as ``navstress run --live`` and ``replay --live`` serve)
is sent ANSI escapes, control characters, a bidirectional override, a huge frame, binary garbage
and a flood of connections that fail the handshake, by a real client (websockets) and raw sockets;
its standard error holds only ``live:`` lines, each escaped and bounded, at most
:data:`~navstress.run.live.LOG_BURST` of them per window and one line counting the others."""

from __future__ import annotations

import io
import logging
import subprocess
import sys
import time

import pytest

from tests.support import loopback
from tests.support.live_garbage import UNSAFE, attack
from navstress.run.live import LOG_BURST, LOG_LINE_CHARS, SDK_LOGGER, ClientLog

SERVER = """
import sys
from navstress.run.live import LivePublisher, LiveSettings
p = LivePublisher(LiveSettings(port=int(sys.argv[1])))
print("up", flush=True)
sys.stdin.read()
p.close()
"""
@pytest.mark.slow
@pytest.mark.parametrize("connections", [0, 30])
def test_client_garbage_is_escaped_bounded_and_counted(connections: int) -> None:
    pytest.importorskip("websockets")
    port = loopback.free_port()
    p = subprocess.Popen([sys.executable, "-c", SERVER, str(port)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, encoding="utf-8", errors="surrogateescape")
    try:
        assert p.stdout is not None and p.stdout.readline().strip() == "up"
        attack(port, connections)
        time.sleep(0.5)
        _out, err = p.communicate("", timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 0, err[-2000:]
    lines = err.splitlines()
    assert lines, "the server logged nothing about the garbage: nothing tested"
    assert err.endswith("\n")
    for ln in lines:
        assert ln.startswith("live: "), repr(ln)
        assert not UNSAFE.search(ln), repr(ln)
        assert len(ln) <= LOG_LINE_CHARS, (len(ln), ln[:100])
    shown = [ln for ln in lines if "not shown" not in ln]
    counted = [ln for ln in lines if "not shown" in ln]
    assert len(shown) <= LOG_BURST and len(counted) <= 1, lines
    assert any("\\x1b[2J\\x1b[31mEVIL\\x07" in ln for ln in shown), lines  # what it sent, escaped
    if connections:
        assert counted and int(counted[0].split()[1]) >= connections, lines


def _record(msg: str) -> logging.LogRecord:
    return logging.LogRecord("foxglove.websocket", logging.ERROR, __file__, 1, msg, None, None)


def test_the_log_says_how_many_lines_it_held_back_each_window() -> None:
    out = io.StringIO()
    log = ClientLog(out, burst=2, window_s=0.3, width=60)
    for i in range(5):
        log.handle(_record(f"bad {i} \x1b[1m" + "y" * 100))
    time.sleep(0.35)
    log.handle(_record("next window"))
    log.flush_counts()
    lines = out.getvalue().splitlines()
    assert [ln[:11] for ln in lines[:2]] == ["live: bad 0", "live: bad 1"], lines
    assert "\\x1b[1m" in lines[0] and all(len(ln) <= 60 for ln in lines[:2]), lines
    assert lines[2].startswith("live: 3 more message(s) about clients not shown"), lines
    assert lines[3] == "live: next window" and len(lines) == 4, lines


def test_the_sdk_logger_is_given_back_as_it_was() -> None:
    log = logging.getLogger(SDK_LOGGER)
    before = (list(log.handlers), log.propagate, log.level)
    h = ClientLog(io.StringIO()).install()
    assert h in log.handlers and not log.propagate
    h.uninstall()
    assert (list(log.handlers), log.propagate, log.level) == before
