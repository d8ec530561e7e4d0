#!/usr/bin/env python3
"""The straight-line navigator as a separate program speaking navstress's line protocol.

Standard library only, to show that a navigator in any language can plug in: read one JSON
object per line on stdin, answer one per line on stdout (flush!), log on stderr. Usage:

    python3 stdio_nav.py ['{"heading_gain": 1.5}']

Protocol (docs/plugins.md in navstress): hello -> hello; reset -> ok; step -> command | status;
close -> exit. Lidar points arrive as base64 of little-endian float32 x, y, z triples.
"""

import base64
import json
import math
import struct
import sys

PROTOCOL = 1
PARAMS = {"max_speed_mps": None, "heading_gain": 1.5, "slowdown_radius_m": 2.0}


def wrap(a):
    return math.remainder(a, math.tau)


def decode_points(scan):
    """[(x, y, z), ...] from a scan's base64 little-endian float32 payload."""
    raw = base64.b64decode(scan["points"])
    flat = struct.unpack("<%df" % (len(raw) // 4), raw)
    return [flat[i:i + 3] for i in range(0, len(flat), 3)]


class StraightLine:
    def __init__(self, params):
        self.params = dict(PARAMS, **params)

    def reset(self, mission, robot, seed):
        self.goal = mission["goal"]
        self.tol = mission["goal_tolerance_m"]
        self.robot = robot
        self.fix = list(mission["start"])
        self.odom_at_fix = None
        self.points_seen = 0

    def step(self, obs):
        for scan in obs["scans"]:
            self.points_seen += len(decode_points(scan))  # a real stack would map them
        o = obs["odom"]
        if obs["pose"] is not None:
            p = obs["pose"]
            self.fix = [p["x"], p["y"], p["yaw"]]
            self.odom_at_fix = (o["x"], o["y"], o["yaw"])
        if self.odom_at_fix is None:
            self.odom_at_fix = (o["x"], o["y"], o["yaw"])
        fx, fy, fyaw = self.fix
        ox, oy, oyaw = self.odom_at_fix
        rot = fyaw - oyaw
        dx, dy = o["x"] - ox, o["y"] - oy
        c, s = math.cos(rot), math.sin(rot)
        x, y, yaw = fx + c * dx - s * dy, fy + s * dx + c * dy, wrap(fyaw + (o["yaw"] - oyaw))
        gx, gy = self.goal
        dist = math.hypot(gx - x, gy - y)
        if dist <= 0.5 * self.tol:  # aim well inside: the estimate is noisy
            return {"type": "status", "kind": "arrived", "message": "%.2f m from the goal" % dist}
        err = wrap(math.atan2(gy - y, gx - x) - yaw)
        wmax = self.robot["max_yaw_rate_rps"]
        vmax = min(float(self.params["max_speed_mps"] or self.robot["max_speed_mps"]),
                   self.robot["max_speed_mps"])
        omega = max(-wmax, min(wmax, self.params["heading_gain"] * err))
        v = vmax * max(0.0, math.cos(err)) ** 2 * min(1.0, dist / self.params["slowdown_radius_m"])
        return {"type": "command", "v": v, "omega": omega}


def send(msg):
    sys.stdout.write(json.dumps(msg) + "\n")
    sys.stdout.flush()


def main():
    nav = StraightLine(json.loads(sys.argv[1]) if len(sys.argv) > 1 else {})
    for line in sys.stdin:
        if not line.strip():
            continue
        msg = json.loads(line)
        kind = msg.get("type")
        if kind == "hello":
            send({"type": "hello", "protocol": PROTOCOL, "name": "straightline-stdio"})
        elif kind == "reset":
            nav.reset(msg["mission"], msg["robot"], msg["seed"])
            send({"type": "ok"})
        elif kind == "step":
            send(nav.step(msg["obs"]))
        elif kind == "close":
            break
        else:
            send({"type": "status", "kind": "error", "message": "unknown message %r" % kind})
    print("straightline-stdio: bye", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
