#!/usr/bin/python3
"""Independent writer of ROS 1 messages for tests/ros_message_test.cpp.

Prints a JSON list of cases, each {name, type, definition, hex, numbers,
strings}: the message definition, the serialised bytes (hex) and the fields as
they should decode, flattened by path ("header.stamp.sec", "position[2]") in
the order of the definition.

The standard messages are serialised by Debian's genpy classes (python3-sensor-msgs,
python3-geometry-msgs, python3-tf2-msgs) and carry their full definition text
(_full_text); their expected fields are read back from the message objects.
The custom message, which uses every primitive, fixed and bounded arrays,
arrays of messages, constants and comments, is written here byte by byte with
the struct module, following http://wiki.ros.org/msg and
http://wiki.ros.org/ROS/Technical%20Overview#Message_serialization_and_msg_MD5_sums.

usage: /usr/bin/python3 ros1_messages.py
"""

import io
import json
import struct
import sys

import genpy
from geometry_msgs.msg import PointStamped, PoseStamped, TransformStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Header
from tf2_msgs.msg import TFMessage


def flatten(msg, prefix, numbers, strings):
    """The fields of a genpy message as (path, value) lists, in slot order."""
    for slot, slot_type in zip(msg.__slots__, msg._slot_types):
        flatten_value(getattr(msg, slot), slot_type, prefix + slot, numbers, strings)


def flatten_value(value, slot_type, path, numbers, strings):
    if "[" in slot_type:
        base = slot_type[: slot_type.index("[")]
        if isinstance(value, (bytes, bytearray)):  # genpy's uint8[] and char[]
            value = list(value)
        for i, item in enumerate(value):
            flatten_value(item, base, "%s[%d]" % (path, i), numbers, strings)
    elif isinstance(value, (genpy.Time, genpy.Duration)):
        numbers.append([path + ".sec", value.secs])
        numbers.append([path + ".nsec", value.nsecs])
    elif isinstance(value, genpy.Message):
        flatten(value, path + ".", numbers, strings)
    elif slot_type == "string":
        strings.append([path, value])
    elif isinstance(value, bool):
        numbers.append([path, int(value)])
    else:
        numbers.append([path, value])


def genpy_case(name, msg):
    buf = io.BytesIO()
    msg.serialize(buf)
    numbers, strings = [], []
    flatten(msg, "", numbers, strings)
    return {
        "name": name,
        "type": msg._type,
        "definition": msg._full_text,
        "hex": buf.getvalue().hex(),
        "numbers": numbers,
        "strings": strings,
    }


def header(seq, secs, nsecs, frame):
    return Header(seq=seq, stamp=genpy.Time(secs, nsecs), frame_id=frame)


def transform(seq, child, xyz, quat):
    t = TransformStamped()
    t.header = header(seq, 1700000000 + seq, 250000000, "world")
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
    r = t.transform.rotation
    r.x, r.y, r.z, r.w = quat
    return t


def standard_cases():
    js = JointState()
    js.header = header(42, 1700000000, 123456789, "base_link")
    js.name = ["shoulder", "upper_arm", "elbow", "forearm", "wrist", "coude_\u00e9"]
    js.position = [0.1, -0.2, 1.5707963267948966, 3.0, -3.14159, 1e-9]
    js.velocity = [0.0, 0.5, -0.5, 1.25, 2.5e-3, 7.0]
    js.effort = []  # an empty array, as many drivers publish
    ps = PoseStamped()
    ps.header = header(7, 1600000000, 999999999, "tracker")
    ps.pose.position.x, ps.pose.position.y, ps.pose.position.z = 0.25, -1.5, 2.0
    o = ps.pose.orientation
    o.x, o.y, o.z, o.w = 0.0, 0.70710678118654757, 0.0, 0.70710678118654757
    pt = PointStamped()
    pt.header = header(0, 0, 1, "")  # an empty frame id
    pt.point.x, pt.point.y, pt.point.z = 1e300, -0.0, 123.456
    tf = TFMessage()
    tf.transforms = [
        transform(1, "tool0", (0.1, 0.2, 0.3), (0.0, 0.0, 0.0, 1.0)),
        transform(2, "marker", (-1.0, 2.5, 1e-3), (0.5, -0.5, 0.5, 0.5)),
    ]
    return [
        genpy_case("joint_state", js),
        genpy_case("pose_stamped", ps),
        genpy_case("point_stamped", pt),
        genpy_case("transform_stamped", transform(3, "camera", (4.0, 5.0, 6.0), (1.0, 0.0, 0.0, 0.0))),
        genpy_case("tf_message", tf),
    ]


CUSTOM_DEFINITION = """# Every ROS 1 primitive, arrays of each kind, nested messages, constants and comments.
int32 FOO=1
string GREETING=hello # not a comment: the value runs to the end of the line
uint8 FLAG = 3   # a comment after a constant
bool b
byte by
char ch
int8 i8
uint8 u8
int16 i16
uint16 u16
int32 i32
uint32 u32
int64 i64
uint64 u64
float32 f32
float64 f64
string s   # a comment after a field
time t
duration d
Header header
float64[3] fixed
string[2] names
int16[<=4] bounded
uint8[] image
Sample[] samples
hapticcal_test/Sample[2] pair
geometry_msgs/Point[] points
Empty[] empties
================================================================================
MSG: std_msgs/Header
uint32 seq
time stamp
string frame_id
================================================================================
MSG: hapticcal_test/Sample
# a nested message with arrays of its own
string label
float32[] values
time[] stamps
Inner inner
================================================================================
MSG: hapticcal_test/Inner
int64 big
bool[2] flags
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: hapticcal_test/Empty
# nothing but a constant: no bytes at all
int32 NOTHING=0
"""


class Writer:
    """Little-endian bytes and the expected fields, side by side."""

    def __init__(self):
        self.out = bytearray()
        self.numbers = []
        self.strings = []

    def num(self, path, fmt, value):
        self.out += struct.pack("<" + fmt, value)
        if fmt == "f":  # the value as float32 holds it
            value = struct.unpack("<f", struct.pack("<f", value))[0]
        self.numbers.append([path, int(value) if fmt == "?" else value])

    def string(self, path, text):
        data = text.encode("utf-8")
        self.out += struct.pack("<I", len(data)) + data
        self.strings.append([path, text])

    def count(self, n):
        self.out += struct.pack("<I", n)

    def time(self, path, secs, nsecs, signed=False):
        self.num(path + ".sec", "i" if signed else "I", secs)
        self.num(path + ".nsec", "i" if signed else "I", nsecs)


def sample(w, path, label, values, stamps, big, flags):
    w.string(path + ".label", label)
    w.count(len(values))
    for i, v in enumerate(values):
        w.num("%s.values[%d]" % (path, i), "f", v)
    w.count(len(stamps))
    for i, (s, n) in enumerate(stamps):
        w.time("%s.stamps[%d]" % (path, i), s, n)
    w.num(path + ".inner.big", "q", big)
    for i, f in enumerate(flags):
        w.num("%s.inner.flags[%d]" % (path, i), "?", f)


def custom_case():
    w = Writer()
    w.num("b", "?", True)
    w.num("by", "b", -128)
    w.num("ch", "B", 255)
    w.num("i8", "b", -7)
    w.num("u8", "B", 200)
    w.num("i16", "h", -32768)
    w.num("u16", "H", 65535)
    w.num("i32", "i", -2147483648)
    w.num("u32", "I", 4294967295)
    w.num("i64", "q", -(2**53))
    w.num("u64", "Q", 2**53)
    w.num("f32", "f", 1.1)
    w.num("f64", "d", -2.718281828459045)
    w.string("s", "a string # with a hash")
    w.time("t", 1700000123, 999999999)
    w.time("d", -5, -250000000, signed=True)
    w.num("header.seq", "I", 9)
    w.time("header.stamp", 1, 2)
    w.string("header.frame_id", "map")
    for i, v in enumerate([1.0, -2.0, 3.5]):
        w.num("fixed[%d]" % i, "d", v)
    for i, v in enumerate(["left", ""]):
        w.string("names[%d]" % i, v)
    w.count(3)
    for i, v in enumerate([-1, 0, 300]):
        w.num("bounded[%d]" % i, "h", v)
    image = bytes([0, 1, 127, 128, 255])
    w.count(len(image))
    for i, v in enumerate(image):
        w.num("image[%d]" % i, "B", v)
    w.count(2)
    sample(w, "samples[0]", "first", [0.5, -0.25], [(10, 20)], 123456789012, [True, False])
    sample(w, "samples[1]", "", [], [], -1, [False, True])
    sample(w, "pair[0]", "p0", [3.0], [(1, 1), (2, 2)], 0, [True, True])
    sample(w, "pair[1]", "p1", [], [(4, 4)], 2**40, [False, False])
    w.count(2)
    for i, (x, y, z) in enumerate([(1.0, 2.0, 3.0), (-4.0, -5.0, -6.0)]):
        w.num("points[%d].x" % i, "d", x)
        w.num("points[%d].y" % i, "d", y)
        w.num("points[%d].z" % i, "d", z)
    w.count(3)  # three empty messages: a count and no bytes
    return {
        "name": "custom_everything",
        "type": "hapticcal_test/Everything",
        "definition": CUSTOM_DEFINITION,
        "hex": bytes(w.out).hex(),
        "numbers": w.numbers,
        "strings": w.strings,
    }


def main():
    cases = standard_cases() + [custom_case()]
    json.dump(cases, sys.stdout, ensure_ascii=True)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
