#!/usr/bin/env python3
"""Plays a ROS 2 MCAP bag onto a ROS 2 graph with PyPI ``cyclonedds`` (no ROS installation), one
scan at a time, and reads back the maps ``lives ros2`` makes of it.

It stands in for ``ros2 bag play`` in tests: an independent DDS implementation publishes the
bag's ``sensor_msgs/LaserScan``, ``nav_msgs/Odometry`` and ``tf2_msgs/TFMessage`` (``tf`` and
``tf_static``, the latter latched) with their recorded stamps, in the bag's order. It waits for
``lives ros2 --lockstep`` to answer (or reject) each scan before it plays the next, so the run
does not depend on the machine's speed. After the last scan it collects the ``lives/lidar_map``
and ``lives/camera_map`` grids (``nav_msgs/OccupancyGrid``, latched) until none has come for
``--settle`` seconds, and prints one JSON line: scans played, answered and rejected by name,
the stops ``lives ros2`` announced (``stale-odometry`` once the bag's odometry ends while a goal
is out), and the last grid's occupied / free / unknown cell counts and origin.

Exit status: 0 when every scan was answered or rejected and a LiDAR map came back; 1 otherwise;
3 when nothing answered at all (discovery failed).

Usage: ``python3 clients/python/ros2_play_bag.py BAG.mcap [--timeout 5] [--settle 3]``
"""

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ros2_msgs as m  # noqa: E402
from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from mcap_ros2.reader import read_ros2_messages  # noqa: E402

XCDR1 = [Policy.DataRepresentation(use_cdrv0_representation=True, use_xcdrv2_representation=False)]
SENSOR = Qos(Policy.Reliability.BestEffort, Policy.Durability.Volatile, Policy.History.KeepLast(5), *XCDR1)
RELIABLE = Qos(Policy.Reliability.Reliable(1_000_000_000), Policy.Durability.Volatile, Policy.History.KeepLast(100), *XCDR1)
LATCHED = Qos(Policy.Reliability.Reliable(1_000_000_000), Policy.Durability.TransientLocal, Policy.History.KeepLast(1), *XCDR1)


def header(h):
    return m.Header(stamp=m.Time(sec=h.stamp.sec, nanosec=h.stamp.nanosec), frame_id=h.frame_id)


def transform(t):
    return m.Transform(
        translation=m.Vector3(x=t.translation.x, y=t.translation.y, z=t.translation.z),
        rotation=m.Quaternion(x=t.rotation.x, y=t.rotation.y, z=t.rotation.z, w=t.rotation.w),
    )


def convert(kind, msg):
    """A decoded bag message as the cyclonedds type."""
    if kind == "scan":
        return m.LaserScan(
            header=header(msg.header), angle_min=msg.angle_min, angle_max=msg.angle_max,
            angle_increment=msg.angle_increment, time_increment=msg.time_increment, scan_time=msg.scan_time,
            range_min=msg.range_min, range_max=msg.range_max, ranges=list(msg.ranges), intensities=list(msg.intensities),
        )
    if kind == "odom":
        p = msg.pose.pose
        return m.Odometry(
            header=header(msg.header), child_frame_id=msg.child_frame_id,
            pose=m.PoseWithCovariance(pose=m.Pose(
                position=m.Point(x=p.position.x, y=p.position.y, z=p.position.z),
                orientation=m.Quaternion(x=p.orientation.x, y=p.orientation.y, z=p.orientation.z, w=p.orientation.w),
            ), covariance=list(msg.pose.covariance)),
        )
    return m.TFMessage(transforms=[
        m.TransformStamped(header=header(t.header), child_frame_id=t.child_frame_id, transform=transform(t.transform))
        for t in msg.transforms
    ])


KINDS = {"sensor_msgs/msg/LaserScan": "scan", "nav_msgs/msg/Odometry": "odom", "tf2_msgs/msg/TFMessage": "tf"}


def grid_counts(g):
    occupied = sum(1 for v in g.data if v == 100)
    free = sum(1 for v in g.data if v == 0)
    return {
        "occupied": occupied, "free": free, "unknown": len(g.data) - occupied - free,
        "width": g.info.width, "height": g.info.height, "resolution": round(g.info.resolution, 6),
        "origin": [g.info.origin.position.x, g.info.origin.position.y], "frame": g.header.frame_id,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("bag")
    ap.add_argument("--timeout", type=float, default=5.0, help="seconds to wait for each scan's answer")
    ap.add_argument("--settle", type=float, default=3.0, help="seconds without a new grid before the last one counts")
    ap.add_argument("--rate", type=float, default=0.0,
                    help="play scans at this many per second without waiting for answers (`lives ros2` in real time): "
                         "measures the scan rate it sustains; the summary's `received` is what its status counted")
    ap.add_argument("--discovery", type=float, default=10.0, help="seconds to wait for lives ros2 to appear")
    ap.add_argument("--pause-after", type=int, default=0,
                    help="after this many scans are answered, publish nothing for --pause-s seconds (a sensor and odometry "
                         "dropout); the summary's `after_pause` is the first tick after it")
    ap.add_argument("--pause-s", type=float, default=2.0)
    args = ap.parse_args()

    dp = DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0")))
    topic = lambda name, ty, q: Topic(dp, "rt/" + name, ty, qos=q)  # noqa: E731
    writers = {
        "scan": DataWriter(dp, topic("scan", m.LaserScan, SENSOR), qos=SENSOR),
        "odom": DataWriter(dp, topic("odom", m.Odometry, RELIABLE), qos=RELIABLE),
        "tf": DataWriter(dp, topic("tf", m.TFMessage, RELIABLE), qos=RELIABLE),
        "tf_static": DataWriter(dp, topic("tf_static", m.TFMessage, LATCHED), qos=LATCHED),
    }
    status = DataReader(dp, topic("lives/status", m.String, RELIABLE), qos=RELIABLE)
    maps = {name: DataReader(dp, topic("lives/" + name, m.OccupancyGrid, LATCHED), qos=LATCHED) for name in ("lidar_map", "camera_map")}

    # Discovery: lives ros2 reads scans and writes status.
    deadline = time.time() + args.discovery
    while time.time() < deadline:
        if writers["scan"].get_matched_subscriptions() and status.get_matched_publications():
            break
        time.sleep(0.05)
    else:
        print(json.dumps({"error": "lives ros2 not found on the graph"}))
        return 3
    time.sleep(0.5)

    answered, unanswered, played, latency = 0, [], 0, []
    rejected = {}
    stops = []
    seen = set()

    def drain():
        for s in status.take(N=1000):
            if not isinstance(s, m.String):
                continue  # a writer gone (an invalid sample carries no data)
            d = json.loads(s.data)
            if os.environ.get("PLAY_DEBUG"): print(s.data[:200], file=sys.stderr)
            if d.get("kind") == "tick":
                last_status.update(d)
                tick_acts[d.get("stamp_ns")] = {"acts": d.get("acts"), "goal": d.get("goal")}
            if d.get("kind") == "stop":
                stops.append(d.get("reason"))
            if d.get("kind") == "rejection":
                rejected[d["name"]] = rejected.get(d["name"], 0) + 1
            if d.get("stamp_ns") is not None and d.get("kind") in ("tick", "rejection"):
                seen.add(d["stamp_ns"])

    waiting = None  # (stamp, published at)

    def settle(stamp, t0):
        nonlocal answered
        end = time.time() + args.timeout
        while stamp not in seen and time.time() < end:
            drain()
            time.sleep(0.0005)
        if stamp in seen:
            answered += 1
            latency.append(time.time() - t0)
        else:
            unanswered.append(stamp)

    last_status = {}
    tick_acts = {}
    pause_next = None  # the first scan stamp after the pause
    started = time.time()
    next_at = time.time()
    for msg in read_ros2_messages(args.bag):
        kind = KINDS.get(msg.schema.name)
        if kind is None:
            continue
        name = "tf_static" if kind == "tf" and msg.channel.topic.endswith("tf_static") else kind
        out = convert(kind, msg.ros_msg)
        if name == "scan" and args.rate > 0:
            next_at += 1.0 / args.rate
            time.sleep(max(0.0, next_at - time.time()))
            writers["scan"].write(out)
            played += 1
            continue
        if name == "scan":
            if waiting:
                settle(*waiting)
            stamp = out.header.stamp.sec * 10**9 + out.header.stamp.nanosec
            if args.pause_after and played == args.pause_after:
                time.sleep(args.pause_s)
                drain()
                pause_next = stamp
            writers["scan"].write(out)
            played += 1
            waiting = (stamp, time.time())
        else:
            writers[name].write(out)
    if waiting:
        settle(*waiting)

    play_s = time.time() - started
    last = {}
    quiet_since = time.time()
    while time.time() - quiet_since < args.settle:
        drain()
        for name, r in maps.items():
            for g in r.take(N=10):
                if not isinstance(g, m.OccupancyGrid):
                    continue
                last[name] = grid_counts(g)
                quiet_since = time.time()
        time.sleep(0.05)
    latency.sort()
    summary = {
        "scans": played, "answered": answered, "unanswered": len(unanswered), "unanswered_stamps_ns": unanswered[:10], "rejected": rejected, "stops": stops,
        "answer_ms": {"p50": round(1e3 * latency[len(latency) // 2], 3), "max": round(1e3 * latency[-1], 3)} if latency else None,
        "maps": last,
    }
    if pause_next is not None:
        # The last tick before the pause, and the first one after it that acted (with how many
        # ticks came after the pause until then, that one included).
        summary["before_pause"] = tick_acts.get(max((t for t in tick_acts if t < pause_next), default=None))
        after = sorted(t for t in tick_acts if t >= pause_next)
        acted = [(i + 1, t) for i, t in enumerate(after) if tick_acts[t]["acts"]]
        if acted:
            summary["after_pause"] = dict(tick_acts[acted[0][1]], ticks=acted[0][0])
    if args.rate > 0:
        summary.update({"rate_hz": args.rate, "play_s": round(play_s, 3), "played_hz": round(played / play_s, 1),
                        "received": last_status.get("received", {}), "ticks": last_status.get("tick")})
        print(json.dumps(summary))
        return 0
    print(json.dumps(summary))
    if answered == 0:
        return 3
    return 0 if not unanswered and "lidar_map" in last else 1


if __name__ == "__main__":
    sys.exit(main())
