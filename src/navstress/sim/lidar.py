"""3-D lidar: a fast ray caster against the heightfield terrain and the obstacles (boxes, cylinders).

Exact to the geometry MuJoCo simulates (checked against ``mujoco.mj_ray`` in the tests):

- terrain: each cell split by the diagonal from vertex (i, j) to (i+1, j+1) (MuJoCo's hfield
  triangulation); the hfield is a solid, so rays entering from outside the map hit its side
  walls below the edge profile (walls extend down without limit here: MuJoCo's base plate,
  ``size[3]`` below the lowest point, is only reachable by rays from under the ground);
  outside the map there is no ground. MuJoCo stores normalised float32 elevations scaled
  by the z size, so its surface differs from ``heights`` by float32 rounding of
  (h - hmin) / (hmax - hmin): about 1e-7 x relief, i.e. below 1e-5 m for relief < 50 m
  (ranges differ by that divided by the sine of the grazing angle).
- boxes: :class:`~navstress.world.world.Obstacle` -> oriented box from ``z`` to ``z + sz``,
  yaw about z only; faces two-sided (a ray starting inside a box hits its exit face).
- cylinders (``Obstacle.shape == "cylinder"``) -> upright solid cylinder of radius ``size[0] / 2``
  from ``z`` to ``z + sz``: the side and both caps, exactly (the same kernel as the disc movers',
  :func:`navstress.sim._raybox._ray_cylinder`), also two-sided.

The scan marches, per azimuth column, the plane of its 32 channels once, lowest unresolved
channel first (channel-major over the columns, a cell walk with per-cell maxima deciding the
exact tests); the cylinders, then the boxes lower those ranges in shape-major passes (boxes near first). See
:func:`navstress.sim._raycast.terrain_kernel` and :func:`navstress.sim._raybox.box_pass`.

    >>> import numpy as np
    >>> from navstress.world.spec import WorldSpec
    >>> from navstress.world.world import World
    >>> lidar = Lidar(build_scene(World.flat(WorldSpec(size_m=(20.0, 20.0)))))
    >>> r = lidar.ranges(np.array([10.0, 10.0, 1.0]), np.eye(3))
    >>> round(float(r[0, 0]), 4)  # lowest channel, -30.67 deg: 1 / sin(30.67 deg)
    1.9604
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from navstress.errors import SpecError
from navstress.sim import _noise, _raybox, _raycast, native
from navstress.sim._raycast import Beams, TerrainGrid
from navstress.world.world import World

__all__ = ["LidarConfig", "LidarScene", "Lidar", "build_scene", "cast_rays"]



@dataclass(frozen=True)
class LidarConfig:
    """A spinning multi-channel lidar (defaults: Velodyne HDL-32E-like).

    Channels are evenly spaced from ``min_elevation_deg`` to ``max_elevation_deg``; azimuth
    step ``a`` points at ``2*pi*a/azimuth_steps`` counter-clockwise from the sensor's +x.
    Returns closer than ``min_range_m`` or farther than ``max_range_m`` are dropped.
    """

    channels: int = 32
    min_elevation_deg: float = -30.67
    max_elevation_deg: float = 10.67
    azimuth_steps: int = 360
    rate_hz: float = 10.0
    max_range_m: float = 70.0
    min_range_m: float = 0.3
    range_noise_std_m: float = 0.02

    def __post_init__(self) -> None:
        def finite(name: str, v: float) -> None:
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise SpecError(f"lidar.{name}", v, "a finite number")

        for name in ("channels", "azimuth_steps"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or not 1 <= v <= 100_000:
                raise SpecError(f"lidar.{name}", v, "an integer in [1, 100000]")
        for name in ("min_elevation_deg", "max_elevation_deg", "rate_hz", "max_range_m",
                     "min_range_m", "range_noise_std_m"):
            finite(name, getattr(self, name))
        for name in ("min_elevation_deg", "max_elevation_deg"):
            v = getattr(self, name)
            if not -89.0 <= v <= 89.0:
                raise SpecError(f"lidar.{name}", v, "degrees in [-89, 89]")
        if self.max_elevation_deg < self.min_elevation_deg or (
                self.channels > 1 and self.max_elevation_deg == self.min_elevation_deg):
            raise SpecError("lidar.max_elevation_deg", self.max_elevation_deg,
                            f"greater than min_elevation_deg={self.min_elevation_deg}",
                            "swap the two values")
        if self.rate_hz <= 0:
            raise SpecError("lidar.rate_hz", self.rate_hz, "a rate > 0")
        if self.min_range_m < 0:
            raise SpecError("lidar.min_range_m", self.min_range_m, "a distance >= 0")
        if self.max_range_m <= self.min_range_m:
            raise SpecError("lidar.max_range_m", self.max_range_m,
                            f"a distance > min_range_m={self.min_range_m}")
        if self.range_noise_std_m < 0:
            raise SpecError("lidar.range_noise_std_m", self.range_noise_std_m, "a standard deviation >= 0")

    @property
    def elevations_rad(self) -> np.ndarray:
        """Channel elevations, ascending, shape (channels,)."""
        return np.radians(np.linspace(self.min_elevation_deg, self.max_elevation_deg, self.channels))

    @property
    def azimuths_rad(self) -> np.ndarray:
        """Azimuth angles, shape (azimuth_steps,)."""
        return 2.0 * np.pi * np.arange(self.azimuth_steps) / self.azimuth_steps

    def directions(self) -> np.ndarray:
        """Unit ray directions in the sensor frame, shape (channels, azimuth_steps, 3)."""
        el = self.elevations_rad[:, None]
        az = self.azimuths_rad[None, :]
        return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az),
                         np.broadcast_to(np.sin(el), (el.shape[0], az.shape[1]))], axis=-1)


@dataclass(frozen=True, eq=False)
class LidarScene:
    """What the lidar sees: terrain heights (float32, ``Terrain`` convention), ``cell_m``, and
    boxes as rows ``[x, y, yaw, half_sx, half_sy, z_bottom, z_top]`` (stored with cos(yaw), sin(yaw)
    appended as columns 7 and 8), and upright cylinders ``discs`` as rows ``[x, y, radius, z_bottom,
    z_top]`` (the cylinder obstacles; the disc movers are added per scan). Derived acceleration data
    (max/min-height mipmaps: ``mip`` float64 (2, n) for the per-ray path, ``mipf`` the same values
    as float32 (n, 2) max/min pairs for scans, exact since they are maxima/minima of float32
    heights; terrain gradient bound) is computed on construction; ``grid`` holds the terrain as
    the kernels read it."""

    heights: np.ndarray
    cell_m: float
    boxes: np.ndarray
    discs: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))
    mip: np.ndarray = field(init=False, repr=False)
    mipf: np.ndarray = field(init=False, repr=False)
    mip_offsets: np.ndarray = field(init=False, repr=False)
    mip_widths: np.ndarray = field(init=False, repr=False)
    grad_max: float = field(init=False)
    grid: TerrainGrid = field(init=False, repr=False)

    def __post_init__(self) -> None:
        h = np.ascontiguousarray(self.heights, dtype=np.float32)
        if h.ndim != 2 or h.shape[0] < 2 or h.shape[1] < 2:
            raise SpecError("scene.heights", getattr(h, "shape", None), "a 2-D grid of at least 2x2 vertices")
        if not np.all(np.isfinite(h)):
            raise SpecError("scene.heights", "non-finite values", "finite heights")
        if not (isinstance(self.cell_m, (int, float)) and math.isfinite(self.cell_m) and self.cell_m > 0):
            raise SpecError("scene.cell_m", self.cell_m, "a cell size > 0 in metres")
        b = np.asarray(self.boxes, dtype=np.float64)
        b = b.reshape(-1, b.shape[-1] if b.ndim == 2 else 7)[:, :7] if b.size else np.zeros((0, 7))
        if b.shape[1] != 7:
            raise SpecError("scene.boxes", f"shape {b.shape}", "rows of 7 values [x, y, yaw, hx, hy, zb, zt]")
        if not np.all(np.isfinite(b)) or np.any(b[:, 3:5] <= 0) or np.any(b[:, 6] < b[:, 5]):
            raise SpecError("scene.boxes", "invalid rows", "finite [x, y, yaw, hx>0, hy>0, zb, zt>=zb]")
        b = np.ascontiguousarray(np.column_stack([b, np.cos(b[:, 2]), np.sin(b[:, 2])]))
        c = np.asarray(self.discs, dtype=np.float64)
        c = np.ascontiguousarray(c.reshape(-1, 5) if c.size == 0 or (c.ndim == 1 and c.size == 5) else c)
        if c.ndim != 2 or c.shape[1] != 5:
            raise SpecError("scene.discs", f"shape {c.shape}", "rows of 5 values [x, y, r, zb, zt]")
        if not np.all(np.isfinite(c)) or np.any(c[:, 2] <= 0) or np.any(c[:, 4] < c[:, 3]):
            raise SpecError("scene.discs", "invalid rows", "finite [x, y, r>0, zb, zt>=zb]")
        h.setflags(write=False)
        b.setflags(write=False)
        c.setflags(write=False)
        object.__setattr__(self, "discs", c)
        object.__setattr__(self, "heights", h)
        object.__setattr__(self, "cell_m", float(self.cell_m))
        object.__setattr__(self, "boxes", b)
        # max- and min-height mipmaps: level 0 = per-cell max/min of its 4 vertices, then 2x2
        # pooling (padding -inf / +inf); stored as mip[0] (max) and mip[1] (min), levels flat
        h64 = h.astype(np.float64)
        c4 = (h64[:-1, :-1], h64[:-1, 1:], h64[1:, :-1], h64[1:, 1:])
        hi = np.maximum(np.maximum(c4[0], c4[1]), np.maximum(c4[2], c4[3]))
        lo = np.minimum(np.minimum(c4[0], c4[1]), np.minimum(c4[2], c4[3]))
        his, los = [hi], [lo]
        while hi.shape[0] > 1 or hi.shape[1] > 1:
            r, c = hi.shape
            ph = np.full((r + r % 2, c + c % 2), -np.inf)
            pl = np.full((r + r % 2, c + c % 2), np.inf)
            ph[:r, :c] = hi
            pl[:r, :c] = lo
            hi = np.maximum(np.maximum(ph[0::2, 0::2], ph[0::2, 1::2]), np.maximum(ph[1::2, 0::2], ph[1::2, 1::2]))
            lo = np.minimum(np.minimum(pl[0::2, 0::2], pl[0::2, 1::2]), np.minimum(pl[1::2, 0::2], pl[1::2, 1::2]))
            his.append(hi)
            los.append(lo)
        sizes = [lv.size for lv in his]
        mip = np.stack([np.concatenate([lv.ravel() for lv in his]), np.concatenate([lv.ravel() for lv in los])])
        object.__setattr__(self, "mip", np.ascontiguousarray(mip))
        object.__setattr__(self, "mipf", np.ascontiguousarray(mip.T.astype(np.float32)))
        object.__setattr__(self, "mip_offsets", np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64))
        object.__setattr__(self, "mip_widths", np.array([lv.shape[1] for lv in his], np.int64))
        # steepest triangle (m/m): bounds how tilted a column plane may be for plane marching
        d_lo_u = h64[:-1, 1:] - h64[:-1, :-1]   # lower triangle (u >= v): dh/du, dh/dv
        d_lo_v = h64[1:, 1:] - h64[:-1, 1:]
        d_up_u = h64[1:, 1:] - h64[1:, :-1]     # upper triangle: dh/du, dh/dv
        d_up_v = h64[1:, :-1] - h64[:-1, :-1]
        g = max(float(np.max(np.hypot(d_lo_u, d_lo_v))), float(np.max(np.hypot(d_up_u, d_up_v))))
        object.__setattr__(self, "grad_max", g / self.cell_m)
        object.__setattr__(self, "grid", TerrainGrid(self.heights, self.cell_m, self.mip, self.mipf, self.mip_offsets,
                                                     self.mip_widths, self.grad_max))

    @property
    def size_m(self) -> tuple[float, float]:
        rows, cols = self.heights.shape
        return ((cols - 1) * self.cell_m, (rows - 1) * self.cell_m)


def build_scene(world: World) -> LidarScene:
    """The lidar scene of a world: its terrain, one box per box obstacle and one disc per cylinder
    (each kind in the world's order)."""
    obs = world.obstacles
    boxes = np.array([[o.x, o.y, o.yaw, o.size[0] / 2, o.size[1] / 2, o.z, o.z + o.size[2]] for o in obs
                      if not o.is_cylinder], dtype=np.float64).reshape(-1, 7)
    discs = np.array([[o.x, o.y, o.size[0] / 2, o.z, o.z + o.size[2]] for o in obs if o.is_cylinder],
                     dtype=np.float64).reshape(-1, 5)
    return LidarScene(world.terrain.heights, world.terrain.cell_m, boxes, discs)


def cast_rays(scene: LidarScene, origins: np.ndarray, directions: np.ndarray, max_range: float) -> np.ndarray:
    """Distance (metres) along each ray to the first surface, inf if none within ``max_range``.

    ``origins`` and ``directions`` are (N, 3) in the world frame; directions need not be unit
    (they are normalised). Per-ray path: every box and cylinder is tested, so cost grows with the
    number of obstacles; use :class:`Lidar` for scans.
    """
    o = np.ascontiguousarray(origins, dtype=np.float64).reshape(-1, 3)
    d = np.ascontiguousarray(directions, dtype=np.float64).reshape(-1, 3)
    if o.shape != d.shape:
        raise SpecError("directions", d.shape, f"the shape of origins {o.shape}")
    n = np.linalg.norm(d, axis=1)
    if not (np.all(np.isfinite(o)) and np.all(np.isfinite(d)) and np.all(n > 0)):
        raise SpecError("rays", "non-finite or zero direction", "finite origins and non-zero directions")
    if not (max_range > 0):
        raise SpecError("max_range", max_range, "a distance > 0")
    d = d / n[:, None]
    out = np.empty(o.shape[0])
    _raycast.cast_rays_kernel(scene.grid, scene.boxes, o, d, float(max_range), out)
    if scene.discs.shape[0]:
        _raybox.lower_with_discs(scene.discs, o, d, float(max_range), out)
    return out


def _check_pose(origin: np.ndarray, rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    o = np.ascontiguousarray(origin, dtype=np.float64)
    r = np.ascontiguousarray(rotation, dtype=np.float64)
    if o.shape != (3,) or not np.isfinite(o).all():
        raise SpecError("origin", origin, "a finite (3,) position in the world frame")
    if r.shape != (3, 3) or not _raycast.rotation_error(r) <= 1e-6:
        raise SpecError("rotation", rotation, "a (3, 3) rotation matrix (world from sensor)")
    return o, r


class Lidar:
    """A lidar on a scene. ``scan`` returns hit points in the sensor frame.

    ``plane_march=False`` marches every ray from the sensor (a slower, independent path used
    as the baseline in benchmarks; same results). ``simd``: walk the terrain marches with the
    native AVX-512 walk (:mod:`navstress.sim.native`; bit-identical ranges); None (default) uses
    it when it is available, False never, True requires it. The first lidar of a process that
    may use it builds it (:func:`navstress.sim.native.load`); ``simd`` can be set later too.
    """

    def __init__(self, scene: LidarScene, config: LidarConfig = LidarConfig(), *, plane_march: bool = True,
                 simd: bool | None = None) -> None:
        if not isinstance(config, LidarConfig):
            raise SpecError("config", config, "a LidarConfig")
        # the scan's constants (walk: address of the native walk, 0: the numba walk)
        self._params = _raycast.new_scan_params(max_range=float(config.max_range_m),
                                                min_range=float(config.min_range_m),
                                                plane_march=int(bool(plane_march)), walk=0)
        self.simd = native.available() if simd is None else simd
        self.scene = scene
        self.config = config
        el = config.elevations_rad
        az = config.azimuths_rad
        self._beams = Beams(np.cos(el), np.sin(el), np.cos(az), np.sin(az))
        self._cos_el, self._sin_el, self._cos_az, self._sin_az = self._beams
        self._dirs = config.directions()
        self._out = np.empty((config.channels, config.azimuth_steps), np.float64)
        self._rot = np.empty((3, 3))  # the last body scan's sensor pose
        self._origin = np.empty(3)
        self._arrays = _raybox.scan_arrays(scene.grid, self._beams, self._out)  # the per-scan kernels' groups
        self._fans: dict[int, tuple[np.ndarray | float, ...]] = {}  # fan_ranges' groups by column count

    @property
    def plane_march(self) -> bool:
        """Whether scans march each azimuth column's plane (False: every ray from the sensor)."""
        return bool(self._params["plane_march"][0])

    @plane_march.setter
    def plane_march(self, on: bool) -> None:
        self._params["plane_march"] = int(bool(on))

    @property
    def simd(self) -> bool:
        """Whether scans walk the terrain with the native walk."""
        return int(self._params["walk"][0]) != 0

    @simd.setter
    def simd(self, on: bool) -> None:
        if not on:
            self._params["walk"] = 0
            return
        nat = native.load()
        if not nat.address:
            raise SpecError("simd", on, "False or None: the native walk is " + nat.status)
        self._params["walk"] = nat.address

    def ranges(self, origin: np.ndarray, rotation: np.ndarray) -> np.ndarray:
        """Noise-free ranges, (channels, azimuth_steps) float32, inf where there is no return."""
        return self._ranges(origin, rotation).astype(np.float32)

    def _ranges(self, origin: np.ndarray, rotation: np.ndarray) -> np.ndarray:
        o, r = _check_pose(origin, rotation)
        # terrain first (no boxes, no min-range filter), then the boxes lower it and filter:
        # bit-identical to scan_kernel with the boxes (min_range applies to the nearer hit)
        _raybox.scan_ranges(self._params, o, r, self.scene.boxes, self.scene.discs, *self._arrays)
        return self._out

    def scan(self, origin: np.ndarray, rotation: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """Hit points (N, 3) float32 in the sensor frame (x forward, y left, z up); rays without a
        return are omitted. With ``rng``, each range gets exact N(0, range_noise_std_m) noise along
        its ray, clamped at 0: one standard normal per return in channel-major order, from a
        ziggurat on raw words of ``rng.bit_generator`` (:mod:`navstress.sim._noise`): one 32-bit
        half of a 64-bit word per sample (``random_raw(ceil(N/2) + N//16 + 64)``, the rest spare
        words for rejections and the tail, refilled by ``random_raw(N//16 + 64)`` if ever
        exhausted); nothing else is drawn. Same generator state -> same points."""
        r = self._ranges(origin, rotation)
        return self._points(_raycast.count_finite(r), rng)

    def scan_body(self, qpos: np.ndarray, mount: np.ndarray, rng: np.random.Generator | None = None, *,
                  discs: np.ndarray | None = None, boxes: np.ndarray | None = None,
                  scene_boxes: np.ndarray | None = None) -> np.ndarray:
        """:meth:`scan` from a body pose: ``qpos[:7]`` = (x, y, z, qw, qx, qy, qz) as in MuJoCo, the
        sensor at ``mount`` (3,) in the body frame and oriented as the body. Same points as
        ``scan(qpos[:3] + R @ mount, R)`` with R from the quaternion (``mju_quat2Mat``'s formula,
        equal to it within 1e-15), up to the rounding of that pose; the pose arithmetic, its check,
        the terrain and box passes and the count run in one compiled call (the simulation's path).

        ``discs`` (rows x, y, radius, z bottom, z top): every upright cylinder of this scan, the
        scene's (``LidarScene.discs``) and the extra ones (the disc movers where they are at scan
        time); None: the scene's. Exact ray-cylinder hits before the box pass. ``boxes`` (rows of
        ``LidarScene.boxes`` without the cos/sin columns) are seen too, for this scan only, with
        the scene's. ``scene_boxes`` (the simulation's path, no copy): every box of
        this scan, in ``LidarScene.boxes``' 9-column layout (the scene's, then the extra ones)."""
        s = self.scene
        all_boxes = s.boxes if scene_boxes is None else scene_boxes
        if boxes is not None and len(boxes):
            b = np.asarray(boxes, dtype=np.float64).reshape(-1, 7)
            all_boxes = np.concatenate([s.boxes, np.column_stack([b, np.cos(b[:, 2]), np.sin(b[:, 2])])])
        d = self.scene.discs if discs is None else np.ascontiguousarray(discs, dtype=np.float64).reshape(-1, 5)
        q, m = np.asarray(qpos), np.ascontiguousarray(mount, dtype=np.float64)
        if q.dtype != np.float64 or q.ndim != 1 or q.shape[0] < 7 or m.shape != (3,):
            raise SpecError("qpos", getattr(qpos, "shape", qpos), "a float64 (>= 7,) body pose and a (3,) mount")
        n = _raybox.body_scan_ranges(self._params, q, m, self._rot, self._origin, all_boxes, d, *self._arrays)
        if n < 0:
            raise SpecError("qpos", q[:7].tolist(), "a finite position and a unit quaternion (w, x, y, z)")
        return self._points(n, rng)

    def mounted_ranges(self, qpos: np.ndarray, mount: np.ndarray, mount_rot: np.ndarray, *,
                       discs: np.ndarray | None = None, scene_boxes: np.ndarray | None = None) -> int:
        """The ranges of a scan from a body pose with the sensor at ``mount`` turned by
        ``mount_rot`` (3, 3, body-from-sensor: the mount's roll, pitch, yaw) into the lidar's
        range buffer (:meth:`last_ranges`); returns the number of returns. ``discs`` and
        ``scene_boxes`` as in :meth:`scan_body`."""
        boxes = self.scene.boxes if scene_boxes is None else scene_boxes
        d = self.scene.discs if discs is None else np.ascontiguousarray(discs, dtype=np.float64).reshape(-1, 5)
        q, m = np.asarray(qpos), np.ascontiguousarray(mount, dtype=np.float64)
        mr = np.ascontiguousarray(mount_rot, dtype=np.float64)
        if q.dtype != np.float64 or q.ndim != 1 or q.shape[0] < 7 or m.shape != (3,) or mr.shape != (3, 3):
            raise SpecError("qpos", getattr(qpos, "shape", qpos), "a float64 (>= 7,) body pose, a (3,) mount and "
                            "a (3, 3) mount rotation")
        n = _raybox.mounted_scan_ranges(self._params, q, m, mr, self._rot, self._origin, boxes, d, *self._arrays)
        if n < 0:
            raise SpecError("qpos", q[:7].tolist(), "a finite position and a unit quaternion (w, x, y, z)")
        return int(n)

    def fan_ranges(self, qpos: np.ndarray, mount: np.ndarray, mount_rot: np.ndarray, columns: int, *,
                   discs: np.ndarray | None = None, scene_boxes: np.ndarray | None = None) -> tuple[np.ndarray, int]:
        """:meth:`mounted_ranges` cast for the first ``columns`` azimuth columns only (a
        ``lidar2d`` fan: its beams are the first columns of the turned full circle): the ranges
        (channels, columns) float64, inf = no return, bit for bit the first columns of
        :meth:`mounted_ranges` (the other columns are neither cast nor culled against; their
        boxes and discs are skipped per obstacle), and the number of returns. The buffer is
        overwritten by the next call."""
        if not (isinstance(columns, int) and 1 <= columns <= self.config.azimuth_steps):
            raise SpecError("columns", columns, f"an integer in [1, {self.config.azimuth_steps}]")
        fan = self._fans.get(columns)
        if fan is None:
            b = self._beams
            buf = np.empty((self.config.channels, columns), np.float64)
            fan = _raybox.scan_arrays(self.scene.grid, Beams(b.cos_el, b.sin_el, np.ascontiguousarray(b.cos_az[:columns]),
                                                             np.ascontiguousarray(b.sin_az[:columns])), buf)
            self._fans[columns] = fan
        boxes = self.scene.boxes if scene_boxes is None else scene_boxes
        d = self.scene.discs if discs is None else np.ascontiguousarray(discs, dtype=np.float64).reshape(-1, 5)
        q, m = np.asarray(qpos), np.ascontiguousarray(mount, dtype=np.float64)
        mr = np.ascontiguousarray(mount_rot, dtype=np.float64)
        if q.dtype != np.float64 or q.ndim != 1 or q.shape[0] < 7 or m.shape != (3,) or mr.shape != (3, 3):
            raise SpecError("qpos", getattr(qpos, "shape", qpos), "a float64 (>= 7,) body pose, a (3,) mount and "
                            "a (3, 3) mount rotation")
        n = _raybox.fan_scan_ranges(self._params, self.config.azimuth_steps, q, np.concatenate([mr, m[None, :]]),
                                    self._rot, self._origin, boxes, d, *fan)
        if n < 0:
            raise SpecError("qpos", q[:7].tolist(), "a finite position and a unit quaternion (w, x, y, z)")
        ranges = fan[-1]
        assert isinstance(ranges, np.ndarray)
        return ranges, int(n)

    def scan_mounted(self, qpos: np.ndarray, mount: np.ndarray, mount_rot: np.ndarray,
                     rng: np.random.Generator | None = None, *, discs: np.ndarray | None = None,
                     scene_boxes: np.ndarray | None = None) -> np.ndarray:
        """:meth:`scan_body` with the sensor turned on the body by ``mount_rot`` (see
        :meth:`mounted_ranges`): the points in the sensor frame, noise as :meth:`scan`'s."""
        n = self.mounted_ranges(qpos, mount, mount_rot, discs=discs, scene_boxes=scene_boxes)
        return self._points(n, rng)

    @property
    def last_ranges(self) -> np.ndarray:
        """The range buffer of the last scan, (channels, azimuth_steps) float64, inf = no return
        (overwritten by the next scan)."""
        return self._out

    @property
    def last_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """(origin (3,), world-from-sensor rotation (3, 3)) of the last body scan."""
        return self._origin, self._rot

    def _points(self, n: int, rng: np.random.Generator | None) -> np.ndarray:
        """The ``n`` returns in ``self._out`` as points, with the range noise of :meth:`scan`."""
        r = self._out
        std = self.config.range_noise_std_m
        pts = np.empty((n, 3), np.float32)
        if rng is None or std <= 0:
            _raycast.points_from_ranges(r, self._dirs, np.empty(0, np.float32), 0.0, pts)
            return pts
        m, s = (n + 1) // 2, _noise.default_spare(n)
        words = rng.bit_generator.random_raw(m + s)
        k = _noise.noisy_points(r, self._dirs, words[:m], words[m:], 0, float(std), pts)
        while k < n:  # spare words exhausted (practically never): refill, redo sample k
            k = _noise.noisy_points(r, self._dirs, words[:m], rng.bit_generator.random_raw(s), k, float(std), pts)
        return pts
