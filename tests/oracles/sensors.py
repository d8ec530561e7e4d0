"""The Python sensors: wheel odometry, pose sensor, IMU, each drawing from its own generator.

:class:`~navstress.sim.simulation.Simulation` runs the same arithmetic compiled
(``navstress.sim._step``: ``odom_update``, ``_fire``); these classes are the reference the tests
compare it with. Readings are the ``navstress.nav.api`` types. Test code only.
"""

from __future__ import annotations

import math

import numpy as np

from navstress.nav.api import Imu, Odometry, PoseReading


def wrap(a: float) -> float:
    """Angle wrapped to [-pi, pi)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


class WheelOdometry:
    """Differential-drive dead reckoning from wheel joint angles.

    Left/right travel is the wheel radius times the mean rotation of the two wheels of a side;
    the heading change uses the calibrated effective track (``track_m``, the skid steer's
    geometric track times its skid factor, as a real platform's odometry is calibrated). Wheel
    slip and skid therefore show up as odometry drift. Each update integrates the exact arc.
    The simulation runs the same arithmetic compiled (``navstress.sim._step.odom_update``).
    """

    def __init__(self, wheel_radius_m: float, track_m: float, wheel_angles: np.ndarray, t: float) -> None:
        self.r = wheel_radius_m
        self.track = track_m
        self.prev = np.asarray(wheel_angles, dtype=np.float64).copy()
        self.x = self.y = self.yaw = 0.0
        self.t = t
        self.last = Odometry(t, 0.0, 0.0, 0.0, 0.0, 0.0)

    def update(self, wheel_angles: np.ndarray, t: float) -> Odometry:
        a = np.asarray(wheel_angles, dtype=np.float64)
        d = a - self.prev  # FL, RL, FR, RR
        self.prev = a.copy()
        dl = self.r * 0.5 * float(d[0] + d[1])
        dr = self.r * 0.5 * float(d[2] + d[3])
        ds = 0.5 * (dl + dr)
        dth = (dr - dl) / self.track
        if abs(dth) > 1e-9:  # the exact circular arc
            k = ds / dth
            self.x += k * (math.sin(self.yaw + dth) - math.sin(self.yaw))
            self.y += k * (math.cos(self.yaw) - math.cos(self.yaw + dth))
        else:
            self.x += ds * math.cos(self.yaw)
            self.y += ds * math.sin(self.yaw)
        self.yaw = wrap(self.yaw + dth)
        dt = t - self.t
        self.t = t
        v, om = (ds / dt, dth / dt) if dt > 0 else (self.last.v, self.last.omega)
        self.last = Odometry(t, self.x, self.y, self.yaw, v, om)
        return self.last


class PoseSensor:
    """The paper's "Pose": true position and attitude plus independent Gaussian noise."""

    def __init__(self, gen: np.random.Generator, pos_std: float, att_std: float, noise: bool) -> None:
        self.gen, self.pos_std, self.att_std, self.noise = gen, pos_std, att_std, noise

    def read(self, t: float, pos: np.ndarray, yaw: float, pitch: float, roll: float) -> PoseReading:
        if self.noise:
            e = self.gen.standard_normal(6)
            p = (float(pos[0]) + self.pos_std * e[0], float(pos[1]) + self.pos_std * e[1],
                 float(pos[2]) + self.pos_std * e[2])
            return PoseReading(t, *p, wrap(yaw + self.att_std * e[3]), pitch + self.att_std * e[4],
                               roll + self.att_std * e[5])
        return PoseReading(t, float(pos[0]), float(pos[1]), float(pos[2]), yaw, pitch, roll)


class ImuSensor:
    """Roll/pitch with white noise; yaw with white noise plus a random-walk bias (drift);
    body angular rates with white noise."""

    def __init__(self, gen: np.random.Generator, att_std: float, rate_std: float, drift: float,
                 noise: bool, t: float) -> None:
        self.gen, self.att_std, self.rate_std, self.drift, self.noise = gen, att_std, rate_std, drift, noise
        self.bias = 0.0
        self.t = t

    def read(self, t: float, yaw: float, pitch: float, roll: float, rates: np.ndarray) -> Imu:
        dt = max(t - self.t, 0.0)
        self.t = t
        w = (float(rates[0]), float(rates[1]), float(rates[2]))
        if not self.noise:
            return Imu(t, roll, pitch, yaw, w)
        e = self.gen.standard_normal(7)
        self.bias += self.drift * math.sqrt(dt) * e[0]
        a = self.att_std
        return Imu(t, roll + a * e[1], pitch + a * e[2], wrap(yaw + self.bias + a * e[3]),
                   (w[0] + self.rate_std * e[4], w[1] + self.rate_std * e[5], w[2] + self.rate_std * e[6]))

    def read_many(self, samples: np.ndarray) -> Imu:
        """:meth:`read` for each row (t, yaw, pitch, roll, wx, wy, wz) in order (the same draws,
        one batch); returns the last reading."""
        n = samples.shape[0]
        if n == 0:
            raise ValueError("read_many needs at least one sample")
        if not self.noise:
            r = samples[-1]
            self.t = float(r[0])
            return self.read(self.t, float(r[1]), float(r[2]), float(r[3]), r[4:7])
        e = self.gen.standard_normal((n, 7))
        for i in range(n):  # the bias random walk over every sample
            t = float(samples[i, 0])
            self.bias += self.drift * math.sqrt(max(t - self.t, 0.0)) * float(e[i, 0])
            self.t = t
        r, z = samples[-1], e[-1]
        a, rs = self.att_std, self.rate_std
        return Imu(self.t, float(r[3]) + a * float(z[1]), float(r[2]) + a * float(z[2]),
                   wrap(float(r[1]) + self.bias + a * float(z[3])),
                   (float(r[4]) + rs * float(z[4]), float(r[5]) + rs * float(z[5]), float(r[6]) + rs * float(z[6])))
