#!/usr/bin/python3
"""Writes a ROS 1 bag with Debian's python3-rosbag, the independent writer of
tests/ros1_bag_test.cpp, and a JSON side file of what it wrote.

usage: write_ros1_bag.py BAG SIDE.json COMPRESSION [MESSAGES]
  COMPRESSION: none, bz2 or lz4. MESSAGES (default 120) JointState messages on
  /joint_states and as many PoseStamped on /tracker/pose, interleaved, with values
  and receive times from a seeded formula (some receive times out of order, one
  at nsec 999999999); chunk_threshold 2048 bytes, so several chunks.

The side file holds:
  connections: as rosbag's own reader reads them back (id, topic, type, md5sum,
               message_definition, callerid, latching; also each type's _full_text)
  messages:    in the order written: topic, receive_ns, the serialised bytes (hex)
  chunks:      each chunk record's offset (pos), its data's offset (data_pos),
               compression, compressed and uncompressed size (rosbag's reader)
  index_pos:   the bag header's index position (rosbag's reader)
  size:        the file's size in bytes
"""
import io
import json
import math
import os
import sys

import genpy
import rosbag
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState

JOINTS = ["joint_%d" % j for j in range(7)]


def joint_state(i):
    m = JointState()
    m.header.seq = i
    m.header.stamp = genpy.Time(1700000000 + i // 10, (i * 7919 * 1000) % 1000000000)
    m.header.frame_id = "base_link"
    m.name = JOINTS
    m.position = [math.sin(0.01 * i + j) for j in range(7)]
    m.velocity = [math.cos(0.02 * i + j) for j in range(7)]
    m.effort = [] if i % 5 == 0 else [0.1 * j - 0.001 * i for j in range(7)]
    return m


def pose(i):
    m = PoseStamped()
    m.header.seq = i
    m.header.stamp = genpy.Time(1700000000 + i // 10, (i * 104729 * 100) % 1000000000)
    m.header.frame_id = "tracker" if i % 3 else "optitrack_world"
    m.pose.position.x = 0.3 + 0.001 * i
    m.pose.position.y = -0.2 + 0.5 * math.sin(0.05 * i)
    m.pose.position.z = 1.0 / (i + 1)
    a = 0.01 * i
    m.pose.orientation.x = math.sin(a / 2) / math.sqrt(2)
    m.pose.orientation.y = 0.0
    m.pose.orientation.z = math.sin(a / 2) / math.sqrt(2)
    m.pose.orientation.w = math.cos(a / 2)
    return m


def receive_time(k):
    """The recorder's time of the k-th message written: mostly increasing,
    every 17th a little back in time, the 5th at nsec 999999999."""
    if k == 5:
        return genpy.Time(1700000000, 999999999)
    ns = 1700000000 * 10**9 + k * 3333333 + 123
    if k % 17 == 16:
        ns -= 20000000
    return genpy.Time(ns // 10**9, ns % 10**9)


def serialise(msg):
    buf = io.BytesIO()
    msg.serialize(buf)
    return buf.getvalue()


def text(value):
    return value.decode() if isinstance(value, bytes) else value


def main():
    bag_path, side_path, compression = sys.argv[1], sys.argv[2], sys.argv[3]
    count = int(sys.argv[4]) if len(sys.argv) > 4 else 120
    messages = []
    # The tracker's connection as a recorder stores it: with callerid and latching.
    pose_header = {
        "topic": "/tracker/pose",
        "type": PoseStamped._type,
        "md5sum": PoseStamped._md5sum,
        "message_definition": PoseStamped._full_text,
        "callerid": "/tracker_node",
        "latching": "0",
    }
    with rosbag.Bag(bag_path, "w", compression=compression, chunk_threshold=2048) as bag:
        for i in range(count):
            for topic, msg, header in (("/joint_states", joint_state(i), None),
                                       ("/tracker/pose", pose(i), pose_header)):
                t = receive_time(len(messages))
                bag.write(topic, msg, t, connection_header=header)
                messages.append({"topic": topic, "receive_ns": t.to_nsec(),
                                 "hex": serialise(msg).hex()})

    # What the file holds, as rosbag's own reader reads it back.
    with rosbag.Bag(bag_path) as bag:
        connections = []
        for conn_id, c in sorted(bag._connections.items()):
            h = {k: text(v) for k, v in c.header.items()}
            full_text = {JointState._type: JointState._full_text,
                         PoseStamped._type: PoseStamped._full_text}.get(h["type"])
            connections.append({"id": conn_id, "topic": c.topic, "type": h["type"],
                                "md5sum": h["md5sum"],
                                "message_definition": h["message_definition"],
                                "callerid": h.get("callerid"), "latching": h.get("latching"),
                                "full_text": full_text})
        chunks = []
        for pos, ch in sorted(bag._chunk_headers.items()):
            chunks.append({"pos": pos, "data_pos": ch.data_pos, "compression": ch.compression,
                           "compressed_size": ch.compressed_size,
                           "uncompressed_size": ch.uncompressed_size})
        index_pos = bag._index_data_pos
        stored = sum(1 for _ in bag.read_messages(raw=True))
    if stored != len(messages):
        sys.exit("rosbag reads back %d messages, %d written" % (stored, len(messages)))
    with open(side_path, "w") as f:
        json.dump({"connections": connections, "messages": messages, "chunks": chunks,
                   "index_pos": index_pos, "size": os.path.getsize(bag_path)}, f)


if __name__ == "__main__":
    main()
