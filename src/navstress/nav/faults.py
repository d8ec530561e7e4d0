"""Fault injection as wrappers around a navigator, never as edits of the stack under test.

A fault is selected by name (``--fault NAME``); :func:`list_faults` gives each with a one-line
description. Two kinds:

* *belief/sensor faults* wrap any navigator (:class:`FaultyNavigator`): they change what the
  navigator is told (the RobotSpec in ``reset``) or what it observes (odometry; the readings of
  every ray sensor, by name in ``Observation.readings`` and the 3-D scans in ``Observation.scans``);
* *config mutants* build a reference navigator (``reference-*``) with a mutated
  :class:`~navstress.nav.reference.config.ReferenceConfig`; they refuse other navigators.

    >>> [f.name for f in list_faults()][:2]
    ['small-footprint', 'odometry-scale']
    >>> factory = apply_fault(my_factory, "small-footprint")  # doctest: +SKIP
    >>> navigator = factory(config={})                         # doctest: +SKIP

All randomness (``dropped-scans``) is drawn from a generator derived from the run seed given to
``reset`` (DESIGN invariant 2): the same seed drops the same scans.
"""

from __future__ import annotations

import collections
import difflib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from navstress._json import dumps
from navstress.errors import NavigatorError
from navstress.nav.api import Command, NavMission, Navigator, Observation, Odometry, Status
from navstress.robot import RobotSpec
from navstress.seeding import rng

__all__ = [
    "DelayedScans", "DroppedScans", "Fault", "FaultyNavigator", "ObservationFault",
    "OdometryScale", "SmallFootprint", "apply_fault", "get_fault", "list_faults", "small_footprint",
]

NavigatorFactory = Callable[..., Navigator]


class ObservationFault:
    """Base of wrapper faults: hooks on ``reset`` (the robot believed) and on observations.

    Subclasses keep per-run state, reset in :meth:`on_reset`; the identity hooks are defaults.
    """

    def on_reset(self, mission: NavMission, robot: RobotSpec, seed: int) -> RobotSpec:
        return robot

    def on_observation(self, obs: Observation) -> Observation:
        return obs


class FaultyNavigator:
    """``inner`` under an :class:`ObservationFault`; itself a Navigator.

        >>> isinstance(FaultyNavigator(object(), SmallFootprint()), Navigator)  # doctest: +SKIP
    """

    def __init__(self, inner: Navigator, fault: ObservationFault) -> None:
        self.inner = inner
        self.fault = fault

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self.inner.reset(mission, self.fault.on_reset(mission, robot, seed), seed=seed)

    def step(self, obs: Observation) -> Command | Status:
        return self.inner.step(self.fault.on_observation(obs))

    def close(self) -> None:
        self.inner.close()


#: The paper's footprint fault: its robot (1.14 m x 0.67 m) believed 0.84 m x 0.45 m. Any robot's
#: believed footprint is its own scaled by these ratios: lengths (x) by 0.84/1.14, widths (y) by 0.45/0.67.
PAPER_TRUE_M = (1.14, 0.67)
PAPER_BELIEVED_M = (0.84, 0.45)


def small_footprint(robot: RobotSpec) -> RobotSpec:
    """What the navigator believes under ``small-footprint``: ``robot`` with its footprint scaled
    by the paper's ratios, lengths (x) by 0.84/1.14 and widths (y) by 0.45/0.67, every other field
    kept, named ``<name>-small-belief``. A box stays a box (its length and width scaled; the paper's
    1.14 m x 0.67 m becomes exactly 0.84 m x 0.45 m, the paper's fault); a polygon's points are
    scaled; a circle becomes the polygon of its outline (32 points) scaled, an ellipse (the two
    ratios differ).

        >>> r = small_footprint(RobotSpec())
        >>> (r.name, r.length_m, r.width_m)
        ('rmp400-small-belief', 0.84, 0.45)
    """
    (tl, tw), (bl, bw) = PAPER_TRUE_M, PAPER_BELIEVED_M
    name = f"{robot.name}-small-belief"
    fp = robot.footprint
    if fp.shape == "box":
        if (robot.length_m, robot.width_m) == PAPER_TRUE_M:  # the paper's robot: its figures, exactly
            length, width = bl, bw
        else:
            length, width = robot.length_m * bl / tl, robot.width_m * bw / tw
        return robot.model_copy(update={"name": name, "length_m": length, "width_m": width})
    pts = robot.footprint_points() * np.array([bl / tl, bw / tw])
    data = robot.model_dump(mode="json")
    data.update(name=name, footprint={"shape": "polygon", "points": [[float(x), float(y)] for x, y in pts]})
    # a mount on the body's edge may lie outside the believed (smaller) outline: no check to trip on
    return RobotSpec.model_validate_json(dumps(data))


class SmallFootprint(ObservationFault):
    """The paper's fault for any robot: the navigator believes the footprint of
    :func:`small_footprint` (the RMP 400: 0.84 m x 0.45 m); every other field of the real robot
    is kept."""

    def on_reset(self, mission: NavMission, robot: RobotSpec, seed: int) -> RobotSpec:
        return small_footprint(robot)


class OdometryScale(ObservationFault):
    """Odometry distances scaled by ``scale`` (1.05: a wheel-radius error of 5%).

    Each increment between successive odometry readings is scaled in the frame of the previous
    reading (forward and lateral parts), yaw increments are kept, and the faulty pose is
    integrated from the first reading after reset; ``v`` is scaled too, ``omega`` is not.
    """

    def __init__(self, scale: float = 1.05) -> None:
        if not (math.isfinite(scale) and scale > 0):
            raise NavigatorError(f"odometry-scale: scale={scale!r} is invalid: expected > 0")
        self.scale = scale
        self._last: Odometry | None = None
        self._faulty: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def on_reset(self, mission: NavMission, robot: RobotSpec, seed: int) -> RobotSpec:
        self._last = None
        return robot

    def on_observation(self, obs: Observation) -> Observation:
        o = obs.odom
        if self._last is None:
            self._faulty = (o.x, o.y, o.yaw)
        else:
            p = self._last
            dx, dy = o.x - p.x, o.y - p.y
            c, s = math.cos(p.yaw), math.sin(p.yaw)
            fwd, lat = c * dx + s * dy, -s * dx + c * dy  # increment in the previous body frame
            fx, fy, fyaw = self._faulty
            cf, sf = math.cos(fyaw), math.sin(fyaw)
            k = self.scale
            fx += k * (cf * fwd - sf * lat)
            fy += k * (sf * fwd + cf * lat)
            dyaw = math.remainder(o.yaw - p.yaw, math.tau)
            self._faulty = (fx, fy, fyaw + dyaw)
        self._last = o
        fx, fy, fyaw = self._faulty
        odom = Odometry(o.t, fx, fy, math.remainder(fyaw, math.tau), o.v * self.scale, o.omega)
        if "odom" in obs.readings:  # the readings by name say the same as the field
            return replace(obs, odom=odom, readings={**obs.readings, "odom": (odom,)})
        return replace(obs, odom=odom)


def _ray_readings(obs: Observation) -> dict[str, tuple[Any, ...]]:
    """The readings of every ray sensor in ``obs`` by name (a 2-D scanner's LaserScans, a 3-D
    lidar's LidarScans, a depth camera's images: the readings of every kind that is not built in)."""
    from navstress.sensors.registry import user_kinds  # local: the kinds are discovered once, on first use

    types = tuple(k.reading for k in user_kinds().values())
    return {name: rs for name, rs in obs.readings.items() if rs and isinstance(rs[0], types)}


def _with_rays(obs: Observation, rays: Mapping[str, tuple[Any, ...]], scans: tuple[Any, ...]) -> Observation:
    """``obs`` with its ray sensors' readings replaced by ``rays`` (a sensor with none left out,
    as the run leaves out a sensor with no new reading) and ``scans``."""
    readings = {n: r for n, r in obs.readings.items() if n not in _ray_readings(obs)}
    readings.update({n: r for n, r in rays.items() if r})
    return replace(obs, scans=scans, readings=readings)


class DroppedScans(ObservationFault):
    """Each reading of every ray sensor (2-D and 3-D scans, depth images) is dropped with
    probability ``fraction`` (default 0.3), independently, drawn from generators derived from
    the run seed, one per sensor: ``rng(seed, "fault", "dropped-scans")`` for the sensor named
    ``lidar`` (the default lidar: the draws of navstress before sensors were declared) and for
    scans an observation carries outside its readings, ``rng(seed, "fault", "dropped-scans",
    name)`` for any other. ``Observation.scans`` keeps exactly the lidar3d scans kept in the
    readings. ``seen``/``dropped`` count this run's readings."""

    def __init__(self, fraction: float = 0.3) -> None:
        if not (0.0 <= fraction <= 1.0):
            raise NavigatorError(f"dropped-scans: fraction={fraction!r} is invalid: "
                                 "expected a probability in [0, 1]")
        self.fraction = fraction
        self._seed = 0
        self._rng: np.random.Generator = rng(0, "fault", "dropped-scans")
        self._rngs: dict[str, np.random.Generator] = {}
        self.seen = 0
        self.dropped = 0

    def on_reset(self, mission: NavMission, robot: RobotSpec, seed: int) -> RobotSpec:
        self._seed = seed
        self._rng = rng(seed, "fault", "dropped-scans")
        self._rngs = {"lidar": self._rng}
        self.seen = self.dropped = 0
        return robot

    def _draw(self, gen: np.random.Generator, n: int) -> np.ndarray:
        keep: np.ndarray = gen.random(n) >= self.fraction
        self.seen += n
        self.dropped += int((~keep).sum())
        return keep

    def on_observation(self, obs: Observation) -> Observation:
        rays = _ray_readings(obs)
        if not rays and not obs.scans:
            return obs
        kept: dict[str, tuple[Any, ...]] = {}
        keep_of: dict[str, np.ndarray] = {}
        for name, rs in rays.items():
            gen = self._rngs.get(name)
            if gen is None:
                gen = self._rngs[name] = rng(self._seed, "fault", "dropped-scans", name)
            keep_of[name] = self._draw(gen, len(rs))
            kept[name] = tuple(r for r, k in zip(rs, keep_of[name]) if k)
        # obs.scans: the k-th scan of a sensor in the readings shares that reading's fate; scans
        # of no sensor in the readings (observations built before readings existed) draw from
        # the default generator, as they always did
        legacy = [s for s in obs.scans if getattr(s, "sensor", None) not in rays]
        legacy_keep = iter(self._draw(self._rng, len(legacy))) if legacy else iter(())
        index: dict[str, int] = {}
        scans = []
        for s in obs.scans:
            sensor = getattr(s, "sensor", None)
            if isinstance(sensor, str) and sensor in rays:
                k = index.get(sensor, 0)
                index[sensor] = k + 1
                ok = bool(keep_of[sensor][k]) if k < len(keep_of[sensor]) else True
            else:
                ok = bool(next(legacy_keep))
            if ok:
                scans.append(s)
        if not rays:
            return replace(obs, scans=tuple(scans))
        return _with_rays(obs, kept, tuple(scans))


class DelayedScans(ObservationFault):
    """Every ray sensor's readings (2-D and 3-D scans, depth images) and ``Observation.scans``
    are delivered ``cycles`` control cycles late (default 3, 0.3 s at 10 Hz), with their
    original capture time ``t``; the last ``cycles`` cycles' readings are never delivered."""

    def __init__(self, cycles: int = 3) -> None:
        if not (isinstance(cycles, int) and cycles >= 0):
            raise NavigatorError(f"delayed-scans: cycles={cycles!r} is invalid: expected an "
                                 "integer >= 0")
        self.cycles = cycles
        self._queue: collections.deque[tuple[tuple[Any, ...], dict[str, tuple[Any, ...]]]] = collections.deque()

    def on_reset(self, mission: NavMission, robot: RobotSpec, seed: int) -> RobotSpec:
        self._queue.clear()
        return robot

    def on_observation(self, obs: Observation) -> Observation:
        rays = _ray_readings(obs)
        self._queue.append((obs.scans, rays))
        late: tuple[tuple[Any, ...], dict[str, tuple[Any, ...]]] = (
            self._queue.popleft() if len(self._queue) > self.cycles else ((), {}))
        if not rays and not late[1]:
            return replace(obs, scans=late[0])
        return _with_rays(obs, late[1], late[0])


# ---------------------------------------------------------------- config mutants


def _is_reference(factory: NavigatorFactory) -> bool:
    if getattr(factory, "__navstress_reference__", False):
        return True  # a reference factory already under a config mutant
    module = getattr(factory, "__module__", "") or ""
    return module == "navstress.nav.reference" or module.startswith("navstress.nav.reference.")


def _unknown_as_free(cfg: dict[str, Any], defaults: Mapping[str, Any]) -> dict[str, Any]:
    # flat ground costs slope_weight*0 + roughness_weight*0 = 0 per node (ReferenceConfig doc)
    return {**cfg, "unknown_cell_cost": 0.0}


def _permissive_slope(cfg: dict[str, Any], defaults: Mapping[str, Any]) -> dict[str, Any]:
    current = float(cfg.get("max_slope_deg", defaults["max_slope_deg"]))
    return {**cfg, "max_slope_deg": min(2.0 * current, 89.0)}


# ---------------------------------------------------------------- the catalogue


@dataclass(frozen=True)
class Fault:
    """A named fault: ``wrapper`` builds the per-run wrapper state, or ``mutate`` the config
    (given the mapping and the defaults of the navigator's config model)."""

    name: str
    description: str
    wrapper: Callable[[], ObservationFault] | None = None
    mutate: Callable[[dict[str, Any], Mapping[str, Any]], dict[str, Any]] | None = None

    @property
    def reference_only(self) -> bool:
        return self.mutate is not None


_FAULTS: dict[str, Fault] = {f.name: f for f in (
    Fault("small-footprint", "navigator told a footprint shrunk by the paper's ratios (length 0.84/1.14, "
          "width 0.45/0.67): the RMP 400 believed 0.84 m x 0.45 m (the paper's fault)", wrapper=SmallFootprint),
    Fault("odometry-scale", "odometry distances scaled by 1.05 (scaled increments integrated)",
          wrapper=OdometryScale),
    Fault("dropped-scans", "30% of every ray sensor's readings (lidar scans, 2D scans, depth images) dropped, "
          "drawn from the run seed",
          wrapper=DroppedScans),
    Fault("delayed-scans", "every ray sensor's readings delivered 3 control cycles late (original timestamps)",
          wrapper=DelayedScans),
    Fault("unknown-as-free", "reference stack only: never-seen cells cost as flat ground "
          "(unknown_cell_cost=0 instead of inf)", mutate=_unknown_as_free),
    Fault("permissive-slope", "reference stack only: max_slope_deg doubled (capped at 89)",
          mutate=_permissive_slope),
)}


def list_faults() -> list[Fault]:
    """Every fault, in catalogue order (name + one-line description)."""
    return list(_FAULTS.values())


def get_fault(name: str) -> Fault:
    """The fault called ``name``; :class:`NavigatorError` listing the faults otherwise."""
    try:
        return _FAULTS[name]
    except (KeyError, TypeError):
        close = difflib.get_close_matches(str(name), list(_FAULTS), n=1, cutoff=0.5)
        hint = f" Did you mean {close[0]!r}?" if close else ""
        raise NavigatorError(
            f"unknown fault {name!r}.{hint} Known faults: {', '.join(_FAULTS)}"
        ) from None


def _config_defaults(model_path: str | None) -> dict[str, Any]:
    """The defaults of a reference navigator's config model (``"module:Class"``; None: the
    reference stack's :class:`~navstress.nav.reference.config.ReferenceConfig`)."""
    import importlib  # local: the models' modules compile numba kernels on import

    module, _, attr = (model_path or "navstress.nav.reference.config:ReferenceConfig").partition(":")
    model = getattr(importlib.import_module(module), attr)
    return {name: f.default for name, f in model.model_fields.items()}


def apply_fault(factory: NavigatorFactory, fault_name: str, *,
                navigator: str | None = None) -> NavigatorFactory:
    """A factory building ``factory``'s navigator under the fault ``fault_name``.

    ``navigator`` (the registered name) only improves error messages. Config mutants raise
    :class:`NavigatorError` at once unless ``factory`` is a reference navigator.
    """
    fault = get_fault(fault_name)
    label = navigator or getattr(factory, "__qualname__", repr(factory))
    if fault.mutate is not None:
        if not _is_reference(factory):
            raise NavigatorError(
                f"fault {fault.name!r} mutates the reference stack's configuration and applies "
                f"only to reference navigators (reference-v1, reference-global-v1, reference-2d-v1), not to "
                f"{label!r}; faults for any navigator: "
                + ", ".join(f.name for f in _FAULTS.values() if not f.reference_only)
            )
        mutate = fault.mutate
        model_path = getattr(factory, "__navstress_config__", None)

        def build_mutant(*, config: Mapping[str, Any] | None = None) -> Navigator:
            return factory(config=mutate(dict(config or {}), _config_defaults(model_path)))

        build_mutant.__qualname__ = f"{fault.name}({label})"
        build_mutant.__navstress_reference__ = True  # type: ignore[attr-defined]
        build_mutant.__navstress_config__ = model_path  # type: ignore[attr-defined]
        return build_mutant

    make_wrapper = fault.wrapper
    assert make_wrapper is not None

    def build_wrapped(*, config: Mapping[str, Any] | None = None) -> Navigator:
        return FaultyNavigator(factory(config=dict(config or {})), make_wrapper())

    build_wrapped.__qualname__ = f"{fault.name}({label})"
    return build_wrapped
