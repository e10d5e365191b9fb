// Independent writer of ROS 2 (CDR) messages, for tests/ros_message_test.cpp
// and for the recordings that the MCAP and rosbag2 writers make.
//
// Cases: each {name, type, definition, hex, numbers, strings}: a ROS 2 message
// definition, the message serialised by Foxglove's
// @foxglove/rosmsg2-serialization MessageWriter (the definition parsed by
// @foxglove/rosmsg with {ros2: true}), and the fields as they should decode,
// flattened by path ("header.stamp.sec", "position[2]") in definition order by
// walking the parsed definition and the written object together. One case is
// written big endian field by field with @foxglove/cdr's CdrWriter, which the
// MessageWriter does not offer.
//
// A recording's worth: topics [{name, type, definition}] (/joint_states, a
// sensor_msgs/msg/JointState; /tracker/pose, a geometry_msgs/msg/PoseStamped)
// and messages [{topic, log_time, data, numbers, strings}] in log_time order:
// 120 joint states 1 ms apart and 60 poses 2 ms apart.
//
// The ROS 2 definitions are the published ones
// (https://docs.ros.org/en/rolling/p/sensor_msgs/, .../p/geometry_msgs/,
// .../p/std_msgs/, .../p/builtin_interfaces/, .../p/tf2_msgs/), written out here.
//
// usage: node cdr_messages.js NODE_MODULES
//   prints {cases, topics, messages} as JSON (data as hex, log_time as a
//   string of nanoseconds);
// or as a module: require('./cdr_messages.js')(NODE_MODULES) returns the same
//   with data as Uint8Array and log_time as a BigInt.
"use strict";

const path = require("path");

let parse, MessageWriter, CdrWriter, EncapsulationKind;
function load(modulesArg) {
  const modules = path.resolve(modulesArg);
  ({ parse } = require(path.join(modules, "@foxglove/rosmsg")));
  ({ MessageWriter } = require(path.join(modules, "@foxglove/rosmsg2-serialization")));
  ({ CdrWriter, EncapsulationKind } = require(path.join(modules, "@foxglove/cdr")));
}

const SEP = "=".repeat(80);
const section = (name, text) => `${SEP}\nMSG: ${name}\n${text}`;

const TIME = "int32 sec\nuint32 nanosec\n";
const HEADER = "builtin_interfaces/Time stamp\nstring frame_id\n";
const POINT = "float64 x\nfloat64 y\nfloat64 z\n";
const QUATERNION = "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
const TRANSFORM_STAMPED =
  "std_msgs/Header header\nstring child_frame_id # the frame id of the child frame\nTransform transform\n";
const TRANSFORM = "Vector3 translation\nQuaternion rotation\n";

const DEFINITIONS = {
  "sensor_msgs/JointState": [
    "std_msgs/Header header\n\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
    section("std_msgs/Header", HEADER),
    section("builtin_interfaces/Time", TIME),
  ].join("\n"),
  "geometry_msgs/PoseStamped": [
    "std_msgs/Header header\nPose pose\n",
    section("std_msgs/Header", HEADER),
    section("builtin_interfaces/Time", TIME),
    section("geometry_msgs/Pose", "Point position\nQuaternion orientation\n"),
    section("geometry_msgs/Point", POINT),
    section("geometry_msgs/Quaternion", QUATERNION),
  ].join("\n"),
  "geometry_msgs/PointStamped": [
    "std_msgs/Header header\nPoint point\n",
    section("std_msgs/Header", HEADER),
    section("builtin_interfaces/Time", TIME),
    section("geometry_msgs/Point", POINT),
  ].join("\n"),
  "geometry_msgs/TransformStamped": [
    TRANSFORM_STAMPED,
    section("std_msgs/Header", HEADER),
    section("builtin_interfaces/Time", TIME),
    section("geometry_msgs/Transform", TRANSFORM),
    section("geometry_msgs/Vector3", POINT),
    section("geometry_msgs/Quaternion", QUATERNION),
  ].join("\n"),
  "tf2_msgs/TFMessage": [
    "geometry_msgs/TransformStamped[] transforms\n",
    section("geometry_msgs/TransformStamped", TRANSFORM_STAMPED),
    section("std_msgs/Header", HEADER),
    section("builtin_interfaces/Time", TIME),
    section("geometry_msgs/Transform", TRANSFORM),
    section("geometry_msgs/Vector3", POINT),
    section("geometry_msgs/Quaternion", QUATERNION),
  ].join("\n"),
  "hapticcal_test/Everything": [
    `# Every ROS 2 primitive, alignment traps, bounded strings and sequences,
# default values, constants and comments.
int32 FOO=1
string GREETING="hello # not a comment"
uint8 u8_first          # then a float64: 7 bytes of padding
float64 f64_after_u8
bool b true
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
float64 f64 3.5
string s "default"
string<=10 bounded_s
builtin_interfaces/Time stamp
builtin_interfaces/Duration span
std_msgs/Header header
float64[3] fixed
string[2] names
int16[<=4] bounded
uint8[] image
Sample[] samples
hapticcal_test/Sample[2] pair
geometry_msgs/Point[] points
Empty[] empties
uint8 last   # the message then ends off a 4-byte boundary
`,
    section("std_msgs/Header", HEADER),
    section("builtin_interfaces/Time", TIME),
    section("builtin_interfaces/Duration", TIME),
    section(
      "hapticcal_test/Sample",
      "# a nested message with arrays of its own\nstring label\nfloat32[] values\nint64[<=3] counts\nInner inner\n",
    ),
    section("hapticcal_test/Inner", "uint8 tag\nfloat64 value   # padding inside a nested message\nbool[2] flags\n"),
    section("geometry_msgs/Point", POINT),
    section("hapticcal_test/Empty", "# nothing but a constant: ROS 2 writes one placeholder byte\nint32 NOTHING=0\n"),
  ].join("\n"),
};

const header = (sec, nanosec, frame) => ({ stamp: { sec, nanosec }, frame_id: frame });
const transform = (n, child, [x, y, z], [qx, qy, qz, qw]) => ({
  header: header(1700000000 + n, 250000000, "world"),
  child_frame_id: child,
  transform: { translation: { x, y, z }, rotation: { x: qx, y: qy, z: qz, w: qw } },
});
const sample = (label, values, counts, tag, value, flags) => ({
  label,
  values: new Float32Array(values),
  counts: counts.map(BigInt),
  inner: { tag, value, flags },
});

const MESSAGES = [
  [
    "joint_state",
    "sensor_msgs/JointState",
    {
      header: header(1700000000, 123456789, "base_link"),
      name: ["shoulder", "upper_arm", "elbow", "forearm", "wrist", "hand"],
      position: [0.1, -0.2, 1.5707963267948966, 3.0, -3.14159, 1e-9],
      velocity: [0.0, 0.5, -0.5, 1.25, 2.5e-3, 7.0],
      effort: [],
    },
  ],
  [
    "pose_stamped",
    "geometry_msgs/PoseStamped",
    {
      header: header(-5, 999999999, "tracker"),
      pose: {
        position: { x: 0.25, y: -1.5, z: 2.0 },
        orientation: { x: 0.0, y: 0.7071067811865476, z: 0.0, w: 0.7071067811865476 },
      },
    },
  ],
  ["point_stamped", "geometry_msgs/PointStamped", { header: header(0, 1, ""), point: { x: 1e300, y: 2, z: 123.456 } }],
  ["transform_stamped", "geometry_msgs/TransformStamped", transform(3, "camera", [4, 5, 6], [1, 0, 0, 0])],
  [
    "tf_message",
    "tf2_msgs/TFMessage",
    {
      transforms: [
        transform(1, "tool0", [0.1, 0.2, 0.3], [0, 0, 0, 1]),
        transform(2, "marker", [-1.0, 2.5, 1e-3], [0.5, -0.5, 0.5, 0.5]),
      ],
    },
  ],
  [
    "custom_everything",
    "hapticcal_test/Everything",
    {
      u8_first: 7,
      f64_after_u8: -1.25,
      b: true,
      by: 255,
      ch: 65,
      i8: -128,
      u8: 200,
      i16: -32768,
      u16: 65535,
      i32: -2147483648,
      u32: 4294967295,
      i64: -(2n ** 53n),
      u64: 2n ** 53n,
      f32: 1.1,
      f64: -2.718281828459045,
      s: "a string # with a hash",
      bounded_s: "ten bytes!",
      stamp: { sec: 1700000123, nanosec: 999999999 },
      span: { sec: -5, nanosec: 250000000 },
      header: header(1, 2, "map"),
      fixed: [1.0, -2.0, 3.5],
      names: ["left", ""],
      bounded: [-1, 0, 300],
      image: new Uint8Array([0, 1, 127, 128, 255]),
      samples: [sample("first", [0.5, -0.25], [1, -2], 3, 0.125, [true, false]), sample("", [], [], 0, -0.0, [false, true])],
      pair: [sample("p0", [3.0], [123456789012], 9, 1e-300, [true, true]), sample("p1", [], [0, 0, 0], 255, 42, [false, false])],
      points: [
        { x: 1, y: 2, z: 3 },
        { x: -4, y: -5, z: -6 },
      ],
      empties: [{}, {}, {}],
      last: 99,
    },
  ],
];

// The written object's fields, flattened by walking the parsed definition.
function flatten(definitions, typeName, value, prefix, numbers, strings) {
  const def = definitions.find((d) => (d.name ?? "") === typeName);
  for (const field of def.definitions) {
    if (field.isConstant === true) continue;
    const fieldPath = prefix + field.name;
    const v = value[field.name];
    if (field.isArray === true) {
      Array.from(v).forEach((item, i) => flattenOne(definitions, field, item, `${fieldPath}[${i}]`, numbers, strings));
    } else {
      flattenOne(definitions, field, v, fieldPath, numbers, strings);
    }
  }
}

function flattenOne(definitions, field, v, fieldPath, numbers, strings) {
  if (field.type === "time" || field.type === "duration") {
    numbers.push([`${fieldPath}.sec`, v.sec]);
    numbers.push([`${fieldPath}.nanosec`, v.nanosec]);
  } else if (field.isComplex === true) {
    flatten(definitions, field.type, v, `${fieldPath}.`, numbers, strings);
  } else if (field.type === "string") {
    strings.push([fieldPath, v]);
  } else if (typeof v === "boolean") {
    numbers.push([fieldPath, v ? 1 : 0]);
  } else if (typeof v === "bigint") {
    if (v > 2n ** 53n || v < -(2n ** 53n)) throw new Error(`${fieldPath}: not exact as a double`);
    numbers.push([fieldPath, Number(v)]);
  } else if (field.type === "float32") {
    numbers.push([fieldPath, Math.fround(v)]);
  } else {
    numbers.push([fieldPath, v]);
  }
}

const hex = (bytes) => Buffer.from(bytes).toString("hex");

function writtenCase(name, type, message) {
  const definition = DEFINITIONS[type];
  const parsed = parse(definition, { ros2: true });
  const bytes = new MessageWriter(parsed).writeMessage(message);
  const numbers = [];
  const strings = [];
  flatten(parsed, parsed[0].name ?? "", message, "", numbers, strings);
  return { name, type, definition, hex: hex(bytes), numbers, strings };
}

// Big endian (CDR_BE), written field by field: uint8, float64 (padding),
// string, int16[], uint64, bool.
function bigEndianCase() {
  const w = new CdrWriter({ kind: EncapsulationKind.CDR_BE });
  w.uint8(3);
  w.float64(-0.5);
  w.string("big endian");
  w.sequenceLength(2);
  w.int16(-2);
  w.int16(513);
  w.uint64(1234567890123n);
  w.int8(1);
  return {
    name: "big_endian",
    type: "hapticcal_test/BigEndian",
    definition: "uint8 a\nfloat64 b\nstring c\nint16[] d\nuint64 e\nbool f\n",
    hex: hex(w.data),
    numbers: [
      ["a", 3],
      ["b", -0.5],
      ["d[0]", -2],
      ["d[1]", 513],
      ["e", 1234567890123],
      ["f", 1],
    ],
    strings: [["c", "big endian"]],
  };
}

// A recording's worth of joint states and poses (see the top).
function recording() {
  const topics = [
    { name: "/joint_states", type: "sensor_msgs/msg/JointState", definition: DEFINITIONS["sensor_msgs/JointState"] },
    { name: "/tracker/pose", type: "geometry_msgs/msg/PoseStamped", definition: DEFINITIONS["geometry_msgs/PoseStamped"] },
  ];
  const writers = topics.map((t) => {
    const parsed = parse(t.definition, { ros2: true });
    return { parsed, writer: new MessageWriter(parsed) };
  });
  const start = 1700000000n * 1000000000n;
  const messages = [];
  const add = (index, logTime, message) => {
    const { parsed, writer } = writers[index];
    const numbers = [];
    const strings = [];
    flatten(parsed, parsed[0].name ?? "", message, "", numbers, strings);
    messages.push({ topic: topics[index].name, log_time: logTime, data: writer.writeMessage(message), numbers, strings });
  };
  for (let k = 0; k < 120; ++k) {
    const t = start + BigInt(k) * 1000000n;
    const stamp = { sec: Number(t / 1000000000n), nanosec: Number(t % 1000000000n) };
    const q = [0, 1, 2, 3, 4, 5].map((j) => Math.sin(0.01 * k + j));
    add(0, t, {
      header: { stamp, frame_id: "base_link" },
      name: ["j1", "j2", "j3", "j4", "j5", "j6"],
      position: q,
      velocity: q.map((v) => 0.5 * v),
      effort: [],
    });
    if (k % 2 === 1) {
      add(1, t, {
        header: { stamp, frame_id: "tracker" },
        pose: { position: { x: 0.001 * k, y: -0.5, z: 1.25 }, orientation: { x: 0, y: 0, z: Math.sin(0.005 * k), w: Math.cos(0.005 * k) } },
      });
    }
  }
  return { topics, messages };
}

function all(modules) {
  load(modules);
  const cases = MESSAGES.map(([name, type, message]) => writtenCase(name, type, message));
  cases.push(bigEndianCase());
  return { cases, ...recording() };
}

if (require.main === module) {
  const modules = process.argv[2];
  if (!modules) {
    process.stderr.write("usage: node cdr_messages.js NODE_MODULES\n");
    process.exit(2);
  }
  const out = all(modules);
  const messages = out.messages.map((m) => ({ ...m, log_time: m.log_time.toString(), data: hex(m.data) }));
  process.stdout.write(`${JSON.stringify({ ...out, messages })}\n`);
} else {
  module.exports = all;
}
