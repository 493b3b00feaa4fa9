#!/usr/bin/env python3
"""The simulated robot for `lives ros2`: LIVES's own simulator, relayed over ROS 2 (issue 31).

It runs ``lives sim-serve ARGS`` (``lives search``'s simulator with the brain outside, speaking
JSON lines on stdin/stdout) as a child process and plays a ROS 2 robot with it, over DDS with
PyPI ``cyclonedds`` (an implementation independent of the RustDDS in `lives ros2`), in lockstep:

* per tick line from sim-serve it publishes, all stamped with the tick's time
  (``sec = t_us // 10**6``, ``nanosec = (t_us % 10**6) * 1000``): ``tf`` (``odom`` ->
  ``base_link``) and ``odom`` (``nav_msgs/Odometry``) when the pose is valid, ``base_blocked``
  (``std_msgs/Bool``), ``detections`` (``vision_msgs/Detection2DArray``, one ``target``; or with
  ``--detection-topic target`` a ``geometry_msgs/PointStamped`` on ``target``) when the camera sees
  the target, and ``scan`` (``sensor_msgs/LaserScan``, frame ``laser``) last;
  ``tf_static`` (``base_link`` -> ``laser``, identity) once at the start;
* it waits (``--timeout``, 20 s) for the ``lives/status`` tick whose ``stamp_ns`` is the tick's,
  and when its ``acts`` say ``path`` or ``stop`` for the ``plan`` with that stamp (an empty
  ``plan`` is a stop), then answers sim-serve: the path (its last pose's yaw) or stop, then the
  gaze and the end from the status (and the controller's ``goals``/``blacklisted`` counts when
  the status carries them, so that the result counts them as ``lives search`` does);
* it collects every ``goal_pose``, and checks that ``lives/lidar_map``, ``lives/camera_map``
  (``nav_msgs/OccupancyGrid``) and ``lives/markers`` (``visualization_msgs/MarkerArray``) each
  arrived at least once and decode (a grid's data is width x height cells of -1, 0 or 100);
* ``--publish-bad KIND`` (repeatable) publishes deliberately bad input once, after discovery and
  before the first tick, and waits (``--bad-wait``) for the rejections `lives ros2` reports on
  ``lives/status`` (``"kind": "rejection"``): ``zero-increment`` (a LaserScan with
  ``angle_increment`` 0 and 10 ranges), ``length-mismatch`` (10 ranges, 5 intensities),
  ``nan-pose`` (an Odometry with x NaN), ``unknown-frame`` (a scan in frame ``nowhere``),
  ``tf-loop`` (a ``tf_static`` with ``a`` -> ``b`` and ``b`` -> ``a``), ``incompatible-qos`` (a
  best-effort, volatile writer on ``tf_static``, which `lives ros2` reads reliable and
  transient-local). They are stamped 0.

The interface (topics, QoS, the JSON lines) is docs/ros2.md's. DDS type names are
``pkg::msg::dds_::Name_`` on topics ``rt/<name>`` (``ros2_msgs.py``), encoded XCDR1; the domain is
``ROS_DOMAIN_ID`` (default 0). Keep DDS on loopback: run it inside ``unshare -n`` (with ``ip link
set lo up``) and with ``CYCLONEDDS_URI=file://…/tests/ros2/cyclonedds-lo.xml``.

It prints one JSON summary line on stdout: ``ok``, sim-serve's ``result`` (what ``lives search
--json`` prints for the same arguments, but ``classifier``), ``ticks``, the ``goals`` received
(``[x, y, yaw, stamp_ns]``), the ``maps``/``markers`` received, the per-tick ``latency_ms``
(scan published -> status received: median, p95, max), ``goal_latency_ms`` (scan published ->
the ``goal_pose`` answering it received), the ``rejections`` seen (names, in
order), the last tick status's ``received`` and ``rejected`` counts, ``discovery_s``, ``error``.
With ``--hello FILE`` it writes sim-serve's hello line there as soon as it has it (its
``lives_ros2_args`` are what `lives ros2` needs to run the controller ``lives search`` runs).

Exit status: 0 when the run ended, every tick was answered, the maps and markers arrived and
decoded, and the target was found; 1 when the run ended otherwise (or sim-serve failed); 3 on a
discovery failure or a tick not answered within ``--timeout``.

With ``--pace SPEEDUP`` it keeps the wall clock (each tick at least a period, 0.2 s, over SPEEDUP
after the one before), as a robot in a team in real time does (docs/team.md); by default it runs
as fast as `lives ros2` answers.

Usage: ``ros2_sim_robot.py --lives target/release/lives [--hello FILE] [--publish-bad KIND]… --
--world apartment --planner lives --seed 1``
"""

import argparse
import json
import math
import os
import statistics
import struct
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ros2_msgs as m  # noqa: E402

BAD_KINDS = ["zero-increment", "length-mismatch", "nan-pose", "unknown-frame", "tf-loop", "incompatible-qos"]


class Failure(Exception):
    """The run cannot go on: ``code`` is the exit status."""

    def __init__(self, code, message):
        super().__init__(message)
        self.code = code


def stamp_of(t_us):
    return m.Time(sec=t_us // 1_000_000, nanosec=(t_us % 1_000_000) * 1000)


def ns_of(stamp):
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def yaw_of(q):
    return 2.0 * math.atan2(q.z, q.w)


class Inbox:
    """What `lives ros2` published, as the DDS listener threads hand it over."""

    def __init__(self):
        self.cond = threading.Condition()
        self.status = {}  # stamp_ns -> tick status
        self.plans = {}  # stamp_ns -> [Path]
        self.goals = []
        self.goal_at = {}
        self.rejections = []
        self.last_tick = None
        self.maps = {"lidar_map": 0, "camera_map": 0, "markers": 0}
        self.bad = []  # what did not decode or is inconsistent
        self.status_at = {}  # stamp_ns -> monotonic receipt time

    def listener(self, name, handle):
        from cyclonedds.core import Listener

        def on_data(reader):
            try:
                samples = reader.take(N=100)
            except Exception as e:  # a sample that does not decode
                with self.cond:
                    self.bad.append(f"{name}: {e}")
                return
            with self.cond:
                for s in samples:
                    # A writer that went away (an earlier `lives ros2` on this domain) comes as
                    # an InvalidSample with no data: nothing to handle.
                    if type(s).__name__ == "InvalidSample":
                        continue
                    handle(s)
                self.cond.notify_all()

        return Listener(on_data_available=on_data)

    def on_status(self, s):
        try:
            v = json.loads(s.data)
        except ValueError as e:
            self.bad.append(f"lives/status: not JSON ({e}): {s.data[:200]}")
            return
        if v.get("kind") == "tick":
            self.status[v["stamp_ns"]] = v
            self.status_at[v["stamp_ns"]] = time.monotonic()
            self.last_tick = v
        elif v.get("kind") == "rejection":
            self.rejections.append(v.get("name"))

    def on_plan(self, p):
        self.plans.setdefault(ns_of(p.header.stamp), []).append(p)

    def on_goal(self, g):
        q = g.pose.orientation
        self.goals.append([g.pose.position.x, g.pose.position.y, yaw_of(q), ns_of(g.header.stamp)])
        self.goal_at.setdefault(ns_of(g.header.stamp), time.monotonic())

    def grid(self, name):
        def handle(g):
            i = g.info
            if len(g.data) != i.width * i.height or any(c not in (-1, 0, 100) for c in set(g.data)):
                self.bad.append(f"{name}: {len(g.data)} cells for {i.width} x {i.height}, or values other than -1, 0, 100")
            else:
                self.maps[name] += 1

        return handle

    def on_markers(self, _a):
        self.maps["markers"] += 1

    def wait(self, pred, timeout):
        """``pred()`` once it is true (under the lock), or None after ``timeout`` seconds."""
        end = time.monotonic() + timeout
        with self.cond:
            while True:
                v = pred()
                if v is not None and v is not False:
                    return v
                left = end - time.monotonic()
                if left <= 0:
                    return None
                self.cond.wait(left)


class Ros:
    """The robot's DDS entities."""

    def __init__(self, inbox):
        from cyclonedds.core import Policy, Qos
        from cyclonedds.domain import DomainParticipant
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic

        self.Policy, self.Qos, self.DataWriter, self.Topic = Policy, Qos, DataWriter, Topic
        self.dp = DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0")))
        self.topics = {}
        be, rel = Policy.Reliability.BestEffort, Policy.Reliability.Reliable(1_000_000_000)
        vol, tl = Policy.Durability.Volatile, Policy.Durability.TransientLocal
        self.qos = lambda rel_, dur, depth: Qos(rel_, dur, Policy.History.KeepLast(depth), *xcdr1(Policy))
        w = lambda name, typ, q: DataWriter(self.dp, self.topic(name, typ), qos=q)  # noqa: E731
        self.scan = w("scan", m.LaserScan, self.qos(be, vol, 5))
        self.points = w("points", m.PointCloud2, self.qos(be, vol, 5))
        self.odom = w("odom", m.Odometry, self.qos(rel, vol, 10))
        self.tf = w("tf", m.TFMessage, self.qos(rel, vol, 100))
        self.tf_static = w("tf_static", m.TFMessage, self.qos(rel, tl, 1))
        self.detections = w("detections", m.Detection2DArray, self.qos(rel, vol, 10))
        self.target = w("target", m.PointStamped, self.qos(rel, vol, 10))
        self.blocked = w("base_blocked", m.Bool, self.qos(rel, vol, 10))
        self.extra = []  # writers of the bad inputs, kept for the run

        def r(name, typ, q, handle):
            return DataReader(self.dp, self.topic(name, typ), qos=q, listener=inbox.listener(name, handle))

        self.readers = {
            "goal_pose": r("goal_pose", m.PoseStamped, self.qos(rel, vol, 10), inbox.on_goal),
            "plan": r("plan", m.Path, self.qos(rel, vol, 10), inbox.on_plan),
            "lives/status": r("lives/status", m.String, self.qos(rel, vol, 100), inbox.on_status),
            "lives/lidar_map": r("lives/lidar_map", m.OccupancyGrid, self.qos(rel, tl, 1), inbox.grid("lidar_map")),
            "lives/camera_map": r("lives/camera_map", m.OccupancyGrid, self.qos(rel, tl, 1), inbox.grid("camera_map")),
            "lives/markers": r("lives/markers", m.MarkerArray, self.qos(rel, vol, 10), inbox.on_markers),
        }

    def topic(self, name, typ):
        if name not in self.topics:
            self.topics[name] = self.Topic(self.dp, "rt/" + name, typ)
        return self.topics[name]

    def unmatched(self):
        """The endpoints `lives ros2` has not matched yet (discovery is done when none is left)."""
        ws = {"scan": self.scan, "points": self.points, "odom": self.odom, "tf": self.tf, "tf_static": self.tf_static,
              "detections": self.detections, "target": self.target, "base_blocked": self.blocked}
        missing = [n for n, w in ws.items() if not w.get_matched_subscriptions()]
        return missing + [n for n in ("plan", "lives/status") if not self.readers[n].get_matched_publications()]


def xcdr1(Policy):
    # ROS 2's DDS middlewares speak XCDR1 (CDR_LE).
    return [Policy.DataRepresentation(use_cdrv0_representation=True)]


def header(t_us, frame):
    return m.Header(stamp=stamp_of(t_us), frame_id=frame)


def publish_tick(ros, v, detection_topic="detections", as_cloud=False):
    """Publishes one tick line's messages (the scan last; as a point cloud on ``points`` with
    ``as_cloud``)."""
    t = v["t_us"]
    if v["pose"] is not None:
        x, y, _ = v["pose"]
        qz, qw = v["quat"]
        q = m.Quaternion(z=qz, w=qw)
        ros.tf.write(m.TFMessage(transforms=[m.TransformStamped(
            header=header(t, "odom"), child_frame_id="base_link",
            transform=m.Transform(translation=m.Vector3(x=x, y=y), rotation=q))]))
        ros.odom.write(m.Odometry(header=header(t, "odom"), child_frame_id="base_link",
                                  pose=m.PoseWithCovariance(pose=m.Pose(position=m.Point(x=x, y=y), orientation=q))))
    ros.blocked.write(m.Bool(data=bool(v["blocked"])))
    if v["detection"] and detection_topic == "target":
        # A detector that publishes a point (the position is not used: the camera confirms).
        ros.target.write(m.PointStamped(header=header(t, "camera"), point=m.Point(x=1.0)))
    elif v["detection"]:
        hyp = m.ObjectHypothesisWithPose(hypothesis=m.ObjectHypothesis(class_id="target", score=1.0))
        ros.detections.write(m.Detection2DArray(header=header(t, "camera"), detections=[
            m.Detection2D(header=header(t, "camera"), results=[hyp], id="target")]))
    if as_cloud:
        ros.points.write(cloud_msg(v))
    else:
        ros.scan.write(scan_msg(v))


def cloud_msg(v):
    """The tick's scan as a 3D LiDAR's ``sensor_msgs/PointCloud2`` in frame ``laser``: a point
    (float32 ``x``, ``y``, ``z`` = 0) per return; no-returns and invalid readings have none."""
    s = v["scan"]
    invalid, no_return = HELLO["range_invalid"], HELLO["range_no_return"]
    pts = []
    for i, r in enumerate(s["ranges_mm"]):
        if r in (invalid, no_return):
            continue
        a = s["angle_min"] + i * s["angle_increment"]
        pts += [r / 1000.0 * math.cos(a), r / 1000.0 * math.sin(a), 0.0]
    n = len(pts) // 3
    fields = [m.PointField(name=c, offset=4 * k, datatype=7, count=1) for k, c in enumerate("xyz")]
    return m.PointCloud2(header=header(v["t_us"], "laser"), height=1, width=n, fields=fields, is_bigendian=False,
                         point_step=12, row_step=12 * n, data=list(struct.pack(f"<{3 * n}f", *pts)), is_dense=True)


def scan_msg(v):
    s = v["scan"]
    invalid, no_return = HELLO["range_invalid"], HELLO["range_no_return"]
    ranges = [math.nan if r == invalid else math.inf if r == no_return else r / 1000.0 for r in s["ranges_mm"]]
    n = len(ranges)
    return m.LaserScan(header=header(v["t_us"], "laser"), angle_min=s["angle_min"],
                       angle_max=s["angle_min"] + (n - 1) * s["angle_increment"], angle_increment=s["angle_increment"],
                       time_increment=0.0, scan_time=HELLO["period_us"] / 1e6, range_min=s["range_min"],
                       range_max=s["range_max"], ranges=ranges, intensities=[])


HELLO = {}


def publish_bad(ros, kinds):
    """Publishes the deliberately bad inputs ``kinds`` once (stamped 0)."""
    scan = lambda **kw: m.LaserScan(**{"header": header(0, "laser"), "angle_min": -1.0, "angle_increment": 0.1,  # noqa: E731
                                       "range_min": 0.1, "range_max": 10.0, "ranges": [1.0] * 10, **kw})
    P = ros.Policy
    for k in kinds:
        if k == "zero-increment":
            ros.scan.write(scan(angle_increment=0.0))
        elif k == "length-mismatch":
            ros.scan.write(scan(intensities=[1.0] * 5))
        elif k == "nan-pose":
            ros.odom.write(m.Odometry(header=header(0, "odom"), child_frame_id="base_link",
                                      pose=m.PoseWithCovariance(pose=m.Pose(position=m.Point(x=math.nan)))))
        elif k == "unknown-frame":
            ros.scan.write(scan(header=header(0, "nowhere")))
        elif k == "tf-loop":
            w = ros.DataWriter(ros.dp, ros.topic("tf_static", m.TFMessage),
                               qos=ros.qos(P.Reliability.Reliable(1_000_000_000), P.Durability.TransientLocal, 1))
            ros.extra.append(w)
            w.write(m.TFMessage(transforms=[
                m.TransformStamped(header=header(0, "a"), child_frame_id="b"),
                m.TransformStamped(header=header(0, "b"), child_frame_id="a")]))
        elif k == "incompatible-qos":
            w = ros.DataWriter(ros.dp, ros.topic("tf_static", m.TFMessage),
                               qos=ros.qos(P.Reliability.BestEffort, P.Durability.Volatile, 1))
            ros.extra.append(w)
            w.write(m.TFMessage(transforms=[m.TransformStamped(header=header(0, "base_link"), child_frame_id="laser")]))


def answer(inbox, stamp_ns, timeout):
    """The answer line for the tick stamped ``stamp_ns``, from `lives ros2`'s status and plan."""
    st = inbox.wait(lambda: inbox.status.get(stamp_ns), timeout)
    if st is None:
        raise Failure(3, f"no lives/status tick with stamp_ns {stamp_ns} within {timeout} s")
    acts = []
    for a in st.get("acts", []):
        if a not in ("path", "stop"):
            raise Failure(1, f"status acts {st['acts']}: unknown act {a!r}")
        plan = inbox.wait(lambda: inbox.plans.get(stamp_ns) or None, timeout)
        if plan is None:
            raise Failure(3, f"status of stamp_ns {stamp_ns} says {a} but no plan with that stamp came within {timeout} s")
        with inbox.cond:
            p = plan.pop(0)
        if (a == "stop") != (not p.poses):
            raise Failure(1, f"status of stamp_ns {stamp_ns} says {a} but its plan has {len(p.poses)} poses")
        if a == "stop":
            acts.append({"stop": True})
        else:
            acts.append({"path": [[q.pose.position.x, q.pose.position.y] for q in p.poses],
                         "yaw": yaw_of(p.poses[-1].pose.orientation)})
    acts.append({"gaze": st.get("gaze")})
    line = {"acts": acts, "end": st.get("end")}
    for k in ("goals", "blacklisted"):
        if k in st:
            line[k] = st[k]
    return line


def pct(xs, p):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(p / 100 * (len(xs) - 1))))]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--lives", required=True, help="the lives binary")
    ap.add_argument("--timeout", type=float, default=20.0, help="seconds to wait for a tick's status and plan")
    ap.add_argument("--discovery-timeout", type=float, default=30.0)
    ap.add_argument("--settle", type=float, default=1.0, help="seconds to wait after discovery before the first tick")
    ap.add_argument("--publish-bad", action="append", default=[], choices=BAD_KINDS, metavar="KIND",
                    help=f"publish bad input once after discovery ({', '.join(BAD_KINDS)}); repeatable")
    ap.add_argument("--bad-wait", type=float, default=5.0, help="seconds to wait for the rejections of --publish-bad")
    ap.add_argument("--maps-wait", type=float, default=5.0, help="seconds to wait at the end for maps and markers not yet seen")
    ap.add_argument("--hello", help="write sim-serve's hello line here")
    ap.add_argument("--pace", type=float, default=0.0, metavar="SPEEDUP",
                    help="keep the wall clock: each tick at least a period / SPEEDUP after the one before "
                         "(a robot in a team in real time); default: as fast as answered")
    ap.add_argument("--detection-topic", choices=["detections", "target"], default="detections",
                    help="where the camera's sightings go: vision_msgs/Detection2DArray on `detections`, or "
                         "geometry_msgs/PointStamped on `target`")
    ap.add_argument("--scan-as-cloud", action="store_true",
                    help="publish each scan as a 3D LiDAR's PointCloud2 on `points` instead of a LaserScan on `scan`")
    ap.add_argument("sim_serve_args", nargs=argparse.REMAINDER, help="-- then the arguments of `lives sim-serve`")
    args = ap.parse_args()
    rest = args.sim_serve_args[1:] if args.sim_serve_args[:1] == ["--"] else args.sim_serve_args

    inbox = Inbox()
    summary = {"ok": False, "result": None, "ticks": 0, "error": None}
    code = 1
    child = subprocess.Popen([args.lives, "sim-serve", *rest], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    latencies = []
    sent_at = {}
    try:
        hello = json.loads(child.stdout.readline() or "null")
        if not hello or "hello" not in hello:
            raise Failure(1, f"lives sim-serve did not say hello (exit {child.wait()})")
        HELLO.update(hello["hello"])
        summary["hello"] = HELLO
        if args.hello:
            with open(args.hello + ".tmp", "w") as f:
                f.write(json.dumps(hello) + "\n")
            os.replace(args.hello + ".tmp", args.hello)
        print("lives ros2 " + " ".join(HELLO["lives_ros2_args"]), file=sys.stderr)

        ros = Ros(inbox)
        ros.tf_static.write(m.TFMessage(transforms=[m.TransformStamped(header=header(0, "base_link"), child_frame_id="laser")]))
        t0 = time.monotonic()
        while ros.unmatched():
            if time.monotonic() - t0 > args.discovery_timeout:
                raise Failure(3, f"discovery: `lives ros2` did not match {', '.join(ros.unmatched())} within {args.discovery_timeout} s")
            time.sleep(0.05)
        summary["discovery_s"] = round(time.monotonic() - t0, 3)
        time.sleep(args.settle)
        if args.publish_bad:
            publish_bad(ros, args.publish_bad)
            inbox.wait(lambda: len(inbox.rejections) >= len(args.publish_bad), args.bad_wait)

        last_sent = None
        period_s = hello["hello"]["period_us"] / 1e6
        while True:
            line = child.stdout.readline()
            if not line:
                raise Failure(1, f"lives sim-serve ended without a result (exit {child.wait()})")
            v = json.loads(line)
            if "result" in v:
                summary["result"] = v["result"]
                break
            stamp_ns = v["t_us"] * 1000
            if args.pace and last_sent is not None:
                # The simulated robot keeps the wall clock: a tick's period (over --pace) at
                # least from the one before; time lost waiting for an answer is not made up.
                time.sleep(max(0.0, last_sent + period_s / args.pace - time.monotonic()))
            sent = time.monotonic()
            last_sent = sent
            sent_at[stamp_ns] = sent
            publish_tick(ros, v, args.detection_topic, args.scan_as_cloud)
            a = answer(inbox, stamp_ns, args.timeout)
            latencies.append((inbox.status_at[stamp_ns] - sent) * 1000.0)
            child.stdin.write(json.dumps(a) + "\n")
            child.stdin.flush()
            summary["ticks"] += 1
        if child.wait() != 0:
            raise Failure(1, f"lives sim-serve exited with {child.returncode}")
        missing = lambda: [k for k, n in inbox.maps.items() if n == 0]  # noqa: E731
        inbox.wait(lambda: not missing(), args.maps_wait)
        problems = [f"no {k} received" for k in missing()] + inbox.bad
        if problems:
            summary["error"] = "; ".join(problems)
        elif not summary["result"].get("found"):
            summary["error"] = f"target not found ({summary['result'].get('outcome')})"
        else:
            summary["ok"], code = True, 0
    except Failure as e:
        summary["error"], code = str(e), e.code
    except (OSError, ValueError, KeyError) as e:
        summary["error"], code = f"{type(e).__name__}: {e}", 1
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    with inbox.cond:
        summary.update(
            goals_received=len(inbox.goals), goals=inbox.goals, maps=dict(inbox.maps), rejections=list(inbox.rejections),
            received=(inbox.last_tick or {}).get("received"), rejected=(inbox.last_tick or {}).get("rejected"))
    goal_lat = [(t - sent_at[s]) * 1000.0 for s, t in inbox.goal_at.items() if s in sent_at]
    if goal_lat:
        summary["goal_latency_ms"] = {"n": len(goal_lat), "median": round(statistics.median(goal_lat), 3),
                                      "p95": round(pct(goal_lat, 95), 3), "max": round(max(goal_lat), 3)}
    if latencies:
        summary["latency_ms"] = {"median": round(statistics.median(latencies), 3), "p95": round(pct(latencies, 95), 3),
                                 "max": round(max(latencies), 3)}
    print(json.dumps(summary), flush=True)
    # Skip the interpreter's teardown of the DDS entities (slow, and noisy when a peer is gone).
    os._exit(code)


if __name__ == "__main__":
    main()
