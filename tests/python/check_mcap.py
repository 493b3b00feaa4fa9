#!/usr/bin/env python3
"""Reads a LIVES recording (`lives search|bridge --record FILE.mcap`) with the independent
PyPI `mcap` reader and checks it: every channel's topic, schema name, schema encoding and
message encoding; exact message counts (`--expect TOPIC=N`); every message decodes as JSON with
the fields its Foxglove schema names, in the right frame, stamped with its log time; and
cross-checks between topics (frontier/candidate updates = planning steps, goals = the
controller's goal count, log lines = mode changes + goals + detections).

    check_mcap.py FILE [--expect TOPIC=N ...] [--partial] [--bridge]

`--partial`: the file was cut short (a crash): read it as a stream up to where it ends, require
no summary, and print what was read. Without it the file must be complete (summary, footer) and
its summary statistics must agree with the messages read.

Prints one JSON object (`counts` per topic, `messages`, `truncated`) on success; exits 1 with the
reasons on failure, 2 if the `mcap` package is missing.
"""

import argparse
import base64
import json
import sys

try:
    from mcap.exceptions import McapError
    from mcap.reader import make_reader
    from mcap.records import Channel, Message, Schema
    from mcap.stream_reader import StreamReader
except ImportError:
    print(
        "missing: the Python `mcap` package (PyPI). Install it with\n"
        "  python3 -m pip install mcap\n"
        "or run ./scripts/test.sh, which installs it into target/py-mcap.",
        file=sys.stderr,
    )
    sys.exit(2)

# topic -> schema name
SCHEMAS = {
    "/tf": "foxglove.FrameTransforms",
    "/lives/pose": "foxglove.PoseInFrame",
    "/lives/scan": "foxglove.PointCloud",
    "/lives/labels": "foxglove.PointCloud",
    "/lives/lidar_grid": "foxglove.Grid",
    "/lives/visual_grid": "foxglove.Grid",
    "/lives/nonmap_points": "foxglove.PointCloud",
    "/lives/frontiers": "foxglove.SceneUpdate",
    "/lives/candidates": "foxglove.SceneUpdate",
    "/lives/goal": "foxglove.PoseInFrame",
    "/lives/path": "foxglove.PosesInFrame",
    "/lives/detection": "foxglove.SceneUpdate",
    "/lives/log": "foxglove.Log",
    "/lives/status": "lives.Status",
}
FRAMES = {
    "/lives/pose": "map",
    "/lives/scan": "laser",
    "/lives/labels": "laser",
    "/lives/lidar_grid": "map",
    "/lives/visual_grid": "map",
    "/lives/nonmap_points": "map",
    "/lives/goal": "map",
    "/lives/path": "map",
}
NUMERIC_SIZE = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 8: 8}

errors = []


def fail(msg):
    errors.append(msg)


def need(obj, path, where):
    """obj[path...] or a recorded failure."""
    cur = obj
    for key in path.split("."):
        if not isinstance(cur, dict) or key not in cur:
            fail(f"{where}: missing field `{path}`")
            return None
        cur = cur[key]
    return cur


def stamp_ns(msg, where):
    ts = need(msg, "timestamp", where)
    if not isinstance(ts, dict) or not isinstance(ts.get("sec"), int) or not isinstance(ts.get("nsec"), int):
        fail(f"{where}: bad timestamp {ts!r}")
        return None
    return ts["sec"] * 1_000_000_000 + ts["nsec"]


def check_pose(p, where):
    for f in ("position.x", "position.y", "position.z", "orientation.x", "orientation.y", "orientation.z", "orientation.w"):
        v = need(p, f, where)
        if v is not None and not isinstance(v, (int, float)):
            fail(f"{where}: `{f}` is not a number")
    q = p.get("orientation", {}) if isinstance(p, dict) else {}
    n = sum(float(q.get(k, 0)) ** 2 for k in "xyzw")
    if abs(n - 1.0) > 1e-6:
        fail(f"{where}: orientation is not a unit quaternion ({n})")


def check_packed(msg, where, stride_key, required):
    stride = need(msg, stride_key, where)
    fields = need(msg, "fields", where) or []
    names = [f.get("name") for f in fields]
    for r in required:
        if r not in names:
            fail(f"{where}: no `{r}` field (has {names})")
    for f in fields:
        if f.get("type") not in NUMERIC_SIZE or f.get("offset", -1) + NUMERIC_SIZE.get(f.get("type"), 0) > (stride or 0):
            fail(f"{where}: field {f} does not fit the stride {stride}")
    data = base64.b64decode(need(msg, "data", where) or "")
    return stride, data


def check_message(topic, msg, log_time, where):
    scene = topic in ("/lives/frontiers", "/lives/candidates", "/lives/detection")
    # FrameTransforms and SceneUpdate stamp their parts, not the message.
    t = stamp_ns(msg, where) if topic != "/tf" and not scene else None
    if t is not None and t != log_time:
        fail(f"{where}: timestamp {t} != log_time {log_time}")
    if topic in FRAMES and msg.get("frame_id") != FRAMES[topic]:
        fail(f"{where}: frame_id {msg.get('frame_id')!r}, expected {FRAMES[topic]!r}")
    if topic == "/tf":
        tfs = need(msg, "transforms", where) or []
        pairs = [(x.get("parent_frame_id"), x.get("child_frame_id")) for x in tfs]
        if pairs != [("map", "base_link"), ("base_link", "laser")]:
            fail(f"{where}: transforms {pairs}")
        for x in tfs:
            if stamp_ns(x, where) != log_time:
                fail(f"{where}: transform stamped off its log time")
            need(x, "translation.x", where)
            need(x, "rotation.w", where)
    elif topic in ("/lives/pose", "/lives/goal"):
        check_pose(need(msg, "pose", where), where)
    elif topic == "/lives/path":
        poses = need(msg, "poses", where) or []
        if not poses:
            fail(f"{where}: empty path")
        for p in poses:
            check_pose(p, where)
    elif topic in ("/lives/scan", "/lives/labels", "/lives/nonmap_points"):
        extra = ["label", "red", "green", "blue", "alpha"] if topic != "/lives/nonmap_points" else ["hits"]
        stride, data = check_packed(msg, where, "point_stride", ["x", "y", "z"] + extra)
        if stride and len(data) % stride:
            fail(f"{where}: {len(data)} data bytes are not whole points of {stride}")
        if topic == "/lives/scan" and stride and len(data) // stride < 100:
            fail(f"{where}: only {len(data) // stride} scan points")
        return {"points": len(data) // stride if stride else 0}
    elif topic in ("/lives/lidar_grid", "/lives/visual_grid"):
        cols = need(msg, "column_count", where)
        stride, data = check_packed(msg, where, "cell_stride", ["occupancy"])
        if need(msg, "row_stride", where) != cols or stride != 1:
            fail(f"{where}: strides {msg.get('row_stride')}/{stride} for {cols} columns of int8")
        if cols and len(data) % cols:
            fail(f"{where}: {len(data)} bytes are not whole rows of {cols}")
        values = set(int.from_bytes(bytes([b]), "little", signed=True) for b in set(data))
        if not values <= {-1, 0, 100}:
            fail(f"{where}: occupancy values {sorted(values)} (expected -1, 0, 100)")
        need(msg, "cell_size.x", where)
        check_pose(need(msg, "pose", where), where)
        return {"cells": len(data), "known": sum(1 for b in data if b != 0xFF)}
    elif topic in ("/lives/frontiers", "/lives/candidates", "/lives/detection"):
        ents = need(msg, "entities", where) or []
        for e in ents:
            if stamp_ns(e, where) != log_time:
                fail(f"{where}: entity {e.get('id')} stamped off its log time")
            for f in ("id", "frame_id", "lifetime", "metadata", "arrows", "spheres", "texts", "cubes", "lines"):
                need(e, f, where)
            if e.get("frame_id") != "map":
                fail(f"{where}: entity frame {e.get('frame_id')!r}")
            keys = {kv.get("key") for kv in e.get("metadata", [])}
            if topic == "/lives/candidates":
                if not {"utility", "unseen", "frontier_near_path", "nonmap", "path_m", "source"} <= keys or not e.get("arrows") or not e.get("texts"):
                    fail(f"{where}: candidate {e.get('id')} without arrow, text or utility terms ({keys})")
            if topic == "/lives/frontiers" and (not {"map", "cells"} <= keys or not e.get("spheres")):
                fail(f"{where}: frontier {e.get('id')} without sphere or map/cells ({keys})")
            if topic == "/lives/detection" and not e.get("spheres"):
                fail(f"{where}: detection without a sphere")
        return {"entities": len(ents)}
    elif topic == "/lives/log":
        if need(msg, "level", where) not in (1, 2, 3, 4, 5) or not need(msg, "message", where):
            fail(f"{where}: bad log line {msg}")
    elif topic == "/lives/status":
        for f in ("mode", "ticks", "scans", "plans", "goals", "blacklisted", "cost.plan", "link.frames_ok"):
            need(msg, f, where)
    return {}


def read(path, partial):
    """(schemas by id, channels by id, [(channel id, log_time, data)], summary, truncated)."""
    schemas, channels, messages = {}, {}, []
    truncated = False
    summary = None
    with open(path, "rb") as f:
        if partial:
            try:
                for r in StreamReader(f, validate_crcs=True).records:
                    if isinstance(r, Schema):
                        schemas[r.id] = r
                    elif isinstance(r, Channel):
                        channels[r.id] = r
                    elif isinstance(r, Message):
                        messages.append((r.channel_id, r.log_time, r.data))
            except Exception as e:  # noqa: BLE001 — any way the stream ends early
                truncated = True
                print(f"note: the stream ends early ({type(e).__name__}: {e})", file=sys.stderr)
        else:
            reader = make_reader(f, validate_crcs=True)
            summary = reader.get_summary()
            if summary is None:
                fail("the file has no summary (not finished)")
                return schemas, channels, messages, None, False
            for schema, channel, message in reader.iter_messages(log_time_order=False):
                schemas[schema.id] = schema
                channels[channel.id] = channel
                messages.append((channel.id, message.log_time, message.data))
    return schemas, channels, messages, summary, truncated


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("file")
    ap.add_argument("--expect", action="append", default=[], metavar="TOPIC=N")
    ap.add_argument("--partial", action="store_true")
    args = ap.parse_args()

    schemas, channels, messages, summary, truncated = read(args.file, args.partial)
    counts = {}
    for ch in channels.values():
        where = f"channel {ch.topic}"
        if ch.topic not in SCHEMAS:
            fail(f"{where}: unexpected topic")
            continue
        sc = schemas.get(ch.schema_id)
        if sc is None:
            fail(f"{where}: no schema record")
            continue
        if sc.name != SCHEMAS[ch.topic] or sc.encoding != "jsonschema" or ch.message_encoding != "json":
            fail(f"{where}: schema {sc.name!r}/{sc.encoding!r}, messages {ch.message_encoding!r}")
        if json.loads(sc.data).get("title") != sc.name:
            fail(f"{where}: the JSON schema's title is not {sc.name}")
        counts[ch.topic] = 0

    last_status = None
    modes = []
    last_t = {}
    details = {}
    for i, (cid, log_time, data) in enumerate(messages):
        ch = channels.get(cid)
        if ch is None:
            fail(f"message {i}: unknown channel {cid}")
            continue
        where = f"{ch.topic} message {counts.get(ch.topic, 0)}"
        counts[ch.topic] = counts.get(ch.topic, 0) + 1
        try:
            msg = json.loads(data)
        except ValueError as e:
            fail(f"{where}: not JSON ({e})")
            continue
        if log_time < last_t.get(ch.topic, 0):
            fail(f"{where}: log time goes back")
        last_t[ch.topic] = log_time
        info = check_message(ch.topic, msg, log_time, where)
        for k, v in info.items():
            details.setdefault(ch.topic, {}).setdefault(k, []).append(v)
        if ch.topic == "/lives/status":
            if last_status is not None and msg["ticks"] <= last_status["ticks"]:
                fail(f"{where}: ticks do not increase")
            if not modes or modes[-1] != msg["mode"]:
                modes.append(msg["mode"])
            last_status = msg

    for e in args.expect:
        topic, _, n = e.partition("=")
        if counts.get(topic, 0) != int(n):
            fail(f"{topic}: {counts.get(topic, 0)} messages, expected {n}")

    # Cross-checks against the controller's own counters (complete in-process recordings).
    if last_status is not None and not truncated:
        if "/lives/frontiers" in counts:
            for t in ("/lives/frontiers", "/lives/candidates"):
                if counts.get(t, 0) != last_status["plans"]:
                    fail(f"{t}: {counts.get(t, 0)} updates, the controller planned {last_status['plans']} times")
        if "/lives/frontiers" in counts and counts.get("/lives/goal", 0) != last_status["goals"]:
            fail(f"/lives/goal: {counts.get('/lives/goal', 0)} goals, the controller issued {last_status['goals']}")
        if counts.get("/lives/goal", 0) != counts.get("/lives/path", 0):
            fail("goals and paths differ in number")
        want_logs = len(modes) + counts.get("/lives/goal", 0) + counts.get("/lives/detection", 0)
        if counts.get("/lives/log", 0) != want_logs:
            fail(f"/lives/log: {counts.get('/lives/log', 0)} lines, expected {want_logs} (modes {modes})")

    if summary is not None:
        stats = summary.statistics
        by_topic = {}
        for cid, n in stats.channel_message_counts.items():
            by_topic[channels[cid].topic if cid in channels else cid] = n
        if stats.message_count != len(messages) or any(by_topic.get(t, 0) != n for t, n in counts.items()):
            fail(f"summary statistics {by_topic} ({stats.message_count}) disagree with the messages read {counts}")

    if errors:
        for e in errors[:40]:
            print("FAIL:", e, file=sys.stderr)
        if len(errors) > 40:
            print(f"... and {len(errors) - 40} more", file=sys.stderr)
        sys.exit(1)
    out = {
        "counts": counts,
        "messages": len(messages),
        "truncated": truncated,
        "modes": modes,
        "last_status": last_status,
        "max_grid_cells": max(details.get("/lives/lidar_grid", {}).get("cells", [0])),
        "max_candidates": max(details.get("/lives/candidates", {}).get("entities", [0])),
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
