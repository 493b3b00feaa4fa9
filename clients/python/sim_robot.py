#!/usr/bin/env python3
"""A tiny kinematic robot in a simple room, driven through the LIVES base adapter.

It stands in for a real robot's program (a Spot SDK script, a ROS 2 node) in tests and demos:

* the room is 12 m x 8 m, split by a wall at x = 6 m with a 3 m doorway at the top, with a
  1 m box in the left half; the robot starts in the left half, the target stands in the right
  half, out of sight;
* scans (720 beams over 360 degrees, 5 Hz) are computed analytically by ray-casting the wall
  segments, the box and the target's 0.4 m square;
* odometry is exact (20 Hz);
* it follows every ``goal`` it receives along its path at ``--speed`` (0.5 m/s), turning at up
  to 1.5 rad/s, and turns to the goal's yaw at the end; it halts on every ``stop``;
* it sends ``detection`` when the target is within 4 m, within the camera's 90 degree field of
  view in front of it, and not hidden by a wall or the box.

Exit status: 0 when it receives ``stop`` with reason ``target-found``; 1 on ``--timeout``; 2 on
``stop`` with reason ``exhausted``; 3 if the connection is refused or lost. It prints one JSON
summary line on stdout (goals received, stops, errors, timings).

Usage: ``python3 clients/python/sim_robot.py --port 7100 [--timeout 180]``
"""

import argparse
import json
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from lives_base import AdapterError, LivesBase  # noqa: E402

ROOM = (0.0, 0.0, 12.0, 8.0)
TARGET = (10.0, 2.0)
START = (1.5, 1.5, 0.0)
CAMERA_RANGE_M = 4.0
CAMERA_HALF_FOV = math.radians(45.0)
BEAMS = 720
RANGE_MAX = 30.0


def box(x0, y0, x1, y1):
    """The four edges of an axis-aligned box."""
    return [((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))]


# Walls and furniture (occlude the camera), and the target's own outline (seen by the LiDAR).
WALLS = box(*ROOM) + [((6.0, 0.0), (6.0, 5.0))] + box(3.0, 3.0, 4.0, 4.0)
TARGET_EDGES = box(TARGET[0] - 0.2, TARGET[1] - 0.2, TARGET[0] + 0.2, TARGET[1] + 0.2)


def ray_hit(ox, oy, dx, dy, seg):
    """Distance along the ray (o, d) to the segment, or None."""
    (ax, ay), (bx, by) = seg
    ex, ey = bx - ax, by - ay
    den = dx * ey - dy * ex
    if abs(den) < 1e-12:
        return None
    t = ((ax - ox) * ey - (ay - oy) * ex) / den
    u = ((ax - ox) * dy - (ay - oy) * dx) / den
    if t > 1e-9 and -1e-9 <= u <= 1 + 1e-9:
        return t
    return None


def cast(x, y, angle, segments):
    """Nearest hit of a ray from (x, y) at ``angle`` (world frame), or inf."""
    dx, dy = math.cos(angle), math.sin(angle)
    best = math.inf
    for s in segments:
        t = ray_hit(x, y, dx, dy, s)
        if t is not None and t < best:
            best = t
    return best


def scan(pose):
    """Ranges of the 720 beams from -pi, in the robot frame (inf: no return within range_max)."""
    x, y, yaw = pose
    segs = WALLS + TARGET_EDGES
    inc = 2 * math.pi / BEAMS
    out = []
    for i in range(BEAMS):
        r = cast(x, y, yaw - math.pi + i * inc, segs)
        out.append(r if r <= RANGE_MAX else math.inf)
    return -math.pi, inc, out


def sees_target(pose):
    """The target within camera range and field of view, with a clear line of sight."""
    x, y, yaw = pose
    dx, dy = TARGET[0] - x, TARGET[1] - y
    dist = math.hypot(dx, dy)
    if dist > CAMERA_RANGE_M:
        return False
    bearing = math.atan2(dy, dx) - yaw
    bearing = math.atan2(math.sin(bearing), math.cos(bearing))
    if abs(bearing) > CAMERA_HALF_FOV:
        return False
    return cast(x, y, math.atan2(dy, dx), WALLS) > dist


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


class Robot:
    """Kinematics: walk the path at ``speed``, facing the way it walks, then turn to the goal yaw."""

    def __init__(self, speed):
        self.x, self.y, self.yaw = START
        self.speed = speed
        self.turn_rate = 1.5
        self.path = []
        self.final_yaw = None
        self.driven = 0.0

    def follow(self, path, yaw):
        self.path = [tuple(p) for p in path]
        self.final_yaw = yaw

    def halt(self):
        self.path = []
        self.final_yaw = None

    def step(self, dt):
        while self.path and math.hypot(self.path[0][0] - self.x, self.path[0][1] - self.y) < 0.05:
            self.path.pop(0)
        if self.path:
            tx, ty = self.path[0]
            heading = math.atan2(ty - self.y, tx - self.x)
            err = wrap(heading - self.yaw)
            self.yaw = wrap(self.yaw + max(-self.turn_rate * dt, min(self.turn_rate * dt, err)))
            if abs(err) < 0.6:
                d = min(self.speed * dt, math.hypot(tx - self.x, ty - self.y))
                self.x += d * math.cos(heading)
                self.y += d * math.sin(heading)
                self.driven += d
        elif self.final_yaw is not None:
            err = wrap(self.final_yaw - self.yaw)
            self.yaw = wrap(self.yaw + max(-self.turn_rate * dt, min(self.turn_rate * dt, err)))
            if abs(err) < 1e-3:
                self.final_yaw = None

    def pose(self):
        return (self.x, self.y, self.yaw)


def inside_room(x, y):
    return ROOM[0] <= x <= ROOM[2] and ROOM[1] <= y <= ROOM[3]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--host", default="127.0.0.1")
    ap.add_argument("--port", type=int, default=7100)
    ap.add_argument("--speed", type=float, default=0.5, help="walking speed, m/s")
    ap.add_argument("--timeout", type=float, default=180.0, help="give up after this many seconds")
    ap.add_argument("--connect-timeout", type=float, default=20.0, help="keep trying to connect this long")
    args = ap.parse_args()

    summary = {"result": None, "goals": [], "stops": [], "errors": [], "status": 0, "detections_sent": 0}
    t0 = time.monotonic()

    def finish(code, result):
        summary["result"] = result
        summary["elapsed_s"] = round(time.monotonic() - t0, 3)
        summary["driven_m"] = round(robot.driven, 3)
        summary["pose"] = [round(v, 3) for v in robot.pose()]
        print(json.dumps(summary), flush=True)
        sys.exit(code)

    robot = Robot(args.speed)
    base = None
    while base is None:
        try:
            base = LivesBase.connect(args.host, args.port, client="sim_robot.py")
        except (OSError, AdapterError) as e:
            if isinstance(e, AdapterError) or time.monotonic() - t0 > args.connect_timeout:
                summary["errors"].append(str(e))
                finish(3, "refused")
            time.sleep(0.2)

    dt = 0.05
    next_step = time.monotonic()
    steps = 0
    while True:
        now = time.monotonic()
        if now - t0 > args.timeout:
            finish(1, "timeout")
        try:
            for msg in base.poll(timeout=max(0.0, next_step - now)):
                kind = msg.get("type")
                if kind == "goal":
                    summary["goals"].append(
                        {
                            "t": round(time.monotonic() - t0, 3),
                            "seq": msg["seq"],
                            "x": msg["x"],
                            "y": msg["y"],
                            "yaw": msg["yaw"],
                            "path": msg["path"],
                            "inside": inside_room(msg["x"], msg["y"]) and all(inside_room(px, py) for px, py in msg["path"]),
                        }
                    )
                    robot.follow(msg["path"], msg["yaw"])
                elif kind == "stop":
                    robot.halt()
                    summary["stops"].append({"t": round(time.monotonic() - t0, 3), "reason": msg["reason"]})
                    if msg["reason"] == "target-found":
                        finish(0, "target-found")
                    if msg["reason"] == "exhausted":
                        finish(2, "exhausted")
                elif kind == "status":
                    summary["status"] += 1
                elif kind == "error":
                    summary["errors"].append(msg)
            if base.closed:
                robot.halt()
                finish(3, "connection-closed")
            if time.monotonic() < next_step:
                continue
            next_step += dt
            robot.step(dt)
            steps += 1
            base.send_odometry(*robot.pose())
            if steps % 4 == 0:
                angle_min, inc, ranges = scan(robot.pose())
                base.send_scan(angle_min, inc, ranges, range_min=0.1, range_max=RANGE_MAX)
                if sees_target(robot.pose()):
                    summary["detections_sent"] += 1
                    summary.setdefault("first_detection_s", round(time.monotonic() - t0, 3))
                    base.send_detection(*TARGET)
        except AdapterError as e:
            robot.halt()
            summary["errors"].append(str(e))
            finish(3, "connection-lost")


if __name__ == "__main__":
    main()
