// usage: node session_ros2.js NODE_MODULES DEVICE_CSV TRACKER_CSV OUT_DIR
//
// A hand-guided session as a ROS 2 robot records it: hapticcal's two streams
// (as session_bag.py reads them) serialised to CDR by Foxglove's published
// writer (@foxglove/rosmsg's parser, @foxglove/rosmsg2-serialization's
// MessageWriter) and written as OUT_DIR/session.mcap by @mcap/core's McapWriter
// (ros2msg schemas, zstd chunks by @foxglove/wasm-zstd), and as
// OUT_DIR/session_db3.json (the topics, and each message's log time and CDR
// bytes as hex) for session_db3.py. Stamps and names as session_bag.py's:
// /touch/joint_states (sensor_msgs/msg/JointState, the device's clock, joints
// in another order plus "gripper") and /tracker/pose (PoseStamped, the
// tracker's clock), each stamp 1733390000 s + the CSV's time rounded to the
// nanosecond, each log time the stamp + 1.5 ms (the joints') or + 4 ms (the others'); /chatter (std_msgs/msg/String)
// is not imported.
'use strict';
const fs = require('fs');
const path = require('path');

const [modules, deviceCsv, trackerCsv, out] = process.argv.slice(2);
const mcap = require(path.join(modules, '@mcap/core'));
const { parse } = require(path.join(modules, '@foxglove/rosmsg'));
const { MessageWriter } = require(path.join(modules, '@foxglove/rosmsg2-serialization'));
const zstd = require(path.join(modules, '@foxglove/wasm-zstd'));

const EPOCH_NS = 1733390000n * 1000000000n;
const NAMES = ['waist', 'shoulder', 'elbow', 'yaw', 'pitch', 'roll'];
const PUBLISHED = ['roll', 'gripper', 'waist', 'pitch', 'shoulder', 'yaw', 'elbow'];
const SEP = '='.repeat(80);
const HEADER = `MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n${SEP}\n` +
    'MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n';
const TYPES = {
  '/touch/joint_states': {
    type: 'sensor_msgs/msg/JointState',
    definition: 'std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n' +
        `float64[] effort\n${SEP}\n${HEADER}`,
  },
  '/tracker/pose': {
    type: 'geometry_msgs/msg/PoseStamped',
    definition: `std_msgs/Header header\ngeometry_msgs/Pose pose\n${SEP}\n${HEADER}${SEP}\n` +
        `MSG: geometry_msgs/Pose\nPoint position\nQuaternion orientation\n${SEP}\n` +
        `MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n${SEP}\n` +
        'MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n',
  },
  '/chatter': {type: 'std_msgs/msg/String', definition: 'string data\n'},
};

function rows(file) {
  const lines = fs.readFileSync(file, 'utf8').split('\n').filter((l) => l && !l.startsWith('#'));
  return {header: lines[0].split(','), rows: lines.slice(1).map((l) => l.split(',').map(Number))};
}

// The CSV's seconds (a shortest decimal) to integer nanoseconds, rounded as
// Python's round(t * 1e9) (session_bag.py): half to even.
function nanoseconds(t) {
  const x = t * 1e9;
  let r = Math.round(x);
  if (Math.abs(x - Math.trunc(x)) === 0.5 && r % 2 !== 0) r -= 1;
  return EPOCH_NS + BigInt(r);
}

function stamp(ns) {
  return {sec: Number(ns / 1000000000n), nanosec: Number(ns % 1000000000n)};
}

class FileSink {
  constructor(file) { this.fd = fs.openSync(file, 'w'); this.size = 0n; }
  async write(buffer) { fs.writeSync(this.fd, buffer); this.size += BigInt(buffer.byteLength); }
  position() { return this.size; }
}

async function main() {
  await zstd.isLoaded;
  const device = rows(deviceCsv), tracker = rows(trackerCsv);
  const events = [];  // [log time, order, topic, message]
  for (const r of device.rows) {
    const ns = nanoseconds(r[0]);
    const q = Object.fromEntries(NAMES.map((n, k) => [n, r[k + 1]]));
    q.gripper = 0.25;
    events.push([ns + 1500000n, 0, '/touch/joint_states', {
      header: {stamp: stamp(ns), frame_id: ''}, name: PUBLISHED, position: PUBLISHED.map((n) => q[n]),
      velocity: [], effort: [],
    }]);
  }
  tracker.rows.forEach((r, k) => {
    const ns = nanoseconds(r[0]);
    events.push([ns + 4000000n, 1, '/tracker/pose', {
      header: {stamp: stamp(ns), frame_id: 'tracker'},
      pose: {position: {x: r[1], y: r[2], z: r[3]}, orientation: {w: r[4], x: r[5], y: r[6], z: r[7]}},
    }]);
    if (k % 50 === 0) events.push([ns + 4000000n, 2, '/chatter', {data: `sample ${k}`}]);
  });
  events.sort((a, b) => (a[0] < b[0] ? -1 : a[0] > b[0] ? 1 : a[1] - b[1]));

  const writers = Object.fromEntries(Object.entries(TYPES).map(([topic, t]) =>
    [topic, new MessageWriter(parse(t.definition, {ros2: true}))]));
  const writer = new mcap.McapWriter({
    writable: new FileSink(path.join(out, 'session.mcap')), useChunks: true, chunkSize: 256 * 1024,
    compressChunk: (data) => ({compression: 'zstd', compressedData: zstd.compress(data, 3)}),
  });
  await writer.start({profile: 'ros2', library: 'hapticcal test writer'});
  const channels = {};
  for (const [topic, t] of Object.entries(TYPES)) {
    const schemaId = await writer.registerSchema({name: t.type, encoding: 'ros2msg', data: Buffer.from(t.definition)});
    channels[topic] = await writer.registerChannel({topic, schemaId, messageEncoding: 'cdr', metadata: new Map()});
  }
  const db3 = {topics: Object.entries(TYPES).map(([name, t]) => ({name, ...t})), messages: []};
  let sequence = 0;
  for (const [logTime, , topic, message] of events) {
    const data = writers[topic].writeMessage(message);
    await writer.addMessage({channelId: channels[topic], sequence: sequence++, logTime, publishTime: logTime, data});
    db3.messages.push({topic, log_time: logTime.toString(), data: Buffer.from(data).toString('hex')});
  }
  await writer.end();
  fs.writeFileSync(path.join(out, 'session_db3.json'), JSON.stringify(db3));
}

main().catch((e) => { console.error(e); process.exit(1); });
