"""A Ray cluster the user started (docs/campaigns.md, "A Ray cluster of your own"), joined with
``--ray-address``: the documented commands run as written against a real head on 127.0.0.1
(its own temporary directory, a free port, token authentication), and addresses that cannot be
joined fail within seconds with Ray's reason in one line (Ray alone retries them for minutes,
in silence).

Everything starts at once, in the module's one fixture, to keep the wall time small: the
family of bad addresses (which needs no head) runs while the head starts; then the documented
campaign and the driver without the token run side by side on the head. About a minute in all
on a 2-core machine that other work keeps busy. Everything listens and talks on 127.0.0.1 only
(a script that imported ray before navstress is sent by Ray to the machine's outside address, so
that case is not run here: its message is covered by a unit test), and the name that does not resolve is looked up in a network namespace that has only loopback.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.support import loopback
from navstress._paths import cache_dir
from navstress.campaign.store import OUTCOMES, Store

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "campaigns.md"
BIN = Path(sys.executable).parent
#: Failing to join takes a few seconds (3-10 s on an idle 2-core machine: Ray waits 5 s for a
#: server that does not speak gRPC; what fails at once is the process's imports); Ray alone
#: retried for 13 minutes or more. The bound leaves room for a machine loaded five times over.
FAIL_WITHIN_S = 60.0

CAMPAIGN = {"name": "tiny", "seed": 5, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
            "experiments": [{"name": "flat", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
            "maps_per_config": 1, "runs_per_map": 1, "navigators": [{"name": "reference-v1"}], "timeout_s": 3.0}
SEARCH = {"name": "tiny-random", "seed": 3, "world": {"size_m": [14.0, 14.0], "cell_m": 0.5},
          "space": {"parameters": [{"path": "obstacles.obstruction.tree", "low": 5, "high": 30}]},
          "navigator": {"name": "reference-v1", "config": {}}, "faults": [None], "objective": {"name": "failure"},
          "timeout_s": 5.0, "budget": {"runs": 2}, "runs_per_candidate": 1,
          "algorithm": {"name": "random", "batch": 2}, "confirm_runs": 1, "elites": 1}

#: Runs CLI invocations (JSON argv lists) one after another in one interpreter (navstress imported
#: once) and times each: exit code, stdout, stderr, seconds.
_CLI_SERIES = r"""
import json, sys, time
from typer.testing import CliRunner
from navstress.cli import app
import navstress.campaign.executors, navstress.search.algorithms  # imported before the clocks start
out = []
for argv in json.loads(sys.argv[1]):
    t = time.monotonic()
    r = CliRunner().invoke(app, argv)
    exc = None if r.exception is None or isinstance(r.exception, SystemExit) else repr(r.exception)
    out.append({"argv": argv, "code": r.exit_code, "stdout": r.stdout, "stderr": r.stderr,
                "s": time.monotonic() - t, "exception": exc})
print(json.dumps(out))
"""
def documented() -> list[str]:
    """The command lines of the docs' block that starts a head, comments taken off."""
    blocks = re.findall(r"```sh\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)
    block = [b for b in blocks if "ray start --head" in b]
    assert len(block) == 1, "docs/campaigns.md: one ```sh block that starts a head"
    return [re.sub(r"\s+#.*$", "", ln).strip() for ln in block[0].splitlines() if ln.strip()]


def _clean_env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}
    env.update(extra)
    return env


def _listen(talk: bool) -> tuple[socket.socket, int]:
    """A TCP server on 127.0.0.1 that is not Ray: silent (never accepts), or one that answers
    every connection with an HTTP/1.0 reply and closes it."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen(16)
    if talk:
        def serve() -> None:
            while True:
                try:
                    c, _ = s.accept()
                except OSError:
                    return
                with c:
                    c.sendall(b"HTTP/1.0 400 Bad Request\r\n\r\nnot ray\r\n")
        threading.Thread(target=serve, daemon=True).start()
    return s, int(s.getsockname()[1])


def _series(argvs: list[list[str]], env: dict[str, str], netns: bool = False) -> subprocess.Popen[str]:
    argv = [sys.executable, "-c", _CLI_SERIES, json.dumps(argvs)]
    return subprocess.Popen(loopback.loopback_only(argv) if netns else argv, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def _results(p: subprocess.Popen[str], timeout: float = 150) -> list[dict[str, Any]]:
    out, err = p.communicate(timeout=timeout)
    assert p.returncode == 0, err[-3000:]
    got: list[dict[str, Any]] = json.loads(out.strip().splitlines()[-1])
    return got


def _run(argv: list[str], out: Path, address: str, spec_of: dict[str, Path]) -> list[str]:
    """``campaign run`` or ``search run`` of the tiny specs into ``out``, on ``address``."""
    return [*argv, str(spec_of[argv[0]]), "-o", str(out), "--executor", "ray", "--ray-address", address, "-q"]


@dataclass
class Results:
    """What the module's fixture ran (each test checks its part)."""
    root: Path
    port: int = 0
    head_log: str = ""
    head_sockets: list[tuple[str, str, str]] = field(default_factory=list)
    ss_lines: list[str] = field(default_factory=list)
    documented: subprocess.CompletedProcess[str] | None = None
    out: Path | None = None
    family: list[tuple[str, dict[str, Any]]] = field(default_factory=list)  # (what its line says, result)
    no_token: list[dict[str, Any]] = field(default_factory=list)
    head_alive: bool = False
    token: str = ""  # ~/.ray/auth_token after `ray get-auth-token --generate`
    printed: str = ""  # what `ray get-auth-token` printed then
    clock: list[tuple[str, float]] = field(default_factory=list)  # (command, seconds since the first began)


def _stop(head: subprocess.Popen[bytes]) -> None:
    """End the head (its ``--block`` process and every process below it) by their ids: never
    ``ray stop``, which stops every Ray instance of this user on the machine (the suite's own)."""
    pids = loopback.descendants(head.pid) - {head.pid}
    head.send_signal(signal.SIGTERM)  # Ray's --block: stops the processes it started
    try:
        head.wait(timeout=20)
    except subprocess.TimeoutExpired:
        head.kill()
        head.wait()
    for pid in pids:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Results]:
    pytest.importorskip("ray", reason="ray is not installed (pip extra 'ray'; the 'test' extra installs it)")
    root = tmp_path_factory.mktemp("ray-external")
    res = Results(root)
    specs = {"campaign": root / "campaign.yaml", "search": root / "search.yaml"}
    specs["campaign"].write_text(yaml.safe_dump(CAMPAIGN, sort_keys=False), encoding="utf-8")
    specs["search"].write_text(yaml.safe_dump(SEARCH, sort_keys=False), encoding="utf-8")

    # 1. the bad addresses, while the head starts: nothing answers, a server that is not Ray,
    # not HOST:PORT; for both commands that take --ray-address
    closed = loopback.free_port()
    silent, silent_port = _listen(talk=False)
    talker, talker_port = _listen(talk=True)
    refused, grpc, form = "nothing answers at", "Ray: Failed to connect to GCS at address", "is not HOST:PORT"
    bad = {"campaign": [(f"127.0.0.1:{closed}", refused), (f"localhost:{closed}", refused), (f"[::1]:{closed}", refused),
                        (f"127.0.0.1:{silent_port}", grpc), (f"127.0.0.1:{talker_port}", grpc), ("127.0.0.1", form),
                        ("127.0.0.1:0", form), ("127.0.0.1:65536", form), (":6379", form)],
           "search": [(f"127.0.0.1:{closed}", refused), (f"127.0.0.1:{silent_port}", grpc), ("127.0.0.1", form)]}
    procs: list[subprocess.Popen[str]] = []  # every process started here: none outlives the fixture
    family: list[tuple[list[str], subprocess.Popen[str]]] = []
    runs = [(_run([c, "run"], root / f"bad-{c}-{i}", a, specs), n) for c, cases in bad.items()
            for i, (a, n) in enumerate(cases)]
    family.append(([n for _r, n in runs], _series([r for r, _n in runs], _clean_env())))
    if loopback.available():  # a name that does not resolve, looked up where nothing leaves the machine
        family.append(([f"{refused} no-such-head.invalid:6379"] * 2,
                       _series([_run([c, "run"], root / f"bad-{c}-name", "no-such-head.invalid:6379", specs)
                                for c in ("campaign", "search")], _clean_env(), netns=True)))
    procs += [p for _n, p in family]

    # 2. the documented commands: a token, the head (its own temp dir and a free port; --block so
    # that the test can end it alone), the campaign
    lines = documented()
    home = root / "home"
    home.mkdir()
    temp = Path(tempfile.mkdtemp(prefix="nsray-", dir="/tmp"))  # short: Ray's socket paths are bounded
    res.port = loopback.free_port()
    env = _clean_env(HOME=str(home), NAVSTRESS_CACHE_DIR=str(cache_dir()), PATH=f"{BIN}{os.pathsep}{os.environ['PATH']}")
    head = None
    log = open(root / "head.log", "w+b")  # the head's output (closed below)
    try:
        t0 = time.monotonic()
        for line in lines:
            res.clock.append((line.split()[0], time.monotonic() - t0))
            line = line.replace("6379", str(res.port)).replace("demo.yaml", str(specs["campaign"])) \
                       .replace("demo-campaign", str(root / "documented"))
            if line.startswith("export "):
                for kv in line.split()[1:]:
                    k, v = kv.split("=", 1)
                    env[k] = v
            elif " ray start --head" in f" {line}":
                head = subprocess.Popen(["bash", "-c", f"exec env {line} --temp-dir={temp} --num-cpus=1 "
                                         "--disable-usage-stats --block"], env=env, stdout=log, stderr=subprocess.STDOUT,
                                        stdin=subprocess.DEVNULL, start_new_session=True)
                deadline = time.monotonic() + 120
                while b"Ray runtime started" not in (root / "head.log").read_bytes():
                    assert head.poll() is None and time.monotonic() < deadline, (root / "head.log").read_text()[-3000:]
                    time.sleep(0.2)
            elif line.startswith("navstress "):
                assert head is not None
                campaign = subprocess.Popen(["bash", "-c", line], env=env, text=True, stdout=subprocess.PIPE,
                                            stderr=subprocess.PIPE)
                procs.append(campaign)
                res.out = root / "documented"
                # beside it, on the same head: a driver without RAY_AUTH_MODE=token, a Ray port that is
                # not the GCS
                res.head_sockets = loopback.sockets_of_tree(head.pid)
                raylet = next(int(s[2].rsplit(":", 1)[1]) for s in res.head_sockets if s[0] == "raylet" and s[1].startswith("tcp"))
                no_token = {k: v for k, v in env.items() if k != "RAY_AUTH_MODE"}
                nt = _series([_run(["campaign", "run"], root / "nt-c", f"127.0.0.1:{res.port}", specs),
                              _run(["search", "run"], root / "nt-s", f"127.0.0.1:{res.port}", specs),
                              _run(["campaign", "run"], root / "nt-r", f"127.0.0.1:{raylet}", specs)], no_token)
                procs.append(nt)
                res.no_token = _results(nt)
                o, e = campaign.communicate(timeout=150)
                res.documented = subprocess.CompletedProcess(line, campaign.returncode, o, e)
                # the head's sockets again, its Ray worker among them now (ss: TCP; /proc: UDP too)
                res.head_sockets = sorted(set(res.head_sockets) | set(loopback.sockets_of_tree(head.pid)))
                if shutil.which("ss"):
                    ss = subprocess.run(["ss", "-ltnpH"], capture_output=True, text=True, check=True).stdout
                    tree = loopback.descendants(head.pid)
                    res.ss_lines = [ln for ln in ss.splitlines()
                                    if any(int(p) in tree for p in re.findall(r"pid=(\d+)", ln))]
            elif line == "ray stop":
                pass  # stops every Ray instance of this user on the machine: the head is ended below
            else:  # ray get-auth-token --generate; then, beside the head, what prints the token again
                subprocess.run(["bash", "-c", line], env=env, check=True, capture_output=True, timeout=120)
                printed = subprocess.Popen([str(BIN / "ray"), "get-auth-token"], env=env, text=True, stdout=subprocess.PIPE,
                                           stderr=subprocess.PIPE)
                procs.append(printed)
        assert head is not None and res.documented is not None, lines
        res.token = (home / ".ray" / "auth_token").read_text(encoding="utf-8")
        res.printed = printed.communicate(timeout=150)[0]
        res.head_alive = head.poll() is None
        res.family = [(n, r) for needles, p in family for n, r in zip(needles, _results(p), strict=True)]
        (root / "results.json").write_text(json.dumps({"family": res.family, "no_token": res.no_token,
                                                        "clock": res.clock}, indent=1))
    finally:
        if head is not None:
            _stop(head)
            res.head_log = (root / "head.log").read_text(errors="replace")
        log.close()
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.communicate()
        silent.close()
        talker.close()
        shutil.rmtree(temp, ignore_errors=True)
    yield res


def test_the_documented_commands_are_the_ones_run() -> None:
    """The block the tests run: a token, token mode, a loopback-only head, a campaign on it, ray stop."""
    lines = documented()
    assert lines[0] == "ray get-auth-token --generate"
    assert lines[1] == "export RAY_AUTH_MODE=token"
    assert lines[2].startswith("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0 ray start --head --node-ip-address=127.0.0.1 "
                               "--port=6379")
    assert lines[3] == "navstress campaign run demo.yaml -o demo-campaign --executor ray --ray-address 127.0.0.1:6379"
    assert lines[4] == "ray stop"


def test_a_campaign_runs_on_a_loopback_only_head_with_a_token(results: Results) -> None:
    """The documented commands as written (the port, spec and directory chosen here): the
    campaign is recorded on the head's Ray workers, the head used token authentication, and
    every socket of the head's processes is on 127.0.0.1 (ss -ltnp, and /proc for UDP too)."""
    done = results.documented
    assert done is not None and results.out is not None
    assert done.returncode == 0, (done.stdout, done.stderr)
    assert "1/1 runs recorded" in done.stdout, done.stdout
    with Store.open(results.out) as s:
        recs = s.records()
    assert len(recs) == 1 and recs[0].outcome in OUTCOMES and recs[0].outcome != "fail-other", recs
    assert recs[0].trace and (results.out / recs[0].trace).is_file()
    assert len(results.token) >= 16 and results.printed.strip() == results.token.strip()
    assert results.head_alive, results.head_log[-3000:]
    assert "Token authentication is disabled" not in results.head_log, results.head_log[-3000:]
    names = {s[0] for s in results.head_sockets}
    assert {"gcs_server", "raylet"} <= names, results.head_sockets
    assert ("gcs_server", "tcp6", f"[::ffff:127.0.0.1]:{results.port}") in results.head_sockets or \
        ("gcs_server", "tcp", f"127.0.0.1:{results.port}") in results.head_sockets, results.head_sockets
    outside = [s for s in results.head_sockets if not loopback.is_loopback(s[2])]
    assert not outside, outside
    if shutil.which("ss"):
        assert results.ss_lines and any(f":{results.port} " in ln for ln in results.ss_lines), results.ss_lines
        assert all(loopback.is_loopback(ln.split()[3]) for ln in results.ss_lines), results.ss_lines


def _one_line_within_seconds(r: dict[str, Any], needle: str) -> None:
    assert r["exception"] is None, r
    assert r["code"] == 2, r
    lines = [ln for ln in r["stderr"].splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: --ray-address="), r
    assert needle in lines[0], (needle, r)
    assert r["s"] < FAIL_WITHIN_S, r
    out = Path(r["argv"][r["argv"].index("-o") + 1])
    assert not out.exists(), f"{out} written by a run that could not join a cluster"


def test_addresses_that_cannot_be_joined_fail_in_one_line_within_seconds(results: Results) -> None:
    """Nothing answers (refused: at once), something that is not Ray answers (Ray's own reason:
    it does not speak gRPC, after Ray's 5 s), not HOST:PORT, a name that does not resolve: one
    line naming --ray-address and the reason, exit 2, nothing written, well within seconds, from
    `campaign run` and `search run` alike."""
    assert len(results.family) >= 12, results.family
    for needle, r in results.family:
        _one_line_within_seconds(r, needle)


def test_a_driver_without_the_token_or_at_another_ray_port_fails_in_one_line(results: Results) -> None:
    """On the running head: without RAY_AUTH_MODE=token (both commands), one line that says what
    to export; at the raylet's port (gRPC, but not the GCS), Ray's reason."""
    c, s, raylet = results.no_token
    for r in (c, s):
        _one_line_within_seconds(r, "Unauthenticated")
        assert "export RAY_AUTH_MODE=token" in r["stderr"], r
    _one_line_within_seconds(raylet, "Ray: Failed to get cluster ID from GCS server")


