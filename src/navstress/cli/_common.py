"""What the command modules share: flag limits, flag parsers, the navigator-config flag, and
checks of output paths made before any work."""

from __future__ import annotations

import errno
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer

from navstress import _files
from navstress.campaign.registry import check_executor
from navstress.campaign.spec import MAX_WORKERS
from navstress.campaign.store import DiskFullError
from navstress._flags import bounded_int, integer, number
from navstress.errors import SpecError, WorldFileError
from navstress.nav.registry import load_config
from navstress.robot import PROFILES, RobotSpec
from navstress.run.robot import robot_of
from navstress.run.sensors import apply_sensor_flags, check_suite
from navstress.sensors import Sensor
from navstress.sensors.text import entries_from_flags
from navstress.seeding import MAX_SEED
from navstress.world.world import is_world_dir

__all__ = ["MAX_RUNS", "MAX_SEED", "MAX_TIMEOUT_S", "MAX_WALL_S", "MAX_WORKERS", "Stopped", "check_executor_flags", "NAV_CONFIG_HELP", "bounded_int",
           "check_file_out", "check_out_dir", "integer", "load_navigator_config", "number", "probe_writable",
           "LidarOpt", "LiveHostOpt", "LiveOpt", "LivePortOpt", "LiveWaitOpt", "NavigatorViewOpt", "SpeedOpt",
           "live_banner", "live_settings", "resumable", "RobotOpt", "load_robot_flag", "SensorOpt", "SensorAddOpt",
           "load_robot_flags"]

#: Longest simulated run (one day, as a campaign spec's timeout_s) and longest wall-clock limit.
MAX_TIMEOUT_S = 86_400.0
MAX_WALL_S = 30 * 86_400.0
#: Most runs one `navstress run` makes (a campaign is the tool for more).
MAX_RUNS = 10_000

NAV_CONFIG_HELP = ("Configuration passed to the navigator: a JSON/YAML file, or inline JSON/YAML text "
                   "such as '{\"command\": [\"./my_nav\"]}'.")


def load_navigator_config(raw: str | None) -> dict[str, Any]:
    """``--navigator-config``: a file path or inline JSON/YAML (SpecError naming the flag)."""
    if raw is None:
        return {}
    return dict(load_config(raw, field="--navigator-config"))


def check_out_dir(path: Path, flag: str = "--output") -> None:
    """A new path or an existing world directory (which will be replaced), else WorldFileError."""
    if path.exists() and not is_world_dir(path):
        raise WorldFileError(f"{flag}={str(path)!r} is invalid: expected a new path or an existing world "
                             "directory (it exists and is not a world); choose another path or remove it")


def check_file_out(dest: Path) -> None:
    """A file path, not a directory (SpecError naming --output)."""
    if dest.exists() and dest.is_dir():
        raise SpecError("--output", str(dest), "a file path (this is a directory)")


def probe_writable(dest: Path) -> None:
    """Fail now (OSError naming ``dest``) if a file cannot be created where ``dest`` will be
    written, before long work whose result would be lost; leaves nothing behind."""
    _files.probe_writable(dest)


class Stopped(BaseException):
    """SIGTERM received by a long command (``campaign run``, ``search``): a BaseException, like
    KeyboardInterrupt, so that no ``except Exception`` on the way swallows it."""

    def __init__(self, signum: int) -> None:
        super().__init__(f"signal {signum}")
        self.signum = signum


@contextmanager
def resumable(command: str, out: Path) -> Iterator[None]:
    """Around the work of a command that running it again resumes (``campaign run``, ``search``,
    ``demo``, writing into ``out``): a full disk's one line says to resume with ``command``, that
    command's own line."""
    try:
        yield
    except DiskFullError as err:
        raise err.resumed_with(command) from None
    except OSError as err:
        if err.errno not in (errno.ENOSPC, errno.EDQUOT):
            raise
        where = err.filename if err.filename is not None else out
        raise DiskFullError(str(where), " ".join(str(err.strerror or err).split()), command) from None


def check_executor_flags(executor: str, workers: int | None, wall_limit: float | None) -> None:
    """The flags of a command that runs a campaign's runs (``campaign run``, ``search``):
    ``--executor``, ``--workers`` and ``--wall-limit`` (SpecError naming the flag)."""
    check_executor(executor)
    if workers is not None and not 1 <= workers <= MAX_WORKERS:
        raise SpecError("--workers", workers, f"an integer in [1, {MAX_WORKERS}]")
    if wall_limit is not None and not 0 < wall_limit <= MAX_WALL_S:
        raise SpecError("--wall-limit", wall_limit, "seconds in (0, 2592000]")


# ---- the robot (world generate, world drive, run, nav check) --------------------------------------

RobotOpt = Annotated[str | None, typer.Option("--robot", metavar="NAME|FILE", help=(
    "The robot: a profile (" + ", ".join(sorted(PROFILES)) + ") or a robot file (YAML or JSON with an "
    "optional base profile and overrides, or a URDF/MJCF body: docs/robots.md). Default rmp400, the paper's "
    "Segway RMP 400."))]


def load_robot_flag(raw: str | None) -> RobotSpec:
    """``--robot``: a profile name or a robot file; a one-line SpecError naming ``--robot`` (with a
    "did you mean" for a misspelt profile) otherwise."""
    if raw is None:
        return PROFILES["rmp400"]
    if not raw.strip():
        raise SpecError("--robot", raw, "a robot profile (" + ", ".join(sorted(PROFILES)) + ") or a robot file")
    return robot_of(raw, field="--robot")


SENSOR_SYNTAX = ("NAME=KIND[:PROFILE][,KEY=VALUE...]: KIND lidar2d, lidar3d or depth; PROFILE one of the kind's "
                 "(lidar2d: ust10, tim571, rplidar_a2; lidar3d: hdl32, vlp16, os1_64; depth: d435); KEY a parameter of "
                 "the kind (max_range_m=30, fov_deg=180, beams=360, rate_hz=15, ...), mount=NAME (a mount of the robot) or "
                 "mount=X:Y:Z with rpy=R:P:Y (m, rad). Or a YAML/JSON file holding a list of sensor entries. docs/sensors.md.")
SensorOpt = Annotated[list[str] | None, typer.Option("--sensor", metavar="SENSOR", help=(
    "A sensor of the robot's suite, replacing the robot's own sensors (repeat it for several): " + SENSOR_SYNTAX
    + " Example: --sensor front_laser=lidar2d:ust10,max_range_m=30,mount=0.12:0:0.3. The same suite a campaign "
    "spec's sensors: gives."))]
SensorAddOpt = Annotated[list[str] | None, typer.Option("--sensor-add", metavar="SENSOR", help=(
    "A sensor added to the robot's suite (its own, or its default 32-channel lidar), repeatable: the same syntax "
    "as --sensor; a campaign spec's sensors_add:. Example: --sensor-add cam=depth:d435."))]


def load_robot_flags(raw: str | None, sensor: list[str] | None = None, sensor_add: list[str] | None = None,
                     sim: Any = None) -> RobotSpec:
    """``--robot`` with ``--sensor`` / ``--sensor-add`` applied (:func:`navstress.run.sensors.apply_sensor_flags`)
    and its suite checked for the simulation (``sim``: a SimConfig, default the default one): one line
    naming the flag for any bad sensor."""
    robot = load_robot_flag(raw)
    if not sensor and not sensor_add:
        check_suite(robot, sim, field_of=lambda s: f"--robot sensors.{s.name}.rate_hz")  # a robot file's sensors
        return robot
    robot = apply_sensor_flags(robot, sensor, sensor_add)
    added = {e.get("name") for e in entries_from_flags(sensor_add, flag="--sensor-add") or () if isinstance(e, dict)}

    def field_of(s: Sensor) -> str:
        flag = "--sensor-add" if s.name in added else "--sensor" if sensor else "--robot sensors."
        return f"{flag} {s.name}.rate_hz" if flag != "--robot sensors." else f"{flag}{s.name}.rate_hz"

    check_suite(robot, sim, field_of=field_of)
    return robot


# ---- what a run records and the live view (navstress run, navstress replay) -----------------------

LidarOpt = Annotated[bool, typer.Option("--lidar", help=(
    "Also record lidar point clouds in the traces (one full scan per simulated second, map frame)."))]
NavigatorViewOpt = Annotated[bool, typer.Option("--navigator-view", help=(
    "Also record the navigator's own view in the traces: what it draws after each step (reference-v1: "
    "its arcs, the elected one, its choice) on /nav/debug, and its map once per simulated second on "
    "/nav/map."))]
LiveOpt = Annotated[bool, typer.Option("--live", help=(
    "Watch each run in Foxglove as it happens: serve it on a Foxglove WebSocket (ws://HOST:PORT, "
    "127.0.0.1:8765 by default), start when a client subscribes, and run at --speed; implies "
    "--navigator-view (the trace is the same as without --live)."))]
LiveHostOpt = Annotated[str, typer.Option(metavar="HOST", help=(
    "Address the live view binds to. Default 127.0.0.1 (this machine only)."))]
LivePortOpt = Annotated[str, typer.Option(metavar="PORT", help="Port of the live view, in [1, 65535]. Default 8765.")]
LiveWaitOpt = Annotated[str, typer.Option(metavar="S", help=(
    "With --live: longest wait in seconds for a client before each run starts anyway, in [0, 3600]. "
    "Default 30."))]
SpeedOpt = Annotated[str, typer.Option(metavar="X", help=(
    "With --live: simulated seconds per real second, in (0, 1000]. Default 1 (real time)."))]


def live_settings(host: str, port: str, wait: str, speed: str) -> Any:
    """The live view's settings, checked: a one-line error for a bad value or a port in use."""
    from navstress.run.live import LiveSettings  # local: the live view imports the mission loop (MuJoCo, numba)

    port_v = bounded_int("--live-port", port, 1, 65535)
    wait_v = number("--live-wait", wait, "a duration in seconds in [0, 3600]")
    if not 0 <= wait_v <= 3600:
        raise SpecError("--live-wait", wait, "a duration in seconds in [0, 3600]")
    speed_v = number("--speed", speed, "simulated seconds per real second, in (0, 1000]")
    if not 0 < speed_v <= 1000:
        raise SpecError("--speed", speed, "simulated seconds per real second, in (0, 1000]")
    try:
        infos = socket.getaddrinfo(host, port_v, type=socket.SOCK_STREAM)
    except (OSError, UnicodeError):
        raise SpecError("--live-host", host, "an address of this machine, such as 127.0.0.1") from None
    family, _type, _proto, _name, addr = infos[0]
    with socket.socket(family, socket.SOCK_STREAM) as s:
        try:
            s.bind(addr)
        except OSError as err:
            raise SpecError("--live-port", port, f"a free port on {host} ({err.strerror or err})") from None
    return LiveSettings(host=host, port=port_v, speed=speed_v, wait_s=wait_v)


def live_banner(settings: Any) -> str:
    """How to watch a live run in Foxglove (printed by every command that serves one)."""
    return (f"live: in Foxglove, Open connection -> Foxglove WebSocket -> ws://{settings.host}:{settings.port}; "
            f"each run starts when a client subscribes (or after {settings.wait_s:g} s)")
