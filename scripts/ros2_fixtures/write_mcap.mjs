// Writes the ROS 2 test recordings of tests/data/ros2 with independent code:
// Foxglove's @mcap/core (MCAP), @foxglove/rosmsg (message definitions) and
// @foxglove/rosmsg2-serialization (CDR), lz4js and @foxglove/wasm-zstd for
// the chunks, jpeg-js for the JPEG. Called by scripts/make_ros2_fixtures.sh
// with the output folder; also writes expected.json (every message with its
// topic, type, log time and fields, for the tests) and db3_messages.json (the
// CDR blobs that the shell script's Python puts into the .db3 file).
import { McapWriter } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import { CdrWriter, EncapsulationKind } from "@foxglove/cdr";
import lz4 from "lz4js";
import zstd from "@foxglove/wasm-zstd";
import jpeg from "jpeg-js";
import fs from "node:fs";
import path from "node:path";
import zlib from "node:zlib";

const out = process.argv[2];
const SEP = "=".repeat(80);

// ROS 2 (Humble) message definitions, as rosbag2 stores them in MCAP schemas.
const DEFS = {
  "builtin_interfaces/Time": "int32 sec\nuint32 nanosec",
  "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id",
  "sensor_msgs/RegionOfInterest": "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify",
  "sensor_msgs/Image": "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data",
  "sensor_msgs/CompressedImage": "std_msgs/Header header\nstring format\nuint8[] data",
  "sensor_msgs/CameraInfo": "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nRegionOfInterest roi",
  "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z",
  "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z",
  "geometry_msgs/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
  "geometry_msgs/Pose": "Point position\nQuaternion orientation",
  "geometry_msgs/PoseWithCovariance": "Pose pose\nfloat64[36] covariance",
  "geometry_msgs/Twist": "Vector3 linear\nVector3 angular",
  "geometry_msgs/TwistWithCovariance": "Twist twist\nfloat64[36] covariance",
  "geometry_msgs/PoseStamped": "std_msgs/Header header\nPose pose",
  "geometry_msgs/PoseWithCovarianceStamped": "std_msgs/Header header\nPoseWithCovariance pose",
  "geometry_msgs/Transform": "Vector3 translation\nQuaternion rotation",
  "geometry_msgs/TransformStamped": "std_msgs/Header header\nstring child_frame_id\nTransform transform",
  "nav_msgs/Odometry": "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist",
  "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms",
};
const DEPS = {
  "sensor_msgs/Image": ["std_msgs/Header", "builtin_interfaces/Time"],
  "sensor_msgs/CompressedImage": ["std_msgs/Header", "builtin_interfaces/Time"],
  "sensor_msgs/CameraInfo": ["std_msgs/Header", "builtin_interfaces/Time", "sensor_msgs/RegionOfInterest"],
  "nav_msgs/Odometry": ["std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/PoseWithCovariance", "geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion", "geometry_msgs/TwistWithCovariance", "geometry_msgs/Twist", "geometry_msgs/Vector3"],
  "geometry_msgs/PoseStamped": ["std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion"],
  "geometry_msgs/PoseWithCovarianceStamped": ["std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/PoseWithCovariance", "geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion"],
  "tf2_msgs/TFMessage": ["geometry_msgs/TransformStamped", "std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/Transform", "geometry_msgs/Vector3", "geometry_msgs/Quaternion"],
};
function schemaText(type) {
  return [DEFS[type], ...DEPS[type].map((d) => `${SEP}\nMSG: ${d}\n${DEFS[d]}`)].join("\n") + "\n";
}
const ros2Type = (type) => type.replace("/", "/msg/");

// A tiny PNG (8x6 grey ramp), written by hand: signature, IHDR, IDAT, IEND.
function crc32(bytes) {
  let c, crc = 0xffffffff;
  for (const b of bytes) {
    c = (crc ^ b) & 0xff;
    for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    crc = (crc >>> 8) ^ c;
  }
  return (crc ^ 0xffffffff) >>> 0;
}
function pngChunk(type, data) {
  const body = Buffer.concat([Buffer.from(type, "ascii"), data]);
  const len = Buffer.alloc(4); len.writeUInt32BE(data.length);
  const crc = Buffer.alloc(4); crc.writeUInt32BE(crc32(body));
  return Buffer.concat([len, body, crc]);
}
function tinyPng(width, height) {
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(width, 0); ihdr.writeUInt32BE(height, 4);
  ihdr[8] = 8; ihdr[9] = 0;  // 8-bit greyscale
  const rows = [];
  for (let y = 0; y < height; y++) {
    rows.push(0);  // filter: none
    for (let x = 0; x < width; x++) rows.push((x * 30 + y * 10) & 0xff);
  }
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]),
    pngChunk("IHDR", ihdr), pngChunk("IDAT", zlib.deflateSync(Buffer.from(rows))),
    pngChunk("IEND", Buffer.alloc(0))]);
}
function tinyJpeg(width, height) {
  const rgba = Buffer.alloc(width * height * 4);
  for (let i = 0; i < width * height; i++) rgba.set([i * 5 & 0xff, 128, 255 - (i * 5 & 0xff), 255], i * 4);
  return jpeg.encode({ data: rgba, width, height }, 90).data;
}

// The recording: known values, receive (log) times 5 ms after the stamps, no two
// alike (the .db3 file is read in time order).
const T0 = 1700000000n * 1000000000n;
const stamp = (ns) => ({ sec: Number(ns / 1000000000n), nanosec: Number(ns % 1000000000n) });
const header = (ns, frame) => ({ stamp: stamp(ns), frame_id: frame });
const quatYaw = (yaw) => ({ x: 0, y: 0, z: Math.sin(yaw / 2), w: Math.cos(yaw / 2) });
const diag6 = (a) => Array.from({ length: 36 }, (_, i) => (i % 7 === 0 ? a * (1 + i / 7) : i === 1 ? 0.001 : 0));
const ms = (n) => BigInt(n) * 1000000n;
const events = [];
const add = (topic, type, stampNs, message) => events.push({ topic, type, log_time: stampNs + ms(5), message });

for (let k = 0; k < 3; k++) {
  const data = Uint8Array.from({ length: 48 }, (_, i) => (i * 7 + k * 13) & 0xff);
  add("/fisheye/image_raw", "sensor_msgs/Image", T0 + ms(100 * k),
    { header: header(T0 + ms(100 * k), "fisheye"), height: 6, width: 8, encoding: "mono8", is_bigendian: 0, step: 8, data });
}
add("/fisheye/camera_info", "sensor_msgs/CameraInfo", T0 + ms(10), {
  header: header(T0 + ms(10), "fisheye"), height: 6, width: 8, distortion_model: "equidistant",
  d: [0.1, -0.02, 0.003, -0.0004], k: [4.5, 0, 3.5, 0, 4.25, 2.5, 0, 0, 1], r: [1, 0, 0, 0, 1, 0, 0, 0, 1],
  p: [4.5, 0, 3.5, 0, 0, 4.25, 2.5, 0, 0, 0, 1, 0], binning_x: 1, binning_y: 2,
  roi: { x_offset: 1, y_offset: 2, height: 3, width: 4, do_rectify: true } });
add("/env_cam/image/compressed", "sensor_msgs/CompressedImage", T0 + ms(50),
  { header: header(T0 + ms(50), "env_cam"), format: "png", data: Uint8Array.from(tinyPng(8, 6)) });
add("/env_cam/image/compressed", "sensor_msgs/CompressedImage", T0 + ms(150),
  { header: header(T0 + ms(150), "env_cam"), format: "jpeg", data: Uint8Array.from(tinyJpeg(8, 6)) });
for (let k = 0; k < 5; k++) {
  add("/odom", "nav_msgs/Odometry", T0 + ms(40 * k + 22), {
    header: header(T0 + ms(40 * k + 22), "odom"), child_frame_id: "base_link",
    pose: { pose: { position: { x: 0.5 * k, y: 0.1 * k, z: -0.25 }, orientation: quatYaw(0.1 * k) }, covariance: diag6(0.01 * (k + 1)) },
    twist: { twist: { linear: { x: 0.5, y: -0.125, z: 0 }, angular: { x: 0, y: 0, z: 0.1 * k } }, covariance: diag6(0.002) } });
}
for (let k = 0; k < 3; k++) {
  add("/ground_truth/pose", "geometry_msgs/PoseStamped", T0 + ms(70 * k + 33),
    { header: header(T0 + ms(70 * k + 33), "map"), pose: { position: { x: 1 + k, y: 2 - k / 3, z: 3.5 }, orientation: quatYaw(-0.2 * k) } });
}
for (let k = 0; k < 2; k++) {
  add("/initialpose", "geometry_msgs/PoseWithCovarianceStamped", T0 + ms(120 * k + 64),
    { header: header(T0 + ms(120 * k + 64), "map"), pose: { pose: { position: { x: -k, y: 0.75, z: 0 }, orientation: quatYaw(1 + k) }, covariance: diag6(0.5) } });
}
for (let k = 0; k < 2; k++) {
  const transform = (child, x, yaw) => ({ header: header(T0 + ms(110 * k + 86), "odom"), child_frame_id: child,
    transform: { translation: { x, y: 0.25 * k, z: 1.5 }, rotation: quatYaw(yaw) } });
  add("/tf", "tf2_msgs/TFMessage", T0 + ms(110 * k + 86),
    { transforms: [transform("base_link", 0.1 * k, 0.3), transform("fisheye", -0.05, 0.7 * k)] });
}
events.sort((a, b) => (a.log_time < b.log_time ? -1 : a.log_time > b.log_time ? 1 : 0));

const writers = {};
for (const type of Object.keys(DEPS)) writers[type] = new MessageWriter(parse(schemaText(type), { ros2: true }));
for (const e of events) e.cdr = writers[e.type].writeMessage(e.message);

class FileSink {
  constructor() { this.parts = []; this.length = 0n; }
  async write(buffer) { this.parts.push(Buffer.from(buffer)); this.length += BigInt(buffer.byteLength); }
  position() { return this.length; }
}

async function writeMcap(file, options, selected = events) {
  const sink = new FileSink();
  const writer = new McapWriter({ writable: sink, chunkSize: 1024, ...options });
  await writer.start({ profile: "ros2", library: "lookboth make_ros2_fixtures (@mcap/core)" });
  const schemas = {}, channels = {};
  for (const e of selected) {
    if (!(e.type in schemas)) {
      schemas[e.type] = await writer.registerSchema({ name: ros2Type(e.type), encoding: "ros2msg",
        data: new TextEncoder().encode(schemaText(e.type)) });
    }
    if (!(e.topic in channels)) {
      channels[e.topic] = await writer.registerChannel({ topic: e.topic, schemaId: schemas[e.type],
        messageEncoding: "cdr", metadata: new Map([["offered_qos_profiles", ""]]) });
    }
  }
  let sequence = 0;
  for (const e of selected) {
    await writer.addMessage({ channelId: channels[e.topic], sequence: sequence++, logTime: e.log_time,
      publishTime: e.log_time, data: e.cdr });
  }
  await writer.end();
  fs.writeFileSync(path.join(out, file), Buffer.concat(sink.parts));
}

await zstd.isLoaded;
await writeMcap("sample_uncompressed.mcap", {});
await writeMcap("sample_lz4.mcap", { compressChunk: (data) => ({ compression: "lz4", compressedData: lz4.compress(data) }) });
await writeMcap("sample_zstd.mcap", { compressChunk: (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 19) }) });
await writeMcap("sample_unchunked.mcap", { useChunks: false });
await writeMcap("sample_nosummary.mcap", { useStatistics: false, useSummaryOffsets: false, useChunkIndex: false,
  useMessageIndex: false, repeatSchemas: false, repeatChannels: false, useAttachmentIndex: false, useMetadataIndex: false });
// The fisheye's mount as static transforms (base_link -> mast -> fisheye_link,
// and a frame elsewhere) on /tf_static, with the odometry of base_link: for
// trajectories carried to the fisheye (mapping body_frame). Not in expected.json.
const staticTf = (parent, child, x, z, yaw) => ({ header: header(T0, parent), child_frame_id: child,
  transform: { translation: { x, y: 0.02, z }, rotation: quatYaw(yaw) } });
const mounts = [{ topic: "/tf_static", type: "tf2_msgs/TFMessage", log_time: T0 + ms(1),
  message: { transforms: [staticTf("base_link", "mast", 0.1, 0.3, 0.25), staticTf("mast", "fisheye_link", 0, 0.05, 0.5),
    staticTf("base_link", "lidar", -0.2, 0.4, 0)] } }];
for (const e of mounts) e.cdr = writers[e.type].writeMessage(e.message);
await writeMcap("sample_tf_static.mcap", {}, [...mounts, ...events.filter((e) => e.topic === "/odom" || e.topic === "/tf")]);
fs.mkdirSync(path.join(out, "sample_mcap_folder"), { recursive: true });
await writeMcap("sample_mcap_folder/sample_mcap_folder_0.mcap", {}, events.slice(0, 10));
await writeMcap("sample_mcap_folder/sample_mcap_folder_1.mcap", {}, events.slice(10));

// One PoseStamped in big-endian CDR, written field by field with @foxglove/cdr.
const be = { header: header(T0 + ms(7), "map"), pose: { position: { x: 1.25, y: -2.5, z: 3.75 }, orientation: { x: 0.1, y: 0.2, z: 0.3, w: 0.9273618495495703 } } };
const w = new CdrWriter({ kind: EncapsulationKind.CDR_BE });
w.int32(be.header.stamp.sec).uint32(be.header.stamp.nanosec).string(be.header.frame_id);
for (const v of [be.pose.position.x, be.pose.position.y, be.pose.position.z, be.pose.orientation.x,
  be.pose.orientation.y, be.pose.orientation.z, be.pose.orientation.w]) w.float64(v);
fs.writeFileSync(path.join(out, "pose_stamped_be.cdr"), w.data);

const plain = (value) => JSON.parse(JSON.stringify(value, (k, v) =>
  (v instanceof Uint8Array ? Array.from(v) : typeof v === "bigint" ? v.toString() : v)));
const topics = {};
for (const e of events) topics[e.topic] = { type: ros2Type(e.type), count: (topics[e.topic]?.count ?? 0) + 1 };
fs.writeFileSync(path.join(out, "expected.json"), JSON.stringify({
  topics, split_after: 10, message_count: events.length,
  messages: events.map((e) => plain({ topic: e.topic, type: ros2Type(e.type), log_time: e.log_time, cdr_size: e.cdr.length, message: e.message })),
  pose_stamped_be: plain(be),
}, null, 1) + "\n");
fs.writeFileSync(path.join(out, "db3_messages.json"), JSON.stringify(events.map((e) => ({
  topic: e.topic, type: ros2Type(e.type), log_time: e.log_time.toString(), cdr: Buffer.from(e.cdr).toString("base64") }))));
