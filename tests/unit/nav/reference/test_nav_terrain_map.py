"""DTM: points land in the right cells, unknown stays NaN, walls are obstacles, slopes are not."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.support.nav_scenes import BASE_H, MOUNT, Scene, scan_points

from navstress.nav.reference.planner import footprint_slope_roughness
from navstress.nav.reference.pose import Pose, sensor_to_map
from navstress.nav.reference.terrain_map import TerrainMap, step_threshold

STEP = step_threshold(0.3, 25.0, 0.3)


def _map(cell: float = 0.3) -> TerrainMap:
    return TerrainMap((-30.0, -30.0), (200, 200), cell, step_threshold(0.3, 25.0, cell), 40.0)


def test_flat_scan_wall_obstacle_shadow_unknown_blind_zone_unknown() -> None:
    wall = (5.0, -3.0, 0.0, 5.4, 3.0, 2.0)
    scene = Scene(boxes=(wall,))
    m = _map()
    pose = Pose(0.0, 0.0, 0.0, BASE_H, 0.0, 0.0, 0.0)
    assert m.integrate(scan_points(scene, 0.0, 0.0, BASE_H, 0.0), MOUNT, pose) > 5000
    elev, obst = m.elevation(), m.obstacles()
    # ground seen around the sensor (x = 0.35) at height 0: dense within ~3 m, rings farther out
    ii, jj = np.indices(elev.shape)
    cx, cy = m.origin[0] + (jj + 0.5) * m.cell_m, m.origin[1] + (ii + 0.5) * m.cell_m
    r = np.hypot(cx - 0.35, cy)
    ring = (r > 2.0) & (r < 3.0)
    assert np.isfinite(elev[ring]).mean() > 0.9
    near = (r > 1.8) & (r < 12.0) & (cx < 4.5) & np.isfinite(elev)
    assert near.sum() > 400 and np.abs(elev[near]).max() < 0.02 and not obst[near].any()
    # the wall's face cells are obstacles (cell holding x = 5.0)
    for y in (-2.0, 0.0, 2.0):
        i, j = m.cell_of(5.01, y)
        assert obst[i, j]
    # behind the wall: never seen; under the robot (lidar blind zone): never seen
    for x, y in ((7.0, 0.0), (0.0, 0.0), (0.8, 0.5)):
        i, j = m.cell_of(x, y)
        assert np.isnan(elev[i, j]) and not obst[i, j]
    # no obstacle away from the wall
    ii, jj = np.nonzero(obst)
    xs = m.origin[0] + (jj + 0.5) * m.cell_m
    assert xs.min() > 4.5 and xs.max() < 5.8


@pytest.mark.parametrize("deg", [0.0, 8.0, 15.0, 22.0])
def test_slope_estimated_from_sloped_plane_and_not_an_obstacle(deg: float) -> None:
    a = math.tan(math.radians(deg))
    scene = Scene(a=a * math.cos(0.5), b=a * math.sin(0.5))  # gradient direction 0.5 rad
    m = _map()
    # the robot stands level-ish on the slope: give it the plane's pitch/roll (robot yaw 0)
    pitch = -math.atan(scene.a)
    roll = math.atan(scene.b * math.cos(pitch))
    for x in np.arange(0.0, 3.0, 0.3):  # the robot drives: the lidar rings sweep the ground
        z = scene.ground_z(x, 0.0) + BASE_H
        m.integrate(scan_points(scene, x, 0.0, z, 0.0, pitch, roll), MOUNT, Pose(0.0, x, 0.0, z, 0.0, pitch, roll))
    for yaw in (0.0, 1.0, 2.5):
        s, r = footprint_slope_roughness(m, 4.0, 1.0, yaw, 0.67, 0.435)
        assert s == pytest.approx(deg, abs=1.0)
        assert r < 0.06
    i, j = m.cell_of(4.0, 1.0)
    assert m.elevation()[i, j] == pytest.approx(scene.ground_z(*m.cell_center(i, j)), abs=0.08)
    assert not m.obstacles().any()


def test_pitch_is_used_when_placing_points() -> None:
    """Same scan, placed with a wrong (zero) pitch, gives a tilted, wrong map: the pose matters."""
    scene = Scene(a=math.tan(math.radians(12.0)))
    pitch = -math.radians(12.0)
    pts = scan_points(scene, 0.0, 0.0, BASE_H, 0.0, pitch, 0.0)
    good, bad = _map(), _map()
    good.integrate(pts, MOUNT, Pose(0.0, 0.0, 0.0, BASE_H, 0.0, pitch, 0.0))
    bad.integrate(pts, MOUNT, Pose(0.0, 0.0, 0.0, BASE_H, 0.0, 0.0, 0.0))
    sg, _ = footprint_slope_roughness(good, 2.5, 0.0, 0.0, 0.67, 0.435)
    sb, _ = footprint_slope_roughness(bad, 2.5, 0.0, 0.0, 0.67, 0.435)
    assert sg == pytest.approx(12.0, abs=1.0) and sb < 3.0


def test_empty_nan_and_outside_points_are_harmless() -> None:
    m = _map()
    pose = Pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert m.integrate(np.zeros((0, 3), np.float32), MOUNT, pose) == 0
    pts = np.array([[np.nan, 0, 0], [1000.0, 0, 0], [2.0, 0.0, -1.0]], np.float32)
    m.max_range_m = 2000.0
    assert m.integrate(pts, MOUNT, pose) == 1
    assert int(m.count.sum()) == 1
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        m.integrate(np.zeros((4, 2)), MOUNT, pose)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-3, 3), st.floats(-3, 3), st.floats(-math.pi, math.pi))
def test_integration_matches_brute_force_binning(seed: int, x: float, y: float, yaw: float) -> None:
    g = np.random.default_rng(seed)
    pts = g.uniform(-15, 15, (500, 3)).astype(np.float32)
    pose = Pose(0.0, x, y, 0.3, yaw, 0.05, -0.02)
    m = TerrainMap((-10.0, -8.0), (50, 60), 0.3, STEP, 100.0)
    n = m.integrate(pts, MOUNT, pose)
    world = sensor_to_map(pts.astype(np.float64), MOUNT, pose)
    i = np.floor((world[:, 1] + 8.0) / 0.3).astype(int)
    j = np.floor((world[:, 0] + 10.0) / 0.3).astype(int)
    inside = (i >= 0) & (i < 50) & (j >= 0) & (j < 60)
    assert n == int(inside.sum())
    cnt = np.zeros((50, 60), int)
    np.add.at(cnt, (i[inside], j[inside]), 1)
    assert np.array_equal(cnt, m.count)
    zs = np.zeros((50, 60))
    np.add.at(zs, (i[inside], j[inside]), world[inside, 2])
    k = cnt > 0
    assert np.allclose(m.elevation()[k], zs[k] / cnt[k], atol=1e-4)
    assert np.all(m.zmin[k] <= m.zmax[k])
    assert np.isnan(m.elevation()[~k]).all()


def test_fill_unknown_uses_the_surrounding_ground_plane() -> None:
    scene = Scene(a=0.1, c=0.5)
    m = _map()
    m.integrate(scan_points(scene, 0.0, 0.0, 0.5 + BASE_H, 0.0, -math.atan(0.1), 0.0), MOUNT,
                Pose(0.0, 0.0, 0.0, 0.5 + BASE_H, 0.0, -math.atan(0.1), 0.0))
    i, j = m.cell_of(0.0, 0.0)
    assert m.count[i, j] == 0
    filled = m.fill_unknown(np.array([i]), np.array([j]), (0.0, 0.0), 3.0, fallback_z=-99.0)
    assert filled == 1
    assert m.elevation()[i, j] == pytest.approx(scene.ground_z(*m.cell_center(i, j)), abs=0.05)
    # nothing known around: fallback height
    empty = _map()
    empty.fill_unknown(np.array([i]), np.array([j]), (0.0, 0.0), 3.0, fallback_z=-1.5)
    assert empty.elevation()[i, j] == -1.5


# ---------------------------------------------------------------- fine obstacle layer
def test_fine_layer_places_a_wall_face_within_a_fine_cell_where_the_coarse_cell_dilates_it() -> None:
    # face at x = 5.05: the coarse cell holding it starts at 4.8 (0.25 m early), the fine one at 5.0
    wall = (5.05, -3.0, 0.0, 5.45, 3.0, 2.0)
    m = _map()
    pose = Pose(0.0, 0.0, 0.0, BASE_H, 0.0, 0.0, 0.0)
    m.integrate(scan_points(Scene(boxes=(wall,)), 0.0, 0.0, BASE_H, 0.0), MOUNT, pose)
    fine, coarse = m.fine_obstacles(), m.obstacles()
    assert fine.shape == (600, 600) and m.fine_cell_m == pytest.approx(0.1)
    fi, fj = np.nonzero(fine)
    fx = m.origin[0] + (fj + 0.5) * m.fine_cell_m
    fy = m.origin[1] + (fi + 0.5) * m.fine_cell_m
    assert fx.min() > 5.0 and fx.max() < 5.2  # only the face's fine column (range noise-free scan)
    assert np.abs(fy).max() < 3.1
    ci, cj = np.nonzero(coarse)
    assert (m.origin[0] + cj * m.cell_m).min() < 4.85  # the coarse layer starts 0.25 m before the face
    # every fine obstacle lies in a coarse obstacle cell
    assert coarse[fi // m.sub, fj // m.sub].all()


def test_fine_layer_keeps_each_cells_latest_scan_and_forgets_a_ghost() -> None:
    # the same wall seen once with a pose 0.2 m off (a ghost 0.2 m nearer), then with the right pose
    wall = (5.05, -3.0, 0.0, 5.45, 3.0, 2.0)
    pts = scan_points(Scene(boxes=(wall,)), 0.0, 0.0, BASE_H, 0.0)
    m = _map()
    m.integrate(pts, MOUNT, Pose(0.0, -0.2, 0.0, BASE_H, 0.0, 0.0, 0.0))
    ghost = m.fine_obstacles()
    gx = m.origin[0] + (np.nonzero(ghost)[1].min() + 0.5) * m.fine_cell_m
    assert 4.8 < gx < 4.9
    m.integrate(pts, MOUNT, Pose(0.1, 0.0, 0.0, BASE_H, 0.0, 0.0, 0.0))
    fine = m.fine_obstacles()
    fx = m.origin[0] + (np.nonzero(fine)[1] + 0.5) * m.fine_cell_m
    assert fx.min() > 5.0 and fx.max() < 5.2
    # the coarse statistics keep every hit: the ghost stays a coarse obstacle
    i, j = m.cell_of(4.85, 0.0)
    assert m.obstacles()[i, j]


def test_bad_obstacle_subcells_is_refused() -> None:
    with pytest.raises(ValueError, match="obstacle_subcells=0"):
        TerrainMap((0.0, 0.0), (10, 10), 0.3, obstacle_subcells=0)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 400), st.integers(1, 400))
def test_fine_layer_and_stats_match_brute_force_over_two_scans(seed: int, n1: int, n2: int) -> None:
    """Two scans of different sizes (the scratch buffers grow): exact min/max/sum/count per cell
    in point order, and per fine sub-cell the max z of the latest scan that hit its cell."""
    g = np.random.default_rng(seed)
    m = TerrainMap((-5.0, -4.0), (20, 30), 0.3, STEP, 100.0)
    pose = Pose(0.0, 0.2, -0.1, 0.3, 0.4, 0.03, -0.02)
    scans = [g.uniform(-6, 6, (n, 3)).astype(np.float32) for n in (n1, n2)]
    zmin = np.full((20, 30), np.inf)
    zmax = np.full((20, 30), -np.inf)
    zsum = np.zeros((20, 30))
    cnt = np.zeros((20, 30))
    fine = np.full((60, 90), -np.inf, dtype=np.float32)
    for pts in scans:
        m.integrate(pts, MOUNT, pose)
        r, t = pose.sensor_transform(MOUNT)
        inv = 1.0 / 0.3
        hit_now = np.zeros((20, 30), bool)
        latest = np.full((60, 90), -np.inf, dtype=np.float32)
        for px, py, pz in pts.astype(np.float64).tolist():  # point order, the map's arithmetic
            x = r[0, 0] * px + r[0, 1] * py + r[0, 2] * pz + t[0]
            y = r[1, 0] * px + r[1, 1] * py + r[1, 2] * pz + t[1]
            z = r[2, 0] * px + r[2, 1] * py + r[2, 2] * pz + t[2]
            fi, fj = (y + 4.0) * inv, (x + 5.0) * inv
            if not (0 <= fi < 20 and 0 <= fj < 30):
                continue
            i, j = int(fi), int(fj)
            zmin[i, j], zmax[i, j] = min(zmin[i, j], z), max(zmax[i, j], z)
            zsum[i, j] += z
            cnt[i, j] += 1
            hit_now[i, j] = True
            u = min(max(int((y + 4.0) * (3 * inv)) - 3 * i, 0), 2)
            v = min(max(int((x + 5.0) * (3 * inv)) - 3 * j, 0), 2)
            latest[3 * i + u, 3 * j + v] = max(latest[3 * i + u, 3 * j + v], np.float32(z))
        mask = np.repeat(np.repeat(hit_now, 3, axis=0), 3, axis=1)
        fine[mask] = latest[mask]
    assert np.array_equal(m.zmin, zmin) and np.array_equal(m.zmax, zmax)
    assert np.array_equal(m.zsum, zsum) and np.array_equal(m.count, cnt)
    got = m.fine[:, :, :9].reshape(20, 30, 3, 3).transpose(0, 2, 1, 3).reshape(60, 90)
    assert np.array_equal(got, fine)


def test_fill_unknown_changes_nothing_when_every_cell_is_known() -> None:
    m = TerrainMap((0.0, 0.0), (10, 10), 0.5, STEP, 40.0)
    m.stats[:, :, 0] = m.stats[:, :, 1] = m.stats[:, :, 2] = 1.5
    m.stats[:, :, 3] = 1.0
    m.stats[4, 6] = (np.inf, -np.inf, 0.0, 0.0)  # unknown, but not among the cells asked
    before = m.stats.copy()
    ii, jj = np.array([2, 3, 3], dtype=np.int64), np.array([2, 2, 3], dtype=np.int64)
    assert m.fill_unknown(ii, jj, (1.5, 1.5), 2.0, 0.0) == 0
    assert np.array_equal(m.stats, before)
    assert m.fill_unknown(np.array([4]), np.array([6]), (3.0, 2.0), 2.0, 0.0) == 1
    assert m.count[4, 6] == 1 and m.zmin[4, 6] == m.zmax[4, 6]
