"""Decodes a ROS 2 MCAP bag with the ROS 2 message decoder of the PyPI `mcap-ros2-support`
package (the `ros2msg` schemas the bag carries, CDR payloads), as Foxglove and rosbag2 read
one, and prints one line per message type: its count and the first message's key fields.

Usage: check_ros2_bag.py BAG.mcap
"""
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def main(path):
    counts, first = {}, {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, _channel, _message, msg in reader.iter_decoded_messages():
            counts[schema.name] = counts.get(schema.name, 0) + 1
            if schema.name in first:
                continue
            if schema.name == "sensor_msgs/msg/LaserScan":
                first[schema.name] = f"frame={msg.header.frame_id} range_max={msg.range_max} beams={len(msg.ranges)}"
            elif schema.name == "nav_msgs/msg/Odometry":
                first[schema.name] = f"frame={msg.header.frame_id} child={msg.child_frame_id}"
            elif schema.name == "tf2_msgs/msg/TFMessage":
                t = msg.transforms[0]
                first[schema.name] = f"parent={t.header.frame_id} child={t.child_frame_id}"
    for name in sorted(counts):
        print(f"{name} {counts[name]} {first.get(name, '')}")


if __name__ == "__main__":
    main(sys.argv[1])
