"""Conformance checker for navigators (in the spirit of Gymnasium's ``utils/env_checker.py``).

:func:`check_navigator` drives a navigator through a scripted sequence of synthetic
observations (no simulator: the robot drives straight on flat ground, a 32-channel lidar scan of
that ground is built analytically) and runs named checks:

``builds``            the factory returns an object with reset/step/close
``valid-types``       every answer is a Command with finite float v/omega or a Status
                      with kind "arrived"/"error" (an infrastructure error fails it)
``resets-cleanly``    reset twice on one instance with the same seed: identical answers
``deterministic``     a fresh instance, same seed, same observations: identical answers
                      (another seed may differ: reported, not judged)
``empty-scan``        a scan with no points and a cycle without scans or pose: no exception
``within-budget``     every step's wall time <= the budget (the first step of the first run is
                      a warm-up, reported but not judged: JIT compilation happens there)
``close-idempotent``  close() twice after a run, and twice on an instance never reset

A navigator that hangs *in-process* hangs the checker (a thread cannot be killed); wrap it in
an :class:`~navstress.nav.external.ExternalNavigator` to get a budget enforced.

    >>> report = check_navigator("straightline-v1")        # doctest: +SKIP
    >>> print(report_text(report)); report.passed          # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import io
import time
import traceback
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console, Group
from rich.table import Table
from rich.text import Text

from navstress.errors import NavstressError
from navstress.isolate import Worker
from navstress.isolate import report as report_to_parent
from navstress.nav.api import (
    Command,
    Imu,
    InvalidAnswer,
    LidarScan,
    NavMission,
    Navigator,
    Observation,
    Odometry,
    PoseReading,
    Status,
    check_answer,
    raised_by_navigator,
)
from navstress.nav.registry import (
    NavigatorNote,
    call_factory,
    load_config,
    load_factory,
    resolve,
)
from navstress.robot import RobotSpec
from navstress.sensors import Sensor, default_suite, kind
from navstress.sensors.kinds.depth import DepthImage
from navstress.sensors.kinds.lidar2d import LaserScan

__all__ = [
    "CHECK_NAMES", "CheckReport", "CheckResult", "check_navigator", "flat_ground_scan",
    "format_report", "report_text", "synthetic_observations",
]

CHECK_NAMES = ("builds", "valid-types", "resets-cleanly", "deterministic", "empty-scan",
               "within-budget", "close-idempotent")

Answer = tuple[str, Any, Any]  # ("command", v, omega) | ("status", kind, message)


@dataclass(frozen=True)
class CheckResult:
    """One named check: passed or not, and a line saying why."""

    name: str
    passed: bool
    detail: str


@dataclass
class CheckReport:
    """All checks of one navigator, plus the measured per-step wall times (seconds)."""

    navigator: str
    results: list[CheckResult]
    step_budget_s: float
    step_times_s: list[float] = field(default_factory=list)
    warmup_step_s: float | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return all(r.passed for r in self.results)

    def result(self, name: str) -> CheckResult:
        for r in self.results:
            if r.name == name:
                return r
        raise KeyError(name)

    def timing(self) -> dict[str, float]:
        """n, median, p95 and max of the judged step times (seconds)."""
        t = np.asarray(self.step_times_s, dtype=float)
        if t.size == 0:
            return {"n": 0.0}
        return {"n": float(t.size), "median": float(np.median(t)),
                "p95": float(np.percentile(t, 95)), "max": float(t.max())}

    def __str__(self) -> str:
        lines = [f"navigator {self.navigator}: {'PASS' if self.passed else 'FAIL'}"]
        lines += [f"  [{'pass' if r.passed else 'FAIL'}] {r.name}: {r.detail}" for r in self.results]
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)


# ---------------------------------------------------------------- synthetic observations


def flat_ground_scan(robot: RobotSpec, t: float, *, azimuth_steps: int = 360,
                     channels: int = 32, elev_min_deg: float = -30.7, elev_max_deg: float = 10.7,
                     max_range_m: float = 70.0) -> LidarScan:
    """The scan of an infinite flat ground, in the sensor frame, computed analytically.

    The sensor is ``robot.wheel_radius_m + robot.lidar.z_m`` above the ground (chassis origin at
    axle height, robot level). A channel at elevation e < 0 hits at horizontal distance
    ``h / tan(-e)``; rays going up or beyond ``max_range_m`` give no return and are omitted.
    """
    h = robot.wheel_radius_m + robot.lidar.z_m
    elev = np.radians(np.linspace(elev_min_deg, elev_max_deg, channels))
    elev = elev[elev < 0]
    elev = elev[h / np.sin(-elev) <= max_range_m]
    r = h / np.tan(-elev)
    az = np.arange(azimuth_steps) * (2.0 * np.pi / azimuth_steps)
    rr, aa = np.meshgrid(r, az, indexing="ij")
    pts = np.stack([rr * np.cos(aa), rr * np.sin(aa), np.full_like(rr, -h)], axis=-1)
    mount = (robot.lidar.x_m, robot.lidar.y_m, robot.lidar.z_m)
    return LidarScan(t, pts.reshape(-1, 3).astype(np.float32), mount)


CHECK_MISSION = NavMission(start=(0.0, 0.0, 0.0), goal=(20.0, 10.0), goal_tolerance_m=2.0)


def with_suite(robot: RobotSpec) -> RobotSpec:
    """``robot`` as a navigator gets it at reset: its sensors listed (its default suite when it
    lists none)."""
    return robot if robot.sensors is not None else robot.model_copy(update={"sensors": default_suite(robot.mounts)})


def _ground_ranges(robot: RobotSpec, sensor: Sensor, dirs: np.ndarray) -> np.ndarray:
    """Distance along each direction ``dirs`` (..., 3), in the sensor frame, to the flat ground
    from ``sensor``'s mount (chassis origin at axle height, robot level); ``inf``: no return
    (upwards, or outside the sensor's range limits). Measured in units of ``|dirs|``."""
    h = robot.wheel_radius_m + sensor.mount.xyz[2]
    dz = dirs @ sensor.mount.rotation()[2]  # the z of each direction in base_link
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(dz < 0, h / -np.where(dz < 0, dz, -1.0), np.inf)
    dist = t * np.linalg.norm(dirs, axis=-1)
    lo, hi = float(sensor.params.get("min_range_m", 0.0)), float(sensor.params.get("max_range_m", np.inf))
    return np.where((dist >= lo) & (dist <= hi) & (h > 0), t, np.inf)


def ground_reading(robot: RobotSpec, sensor: Sensor, t: float, *, empty: bool = False) -> Any:
    """The reading ``sensor`` takes of an infinite flat ground at time ``t``, computed analytically
    (``empty``: the same sensor seeing nothing: no point, every range and depth ``inf``)."""
    k = kind(sensor.kind)
    p = sensor.config()
    mount, rpy = tuple(float(v) for v in sensor.mount.xyz), tuple(float(v) for v in sensor.mount.rpy)
    if k.name == "lidar2d":
        _el, az = k.beams(p) if k.beams is not None else (None, np.zeros(0))
        dirs = np.stack([np.cos(az), np.sin(az), np.zeros_like(az)], axis=-1)
        r = np.full(len(az), np.inf) if empty else _ground_ranges(robot, sensor, dirs)
        return LaserScan(t, r.astype(np.float32), p.angle_min, p.angle_increment, p.min_range_m, p.max_range_m,
                         mount, rpy, sensor.name)  # type: ignore[arg-type]
    if k.name == "depth":
        dirs = k.rays(p) if k.rays is not None else np.zeros((0, 0, 3))
        d = np.full(dirs.shape[:2], np.inf) if empty else _ground_ranges(robot, sensor, dirs)
        fx, fy, cx, cy = p.intrinsics()
        return DepthImage(t, d.astype(np.float32), fx, fy, cx, cy, mount, rpy, sensor.name)  # type: ignore[arg-type]
    if k.beams is None:
        raise ValueError(f"no synthetic reading for the {k.name} sensor kind")
    el, az = k.beams(p)
    ee, aa = np.meshgrid(el, az, indexing="ij")
    dirs = np.stack([np.cos(ee) * np.cos(aa), np.cos(ee) * np.sin(aa), np.sin(ee)], axis=-1).reshape(-1, 3)
    r = _ground_ranges(robot, sensor, dirs)
    hit = np.isfinite(r)
    pts = dirs[hit] * r[hit][:, None] if not empty else np.zeros((0, 3))
    return LidarScan(t, pts.astype(np.float32), mount, sensor.name, rpy)  # type: ignore[arg-type]


def synthetic_observations(robot: RobotSpec, n_steps: int, *, dt: float = 0.1,
                           speed: float = 0.5, azimuth_steps: int = 360) -> list[Observation]:
    """A scripted drive straight along +x from the origin at ``speed`` on flat ground.

    Every cycle has a flat-ground reading of every sensor the robot carries (``readings``, by
    name: lidar3d clouds, lidar2d scans, depth images; its lidar3d clouds in ``scans`` too); the
    pose sensor reads every second cycle (``None`` otherwise, as a slower sensor would). A robot
    without its own suite gets the paper's lidar's scan of :func:`flat_ground_scan`, as before
    sensors were declared. Not closed-loop: the script ignores the commands.
    """
    suite = robot.sensors
    scan0 = flat_ground_scan(robot, 0.0, azimuth_steps=azimuth_steps) if suite is None else None
    firsts = {s.name: ground_reading(robot, s, 0.0) for s in suite or ()}
    out = []
    for k in range(1, n_steps + 1):
        t = k * dt
        x = speed * t
        pose = PoseReading(t, x, 0.0, 0.0, 0.0, 0.0, 0.0) if k % 2 == 0 else None
        odom, imu = Odometry(t, x, 0.0, 0.0, speed, 0.0), Imu(t, 0.0, 0.0, 0.0, (0.0, 0.0, 0.0))
        if scan0 is not None:
            scans: tuple[LidarScan, ...] = (LidarScan(t - 0.5 * dt, scan0.points, scan0.mount),)
            readings: dict[str, tuple[Any, ...]] = {"lidar": scans}
        else:
            readings = {n: (dataclasses.replace(r, t=t - 0.5 * dt),) for n, r in firsts.items()}
            scans = tuple(r[0] for r in readings.values() if isinstance(r[0], LidarScan))
        readings.update({"odom": (odom,), "imu": (imu,), **({"pose": (pose,)} if pose is not None else {})})
        out.append(Observation(t, odom, imu, pose, scans, readings))
    return out


def _empty_scan_observations(robot: RobotSpec, dt: float = 0.1) -> list[Observation]:
    empty = np.zeros((0, 3), dtype=np.float32)
    mount = (robot.lidar.x_m, robot.lidar.y_m, robot.lidar.z_m)

    def base(t: float) -> tuple[Odometry, Imu]:
        return Odometry(t, 0.0, 0.0, 0.0, 0.0, 0.0), Imu(t, 0.0, 0.0, 0.0, (0.0, 0.0, 0.0))

    def seen(t: float) -> tuple[tuple[LidarScan, ...], dict[str, tuple[Any, ...]]]:
        if robot.sensors is None:
            return (LidarScan(t, empty, mount),), {"lidar": (LidarScan(t, empty, mount),)}
        readings = {s.name: (ground_reading(robot, s, t, empty=True),) for s in robot.sensors}
        return tuple(r[0] for r in readings.values() if isinstance(r[0], LidarScan)), readings

    o1, i1 = base(dt)
    o2, i2 = base(2 * dt)
    o3, i3 = base(3 * dt)
    s1, r1 = seen(dt)
    s3, r3 = seen(3 * dt)
    p1 = PoseReading(dt, 0, 0, 0, 0, 0, 0)
    return [
        Observation(dt, o1, i1, p1, s1, {**r1, "odom": (o1,), "imu": (i1,), "pose": (p1,)}),
        Observation(2 * dt, o2, i2, None, (), {"odom": (o2,), "imu": (i2,)}),
        Observation(3 * dt, o3, i3, None, s3, {**r3, "odom": (o3,), "imu": (i3,)}),
    ]


# ---------------------------------------------------------------- running


class _Invalid(Exception):
    pass


def _normalise(out: object) -> Answer:
    """Validate one answer (:func:`~navstress.nav.api.check_answer`, as the run loop does);
    :class:`_Invalid` says what is wrong."""
    try:
        ans = check_answer(out)
    except InvalidAnswer as e:
        raise _Invalid(str(e)) from None
    if isinstance(ans, Command):
        return ("command", ans.v, ans.omega)
    if ans.infrastructure:
        raise _Invalid(f"infrastructure error: {ans.message}")
    return ("status", ans.kind, ans.message)


@dataclass
class _Run:
    answers: list[Answer]
    times: list[float]
    invalid: str | None = None


def _drive(nav: Navigator, robot: RobotSpec, seed: int, obs: list[Observation]) -> _Run:
    """reset + steps until a Status (the run would end there) or the script ends."""
    nav.reset(CHECK_MISSION, robot, seed=seed)
    run = _Run([], [])
    for k, o in enumerate(obs):
        t0 = time.perf_counter()
        out = nav.step(o)
        run.times.append(time.perf_counter() - t0)
        try:
            ans = _normalise(out)
        except _Invalid as e:
            if run.invalid is None:
                run.invalid = f"step {k}: {e}"
            ans = ("invalid", repr(out), None)
        run.answers.append(ans)
        if ans[0] != "command":
            break
    return run


def _reraise_unless_navigator(e: BaseException) -> None:
    """Re-raise ``e`` unless the navigator raised it (``sys.exit`` in a plug-in is a failed
    check, not the end of the checker; see :func:`~navstress.nav.api.raised_by_navigator`)."""
    if not raised_by_navigator(e):
        raise e


def _why(e: BaseException) -> str:
    frames = traceback.extract_tb(e.__traceback__)
    where = f" (at {Path(frames[-1].filename).name}:{frames[-1].lineno})" if frames else ""
    return f"raised {type(e).__name__}: {e}{where}"


def _first_difference(a: list[Answer], b: list[Answer]) -> str:
    for k, (x, y) in enumerate(zip(a, b)):
        if x != y:
            return f"step {k}: {_show(x)} vs {_show(y)}"
    return f"{len(a)} vs {len(b)} answers"


def _show(a: Answer) -> str:
    if a[0] == "command":
        return f"Command(v={a[1]!r}, omega={a[2]!r})"
    if a[0] == "status":
        return f"Status({a[1]!r}, {a[2]!r:.60})"
    return str(a[1])


def _safe_close(nav: Navigator | None) -> None:
    if nav is not None:
        try:
            nav.close()
        except BaseException as e:
            _reraise_unless_navigator(e)


def check_navigator(
    name_or_factory: str | Callable[..., Navigator],
    config: Mapping[str, Any] | str | Path | None = None,
    *,
    seed: int = 12345,
    n_steps: int = 30,
    step_budget_s: float = 0.5,
    robot: RobotSpec | None = None,
    azimuth_steps: int = 360,
    progress: Callable[[str, list[CheckResult]], None] | None = None,
) -> CheckReport:
    """Run every named check on a registered navigator (by name) or a factory, in this process
    (see :func:`check_in_worker` for a navigator that may exit, crash or hang).

    ``config`` is passed to the factory (``factory(config=...)``); ``step_budget_s`` is the
    wall-clock budget per step judged by ``within-budget``. ``progress(name, results)`` is
    called as each check starts, with the results so far.
    """
    notes: list[str] = []
    results: list[CheckResult] = []

    def phase(name: str) -> None:
        if progress is not None:
            progress(name, list(results))

    phase("builds")
    if isinstance(name_or_factory, str):
        spec, note = resolve(name_or_factory)
        if note:
            notes.append(note)
        label = spec.id
        factory = load_factory(spec)
    else:
        factory = name_or_factory
        label = getattr(factory, "__qualname__", None) or repr(factory)
    cfg = load_config(config)
    robot = robot or RobotSpec.model_validate({})
    obs = synthetic_observations(robot, n_steps, azimuth_steps=azimuth_steps)
    given, robot = robot, with_suite(robot)  # what the navigator is told at reset: its sensors listed
    times: list[float] = []
    warmup: float | None = None

    def build() -> Navigator:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NavigatorNote)
            return call_factory(factory, cfg, name=label)

    def skipped(names: tuple[str, ...], why: str) -> None:
        results.extend(CheckResult(n, False, f"not run: {why}") for n in names)

    # builds
    try:
        nav_a: Navigator = build()
        results.append(CheckResult("builds", True, f"{type(nav_a).__name__} with config {cfg!r}"))
    except BaseException as e:
        _reraise_unless_navigator(e)
        results.append(CheckResult("builds", False, _why(e)))
        skipped(CHECK_NAMES[1:], "the navigator could not be built")
        return CheckReport(label, results, step_budget_s, notes=notes)

    # valid-types + resets-cleanly on instance A
    phase("valid-types")
    run1 = run2 = None
    try:
        run1 = _drive(nav_a, robot, seed, obs)
        warmup, times = run1.times[0] if run1.times else None, list(run1.times[1:])
        ok = run1.invalid is None
        detail = (f"{len(run1.answers)} answers: "
                  + ", ".join(f"{n} {k}" for k, n in _count(run1.answers).items())
                  if ok else str(run1.invalid))
        results.append(CheckResult("valid-types", ok, detail))
    except BaseException as e:
        _reraise_unless_navigator(e)
        results.append(CheckResult("valid-types", False, "first run " + _why(e)))
    if run1 is not None:
        phase("resets-cleanly")
        try:
            run2 = _drive(nav_a, robot, seed, obs)
            times += run2.times
            same = run2.answers == run1.answers
            results.append(CheckResult(
                "resets-cleanly", same,
                "second reset, same seed: identical answers" if same else
                "second reset, same seed, different answers: "
                + _first_difference(run1.answers, run2.answers)))
        except BaseException as e:
            _reraise_unless_navigator(e)
            results.append(CheckResult("resets-cleanly", False, "second reset/run " + _why(e)))
    else:
        skipped(("resets-cleanly",), "the first run failed")

    # deterministic: fresh instances
    phase("deterministic")
    if run1 is not None:
        nav_b = nav_c = None
        try:
            nav_b = build()
            run3 = _drive(nav_b, robot, seed, obs)
            times += run3.times
            same = run3.answers == run1.answers
            try:
                nav_c = build()
                run4 = _drive(nav_c, robot, seed + 1, obs)
                times += run4.times
                other = ("another seed gives different answers" if run4.answers != run1.answers
                         else "another seed gives the same answers")
            except BaseException as e:
                _reraise_unless_navigator(e)
                other = "another seed " + _why(e)
            results.append(CheckResult(
                "deterministic", same,
                (f"fresh instance, seed {seed}: identical answers; {other}" if same else
                 f"fresh instance, seed {seed}, different answers: "
                 + _first_difference(run1.answers, run3.answers))))
        except BaseException as e:
            _reraise_unless_navigator(e)
            results.append(CheckResult("deterministic", False, "fresh instance " + _why(e)))
        finally:
            _safe_close(nav_b)
            _safe_close(nav_c)
    else:
        skipped(("deterministic",), "the first run failed")

    # empty-scan
    phase("empty-scan")
    nav_d = None
    try:
        nav_d = build()
        run5 = _drive(nav_d, robot, seed, _empty_scan_observations(given))
        times += run5.times
        results.append(CheckResult(
            "empty-scan", run5.invalid is None,
            "empty scan and a cycle without scans or pose: valid answers"
            if run5.invalid is None else str(run5.invalid)))
    except BaseException as e:
        _reraise_unless_navigator(e)
        results.append(CheckResult("empty-scan", False, _why(e)))
    finally:
        _safe_close(nav_d)

    # within-budget
    if times:
        worst = max(times)
        over = sum(t > step_budget_s for t in times)
        med = float(np.median(times))
        results.append(CheckResult(
            "within-budget", over == 0,
            f"{len(times)} steps: median {med * 1e3:.2f} ms, max {worst * 1e3:.2f} ms, "
            f"budget {step_budget_s * 1e3:.0f} ms"
            + (f"; {over} over budget" if over else "")
            + (f"; warm-up step {warmup * 1e3:.1f} ms not judged" if warmup is not None else "")))
    else:
        skipped(("within-budget",), "no step was timed")

    # close-idempotent
    phase("close-idempotent")
    problems = []
    for label_c, nav in (("after a run", nav_a), ("never reset", None)):
        try:
            target: Navigator = nav if nav is not None else build()
            target.close()
            target.close()
        except BaseException as e:
            _reraise_unless_navigator(e)
            problems.append(f"{label_c}: {_why(e)}")
    results.append(CheckResult("close-idempotent", not problems,
                               "close() twice after a run and on a never-reset instance"
                               if not problems else "; ".join(problems)))
    order = {n: i for i, n in enumerate(CHECK_NAMES)}
    results.sort(key=lambda r: order.get(r.name, len(order)))
    return CheckReport(label, results, step_budget_s, times, warmup, notes)


def _count(answers: list[Answer]) -> dict[str, int]:
    counts: dict[str, int] = {}
    for a in answers:
        key = a[0] if a[0] != "status" else f"status {a[1]}"
        counts[key] = counts.get(key, 0) + 1
    return counts


# ---------------------------------------------------------------- reporting


def format_report(report: CheckReport) -> Any:
    """A rich renderable (table + verdict) for ``rich.console.Console().print``."""
    table = Table(title=f"navigator conformance: {report.navigator}", title_justify="left")
    table.add_column("check", no_wrap=True)
    table.add_column("result", no_wrap=True)
    table.add_column("detail")
    for r in report.results:
        table.add_row(r.name, Text("pass", style="green") if r.passed
                      else Text("FAIL", style="bold red"), r.detail)
    parts: list[Any] = [table]
    parts += [Text(f"note: {n}", style="yellow") for n in report.notes]
    failed = [r.name for r in report.results if not r.passed]
    parts.append(Text(f"{report.navigator}: PASS ({len(report.results)} checks)", style="bold green")
                 if not failed else
                 Text(f"{report.navigator}: FAIL ({', '.join(failed)})", style="bold red"))
    return Group(*parts)


def report_text(report: CheckReport, *, width: int = 110) -> str:
    """:func:`format_report` rendered to plain text."""
    console = Console(width=width, record=True, color_system=None, force_terminal=False,
                      file=io.StringIO())
    console.print(format_report(report))
    return console.export_text()


# ---------------------------------------------------------------- in a worker process


def _check_and_report(name: str, config: dict[str, Any], kwargs: dict[str, Any]) -> CheckReport:
    """In the worker: :func:`check_navigator`, announcing each check to the parent."""
    return check_navigator(name, config, progress=lambda n, r: report_to_parent((n, r)), **kwargs)


#: Default wall-clock limit of each check in :func:`check_in_worker` (real seconds).
CHECK_WALL_LIMIT_S = 300.0


def check_in_worker(name: str, config: Mapping[str, Any] | str | Path | None = None, *,
                    wall_limit_s: float = CHECK_WALL_LIMIT_S, worker: Any = None, **kwargs: Any) -> CheckReport:
    """:func:`check_navigator` in a worker process (:mod:`navstress.isolate`), as ``navstress
    nav check`` runs it: a navigator that exits (``sys.exit``, ``os._exit``), crashes its
    process or hangs longer than ``wall_limit_s`` (real seconds per check) fails that check with the reason;
    the checks after it are not run. An unknown name or a bad config raises here, as
    :func:`check_navigator` does. ``worker``: a :class:`navstress.isolate.Worker` to use (and
    keep) instead of a fresh one (its own limit then applies)."""
    spec, _note = resolve(name)  # bad input raises here, before any process starts
    cfg = load_config(config)
    state: dict[str, Any] = {"phase": "builds", "results": []}

    def on_message(msg: Any) -> None:
        state["phase"], state["results"] = msg

    if worker is not None:
        status, value = worker.call(_check_and_report, name, cfg, kwargs, on_message=on_message,
                                    limit_per_message=True)
    else:
        with Worker(wall_limit_s) as fresh:
            status, value = fresh.call(_check_and_report, name, cfg, kwargs, on_message=on_message,
                                       limit_per_message=True)
    if status == "ok":
        done: CheckReport = value
        return done
    if status == "raised" and isinstance(value, NavstressError):
        raise value  # bad input (e.g. a config the factory refuses), as in this process
    if status == "raised":
        why = f"raised {type(value).__name__}: {value}"
    elif status == "died":
        why = f"the navigator killed the checking process ({value})"
    else:
        why = f"the navigator hung: no end within the wall-clock limit ({value:g} s); process killed"
    current: str = state["phase"]
    results: list[CheckResult] = list(state["results"])
    results.append(CheckResult(current, False, f"{why} during this check"))
    seen = {r.name for r in results}
    results += [CheckResult(n, False, f"not run: the checking process ended during {current}")
                for n in CHECK_NAMES if n not in seen]
    order = {n: i for i, n in enumerate(CHECK_NAMES)}
    results.sort(key=lambda r: order.get(r.name, len(order)))
    return CheckReport(spec.id, results, float(kwargs.get("step_budget_s", 0.5)))
