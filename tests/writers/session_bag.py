#!/usr/bin/python3
"""usage: session_bag.py DEVICE_CSV TRACKER_CSV OUT_DIR COMPRESSION

A hand-guided session as a robot records it: hapticcal's two streams (t, q1..q6
and t, x, y, z, qw, qx, qy, qz, as `simulate` writes them) written as a ROS 1
bag by Debian's python3-rosbag (COMPRESSION none, bz2 or lz4):
  /touch/joint_states  sensor_msgs/JointState, the device's clock in its
                       header stamps, the joints named as the Touch's links but
                       published in another order and with one more ("gripper")
  /tracker/pose        geometry_msgs/PoseStamped, the tracker's clock
  /tf                  tf2_msgs/TFMessage, an unrelated transform (not imported)
  /rosout_note         std_msgs/String (not imported)
Each stamp is 1733390000 s + the CSV's time rounded to the nanosecond; each
message's record (receive) time is its stamp + 1.5 ms. Also writes
OUT_DIR/device_ref.csv and tracker_ref.csv: the same streams with the times as
written to the bag (the nanoseconds less the earlier stream's first, as exact
decimals), the reference an import must reproduce.
"""
import csv
import os
import sys

import rosbag
import rospy
from geometry_msgs.msg import PoseStamped, TransformStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

EPOCH_NS = 1733390000 * 10**9
NAMES = ["waist", "shoulder", "elbow", "yaw", "pitch", "roll"]
PUBLISHED = ["roll", "gripper", "waist", "pitch", "shoulder", "yaw", "elbow"]


def rows(path):
    with open(path) as f:
        lines = [l for l in f if not l.startswith("#")]
    reader = csv.reader(lines)
    header = next(reader)
    return header, [[float(v) for v in r] for r in reader]


def ns_of(t):
    return EPOCH_NS + round(t * 1e9)


def decimal(ns):
    sign = "-" if ns < 0 else ""
    ns = abs(ns)
    return f"{sign}{ns // 10**9}.{ns % 10**9:09d}"


def time_of(ns):
    return rospy.Time(ns // 10**9, ns % 10**9)


def main():
    device_csv, tracker_csv, out, compression = sys.argv[1:5]
    dh, device = rows(device_csv)
    th, tracker = rows(tracker_csv)
    assert dh[0] == "t" and th[:8] == ["t", "x", "y", "z", "qw", "qx", "qy", "qz"], (dh, th)
    device_ns = [ns_of(r[0]) for r in device]
    tracker_ns = [ns_of(r[0]) for r in tracker]
    origin = min(device_ns[0], tracker_ns[0])
    events = []  # (record time, order, topic, message)
    for k, (r, ns) in enumerate(zip(device, device_ns)):
        m = JointState()
        m.header.seq = k
        m.header.stamp = time_of(ns)
        m.header.frame_id = ""
        m.name = PUBLISHED
        q = dict(zip(NAMES, r[1:7]))
        q["gripper"] = 0.25
        m.position = [q[n] for n in PUBLISHED]
        events.append((ns + 1500000, 0, "/touch/joint_states", m))
    for k, (r, ns) in enumerate(zip(tracker, tracker_ns)):
        m = PoseStamped()
        m.header.seq = k
        m.header.stamp = time_of(ns)
        m.header.frame_id = "tracker"
        m.pose.position.x, m.pose.position.y, m.pose.position.z = r[1:4]
        m.pose.orientation.w, m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z = r[4:8]
        events.append((ns + 4000000, 1, "/tracker/pose", m))
        if k % 50 == 0:
            tf = TransformStamped()
            tf.header.stamp = time_of(ns)
            tf.header.frame_id = "world"
            tf.child_frame_id = "table"
            tf.transform.rotation.w = 1.0
            events.append((ns + 4000000, 2, "/tf", TFMessage(transforms=[tf])))
            events.append((ns + 4000000, 3, "/rosout_note", String(data="sample %d" % k)))
    events.sort(key=lambda e: (e[0], e[1]))
    with rosbag.Bag(os.path.join(out, "session.bag"), "w", compression=compression,
                    chunk_threshold=256 * 1024) as bag:
        for record, _, topic, m in events:
            bag.write(topic, m, t=time_of(record))
    with open(os.path.join(out, "device_ref.csv"), "w") as f:
        f.write(",".join(dh) + "\n")
        for r, ns in zip(device, device_ns):
            f.write(",".join([decimal(ns - origin)] + [repr(v) for v in r[1:]]) + "\n")
    with open(os.path.join(out, "tracker_ref.csv"), "w") as f:
        f.write(",".join(th) + "\n")
        for r, ns in zip(tracker, tracker_ns):
            f.write(",".join([decimal(ns - origin)] + [repr(v) for v in r[1:]]) + "\n")


main()
