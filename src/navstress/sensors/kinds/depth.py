"""``depth``: a ray-cast depth camera (pinhole). ``width`` x ``height`` pixels over a horizontal
field of view ``hfov_deg`` (the vertical one follows from square pixels unless ``vfov_deg`` is
given), looking along the sensor's +x. A pixel's value is its depth: the distance along the
optical axis (the sensor's +x) to the first surface through the pixel's centre, as depth cameras
report it (REP 118); ``inf`` where nothing is within [``min_range_m``, ``max_range_m``] of depth.
Noise grows with the square of the depth, as a stereo camera's does: N(0, ``noise_std_at_1m_m``
x depth^2); each pixel is lost with ``dropout_prob``.

Reading: :class:`DepthImage` (the image and the intrinsics a ``sensor_msgs/CameraInfo`` holds).

Profile (sources in docs/sensors.md): ``d435`` (Intel RealSense D435 class, the default).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydantic import Field, model_validator

from navstress.errors import SpecError
from navstress.sensors import encode
from navstress.sensors.base import SensorKind, SensorParams
from navstress.sensors.wirefields import array, f32, num, pose_fields, text, vec3


class DepthParams(SensorParams):
    """A depth camera's figures (defaults: RealSense D435 class at 424 x 240, 15 Hz)."""

    width: int = Field(424, ge=1, le=4096)
    height: int = Field(240, ge=1, le=4096)
    hfov_deg: float = Field(87.0, gt=0, lt=180.0)
    vfov_deg: float | None = Field(None, gt=0, lt=180.0, description="None: square pixels")
    rate_hz: float = Field(15.0, gt=0)
    min_range_m: float = Field(0.105, ge=0)
    max_range_m: float = Field(10.0, gt=0)
    noise_std_at_1m_m: float = Field(0.01, ge=0, description="depth noise std at 1 m; grows with depth^2")
    dropout_prob: float = Field(0.0, ge=0, lt=1, description="chance that a pixel is lost")

    @model_validator(mode="after")
    def _check(self) -> "DepthParams":
        if self.max_range_m <= self.min_range_m:
            raise SpecError("max_range_m", self.max_range_m, f"a distance > min_range_m={self.min_range_m}")
        return self

    def intrinsics(self) -> tuple[float, float, float, float]:
        """(fx, fy, cx, cy) in pixels: pixel (u, v)'s centre is at (u + 0.5, v + 0.5)."""
        fx = self.width / 2 / math.tan(math.radians(self.hfov_deg) / 2)
        fy = fx if self.vfov_deg is None else self.height / 2 / math.tan(math.radians(self.vfov_deg) / 2)
        return fx, fy, self.width / 2, self.height / 2


@dataclass(frozen=True, eq=False)
class DepthImage:
    """One depth frame: ``depth`` (height, width) float32 meters along the optical axis, ``inf``
    where there is no return; row 0 is the top of the image, column 0 its left. ``fx, fy, cx, cy``:
    the pinhole intrinsics (pixels). ``t``, ``mount``, ``rpy``, ``sensor`` as for every reading.
    The optical frame (z forward, x right, y down) is the sensor frame rotated; the pixel (u, v)
    looks along (1, -(u + 0.5 - cx) / fx, -(v + 0.5 - cy) / fy) in the sensor frame."""

    t: float
    depth: np.ndarray
    fx: float
    fy: float
    cx: float
    cy: float
    mount: tuple[float, float, float]
    rpy: tuple[float, float, float]
    sensor: str

    def points(self) -> np.ndarray:
        """The returns as (N, 3) float32 points in the sensor frame."""
        h, w = self.depth.shape
        v, u = np.mgrid[0:h, 0:w]
        ok = np.isfinite(self.depth)
        z = self.depth[ok].astype(np.float64)
        return np.stack([z, -(u[ok] + 0.5 - self.cx) / self.fx * z, -(v[ok] + 0.5 - self.cy) / self.fy * z],
                        axis=1).astype(np.float32)


def rays(p: DepthParams) -> np.ndarray:
    """(height, width, 3) directions in the sensor frame, x component 1 (depth = range * x / |d|)."""
    fx, fy, cx, cy = p.intrinsics()
    v, u = np.mgrid[0:p.height, 0:p.width].astype(np.float64)
    return np.stack([np.ones_like(u), -(u + 0.5 - cx) / fx, -(v + 0.5 - cy) / fy], axis=-1)


PROFILES: dict[str, dict[str, object]] = {
    # Intel RealSense D435: depth field of view 87 x 58 deg, depth streams up to 1280 x 720 (424 x 240 is
    # one of its modes), up to 90 fps, minimum depth 0.105 m, about 10 m maximum range, depth RMS error
    # under 2 % at 2 m (0.04 m: 0.01 m x 2^2)
    "d435": {},
}

#: Fewest simulated seconds between two recorded frames of one camera: a 424 x 240 frame is
#: 407 kB of float32 (6.1 MB per simulated second at 15 Hz), so a trace keeps one a second
#: (docs/traces.md has the figures).
TRACE_PERIOD_S = 1.0


def optical_frame(name: str) -> str:
    """The camera's optical frame (z forward, x right, y down: REP 103's ``_optical`` frame)."""
    return name + encode.OPTICAL_SUFFIX


def frames(sensor: Any) -> list[tuple[str, str, tuple[float, float, float], tuple[float, float, float]]]:
    """The optical frame below the sensor's: (parent, child, xyz, rpy)."""
    return [(sensor.name, optical_frame(sensor.name), (0.0, 0.0, 0.0), encode.OPTICAL_RPY)]


def trace_topics(sensor: Any) -> dict[str, Any]:
    """A camera named N: ``/sensors/N/depth`` (``foxglove.RawImage``) and ``/sensors/N/calibration``
    (``foxglove.CameraCalibration``)."""
    from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
    from foxglove_schemas_protobuf.RawImage_pb2 import RawImage

    return {encode.topic(sensor.name, "depth"): RawImage, encode.topic(sensor.name, "calibration"): CameraCalibration}


def calibration_matrices(fx: float, fy: float, cx: float, cy: float) -> tuple[list[float], list[float], list[float]]:
    """K (3 x 3), R (3 x 3), P (3 x 4), row-major, as ``sensor_msgs/CameraInfo`` has them. ROS puts
    pixel centres on integer coordinates, a :class:`DepthImage` at ``u + 0.5``: the principal point
    moves by half a pixel."""
    cxr, cyr = cx - 0.5, cy - 0.5
    return ([fx, 0.0, cxr, 0.0, fy, cyr, 0.0, 0.0, 1.0], [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            [fx, 0.0, cxr, 0.0, 0.0, fy, cyr, 0.0, 0.0, 0.0, 1.0, 0.0])


def trace(r: DepthImage, sensor: Any) -> list[tuple[str, Any]]:
    """A frame as a ``foxglove.RawImage`` (``32FC1``: float32 metres, little-endian, ``inf`` no
    return) and its ``foxglove.CameraCalibration`` (no distortion), both in the optical frame."""
    (t_img, img_cls), (t_cal, cal_cls) = trace_topics(sensor).items()
    d = np.ascontiguousarray(r.depth, dtype="<f4")
    h, w = d.shape
    frame, ts = optical_frame(sensor.name), encode.stamp(r.t)
    k, rr, p = calibration_matrices(r.fx, r.fy, r.cx, r.cy)
    return [(t_img, img_cls(timestamp=ts, frame_id=frame, width=w, height=h, encoding="32FC1", step=4 * w,
                            data=d.tobytes())),
            (t_cal, cal_cls(timestamp=ts, frame_id=frame, width=w, height=h, distortion_model="plumb_bob",
                            D=[0.0] * 5, K=k, R=rr, P=p))]


def ros2_image(types: Any, topic: str, m: Any, sensor: Any) -> list[tuple[str, Any]]:
    """``foxglove.RawImage`` -> ``sensor_msgs/Image`` on the same topic (the bytes as they are)."""
    return [(topic, types["sensor_msgs/msg/Image"](
        header=encode.ros_header(types, m), height=m.height, width=m.width, encoding=m.encoding, is_bigendian=0,
        step=m.step, data=np.frombuffer(m.data, dtype=np.uint8)))]


def ros2_info(types: Any, topic: str, m: Any, sensor: Any) -> list[tuple[str, Any]]:
    """``foxglove.CameraCalibration`` -> ``sensor_msgs/CameraInfo`` on ``.../camera_info`` (the ROS
    name, beside the image)."""
    out = topic.rsplit("/", 1)[0] + "/camera_info"
    roi = types["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    return [(out, types["sensor_msgs/msg/CameraInfo"](
        header=encode.ros_header(types, m), height=m.height, width=m.width, distortion_model=m.distortion_model,
        d=np.array(m.D, dtype=np.float64), k=np.array(m.K, dtype=np.float64), r=np.array(m.R, dtype=np.float64),
        p=np.array(m.P, dtype=np.float64), binning_x=0, binning_y=0, roi=roi))]

def to_wire(r: DepthImage) -> dict[str, Any]:
    """A depth frame for the line protocol (version 2): ``depth`` a base64 (H, W) float32 array
    (``inf``: no return), the pinhole intrinsics ``fx fy cx cy``."""
    return {**pose_fields(r), "depth": f32(r.depth), "fx": float(r.fx), "fy": float(r.fy), "cx": float(r.cx),
            "cy": float(r.cy)}


def from_wire(d: dict[str, Any]) -> DepthImage:
    """Inverse of :func:`to_wire`; ValueError naming the bad field."""
    return DepthImage(t=num(d, "t"), depth=array(d, "depth", ndim=2), fx=num(d, "fx"), fy=num(d, "fy"),
                      cx=num(d, "cx"), cy=num(d, "cy"), mount=vec3(d, "mount"), rpy=vec3(d, "rpy"),
                      sensor=text(d, "sensor"))


KIND = SensorKind(name="depth", params=DepthParams, profiles=PROFILES, default_profile="d435",
                  reading=DepthImage, caster="pinhole", summary="ray-cast depth camera (depth image)",
                  rays=rays, trace=trace,
                  ros2={"foxglove.RawImage": ros2_image, "foxglove.CameraCalibration": ros2_info},
                  extra={"topics": trace_topics, "trace_period_s": TRACE_PERIOD_S, "frames": frames},
                  to_wire=to_wire, from_wire=from_wire)
