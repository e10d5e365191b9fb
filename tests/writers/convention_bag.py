#!/usr/bin/python3
"""usage: convention_bag.py READINGS_CSV OUT_DIR

The joint states each driver publishes for the readings of READINGS_CSV (t,
q1..q6: the Touch's OpenHaptics HD_CURRENT_JOINT_ANGLES and
HD_CURRENT_GIMBAL_ANGLES; with q7, the dVRK MTM's actuators), as the drivers'
own code computes them, written as ROS 1 bags by python3-rosbag (one a driver,
OUT_DIR/<convention>.bag, topic /joint_states). The formulas restate the
drivers' published statements:
  ros-geomagic (WPI-AIM/ros_geomagic device_node.cpp): position = [-t1, t2, t3,
      -t4 + pi, -t5 - 3 pi/4, -(-t6 - pi)], t = {joints[0], joints[1],
      joints[2] - joints[1], gimbal[0], gimbal[1], gimbal[2]}
  phantom-omni (omni_common omni_state.cpp): as ros-geomagic, [5] = -t6 - pi
  touch-common (Carrot404 touch_state.cpp): [-j0, j1, j2 - j1, -g0, g1 + 1.49, g2]
  saw-sensable-phantom (mtsSensableHD.cpp, default scales and offsets):
      [-j0, j1, j2 - j1, g0, g1, g2]
  dvrk-mtm (ActuatorToJointPosition of mtmr.json): joints = [a1, a2, a3 - a2,
      a4 + 0.6697 (a2 - a3), a5, a6, a7]
"""
import csv
import math
import os
import sys

import rosbag
import rospy
from sensor_msgs.msg import JointState

TOUCH = ["waist", "shoulder", "elbow", "yaw", "pitch", "roll"]
MTM = ["outer_yaw", "shoulder_pitch", "elbow_pitch", "wrist_platform", "wrist_pitch", "wrist_yaw", "wrist_roll"]


def touch(q, gimbal):
    j0, j1, j2 = q[0], q[1], q[2]
    return [-j0, j1, j2 - j1] + gimbal(q[3], q[4], q[5])


DRIVERS = {
    "ros-geomagic": lambda q: touch(q, lambda g0, g1, g2: [-g0 + math.pi, -g1 - 3 * math.pi / 4, -(-g2 - math.pi)]),
    "phantom-omni": lambda q: touch(q, lambda g0, g1, g2: [-g0 + math.pi, -g1 - 3 * math.pi / 4, -g2 - math.pi]),
    "touch-common": lambda q: touch(q, lambda g0, g1, g2: [-g0, g1 + 1.49, g2]),
    "saw-sensable-phantom": lambda q: touch(q, lambda g0, g1, g2: [g0, g1, g2]),
}


def mtm(a):
    return [a[0], a[1], a[2] - a[1], a[3] + 0.6697 * (a[1] - a[2]), a[4], a[5], a[6]]


def main():
    source, out = sys.argv[1:3]
    with open(source) as f:
        rows = [[float(v) for v in r] for r in list(csv.reader(l for l in f if not l.startswith("#")))[1:]]
    drivers = dict(DRIVERS) if len(rows[0]) == 7 else {"dvrk-mtm": mtm}
    names = TOUCH if len(rows[0]) == 7 else MTM
    for name, publish in drivers.items():
        with rosbag.Bag(os.path.join(out, name + ".bag"), "w") as bag:
            for k, r in enumerate(rows):
                stamp = rospy.Time(1733390000 + k // 1000, (k % 1000) * 1000000)
                m = JointState()
                m.header.stamp = stamp
                m.name = names
                m.position = publish(r[1:])
                bag.write("/joint_states", m, t=stamp)


main()
