// ROS 2 bags (rosbag2) read without a ROS installation: the storage only
// (MCAP files, sqlite3 .db3 files, bag folders with metadata.yaml). The
// messages come out as stored, CDR with its encapsulation header; ros2_cdr.h
// decodes them.
//
// MCAP follows the published specification (https://mcap.dev/spec): records
// are read one at a time and one chunk at a time, so memory does not grow
// with the file. The summary section, when there is one, gives the topics
// and the message counts; without it (a recording cut off) the data section
// is scanned once at open for them. Inputs are only ever read.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "lookboth/geometry/time.h"

namespace lookboth::ros2 {

struct Topic {
  std::string name;                  ///< e.g. "/fisheye/image_raw"
  std::string type;                  ///< e.g. "sensor_msgs/msg/Image"
  std::string serialization_format;  ///< "cdr" for the types ros2_cdr.h decodes
};

struct Message {
  const Topic* topic = nullptr;  ///< Points into BagReader::topics().
  TimeNs log_time = 0;           ///< The recorder's receive time, ns since the epoch.
  /// The serialized message as stored (CDR with its 4-byte encapsulation header).
  std::vector<std::uint8_t> data;
  /// Where the message is, for error messages: "run_0.mcap, byte 1234",
  /// "run_0.db3, message id 17".
  std::string where;
};

/// One rosbag2 recording, read forwards. Not thread-safe.
class BagReader {
 public:
  virtual ~BagReader() = default;

  /// `path`: a rosbag2 folder (metadata.yaml and the storage files it lists,
  /// read in order as one bag), one .mcap file or one .db3 file. A folder
  /// without metadata.yaml is read when it holds exactly one .mcap or .db3
  /// file. Throws lookboth::Error naming the file for anything unreadable.
  static std::unique_ptr<BagReader> open(const std::filesystem::path& path);

  /// Every topic of the bag, by name; fixed once opened.
  virtual const std::vector<Topic>& topics() const = 0;
  /// Messages on these topics (empty = all) as the storage records them
  /// (MCAP statistics, sqlite COUNT, metadata.yaml, or counted when an MCAP
  /// file without summary was scanned at open); -1 when unknown.
  virtual std::int64_t messageCount(const std::set<std::string>& topics) = 0;
  /// Next message on one of `topics` (empty = all), in storage order; false
  /// at the end. Throws lookboth::Error (file and byte offset) on a
  /// truncated or corrupt file.
  virtual bool next(const std::set<std::string>& topics, Message* message) = 0;
  /// Back to the first message.
  virtual void rewind() = 0;
  /// What the reader found that does not stop it, for the user to know (an
  /// MCAP file whose end is missing after its last message).
  virtual std::vector<std::string> notes() const { return {}; }
};

}  // namespace lookboth::ros2
