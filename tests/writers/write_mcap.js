// usage: node write_mcap.js NODE_MODULES OUT_DIR [small]
// Writes the MCAP files hapticcal's MCAP reader is tested on, with Foxglove's
// published writer (@mcap/core's McapWriter), each with a side file NAME.json
// of what was written (the channels as registered, every message's channel,
// log_time and bytes as hex, the chunks as @mcap/core's own indexed reader
// finds them) for the test to compare with:
//   unchunked.mcap                records straight in the data section
//   chunked-none.mcap             small chunks, uncompressed
//   chunked-zstd.mcap             zstd chunks (@foxglove/wasm-zstd)
//   chunked-lz4.mcap              lz4-frame chunks: Debian's python3-roslz4
//                                 compresses (@foxglove/wasm-lz4 only
//                                 decompresses: it checks each chunk)
// and, from @mcap/core's record builder, two malformed files:
//   undefined-schema.mcap         a channel naming a schema never defined
//   undefined-channel.mcap        a message on a channel never defined
// Channels: the ROS 2 messages of cdr_messages.js (ros2msg schemas, cdr), a
// ROS 1 std_msgs/String (ros1msg, ros1; its bytes written here by the ROS 1
// rule: uint32 length, then the characters), a JSON channel, a CDR channel
// without a schema and a CDR channel with a ros2idl schema; a Metadata and an
// Attachment record between the messages. With "small": the first messages
// only, a few kB a file (the fuzz target's seeds, fuzz/seeds/mcap).
'use strict';
const fs = require('fs');
const path = require('path');
const { execFileSync } = require('child_process');

const [modules, outDir, size] = process.argv.slice(2);
const SMALL = size === 'small';
if (!modules || !outDir) {
  process.stderr.write('usage: node write_mcap.js NODE_MODULES OUT_DIR\n');
  process.exit(2);
}
const mcap = require(path.join(modules, '@mcap/core'));
const zstd = require(path.join(modules, '@foxglove/wasm-zstd'));
const lz4Decompress = require(path.join(modules, '@foxglove/wasm-lz4'));
const cdr = require('./cdr_messages.js')(modules);

function lz4Compress(data) {
  const compressed = execFileSync(
    '/usr/bin/python3',
    ['-c', 'import sys, roslz4; sys.stdout.buffer.write(roslz4.compress(sys.stdin.buffer.read()))'],
    { input: Buffer.from(data), maxBuffer: 1 << 30 });
  const back = lz4Decompress(compressed, data.length);
  if (Buffer.compare(back, Buffer.from(data)) !== 0) throw new Error('lz4 round trip failed');
  return compressed;
}

const ROS1_STRING = 'string data\n';
const IDL = 'module example_msgs {\n  module msg {\n    struct Reading {\n      double value;\n    };\n  };\n};\n';
const JSON_SCHEMA = JSON.stringify({ type: 'object', properties: { level: { type: 'integer' } } });

// The channels: [topic, schema (or null), message encoding].
const CHANNELS = [
  ['/joint_states', { name: cdr.topics[0].type, encoding: 'ros2msg', data: cdr.topics[0].definition }, 'cdr'],
  ['/tracker/pose', { name: cdr.topics[1].type, encoding: 'ros2msg', data: cdr.topics[1].definition }, 'cdr'],
  ['/chatter', { name: 'std_msgs/String', encoding: 'ros1msg', data: ROS1_STRING }, 'ros1'],
  ['/diagnostics', { name: 'Diagnostics', encoding: 'jsonschema', data: JSON_SCHEMA }, 'json'],
  ['/raw', null, 'cdr'],
  ['/reading', { name: 'example_msgs/msg/Reading', encoding: 'ros2idl', data: IDL }, 'cdr'],
];

// Every message in the order written: [channel index, log_time, bytes].
function messages() {
  const out = [];
  let k = 0;
  for (const m of SMALL ? cdr.messages.slice(0, 4) : cdr.messages) {
    out.push([m.topic === '/joint_states' ? 0 : 1, m.log_time, m.data]);
    if (++k % (SMALL ? 4 : 40) === 0) {
      const text = `tick ${k} \u00e9`;  // non-ASCII: bytes, not characters
      const bytes = Buffer.from(text, 'utf8');
      const ros1 = Buffer.alloc(4 + bytes.length);
      ros1.writeUInt32LE(bytes.length, 0);
      bytes.copy(ros1, 4);
      out.push([2, m.log_time + 1n, ros1]);
      out.push([3, m.log_time + 2n, Buffer.from(JSON.stringify({ level: k }))]);
      out.push([4, m.log_time + 3n, k % 80 === 0 ? Buffer.alloc(0) : Buffer.from([0, 1, 0, 0, k & 255])]);
      out.push([5, m.log_time + 4n, Buffer.from([0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xf0, 0x3f])]);
    }
  }
  return out;
}

class Sink {
  constructor() { this.parts = []; this.size = 0n; }
  async write(buffer) { this.parts.push(Buffer.from(buffer)); this.size += BigInt(buffer.byteLength); }
  position() { return this.size; }
  bytes() { return Buffer.concat(this.parts); }
}

async function writeFile(name, options) {
  const sink = new Sink();
  const writer = new mcap.McapWriter({ writable: sink, ...options });
  await writer.start({ profile: 'ros2', library: 'hapticcal tests (@mcap/core)' });
  const ids = [];
  const side = { channels: [], messages: [], chunks: [] };
  for (const [topic, schema, messageEncoding] of CHANNELS) {
    const schemaId = schema ? await writer.registerSchema({ ...schema, data: Buffer.from(schema.data) }) : 0;
    const id = await writer.registerChannel({
      topic, messageEncoding, schemaId, metadata: new Map([['offered_qos_profiles', '']]),
    });
    ids.push(id);
    side.channels.push({
      id, topic, message_encoding: messageEncoding,
      schema_name: schema ? schema.name : '', schema_encoding: schema ? schema.encoding : '',
      schema_data: schema ? schema.data : '',
    });
  }
  let sequence = 0;
  for (const [channel, logTime, data] of messages()) {
    await writer.addMessage({
      channelId: ids[channel], sequence: sequence++, logTime, publishTime: logTime - 5n, data,
    });
    side.messages.push({ channel: ids[channel], log_time: logTime.toString(), data: Buffer.from(data).toString('hex') });
    if (sequence === (SMALL ? 3 : 100)) {
      await writer.addMetadata({ name: 'session', metadata: new Map([['operator', 'test']]) });
      await writer.addAttachment({
        name: 'notes.txt', mediaType: 'text/plain', logTime, createTime: 0n, data: Buffer.from('calibration run'),
      });
    }
  }
  await writer.end();
  const bytes = sink.bytes();
  const reader = await mcap.McapIndexedReader.Initialize({ readable: new mcap.TempBuffer(bytes) });
  for (const c of reader.chunkIndexes) {
    side.chunks.push({
      offset: Number(c.chunkStartOffset), length: Number(c.chunkLength), compression: c.compression,
      compressed_size: Number(c.compressedSize), uncompressed_size: Number(c.uncompressedSize),
    });
  }
  side.data_end_offset = Number(reader.dataEndOffset);
  fs.writeFileSync(path.join(outDir, `${name}.mcap`), bytes);
  fs.writeFileSync(path.join(outDir, `${name}.json`), JSON.stringify(side, null, 1));
}

// A file of hand-ordered records (@mcap/core's builder checks nothing).
function writeRecords(name, build) {
  const b = new mcap.McapRecordBuilder();
  b.writeMagic();
  b.writeHeader({ profile: '', library: 'hapticcal tests' });
  build(b);
  b.writeDataEnd({ dataSectionCrc: 0 });
  b.writeFooter({ summaryStart: 0n, summaryOffsetStart: 0n, summaryCrc: 0 });
  b.writeMagic();
  fs.writeFileSync(path.join(outDir, `${name}.mcap`), Buffer.from(b.buffer));
}

async function main() {
  await zstd.isLoaded;
  await lz4Decompress.isLoaded;
  fs.mkdirSync(outDir, { recursive: true });
  await writeFile('unchunked', { useChunks: false });
  const chunkSize = SMALL ? 512 : 4096;
  await writeFile('chunked-none', { chunkSize });
  await writeFile('chunked-zstd', {
    chunkSize, compressChunk: (data) => ({ compression: 'zstd', compressedData: zstd.compress(data, 3) }),
  });
  await writeFile('chunked-lz4', {
    chunkSize, compressChunk: (data) => ({ compression: 'lz4', compressedData: lz4Compress(data) }),
  });
  const message = { channelId: 1, sequence: 0, logTime: 5n, publishTime: 5n, data: new Uint8Array([1, 2]) };
  writeRecords('undefined-schema', (b) => {
    b.writeChannel({ id: 1, schemaId: 7, topic: '/x', messageEncoding: 'cdr', metadata: new Map() });
    b.writeMessage(message);
  });
  writeRecords('undefined-channel', (b) => {
    b.writeSchema({ id: 1, name: 'std_msgs/msg/Empty', encoding: 'ros2msg', data: new Uint8Array() });
    b.writeChannel({ id: 2, schemaId: 1, topic: '/x', messageEncoding: 'cdr', metadata: new Map() });
    b.writeMessage(message);
  });
}

main().catch((e) => {
  process.stderr.write(`${e.stack || e}\n`);
  process.exit(1);
});
