"""``pose``: the paper's pose sensor, noisy position and attitude in the map frame, computed in
the compiled step. Built in: every robot has one, named ``pose``, its figures in ``sim:``
(``pose_rate_hz``, ``pose_pos_std_m``, ``pose_att_std_rad``). Reading: :class:`PoseReading`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from navstress.sensors.base import SensorKind, SensorParams
from navstress.sensors.wirefields import num


@dataclass(frozen=True)
class PoseReading:
    """The pose sensor (the paper's "Pose"): noisy position and attitude in the map frame."""

    t: float
    x: float
    y: float
    z: float
    yaw: float
    pitch: float
    roll: float


FIELDS = ("t", "x", "y", "z", "yaw", "pitch", "roll")


def to_wire(r: PoseReading) -> dict[str, Any]:
    """The pose sensor for the line protocol (as version 1's ``pose``)."""
    return {k: float(getattr(r, k)) for k in FIELDS}


def from_wire(d: dict[str, Any]) -> PoseReading:
    """Inverse of :func:`to_wire`; ValueError naming the bad field."""
    return PoseReading(*(num(d, k) for k in FIELDS))


KIND = SensorKind(name="pose", params=SensorParams, profiles={"builtin": {"rate_hz": 10.0}},
                  default_profile="builtin", reading=PoseReading, caster="builtin",
                  summary="pose in the map frame (built in: `pose`, configured in sim:)",
                  to_wire=to_wire, from_wire=from_wire)
