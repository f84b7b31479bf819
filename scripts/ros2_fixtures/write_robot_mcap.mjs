// Writes a robot's ROS 2 recording (MCAP, zstd chunks, as `ros2 bag record`
// does by default) from a lookboth folder dataset, with the same independent
// npm code as the fixtures (@mcap/core, @foxglove/rosmsg2-serialization):
// the fisheye's frames as sensor_msgs/CompressedImage (the PNG bytes) on
// /fisheye/image/compressed and the odometry as nav_msgs/Odometry on /odom,
// each stamped with its dataset time and logged 5 ms later. For
// scripts/demo_ros2_video.sh. Usage:
//   node write_robot_mcap.mjs <dataset folder> <out.mcap>
import { parse } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import zstd from "@foxglove/wasm-zstd";
import fs from "node:fs";
import path from "node:path";
import { openRos2Mcap, schemaText } from "./ros2_schemas.mjs";

const [dataset, out] = [process.argv[2], process.argv[3]];
const TOPICS = [
  ["/fisheye/image/compressed", "sensor_msgs/CompressedImage"],
  ["/odom", "nav_msgs/Odometry"],
];
const serializers = TOPICS.map(([, t]) => new MessageWriter(parse(schemaText(t), { ros2: true })));

const rows = (file) => fs.readFileSync(file, "utf8").split("\n").map((l) => l.trim())
  .filter((l) => l && !l.startsWith("#"));
// Exact nanoseconds from TUM's decimal seconds ("1700000000.123456789").
const tumNs = (text) => {
  const [sec, frac = ""] = text.split(".");
  return BigInt(sec) * 1000000000n + BigInt((frac + "000000000").slice(0, 9));
};
const records = [];
const frames = rows(path.join(dataset, "fisheye/frames.csv")).slice(1);
for (const line of frames) {
  const [t, file] = line.split(",");
  records.push({ t: BigInt(t), topic: 0, file: path.join(dataset, "fisheye", file) });
}
for (const line of rows(path.join(dataset, "odometry/trajectory.tum"))) {
  const [t, x, y, z, qx, qy, qz, qw] = line.split(/\s+/);
  records.push({ t: tumNs(t), topic: 1, pose: [x, y, z, qx, qy, qz, qw].map(Number) });
}
records.sort((a, b) => (a.t < b.t ? -1 : a.t > b.t ? 1 : a.topic - b.topic));

await zstd.isLoaded;
const { writer, sink, channels } = await openRos2Mcap(out, TOPICS, "lookboth demo_ros2_video (@mcap/core)",
  { compressChunk: (d) => ({ compression: "zstd", compressedData: zstd.compress(d, 3) }) });
const stamp = (ns) => ({ sec: Number(ns / 1000000000n), nanosec: Number(ns % 1000000000n) });
const zeros = Array(36).fill(0);
let sequence = 0;
for (const r of records) {
  const message = r.topic === 0
    ? { header: { stamp: stamp(r.t), frame_id: "fisheye" }, format: "png", data: fs.readFileSync(r.file) }
    : { header: { stamp: stamp(r.t), frame_id: "odom" }, child_frame_id: "fisheye",
        pose: { pose: { position: { x: r.pose[0], y: r.pose[1], z: r.pose[2] },
          orientation: { x: r.pose[3], y: r.pose[4], z: r.pose[5], w: r.pose[6] } }, covariance: zeros },
        twist: { twist: { linear: { x: 0, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0 } }, covariance: zeros } };
  const logTime = r.t + 5000000n;
  await writer.addMessage({ channelId: channels[r.topic], sequence: sequence++, logTime, publishTime: logTime,
    data: serializers[r.topic].writeMessage(message) });
}
await writer.end();
fs.closeSync(sink.fd);
console.log(`write_robot_mcap.mjs: ${out}: ${frames.length} fisheye frames, ${records.length - frames.length} odometry poses`);
