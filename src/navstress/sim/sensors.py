"""Sensor-frame arithmetic shared outside the compiled step: Euler angles of a rotation.

The sensors themselves (wheel odometry, pose, IMU) run compiled in ``navstress.sim._step``
(``odom_update``, ``_fire``); their Python references, which the tests compare the compiled
step with, are in ``tests/oracles/sensors.py``.
"""

from __future__ import annotations

import math

import numpy as np


def euler_from_mat(r: np.ndarray) -> tuple[float, float, float]:
    """(yaw, pitch, roll), Z-Y-X convention, from a 3x3 world-from-body rotation."""
    yaw = math.atan2(float(r[1, 0]), float(r[0, 0]))
    pitch = math.asin(max(-1.0, min(1.0, -float(r[2, 0]))))
    roll = math.atan2(float(r[2, 1]), float(r[2, 2]))
    return yaw, pitch, roll
