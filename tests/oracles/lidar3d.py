"""Analytic ranges of a ``lidar3d`` scan from a mount turned by roll, pitch, yaw: every ray of the
channels x azimuths grid (``LidarConfig.directions``) turned by body and mount, intersected with
the scene of :mod:`tests.oracles.lidar2d` (ground plane, boxes, cylinders). Test code only."""

from __future__ import annotations

import numpy as np

from tests.oracles.lidar2d import ranges as _ranges, sensor_pose


def scan_ranges(q: np.ndarray, mount_xyz: tuple[float, float, float], mount_rpy: tuple[float, float, float],
                directions: np.ndarray, **scene: object) -> np.ndarray:
    """(channels, azimuths) ranges (inf: none) for ``directions`` (channels, azimuths, 3) in the
    sensor frame; ``scene``: the keywords of :func:`tests.oracles.lidar2d.ranges`."""
    o, r = sensor_pose(q, mount_xyz, mount_rpy)
    d = directions.reshape(-1, 3) @ r.T
    return _ranges(o, d, **scene).reshape(directions.shape[:2])  # type: ignore[arg-type]
