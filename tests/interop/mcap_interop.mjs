// Checks visnav's MCAP files with the independent @mcap/core reader, and writes a ROS 2 bag with
// @mcap/core's writer for visnav to read (tests/interop/test_mcap_interop.cpp).
//   node mcap_interop.mjs read FILE    -> JSON summary on stdout (exit 1 with the error otherwise)
//   node mcap_interop.mjs write FILE [lz4] -> a bag: /camera/image_raw (Image mono8), /odom, /cmd_vel
//                                            (uncompressed chunks, or lz4 frames made by lz4js)
import { McapIndexedReader, McapStreamReader, McapWriter } from "@mcap/core";
import { decompress } from "fzstd";
import lz4 from "lz4js";
import { open, readFile } from "node:fs/promises";

const decompressHandlers = {
  zstd: (buffer, size) => decompress(buffer, new Uint8Array(Number(size))),
  lz4: (buffer, size) => Uint8Array.from(lz4.decompress(buffer, Number(size))),
};

async function read(path) {
  const bytes = await readFile(path);
  // 1. Linear: every record, chunk CRCs validated.
  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  stream.append(bytes);
  const topics = {};
  const channels = new Map();
  const schemas = new Map();
  let header = null;
  let messages = 0;
  const attachments = [];
  let firstTwist = null;
  let firstStatus = null;
  for (let r; (r = stream.nextRecord()); ) {
    if (r.type === "Header") header = r;
    if (r.type === "Schema") schemas.set(r.id, r);
    if (r.type === "Channel") channels.set(r.id, r);
    if (r.type === "Attachment") attachments.push(r.name);
    if (r.type === "Message") {
      const ch = channels.get(r.channelId);
      if (ch.topic === "/visnav/status" && firstStatus === null) firstStatus = JSON.parse(new TextDecoder().decode(r.data));
      const schema = schemas.get(ch.schemaId);
      const t = (topics[ch.topic] ??= { count: 0, schema: schema ? schema.name : "", encoding: ch.messageEncoding });
      t.count++;
      messages++;
      if (schema && schema.name === "geometry_msgs/msg/Twist" && firstTwist === null) {
        const v = new DataView(r.data.buffer, r.data.byteOffset, r.data.byteLength);
        firstTwist = { linear_x: v.getFloat64(4, true), angular_z: v.getFloat64(4 + 40, true) };
      }
    }
  }
  if (!stream.done()) throw new Error("stream reader: the file is not complete");
  // 2. Indexed: footer, summary, chunk indexes and message indexes.
  const handle = await open(path, "r");
  const readable = {
    size: async () => BigInt((await handle.stat()).size),
    read: async (offset, size) => {
      const buf = new Uint8Array(Number(size));
      await handle.read(buf, 0, Number(size), Number(offset));
      return buf;
    },
  };
  const indexed = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  let indexedMessages = 0;
  let lastTime = -1n;
  let ordered = true;
  for await (const m of indexed.readMessages({ validateCrcs: true })) {
    indexedMessages++;
    if (m.logTime < lastTime) ordered = false;
    lastTime = m.logTime;
  }
  const indexedAttachments = [];
  for await (const a of indexed.readAttachments({ validateCrcs: true })) indexedAttachments.push(a.name);
  await handle.close();
  console.log(JSON.stringify({
    profile: header ? header.profile : null,
    messages,
    indexed_messages: indexedMessages,
    indexed_in_time_order: ordered,
    statistics_message_count: indexed.statistics ? Number(indexed.statistics.messageCount) : -1,
    chunks: indexed.chunkIndexes.length,
    chunk_compression: [...new Set(indexed.chunkIndexes.map((c) => c.compression))],
    topics,
    attachments,
    indexed_attachments: indexedAttachments,
    first_twist: firstTwist,
    first_status: firstStatus,
  }));
}

// ROS 2 CDR (little-endian, XCDR1) for the test bag.
class Cdr {
  constructor() { this.bytes = [0, 1, 0, 0]; }
  align(n) { while ((this.bytes.length - 4) % n !== 0) this.bytes.push(0); }
  raw(n, write) { this.align(n); const b = new Uint8Array(n); write(new DataView(b.buffer)); this.bytes.push(...b); }
  u32(v) { this.raw(4, (d) => d.setUint32(0, v, true)); }
  i32(v) { this.raw(4, (d) => d.setInt32(0, v, true)); }
  f64(v) { this.raw(8, (d) => d.setFloat64(0, v, true)); }
  u8(v) { this.bytes.push(v); }
  str(s) { const e = new TextEncoder().encode(s); this.u32(e.length + 1); this.bytes.push(...e, 0); }
  seq(u8s) { this.u32(u8s.length); this.bytes.push(...u8s); }
  header(t, frame) { this.i32(Math.floor(t)); this.u32(Math.round((t - Math.floor(t)) * 1e9)); this.str(frame); }
  done() { return new Uint8Array(this.bytes); }
}

const SEP = "=".repeat(80) + "\n";
const TIME = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
const HEADER = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n" + SEP + TIME;
const VEC3 = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";

async function write(path, compression) {
  const handle = await open(path, "w");
  let position = 0n;
  const writable = {
    position: () => position,
    write: async (buffer) => { await handle.write(buffer); position += BigInt(buffer.byteLength); },
  };
  const compressChunk = compression === "lz4"
    ? (data) => ({ compression: "lz4", compressedData: Uint8Array.from(lz4.compress(data)) })
    : undefined;
  const w = new McapWriter({ writable, chunkSize: 4096, compressChunk });
  await w.start({ profile: "ros2", library: "mcap-interop-test" });
  const enc = (s) => new TextEncoder().encode(s);
  const imageSchema = await w.registerSchema({ name: "sensor_msgs/msg/Image", encoding: "ros2msg", data: enc(
    "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data\n" + SEP + HEADER) });
  const odomSchema = await w.registerSchema({ name: "nav_msgs/msg/Odometry", encoding: "ros2msg", data: enc("(test)") });
  const twistSchema = await w.registerSchema({ name: "geometry_msgs/msg/Twist", encoding: "ros2msg", data: enc(
    "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n" + SEP + VEC3) });
  const image = await w.registerChannel({ schemaId: imageSchema, topic: "/camera/image_raw", messageEncoding: "cdr", metadata: new Map() });
  const odom = await w.registerChannel({ schemaId: odomSchema, topic: "/odom", messageEncoding: "cdr", metadata: new Map() });
  const cmd = await w.registerChannel({ schemaId: twistSchema, topic: "/cmd_vel", messageEncoding: "cdr", metadata: new Map() });
  let seq = 0;
  for (let i = 0; i < 20; i++) {
    const t = 100 + 0.1 * i;  // robot time: 100 s + 0.1 s per step, driving 0.5 m/s along x
    const ns = BigInt(Math.round(t * 1e9));
    const o = new Cdr();
    o.header(t, "odom"); o.str("base_link");
    o.f64(0.05 * i); o.f64(0); o.f64(0);  // position
    o.f64(0); o.f64(0); o.f64(0); o.f64(1);  // orientation
    for (let k = 0; k < 36; k++) o.f64(0);
    o.f64(0.5); o.f64(0); o.f64(0); o.f64(0); o.f64(0); o.f64(0.01 * i);  // twist
    for (let k = 0; k < 36; k++) o.f64(0);
    await w.addMessage({ channelId: odom, sequence: seq++, logTime: ns, publishTime: ns, data: o.done() });
    if (i % 2 === 0) {
      const im = new Cdr();
      im.header(t, "camera"); im.u32(6); im.u32(8); im.str("mono8"); im.u8(0); im.u32(8);
      im.seq(Array.from({ length: 48 }, (_, k) => (k * 5 + i * 10) % 256));
      await w.addMessage({ channelId: image, sequence: seq++, logTime: ns + 1000n, publishTime: ns, data: im.done() });
    }
    const c = new Cdr();
    c.f64(0.5); c.f64(0); c.f64(0); c.f64(0); c.f64(0); c.f64(0.01 * i);
    await w.addMessage({ channelId: cmd, sequence: seq++, logTime: ns + 2000n, publishTime: ns, data: c.done() });
  }
  await w.end();
  await handle.close();
}

const [mode, file, compression] = process.argv.slice(2);
try {
  if (mode === "read") await read(file);
  else if (mode === "write") await write(file, compression);
  else throw new Error("usage: node mcap_interop.mjs read|write FILE");
} catch (e) {
  console.error(`mcap_interop: ${e.stack ?? e}`);
  process.exit(1);
}
