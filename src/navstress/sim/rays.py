"""The ray sensors a :class:`~navstress.sim.simulation.Simulation` casts: one caster per sensor of
the run's suite (:func:`navstress.sim.suite.suite`), made by :func:`caster` from the sensor's
kind. Each turns a body pose into the kind's reading:

- ``lidar3d``: :class:`~navstress.sim.lidar.Lidar` with the sensor's figures; a mount turned by
  roll, pitch or yaw turns the scan (a mount without rotation takes the lidar's own path:
  :meth:`~navstress.sim.lidar.Lidar.scan_body`, byte-identical to the lidar before sensors were
  declared); reading :class:`~navstress.sensors.kinds.lidar3d.LidarScan`.
- ``lidar2d``: a planar fan from the mount pose (it hits the ground on slopes and when the body
  pitches). Beams evenly around the circle (every profile's: 0.25, 1/3, 0.9 degrees) are the first
  columns of a one-channel :class:`~navstress.sim.lidar.Lidar` of the whole circle turned to the
  first beam, and only they are cast (:meth:`~navstress.sim.lidar.Lidar.fan_ranges`: the scan
  kernels, boxes and movers culled per column, the terrain skipped when no beam can reach it);
  any other spacing ray by ray (:func:`navstress.sim._raybox.rays_ranges`, every box tested). Reading
  :class:`~navstress.sensors.kinds.lidar2d.LaserScan`.
- ``depth``: :class:`navstress.sim.depth.DepthCamera`; reading
  :class:`~navstress.sensors.kinds.depth.DepthImage`.

Streams (DESIGN invariant 2), keyed by the sensor's name: range noise ``rng(seed, "sim", "noise",
name)``, dropouts ``rng(seed, "sim", "dropout", name)`` (made, and drawn, only when the sensor's
``dropout_prob`` > 0); the rate jitter's ``rng(seed, "sim", "timing", name)`` is the simulation's.
With ``sim.noise`` off neither noise nor dropouts are applied.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from navstress.errors import SpecError
from navstress.seeding import rng
from navstress.sensors import Sensor
from navstress.sensors.kinds.depth import DepthImage, DepthParams
from navstress.sensors.kinds.lidar2d import LaserScan, Lidar2dParams
from navstress.sensors.kinds.lidar3d import LidarScan
from navstress.sim import _raybox
from navstress.sim.lidar import Lidar, LidarConfig, LidarScene
from navstress.sim.suite import lidar_config

_TWO_PI = 2.0 * math.pi


class RayCaster:
    """One ray sensor of a run: its name, kind, mount and streams; :meth:`cast` makes a reading."""

    def __init__(self, sensor: Sensor, seed: int) -> None:
        self.sensor = sensor
        self.name = sensor.name
        self.kind = sensor.kind
        m = sensor.mount
        self.mount = (float(m.xyz[0]), float(m.xyz[1]), float(m.xyz[2]))
        self.rpy = (float(m.rpy[0]), float(m.rpy[1]), float(m.rpy[2]))
        self.mount_v = np.array(self.mount)
        self.mount_rot = m.rotation()
        self.params: Any = sensor.config()
        self.rate_hz = float(self.params.rate_hz)
        self.dropout_prob = float(getattr(self.params, "dropout_prob", 0.0))
        self.noise_gen = rng(seed, "sim", "noise", sensor.name)
        self.dropout_gen = rng(seed, "sim", "dropout", sensor.name) if self.dropout_prob > 0 else None

    def cast(self, qpos: np.ndarray, t: float, noisy: bool, discs: np.ndarray | None,
             scene_boxes: np.ndarray | None) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError


class Lidar3dCaster(RayCaster):
    """A ``lidar3d`` sensor."""

    def __init__(self, sensor: Sensor, seed: int, scene: LidarScene) -> None:
        super().__init__(sensor, seed)
        self.lidar = Lidar(scene, lidar_config(sensor))
        self.turned = self.rpy != (0.0, 0.0, 0.0)

    def cast(self, qpos: np.ndarray, t: float, noisy: bool, discs: np.ndarray | None,
             scene_boxes: np.ndarray | None) -> LidarScan:
        gen = self.noise_gen if noisy else None
        if self.turned:
            pts = self.lidar.scan_mounted(qpos, self.mount_v, self.mount_rot, gen, discs=discs,
                                          scene_boxes=scene_boxes)
        else:
            pts = self.lidar.scan_body(qpos, self.mount_v, gen, discs=discs, scene_boxes=scene_boxes)
        if noisy and self.dropout_gen is not None and len(pts):
            pts = pts[self.dropout_gen.random(len(pts)) >= self.dropout_prob]
        return LidarScan(t, pts, self.mount, self.name, self.rpy)


def circle_steps(angle_increment: float, beams: int) -> int:
    """How many steps of ``angle_increment`` make the whole circle when that is a whole number of
    at least ``beams`` (the fan then is the first columns of a turned full-circle scan); 0
    otherwise."""
    if not angle_increment > 0:
        return 0
    n = int(round(_TWO_PI / angle_increment))
    if n < beams or n > 100_000 or abs(n * angle_increment - _TWO_PI) > 1e-9:
        return 0
    return n


class Lidar2dCaster(RayCaster):
    """A ``lidar2d`` sensor (see the module's text)."""

    def __init__(self, sensor: Sensor, seed: int, scene: LidarScene) -> None:
        super().__init__(sensor, seed)
        p: Lidar2dParams = self.params
        self.scene = scene
        self.beams = int(p.beams)
        self.angle_min, self.angle_increment = float(p.angle_min), float(p.angle_increment)
        self.min_range, self.max_range = float(p.min_range_m), float(p.max_range_m)
        self.std = float(p.range_noise_std_m)
        steps = circle_steps(self.angle_increment, self.beams)
        self.lidar: Lidar | None = None
        a0 = self.angle_min
        # the fan's first beam is column 0: the sensor frame turned by angle_min about its z
        rz = np.array([[math.cos(a0), -math.sin(a0), 0.0], [math.sin(a0), math.cos(a0), 0.0], [0.0, 0.0, 1.0]])
        self.fan_rot = self.mount_rot @ rz
        if steps:
            self.lidar = Lidar(scene, LidarConfig(channels=1, min_elevation_deg=0.0, max_elevation_deg=0.0,
                                                  azimuth_steps=steps, rate_hz=self.rate_hz,
                                                  max_range_m=self.max_range, min_range_m=self.min_range,
                                                  range_noise_std_m=self.std))
        else:
            a = a0 + self.angle_increment * np.arange(self.beams)
            dirs = np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1)
            self._dirs_body = dirs @ self.mount_rot.T  # (n, 3) in base_link
            self._out = np.empty(self.beams)

    def ranges(self, qpos: np.ndarray, discs: np.ndarray | None = None,
               scene_boxes: np.ndarray | None = None) -> np.ndarray:
        """Noise-free ranges (beams,) float64 from the body pose ``qpos``, inf = no return."""
        return self._ranges(qpos, discs, scene_boxes)[0].copy()

    def _ranges(self, qpos: np.ndarray, discs: np.ndarray | None,
                scene_boxes: np.ndarray | None) -> tuple[np.ndarray, int]:
        """:meth:`ranges` (a buffer that the next cast overwrites) and the number of returns."""
        if self.lidar is not None:
            out, n = self.lidar.fan_ranges(qpos, self.mount_v, self.fan_rot, self.beams, discs=discs,
                                           scene_boxes=scene_boxes)
            return out[0], n
        q = np.asarray(qpos, dtype=np.float64)
        qw, qx, qy, qz = (float(v) for v in q[3:7])
        nq = qw * qw + qx * qx + qy * qy + qz * qz
        if not (math.isfinite(nq) and abs(nq - 1.0) <= 1e-6 and np.all(np.isfinite(q[:3]))):
            raise SpecError("qpos", q[:7].tolist(), "a finite position and a unit quaternion (w, x, y, z)")
        rb = np.array([[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
                       [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
                       [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]])
        origin = q[:3] + rb @ self.mount_v
        dirs = np.ascontiguousarray(self._dirs_body @ rb.T)
        boxes = self.scene.boxes if scene_boxes is None else scene_boxes
        d = self.scene.discs if discs is None else np.ascontiguousarray(discs, dtype=np.float64).reshape(-1, 5)
        _raybox.rays_ranges(self.scene.grid, boxes, d, origin, dirs, self.max_range, self.min_range, self._out)
        return self._out, int(np.count_nonzero(self._out < np.inf))

    def cast(self, qpos: np.ndarray, t: float, noisy: bool, discs: np.ndarray | None,
             scene_boxes: np.ndarray | None) -> LaserScan:
        r, n = self._ranges(qpos, discs, scene_boxes)
        r32 = np.empty(self.beams, np.float32)
        if noisy and self.std > 0:
            # r + std * z per return, then [min_range, max_range] (else inf), as float32 (one kernel:
            # the same arithmetic as numpy's r[hit] += std * z; r[(r < lo) | (r > hi)] = inf; astype)
            _raybox.noisy_ranges32(r, self.noise_gen.standard_normal(n), self.std, self.min_range, self.max_range,
                                   r32)
        else:
            r32[:] = r
        if noisy and self.dropout_gen is not None:
            r32[self.dropout_gen.random(self.beams) < self.dropout_prob] = np.inf
        return LaserScan(t, r32, self.angle_min, self.angle_increment, self.min_range,
                         self.max_range, self.mount, self.rpy, self.name)


class DepthCaster(RayCaster):
    """A ``depth`` sensor (the camera of :mod:`navstress.sim.depth`)."""

    def __init__(self, sensor: Sensor, seed: int, scene: LidarScene) -> None:
        super().__init__(sensor, seed)
        from navstress.sim.depth import DepthCamera  # the depth helper's module

        p: DepthParams = self.params
        self.camera = DepthCamera(scene, p)
        self.intrinsics = p.intrinsics()

    def cast(self, qpos: np.ndarray, t: float, noisy: bool, discs: np.ndarray | None,
             scene_boxes: np.ndarray | None) -> DepthImage:
        img = self.camera.render(qpos, self.sensor.mount, self.noise_gen if noisy else None,
                                 self.dropout_gen if noisy else None, discs=discs, scene_boxes=scene_boxes)
        fx, fy, cx, cy = self.intrinsics
        return DepthImage(t, img, fx, fy, cx, cy, self.mount, self.rpy, self.name)


_CASTERS: dict[str, type[Lidar3dCaster] | type[Lidar2dCaster] | type[DepthCaster]] = {
    "lidar3d": Lidar3dCaster, "lidar2d": Lidar2dCaster, "depth": DepthCaster}


def caster(sensor: Sensor, seed: int, scene: LidarScene) -> RayCaster:
    """The caster of ``sensor`` on ``scene`` (SpecError for a kind the simulation cannot cast)."""
    cls = _CASTERS.get(sensor.kind)
    if cls is None:
        raise SpecError(f"sensors.{sensor.name}.kind", sensor.kind, "a kind the simulation casts: "
                        + ", ".join(_CASTERS))
    return cls(sensor, seed, scene)
