"""Reference client of the LIVES base adapter (interface v1), Python standard library only.

The bridge (``lives bridge --source robot --base-listen 127.0.0.1:7100``) listens on a local TCP
socket and speaks JSON lines: one JSON object per line, UTF-8, ``\\n``-terminated. The robot's
program (a Spot SDK script, a ROS 2 node) uses this class to send odometry, scans and
detections, and to receive goals, stops and status. Every message is described, with an
example line, in ``docs/base-adapter.md``.

Conventions: REP-103 (x forward, y left, yaw counter-clockwise), metres and radians, poses in the
odometry/map frame, scans in the robot frame. Ranges follow REP-117: ``float('nan')`` an invalid
reading, ``float('inf')`` no return, ``-inf`` too close; JSON has no NaN or Infinity, so this
client sends them as ``null``, ``"inf"`` and ``"-inf"``.

Safety: if the connection drops, or a ``stop`` arrives, the robot must stop. The bridge treats a
client that sends no odometry for its watchdog period (1 s) as stale and forwards no goals:
send odometry at 5 Hz or more.

Example::

    base = LivesBase.connect("127.0.0.1", 7100, client="my-robot")
    while True:
        base.send_odometry(x, y, yaw)
        base.send_scan(angle_min, angle_increment, ranges, range_min=0.1, range_max=30.0)
        for msg in base.poll(timeout=0.05):
            if msg["type"] == "goal":
                follow(msg["path"], msg["yaw"])
            elif msg["type"] == "stop":
                halt()
"""

import json
import math
import select
import socket
import time

VERSION = 1


class AdapterError(Exception):
    """The bridge refused the session (for example, a wrong version) or the connection failed."""


class LivesBase:
    """A connection to the bridge's base adapter.

    Use :meth:`connect` (which also says ``hello``), then the ``send_*`` methods and
    :meth:`poll` or iteration to receive ``goal``, ``stop``, ``status`` and ``error`` messages
    (each a ``dict`` as parsed from its line).
    """

    def __init__(self, sock, client="lives_base.py"):
        """Wraps a connected socket. Prefer :meth:`connect`."""
        self.sock = sock
        self.client = client
        self._buf = b""
        self._pending = []
        self.server_hello = None
        self.closed = False

    @classmethod
    def connect(cls, host="127.0.0.1", port=7100, client="lives_base.py", timeout=5.0, version=VERSION):
        """Connects, sends ``hello`` with ``version`` and waits for the bridge's ``hello``.

        Raises :class:`AdapterError` with the bridge's message if it refuses (e.g. another
        version), or if no answer comes within ``timeout`` seconds.
        """
        sock = socket.create_connection((host, port), timeout=timeout)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        base = cls(sock, client)
        base.hello(version=version, timeout=timeout)
        return base

    def hello(self, version=VERSION, timeout=5.0):
        """Sends ``hello`` and waits for the answer; returns the bridge's ``hello`` message."""
        self.send({"type": "hello", "v": version, "client": self.client})
        for msg in self.poll(timeout=timeout, until=lambda m: m["type"] in ("hello", "error")):
            if msg["type"] == "hello":
                self.server_hello = msg
                return msg
            raise AdapterError("%s: %s" % (msg.get("code"), msg.get("message")))
        raise AdapterError("no hello from the bridge within %.1f s" % timeout)

    def send(self, obj):
        """Sends one message (a ``dict``) as a line. NaN and infinities are refused here: JSON
        has none (:meth:`send_scan` encodes them the way the adapter expects)."""
        line = json.dumps(obj, allow_nan=False, separators=(",", ":")) + "\n"
        try:
            self.sock.sendall(line.encode("utf-8"))
        except OSError as e:
            self.closed = True
            raise AdapterError("connection lost: %s" % e)

    def send_odometry(self, x, y, yaw, blocked=False):
        """The base's pose in the odometry/map frame (metres, radians). ``blocked``: the base
        cannot follow its path (obstacle, person)."""
        self.send({"type": "odometry", "x": float(x), "y": float(y), "yaw": float(yaw), "blocked": bool(blocked)})

    def send_scan(self, angle_min, angle_increment, ranges, range_min=0.1, range_max=30.0):
        """A planar scan in the robot frame, like ``sensor_msgs/LaserScan`` (radians, metres).
        NaN becomes ``null``, +/-inf ``"inf"``/``"-inf"``."""

        def enc(r):
            r = float(r)
            if math.isnan(r):
                return None
            if math.isinf(r):
                return "inf" if r > 0 else "-inf"
            return round(r, 4)

        self.send(
            {
                "type": "scan",
                "angle_min": float(angle_min),
                "angle_increment": float(angle_increment),
                "range_min": float(range_min),
                "range_max": float(range_max),
                "ranges": [enc(r) for r in ranges],
            }
        )

    def send_detection(self, x=None, y=None):
        """The target is in view (optionally where, in the map frame)."""
        msg = {"type": "detection"}
        if x is not None and y is not None:
            msg["x"], msg["y"] = float(x), float(y)
        self.send(msg)

    def _read_lines(self, timeout):
        """Reads what is there within ``timeout`` s into the pending messages."""
        if self.closed:
            return
        ready, _, _ = select.select([self.sock], [], [], max(0.0, timeout))
        if not ready:
            return
        try:
            data = self.sock.recv(65536)
        except OSError as e:
            self.closed = True
            raise AdapterError("connection lost: %s" % e)
        if not data:
            self.closed = True
            return
        self._buf += data
        while b"\n" in self._buf:
            line, self._buf = self._buf.split(b"\n", 1)
            if line.strip():
                self._pending.append(json.loads(line.decode("utf-8")))

    def poll(self, timeout=0.0, until=None):
        """Yields the messages received within ``timeout`` seconds (each once). With ``until``, a
        predicate, stops after the first message it accepts."""
        deadline = time.monotonic() + timeout
        while True:
            while self._pending:
                msg = self._pending.pop(0)
                yield msg
                if until is not None and until(msg):
                    return
            left = deadline - time.monotonic()
            if left <= 0 or self.closed:
                return
            self._read_lines(left)

    def __iter__(self):
        """Iterates over incoming messages until the connection closes (blocking)."""
        while not self.closed or self._pending:
            for msg in self.poll(timeout=1.0):
                yield msg

    def close(self):
        """Closes the connection (the bridge then considers the base stopped)."""
        self.closed = True
        try:
            self.sock.close()
        except OSError:
            pass
