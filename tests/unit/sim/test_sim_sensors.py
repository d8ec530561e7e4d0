"""Sensors and observer in isolation: analytic cross-checks and event bookkeeping."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings, strategies as st
from scipy.spatial.transform import Rotation

from navstress.sim.observer import Observer
from navstress.sim.sensors import euler_from_mat
from tests.oracles.sensors import ImuSensor, PoseSensor, WheelOdometry


@settings(max_examples=50, deadline=None)
@given(yaw=st.floats(-3.1, 3.1), pitch=st.floats(-1.5, 1.5), roll=st.floats(-3.1, 3.1))
def test_euler_matches_scipy_zyx(yaw: float, pitch: float, roll: float) -> None:
    r = Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix()
    np.testing.assert_allclose(euler_from_mat(r), (yaw, pitch, roll), atol=1e-9)


@settings(max_examples=50, deadline=None)
@given(dl=st.floats(-3.0, 3.0), dr=st.floats(-3.0, 3.0))
def test_odometry_single_update_is_the_exact_arc(dl: float, dr: float) -> None:
    """One update equals the exact circular arc of a differential drive (left/right travel)."""
    r, track = 0.25, 1.5
    od = WheelOdometry(r, track, np.zeros(4), 0.0)
    o = od.update(np.array([dl, dl, dr, dr]) / r, 1.0)
    sl, sr = dl, dr
    th = (sr - sl) / track
    s = (sl + sr) / 2
    if abs(th) < 1e-9:
        ex, ey = s, 0.0
    else:
        rad = s / th
        ex, ey = rad * math.sin(th), rad * (1 - math.cos(th))
    assert math.isclose(o.x, ex, abs_tol=1e-9) and math.isclose(o.y, ey, abs_tol=1e-9)
    assert math.isclose(o.v, s, abs_tol=1e-12) and math.isclose(o.omega, th, abs_tol=1e-12)


def test_noise_is_seeded_and_off_means_exact() -> None:
    a = PoseSensor(np.random.default_rng(1), 0.1, 0.01, True).read(0.0, np.zeros(3), 0.0, 0.0, 0.0)
    b = PoseSensor(np.random.default_rng(1), 0.1, 0.01, True).read(0.0, np.zeros(3), 0.0, 0.0, 0.0)
    c = PoseSensor(np.random.default_rng(2), 0.1, 0.01, True).read(0.0, np.zeros(3), 0.0, 0.0, 0.0)
    assert a == b and a != c
    exact = PoseSensor(np.random.default_rng(1), 0.1, 0.01, False).read(1.0, np.array([1.0, 2.0, 3.0]), 0.5, 0.1, 0.2)
    assert (exact.x, exact.y, exact.z, exact.yaw, exact.pitch, exact.roll) == (1.0, 2.0, 3.0, 0.5, 0.1, 0.2)


def test_imu_yaw_drifts_as_a_random_walk() -> None:
    """Yaw bias std after T seconds is drift*sqrt(T) (checked over many seeds, 15 %)."""
    ends = []
    for seed in range(300):
        imu = ImuSensor(np.random.default_rng(seed), 0.0, 0.0, 0.01, True, 0.0)
        for k in range(1, 101):
            out = imu.read(k * 1.0, 0.0, 0.0, 0.0, np.zeros(3))
        ends.append(out.yaw)
    assert np.std(ends) == __import__("pytest").approx(0.01 * math.sqrt(100), rel=0.15)


def test_observer_debounces_sustained_contact_but_counts_starts() -> None:
    ob = Observer(debounce_s=0.5)
    ob.contacts(1.0, 0, 0, {3})
    ob.contacts(1.1, 0, 0, {3})
    ob.contacts(1.2, 0, 0, set())  # a short bounce
    ob.contacts(1.3, 0, 0, {3})
    ob.contacts(1.4, 0, 0, {3, 5})
    ob.contacts(1.5, 0, 0, set())
    ob.contacts(2.5, 0, 0, {3})  # long after: a new event
    assert [(e.t, e.obstacle) for e in ob.collisions] == [(1.0, 3), (1.4, 5), (2.5, 3)]
    assert ob.contact_starts == 4


def test_observer_pose_arrays_grow() -> None:
    ob = Observer(0.5)
    for k in range(1000):
        ob.record_pose((k * 0.1, k, 0, 0, 0, 0, 0))
    p = ob.poses
    assert p.shape == (1000, 7) and p[-1, 1] == 999 and not p.flags.writeable
