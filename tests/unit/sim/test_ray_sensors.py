"""The ray sensors a simulation casts (navstress.sim.rays) against analytic scenes
(tests/oracles/lidar2d.py, tests/oracles/lidar3d.py): planar scanners pitched at the ground, tilted
bodies on slopes, box faces, the field of view's edges, range cut-offs, turned lidar3d mounts,
movers; noise and dropout statistics."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from navstress.sensors import Sensor
from navstress.sensors.registry import sensor_from_mapping
from navstress.sim.lidar import LidarScene
from navstress.sim.rays import Lidar2dCaster, Lidar3dCaster, circle_steps
from tests.oracles import lidar2d as o2
from tests.oracles.lidar3d import scan_ranges

CELL = 0.5
N = 81  # vertices per side: a 40 m map


def _scene(slope: tuple[float, float] = (0.0, 0.0), c: float = 0.0, boxes: tuple[tuple[float, ...], ...] = ()) -> LidarScene:
    """A planar ground z = a x + b y + c (exact on the grid's triangles) and boxes."""
    j, i = np.meshgrid(np.arange(N), np.arange(N))
    h = (slope[0] * j * CELL + slope[1] * i * CELL + c).astype(np.float32)
    return LidarScene(h, CELL, np.array(boxes, dtype=np.float64).reshape(-1, 7))


def _sensor(kind: str, xyz: tuple[float, float, float] = (0.0, 0.0, 0.3), rpy: tuple[float, float, float] = (0, 0, 0),
            name: str = "s", **params: Any) -> Sensor:
    return sensor_from_mapping({"name": name, "kind": kind, "mount": {"xyz": list(xyz), "rpy": list(rpy)}, **params},
                               where="sensors[0]", mounts={})


def _oracle2d(c: Lidar2dCaster, q: np.ndarray, **scene: Any) -> np.ndarray:
    o, r = o2.sensor_pose(q, c.mount, c.rpy)
    d = o2.fan(c.angle_min, c.angle_increment, c.beams) @ r.T
    return o2.ranges(o, d, min_range=c.min_range, max_range=c.max_range, **scene)


def _close(got: np.ndarray, want: np.ndarray, tol: float = 1e-6) -> None:
    assert np.array_equal(np.isfinite(got), np.isfinite(want)), np.flatnonzero(np.isfinite(got) != np.isfinite(want))
    ok = np.isfinite(want)
    assert np.max(np.abs(got[ok] - want[ok]), initial=0.0) <= tol * (1 + np.max(want[ok], initial=0.0))


@pytest.mark.parametrize("profile", ["ust10", "tim571", "rplidar_a2"])
def test_profiles_run_as_turned_full_circle_scans(profile: str) -> None:
    c = Lidar2dCaster(_sensor("lidar2d", profile=profile), 1, _scene())
    assert c.lidar is not None and circle_steps(c.angle_increment, c.beams) >= c.beams


@pytest.mark.parametrize("beams", [1081, 1001])  # 1001: 0.27 degrees apart (not a whole circle), the ray-by-ray path
@pytest.mark.parametrize("pitch_deg", [5.0, 12.0, 30.0])
def test_a_pitched_down_scanner_meets_flat_ground_where_geometry_says(beams: int, pitch_deg: float) -> None:
    c = Lidar2dCaster(_sensor("lidar2d", rpy=(0, math.radians(pitch_deg), 0), beams=beams, max_range_m=30.0), 1,
                      _scene())
    assert (c.lidar is None) == (beams == 1001)
    q = o2.qpos(20.0, 20.0, 0.2)
    got = c.ranges(q)
    _close(got, _oracle2d(c, q, plane=(0.0, 0.0, 0.0)))
    mid = beams // 2  # straight ahead: height / sin(pitch)
    assert got[mid] == pytest.approx(0.5 / math.sin(math.radians(pitch_deg)), rel=1e-9)
    assert np.isinf(got[0]) and np.isinf(got[-1])  # the edges (+-135 deg) point up and away


@pytest.mark.parametrize("slope,yaw", [(0.15, 0.0), (0.15, 0.7), (-0.1, 2.5)])
def test_a_level_scanner_on_a_body_tilted_by_a_slope_hits_the_slope(slope: float, yaw: float) -> None:
    """The body pitched nose-down on a downhill heading, the beams leave its plane: the ground
    ahead (uphill) or the ground all around at the distances of the tilted plane."""
    pitch = math.atan(slope) * 1.3  # tilted more than the ground: the fan meets it
    c = Lidar2dCaster(_sensor("lidar2d", max_range_m=30.0), 1, _scene((slope, 0.0)))
    z0 = slope * 20.0 + 0.2
    q = o2.qpos(20.0, 20.0, z0, pitch=pitch, yaw=yaw)
    got = c.ranges(q)
    _close(got, _oracle2d(c, q, plane=(slope, 0.0, 0.0)), 1e-5)
    assert np.isfinite(got).sum() > 50


def test_box_faces_fov_edges_and_range_cut_offs() -> None:
    boxes = ((25.0, 20.0, 0.0, 0.5, 2.0, -1.0, 3.0),  # face at x = 24.5: 4.5 m ahead
             (20.0 - 3 * math.sqrt(0.5), 20.0 - 3 * math.sqrt(0.5), math.pi / 4, 0.3, 0.3, -1.0, 3.0),  # -135 deg
             (16.0, 20.0, 0.0, 0.5, 0.5, -1.0, 3.0),  # straight behind: outside the 270 degrees
             (20.0, 20.04, 0.0, 0.01, 0.01, -1.0, 3.0))  # inside min range (0.06)
    c = Lidar2dCaster(_sensor("lidar2d", xyz=(0.0, 0.0, 0.3)), 1, _scene(c=-5.0, boxes=boxes))
    q = o2.qpos(20.0, 20.0, 0.2)
    got = c.ranges(q)
    want = _oracle2d(c, q, plane=(0.0, 0.0, -5.0), boxes=boxes)
    _close(got, want)
    assert got[540] == pytest.approx(4.5, abs=1e-9)  # straight ahead
    assert c.angle_min == pytest.approx(-0.75 * math.pi) and got[0] == pytest.approx(3.0 - 0.3, abs=1e-6)
    assert np.isinf(got[-1])  # +135 deg: nothing
    # the box behind is seen by none of the 1081 beams: the fan's ranges are all those of the others
    without = _oracle2d(c, q, plane=(0.0, 0.0, -5.0), boxes=boxes[:2] + boxes[3:])
    _close(got, without)
    # max range: the box ahead at 4.5 m is cut off at 4 m
    c4 = Lidar2dCaster(_sensor("lidar2d", max_range_m=4.0), 1, _scene(c=-5.0, boxes=boxes))
    r4 = c4.ranges(q)
    assert np.isinf(r4[540]) and np.isfinite(got[0]) and r4[0] == got[0]


@pytest.mark.parametrize("rpy", [(0.0, 0.0, math.pi / 2), (0.3, 0.0, 0.0), (0.2, 0.25, -1.0), (0.0, -0.2, 0.0)])
def test_a_turned_lidar3d_mount_turns_the_scan(rpy: tuple[float, float, float]) -> None:
    boxes = ((26.0, 21.0, 0.3, 1.0, 0.7, 0.0, 2.0), (17.0, 18.0, 0.0, 0.5, 0.5, 0.0, 4.0))
    s = _sensor("lidar3d", xyz=(0.2, 0.1, 0.6), rpy=rpy, channels=8, azimuth_steps=90, max_range_m=30.0)
    c = Lidar3dCaster(s, 1, _scene((0.05, -0.02), 0.0, boxes))
    q = o2.qpos(20.0, 20.0, 0.25, 0.05, -0.03, 0.4)
    pts = c.cast(q, 0.0, False, None, None).points
    want = scan_ranges(q, c.mount, rpy, c.lidar.config.directions(), plane=(0.05, -0.02, 0.0), boxes=boxes,
                       min_range=0.3, max_range=30.0)
    _close(c.lidar.last_ranges, want, 1e-5)
    assert len(pts) == int(np.isfinite(want).sum()) > 0


def test_a_lidar3d_yawed_a_quarter_turn_sees_the_columns_shifted() -> None:
    boxes = ((26.0, 21.0, 0.3, 1.0, 0.7, 0.0, 2.0),)
    scene = _scene((0.0, 0.0), 0.0, boxes)
    q = o2.qpos(20.0, 20.0, 0.25)
    a = Lidar3dCaster(_sensor("lidar3d", channels=4, azimuth_steps=360), 1, scene)
    b = Lidar3dCaster(_sensor("lidar3d", rpy=(0, 0, math.pi / 2), channels=4, azimuth_steps=360), 1, scene)
    a.cast(q, 0.0, False, None, None)
    ra = a.lidar.last_ranges.copy()
    b.cast(q, 0.0, False, None, None)
    _close(np.roll(b.lidar.last_ranges, 90, axis=1), ra, 1e-9)


def test_an_unturned_mount_keeps_the_lidars_own_path() -> None:
    """rpy 0: scan_body, bit for bit the points of the lidar before sensors were declared; the
    turned path with the identity gives the same ranges."""
    scene = _scene((0.05, 0.0), 0.0, ((26.0, 21.0, 0.3, 1.0, 0.7, 0.0, 2.0),))
    c = Lidar3dCaster(_sensor("lidar3d"), 1, scene)
    assert not c.turned
    q = o2.qpos(20.0, 20.0, 1.3, 0.02, 0.01, 0.3)
    p1 = c.cast(q, 0.0, False, None, None).points
    r1 = c.lidar.last_ranges.copy()
    p2 = c.lidar.scan_mounted(q, c.mount_v, np.eye(3))
    assert np.array_equal(r1, c.lidar.last_ranges) and np.array_equal(p1, p2)


def test_movers_are_seen_by_the_planar_scanner() -> None:
    discs = np.array([[23.0, 20.0, 0.4, 0.0, 1.8]])
    mover_box = (20.0, 23.0, 0.2, 0.5, 0.3, 0.0, 1.5)
    scene = _scene()
    boxes = np.zeros((1, 9))
    boxes[0, :7] = mover_box
    boxes[0, 7:] = math.cos(0.2), math.sin(0.2)
    q = o2.qpos(20.0, 20.0, 0.2)
    for beams in (1081, 1001):
        c = Lidar2dCaster(_sensor("lidar2d", beams=beams), 1, scene)
        got = c.ranges(q, discs, boxes)
        _close(got, _oracle2d(c, q, plane=(0.0, 0.0, 0.0), boxes=(mover_box,), discs=(tuple(discs[0]),)))
        assert np.nanmin(np.where(np.isfinite(got), got, np.nan)) == pytest.approx(2.6, abs=1e-6)


def test_noise_and_dropouts_have_the_configured_statistics() -> None:
    boxes = ((20.0, 20.0, 0.0, 3.0, 3.0, -1.0, 3.0),)  # the scanner inside a box: every beam returns
    c = Lidar2dCaster(_sensor("lidar2d", range_noise_std_m=0.05, dropout_prob=0.1), 7, _scene(c=-5.0, boxes=boxes))
    q = o2.qpos(20.0, 20.0, 0.2)
    clean = c.ranges(q)
    assert np.isfinite(clean).all()
    err, lost, total = [], 0, 0
    for k in range(40):
        r = c.cast(q, 0.1 * k, True, None, None).ranges.astype(np.float64)
        ok = np.isfinite(r)
        err.append(r[ok] - clean[ok])
        lost += int((~ok).sum())
        total += r.size
    e = np.concatenate(err)
    assert abs(e.mean()) < 4 * 0.05 / math.sqrt(e.size)
    assert e.std() == pytest.approx(0.05, rel=0.03)
    p = lost / total
    assert abs(p - 0.1) < 4 * math.sqrt(0.1 * 0.9 / total)
    # noise off: the clean ranges exactly (as float32)
    assert np.array_equal(c.cast(q, 0.0, False, None, None).ranges, clean.astype(np.float32))
