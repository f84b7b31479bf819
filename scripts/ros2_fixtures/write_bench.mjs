// Writes a large synthetic ROS 2 recording for scripts/bench_ros2_import.sh, with
// the same independent npm code as write_mcap.mjs (@mcap/core, @foxglove/rosmsg2-
// serialization, @foxglove/wasm-zstd, jpeg-js). Usage:
//   node write_bench.mjs <out folder> <name> <seconds>
// writes <name>_zstd.mcap and <name>_plain.mcap (rosbag2's 768 KiB chunks, zstd
// level 3 / uncompressed) and <name>.msgs, the same CDR messages framed as
// (u8 topic, u64 log time, u32 size, bytes) for write_bench_db3.py.
// Topics: /fisheye/image/compressed (1280x720 JPEG, ~300 KB, 20 Hz),
// /cam/image_raw (640x480 mono8, 20 Hz), /odom (nav_msgs/Odometry, 100 Hz).
import { parse } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import zstd from "@foxglove/wasm-zstd";
import jpeg from "jpeg-js";
import fs from "node:fs";
import path from "node:path";
import { openRos2Mcap, schemaText } from "./ros2_schemas.mjs";

const [out, name, seconds] = [process.argv[2], process.argv[3], Number(process.argv[4])];
const TOPICS = [
  ["/fisheye/image/compressed", "sensor_msgs/CompressedImage"],
  ["/cam/image_raw", "sensor_msgs/Image"],
  ["/odom", "nav_msgs/Odometry"],
];
const serializers = TOPICS.map(([, t]) => new MessageWriter(parse(schemaText(t), { ros2: true })));

// Pseudo-random texture: smooth pattern plus sensor-like noise (so neither JPEG
// nor PNG/zstd find it trivially compressible).
let seed = 12345;
const rnd = () => ((seed = (seed * 1103515245 + 12345) >>> 0) >>> 16) & 0xff;
const texture = (x, y, phase) => 128 + 60 * Math.sin(x / 23 + phase) * Math.cos(y / 17) + 40 * Math.sin((x + y) / 7);
const clamp = (v) => Math.max(0, Math.min(255, v));

// Four distinct 1280x720 JPEGs, cycled; each frame gets a COM segment with its
// index so that no two frames are byte-identical (still valid JPEG).
const [JW, JH] = [1280, 720];
const jpegs = [0, 1, 2, 3].map((k) => {
  const rgba = Buffer.alloc(JW * JH * 4);
  for (let y = 0; y < JH; y++) for (let x = 0; x < JW; x++) {
    const i = (y * JW + x) * 4, b = texture(x, y, k);
    for (let c = 0; c < 3; c++) rgba[i + c] = clamp(b + 10 * c + (rnd() - 128) / 12);
    rgba[i + 3] = 255;
  }
  return Buffer.from(jpeg.encode({ data: rgba, width: JW, height: JH }, 90).data);
});
function jpegFrame(k) {
  const text = Buffer.from(`frame ${k}`), com = Buffer.alloc(4);
  com.writeUInt16BE(0xfffe, 0); com.writeUInt16BE(text.length + 2, 2);
  const j = jpegs[k % jpegs.length];
  return Buffer.concat([j.subarray(0, 2), com, text, j.subarray(2)]);
}
// mono8 frames: windows into a base image twice the frame's size, shifted per frame.
const [MW, MH] = [640, 480];
const mono = Buffer.alloc(MW * MH * 2);
for (let i = 0; i < mono.length; i++) mono[i] = clamp(texture(i % MW, Math.floor(i / MW), 0) + (rnd() - 128) / 16);
const monoFrame = (k) => mono.subarray((k * 6133) % (MW * MH), (k * 6133) % (MW * MH) + MW * MH);

const openMcap = (file, options) =>
  openRos2Mcap(path.join(out, file), TOPICS, "lookboth bench_ros2_import (@mcap/core)", options);

await zstd.isLoaded;
const mcaps = [
  await openMcap(`${name}_zstd.mcap`, { compressChunk: (d) => ({ compression: "zstd", compressedData: zstd.compress(d, 3) }) }),
  await openMcap(`${name}_plain.mcap`, {}),
];
const msgs = fs.openSync(path.join(out, `${name}.msgs`), "w");

// 10 ms ticks: odometry every tick, the cameras every 5th (offset by 2 and 4 ms).
const T0 = 1700000000n * 1000000000n;
const stamp = (ns) => ({ sec: Number(ns / 1000000000n), nanosec: Number(ns % 1000000000n) });
let sequence = 0;
async function emit(topicIndex, stampNs, message) {
  const cdr = serializers[topicIndex].writeMessage(message), logTime = stampNs + 5000000n;
  for (const m of mcaps) {
    await m.writer.addMessage({ channelId: m.channels[topicIndex], sequence, logTime, publishTime: logTime, data: cdr });
  }
  sequence++;
  const head = Buffer.alloc(13);
  head.writeUInt8(topicIndex, 0); head.writeBigUInt64LE(logTime, 1); head.writeUInt32LE(cdr.byteLength, 9);
  fs.writeSync(msgs, head); fs.writeSync(msgs, cdr);
}
for (let tick = 0; tick < seconds * 100; tick++) {
  const t = T0 + BigInt(tick) * 10000000n, yaw = tick * 0.001;
  await emit(2, t, { header: { stamp: stamp(t), frame_id: "odom" }, child_frame_id: "base_link",
    pose: { pose: { position: { x: 0.005 * tick, y: Math.sin(yaw), z: 0 }, orientation: { x: 0, y: 0, z: Math.sin(yaw / 2), w: Math.cos(yaw / 2) } },
      covariance: Array(36).fill(0.001) },
    twist: { twist: { linear: { x: 0.5, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0.1 } }, covariance: Array(36).fill(0.002) } });
  if (tick % 5 === 0) {
    const k = tick / 5, ts = t + 2000000n, tc = t + 4000000n;
    await emit(0, ts, { header: { stamp: stamp(ts), frame_id: "fisheye" }, format: "jpeg", data: jpegFrame(k) });
    await emit(1, tc, { header: { stamp: stamp(tc), frame_id: "cam01" }, height: MH, width: MW, encoding: "mono8",
      is_bigendian: 0, step: MW, data: monoFrame(k) });
  }
}
for (const m of mcaps) { await m.writer.end(); fs.closeSync(m.sink.fd); }
fs.closeSync(msgs);
console.log(`write_bench.mjs: ${name}: ${sequence} messages, JPEG ${jpegs.map((j) => j.length).join("/")} bytes`);
