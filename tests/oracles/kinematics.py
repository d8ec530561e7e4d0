"""Analytic kinematics of wheeled bases: the unicycle (a differential or skid-steer base seen as a
twist) and the bicycle (an Ackermann base about its rear axle). Test code only: the simulation's
measured motion is compared with these."""

from __future__ import annotations

import math


def unicycle(pose: tuple[float, float, float], v: float, w: float, t: float) -> tuple[float, float, float]:
    """The pose after ``t`` seconds at constant forward speed ``v`` and yaw rate ``w`` (exact arc)."""
    x, y, th = pose
    if abs(w) < 1e-12:
        return x + v * t * math.cos(th), y + v * t * math.sin(th), th
    return (x + v / w * (math.sin(th + w * t) - math.sin(th)), y + v / w * (math.cos(th) - math.cos(th + w * t)),
            th + w * t)


def bicycle_steer(v: float, w: float, wheelbase: float) -> float:
    """The bicycle model's steering angle for the twist (v, w) about the rear axle."""
    return math.atan(wheelbase * w / v)


def bicycle_yaw_rate(v: float, steer: float, wheelbase: float) -> float:
    """Yaw rate of a bicycle at rear-axle speed ``v`` and steering angle ``steer``."""
    return v * math.tan(steer) / wheelbase


def ackermann_angles(steer: float, wheelbase: float, track: float) -> tuple[float, float]:
    """(left, right) front wheel angles of an Ackermann linkage for the bicycle angle ``steer``:
    both wheel axles point at the turn centre on the rear axle line."""
    if abs(steer) < 1e-12:
        return 0.0, 0.0
    radius = wheelbase / math.tan(steer)  # signed: > 0 turning left
    return math.atan(wheelbase / (radius - track / 2)), math.atan(wheelbase / (radius + track / 2))


def coulomb_track_multiplier(half_wheelbase: float, half_track: float) -> float:
    """Effective track / track of a four-wheel skid steer turning in place with Coulomb friction and
    equal loads on wheels at (+-a, +-b): 1 + (a / b)^2."""
    return 1.0 + (half_wheelbase / half_track) ** 2
