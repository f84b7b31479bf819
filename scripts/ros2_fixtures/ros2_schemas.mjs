// Shared by the benchmark's and the demo's recording writers: the ROS 2
// message definitions they use, as rosbag2 stores them in an MCAP schema (the
// type, then each dependency after a line of '='), for
// @foxglove/rosmsg2-serialization; and an MCAP file opened as rosbag2 writes
// one, streamed to disk (a recording need not fit in memory).
import { McapWriter } from "@mcap/core";
import fs from "node:fs";

export class FileSink {
  constructor(file) { this.fd = fs.openSync(file, "w"); this.length = 0n; }
  async write(buffer) { fs.writeSync(this.fd, buffer); this.length += BigInt(buffer.byteLength); }
  position() { return this.length; }
}

export const SEP = "=".repeat(80);
export const DEFS = {
  "builtin_interfaces/Time": "int32 sec\nuint32 nanosec",
  "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id",
  "sensor_msgs/Image": "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data",
  "sensor_msgs/CompressedImage": "std_msgs/Header header\nstring format\nuint8[] data",
  "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z",
  "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z",
  "geometry_msgs/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
  "geometry_msgs/Pose": "Point position\nQuaternion orientation",
  "geometry_msgs/PoseWithCovariance": "Pose pose\nfloat64[36] covariance",
  "geometry_msgs/Twist": "Vector3 linear\nVector3 angular",
  "geometry_msgs/TwistWithCovariance": "Twist twist\nfloat64[36] covariance",
  "nav_msgs/Odometry": "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist",
};
export const DEPS = {
  "sensor_msgs/Image": ["std_msgs/Header", "builtin_interfaces/Time"],
  "sensor_msgs/CompressedImage": ["std_msgs/Header", "builtin_interfaces/Time"],
  "nav_msgs/Odometry": ["std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/PoseWithCovariance", "geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion", "geometry_msgs/TwistWithCovariance", "geometry_msgs/Twist", "geometry_msgs/Vector3"],
};
export const schemaText = (t) => [DEFS[t], ...DEPS[t].map((d) => `${SEP}\nMSG: ${d}\n${DEFS[d]}`)].join("\n") + "\n";

/// Opens `file` as a rosbag2 MCAP (768 KiB chunks; `options` adds e.g. chunk
/// compression) with one channel per [topic, type] of `topics`, in that order.
export async function openRos2Mcap(file, topics, library, options = {}) {
  const sink = new FileSink(file);
  const writer = new McapWriter({ writable: sink, chunkSize: 768 * 1024, ...options });
  await writer.start({ profile: "ros2", library });
  const channels = [];
  for (const [topic, type] of topics) {
    const schemaId = await writer.registerSchema({ name: type.replace("/", "/msg/"), encoding: "ros2msg",
      data: new TextEncoder().encode(schemaText(type)) });
    channels.push(await writer.registerChannel({ topic, schemaId, messageEncoding: "cdr",
      metadata: new Map([["offered_qos_profiles", ""]]) }));
  }
  return { writer, sink, channels };
}
