// ROS 2 bags: every fixture of tests/data/ros2 (written by Foxglove's MCAP
// writer and ROS 2 CDR serializer, scripts/make_ros2_fixtures.sh) read and
// decoded, compared with the writer's own values in expected.json; damaged
// copies (cut, corrupted) rejected with the file and the byte named.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "../src/ros2_bag.h"
#include "../src/ros2_cdr.h"
#include "lookboth/core/error.h"

namespace lookboth::ros2 {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Bytes = std::vector<std::uint8_t>;

const fs::path kData = fs::path(LOOKBOTH_TEST_DATA_DIR) / "ros2";

const json& expected() {
  static const json kExpected = json::parse(std::ifstream(kData / "expected.json"));
  return kExpected;
}

Bytes readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), {});
}

void writeFile(const fs::path& path, const Bytes& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "ros2_bag_test";
  fs::create_directories(dir);
  return dir / name;
}

std::vector<Message> readAll(BagReader& bag, const std::set<std::string>& topics = {}) {
  std::vector<Message> messages;
  Message message;
  while (bag.next(topics, &message)) messages.push_back(message);
  return messages;
}

// ---------------------------------------------------------------------------
// Decoded values against the writer's message objects (ROS 2 field names).

void expectHeader(const std_msgs::Header& header, const json& truth) {
  EXPECT_EQ(header.stamp.sec, truth["stamp"]["sec"].get<std::uint32_t>());
  EXPECT_EQ(header.stamp.nsec, truth["stamp"]["nanosec"].get<std::uint32_t>());
  EXPECT_EQ(header.frame_id, truth["frame_id"].get<std::string>());
}

template <class Values>
void expectValues(const Values& values, const json& truth) {
  ASSERT_EQ(values.size(), truth.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    EXPECT_DOUBLE_EQ(static_cast<double>(values[i]), truth[i].get<double>()) << "element " << i;
  }
}

template <class Vector>
void expectXyz(const Vector& vector, const json& truth) {
  EXPECT_DOUBLE_EQ(vector.x, truth["x"].get<double>());
  EXPECT_DOUBLE_EQ(vector.y, truth["y"].get<double>());
  EXPECT_DOUBLE_EQ(vector.z, truth["z"].get<double>());
}

void expectQuaternion(const geometry_msgs::Quaternion& quaternion, const json& truth) {
  expectXyz(quaternion, truth);
  EXPECT_DOUBLE_EQ(quaternion.w, truth["w"].get<double>());
}

void expectPose(const geometry_msgs::Pose& pose, const json& truth) {
  expectXyz(pose.position, truth["position"]);
  expectQuaternion(pose.orientation, truth["orientation"]);
}

void expectImage(const Bytes& cdr, const json& truth) {
  const sensor_msgs::Image image = decodeImage(cdr);
  expectHeader(image.header, truth["header"]);
  EXPECT_EQ(image.height, truth["height"].get<std::uint32_t>());
  EXPECT_EQ(image.width, truth["width"].get<std::uint32_t>());
  EXPECT_EQ(image.encoding, truth["encoding"].get<std::string>());
  EXPECT_EQ(image.is_bigendian, truth["is_bigendian"].get<int>());
  EXPECT_EQ(image.step, truth["step"].get<std::uint32_t>());
  EXPECT_EQ(image.data, truth["data"].get<Bytes>());
}

void expectCompressedImage(const Bytes& cdr, const json& truth) {
  const sensor_msgs::CompressedImage image = decodeCompressedImage(cdr);
  expectHeader(image.header, truth["header"]);
  EXPECT_EQ(image.format, truth["format"].get<std::string>());
  EXPECT_EQ(image.data, truth["data"].get<Bytes>());
  const std::string magic = image.format == "png" ? "\x89PNG" : "\xff\xd8\xff";
  ASSERT_GE(image.data.size(), magic.size());
  EXPECT_TRUE(std::equal(magic.begin(), magic.end(), image.data.begin(),
                         [](char a, std::uint8_t b) { return static_cast<std::uint8_t>(a) == b; }));
}

void expectCameraInfo(const Bytes& cdr, const json& truth) {
  const sensor_msgs::CameraInfo info = decodeCameraInfo(cdr);
  expectHeader(info.header, truth["header"]);
  EXPECT_EQ(info.height, truth["height"].get<std::uint32_t>());
  EXPECT_EQ(info.width, truth["width"].get<std::uint32_t>());
  EXPECT_EQ(info.distortion_model, truth["distortion_model"].get<std::string>());
  expectValues(info.D, truth["d"]);
  expectValues(info.K, truth["k"]);
  expectValues(info.R, truth["r"]);
  expectValues(info.P, truth["p"]);
  EXPECT_EQ(info.binning_x, truth["binning_x"].get<std::uint32_t>());
  EXPECT_EQ(info.binning_y, truth["binning_y"].get<std::uint32_t>());
  EXPECT_EQ(info.roi.x_offset, truth["roi"]["x_offset"].get<std::uint32_t>());
  EXPECT_EQ(info.roi.y_offset, truth["roi"]["y_offset"].get<std::uint32_t>());
  EXPECT_EQ(info.roi.height, truth["roi"]["height"].get<std::uint32_t>());
  EXPECT_EQ(info.roi.width, truth["roi"]["width"].get<std::uint32_t>());
  EXPECT_EQ(info.roi.do_rectify != 0, truth["roi"]["do_rectify"].get<bool>());
}

void expectOdometry(const Bytes& cdr, const json& truth) {
  const nav_msgs::Odometry odometry = decodeOdometry(cdr);
  expectHeader(odometry.header, truth["header"]);
  EXPECT_EQ(odometry.child_frame_id, truth["child_frame_id"].get<std::string>());
  expectPose(odometry.pose.pose, truth["pose"]["pose"]);
  expectValues(odometry.pose.covariance, truth["pose"]["covariance"]);
  expectXyz(odometry.twist.twist.linear, truth["twist"]["twist"]["linear"]);
  expectXyz(odometry.twist.twist.angular, truth["twist"]["twist"]["angular"]);
  expectValues(odometry.twist.covariance, truth["twist"]["covariance"]);
}

void expectTransforms(const Bytes& cdr, const json& truth) {
  const std::vector<geometry_msgs::TransformStamped> transforms = decodeTfMessage(cdr);
  ASSERT_EQ(transforms.size(), truth["transforms"].size());
  for (std::size_t i = 0; i < transforms.size(); ++i) {
    const json& one = truth["transforms"][i];
    expectHeader(transforms[i].header, one["header"]);
    EXPECT_EQ(transforms[i].child_frame_id, one["child_frame_id"].get<std::string>());
    expectXyz(transforms[i].transform.translation, one["transform"]["translation"]);
    expectQuaternion(transforms[i].transform.rotation, one["transform"]["rotation"]);
  }
}

void expectDecoded(const Bytes& cdr, const std::string& type, const json& truth) {
  if (type == "sensor_msgs/msg/Image") return expectImage(cdr, truth);
  if (type == "sensor_msgs/msg/CompressedImage") return expectCompressedImage(cdr, truth);
  if (type == "sensor_msgs/msg/CameraInfo") return expectCameraInfo(cdr, truth);
  if (type == "nav_msgs/msg/Odometry") return expectOdometry(cdr, truth);
  if (type == "tf2_msgs/msg/TFMessage") return expectTransforms(cdr, truth);
  if (type == "geometry_msgs/msg/PoseStamped") {
    const geometry_msgs::PoseStamped pose = decodePoseStamped(cdr);
    expectHeader(pose.header, truth["header"]);
    return expectPose(pose.pose, truth["pose"]);
  }
  ASSERT_EQ(type, "geometry_msgs/msg/PoseWithCovarianceStamped");
  const geometry_msgs::PoseWithCovarianceStamped pose = decodePoseWithCovarianceStamped(cdr);
  expectHeader(pose.header, truth["header"]);
  expectPose(pose.pose.pose, truth["pose"]["pose"]);
  expectValues(pose.pose.covariance, truth["pose"]["covariance"]);
}

void decodeAny(const Bytes& cdr, const std::string& type) {
  if (type == "sensor_msgs/msg/Image") decodeImage(cdr);
  if (type == "sensor_msgs/msg/CompressedImage") decodeCompressedImage(cdr);
  if (type == "sensor_msgs/msg/CameraInfo") decodeCameraInfo(cdr);
  if (type == "nav_msgs/msg/Odometry") decodeOdometry(cdr);
  if (type == "tf2_msgs/msg/TFMessage") decodeTfMessage(cdr);
  if (type == "geometry_msgs/msg/PoseStamped") decodePoseStamped(cdr);
  if (type == "geometry_msgs/msg/PoseWithCovarianceStamped") decodePoseWithCovarianceStamped(cdr);
}

/// `messages` are the expected messages whose topics are in `topics` (all
/// when empty), in order, with the writer's values.
void expectMessages(const std::vector<Message>& messages, const std::set<std::string>& topics) {
  std::vector<json> truth;
  for (const json& one : expected()["messages"]) {
    if (topics.empty() || topics.count(one["topic"].get<std::string>())) truth.push_back(one);
  }
  ASSERT_EQ(messages.size(), truth.size());
  for (std::size_t i = 0; i < messages.size(); ++i) {
    SCOPED_TRACE("message " + std::to_string(i) + " at " + messages[i].where);
    ASSERT_NE(messages[i].topic, nullptr);
    EXPECT_EQ(messages[i].topic->name, truth[i]["topic"].get<std::string>());
    EXPECT_EQ(messages[i].topic->type, truth[i]["type"].get<std::string>());
    EXPECT_EQ(messages[i].topic->serialization_format, "cdr");
    EXPECT_EQ(messages[i].log_time, std::stoll(truth[i]["log_time"].get<std::string>()));
    EXPECT_EQ(messages[i].data.size(), truth[i]["cdr_size"].get<std::size_t>());
    expectDecoded(messages[i].data, truth[i]["type"], truth[i]["message"]);
  }
}

// ---------------------------------------------------------------------------
// Every storage variant reads as the same recording.

class Ros2Fixture : public testing::TestWithParam<std::string> {};

TEST_P(Ros2Fixture, ReadsEveryMessageAsWritten) {
  const std::unique_ptr<BagReader> bag = BagReader::open(kData / GetParam());
  std::set<std::string> names;
  for (const Topic& topic : bag->topics()) {
    names.insert(topic.name);
    ASSERT_TRUE(expected()["topics"].contains(topic.name)) << topic.name;
    EXPECT_EQ(topic.type, expected()["topics"][topic.name]["type"].get<std::string>());
    EXPECT_EQ(topic.serialization_format, "cdr");
    EXPECT_TRUE(isSupportedType(topic.type)) << topic.type;
  }
  EXPECT_EQ(names.size(), expected()["topics"].size());
  expectMessages(readAll(*bag), {});
}

TEST_P(Ros2Fixture, CountsMessages) {
  const std::unique_ptr<BagReader> bag = BagReader::open(kData / GetParam());
  EXPECT_EQ(bag->messageCount({}), expected()["message_count"].get<std::int64_t>());
  EXPECT_EQ(bag->messageCount({"/odom"}), 5);
  EXPECT_EQ(bag->messageCount({"/odom", "/tf", "/no/such/topic"}), 7);
  EXPECT_EQ(bag->messageCount({"/no/such/topic"}), 0);
}

TEST_P(Ros2Fixture, FiltersTopicsAndRewinds) {
  const std::unique_ptr<BagReader> bag = BagReader::open(kData / GetParam());
  const std::set<std::string> topics = {"/odom", "/tf", "/env_cam/image/compressed"};
  const std::vector<Message> first = readAll(*bag, topics);
  expectMessages(first, topics);
  Message message;
  EXPECT_FALSE(bag->next({}, &message));  // stays at the end
  bag->rewind();
  const std::vector<Message> all = readAll(*bag);
  expectMessages(all, {});
  bag->rewind();
  const std::vector<Message> again = readAll(*bag, topics);
  ASSERT_EQ(again.size(), first.size());
  for (std::size_t i = 0; i < again.size(); ++i) {
    EXPECT_EQ(again[i].data, first[i].data);
    EXPECT_EQ(again[i].where, first[i].where);
  }
}

INSTANTIATE_TEST_SUITE_P(AllStorage, Ros2Fixture,
                         testing::Values("sample_uncompressed.mcap", "sample_lz4.mcap",
                                         "sample_zstd.mcap", "sample_unchunked.mcap",
                                         "sample_nosummary.mcap", "sample_mcap_folder",
                                         "sample_mcap_folder/metadata.yaml", "sample_db3",
                                         "sample_db3/sample_db3_0.db3"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           std::string name = info.param;
                           std::replace_if(
                               name.begin(), name.end(), [](char c) { return !std::isalnum(c); },
                               '_');
                           return name;
                         });

TEST(Ros2Bag, MessagesSayWhereTheyAre) {
  const std::unique_ptr<BagReader> mcap = BagReader::open(kData / "sample_uncompressed.mcap");
  const std::unique_ptr<BagReader> db3 = BagReader::open(kData / "sample_db3");
  Message message;
  ASSERT_TRUE(mcap->next({}, &message));
  EXPECT_EQ(message.where.rfind("sample_uncompressed.mcap, byte ", 0), 0u) << message.where;
  ASSERT_TRUE(db3->next({}, &message));
  // Ids 1 and 2 hold the second and first message in time: read in time order.
  EXPECT_EQ(message.where, "sample_db3_0.db3, message id 2");
}

TEST(Ros2Bag, Db3LeavesNothingNextToTheInput) {
  const fs::path folder = scratch("db3_read_only");
  fs::remove_all(folder);
  fs::copy(kData / "sample_db3", folder);
  fs::permissions(folder / "sample_db3_0.db3", fs::perms::owner_read, fs::perm_options::replace);
  const auto before = fs::last_write_time(folder / "sample_db3_0.db3");
  {
    const std::unique_ptr<BagReader> bag = BagReader::open(folder);
    EXPECT_EQ(readAll(*bag).size(), 18u);
    EXPECT_EQ(bag->messageCount({}), 18);
  }
  std::set<std::string> files;
  for (const auto& entry : fs::directory_iterator(folder)) {
    files.insert(entry.path().filename().string());
  }
  EXPECT_EQ(files, (std::set<std::string>{"metadata.yaml", "sample_db3_0.db3"}));
  EXPECT_EQ(fs::last_write_time(folder / "sample_db3_0.db3"), before);
  fs::permissions(folder / "sample_db3_0.db3", fs::perms::owner_all, fs::perm_options::replace);
}

// ---------------------------------------------------------------------------
// Damaged inputs: an Error naming the file and the byte, never a crash.

std::string errorOf(const fs::path& path) {
  try {
    const std::unique_ptr<BagReader> bag = BagReader::open(path);
    readAll(*bag);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

/// Offsets of the top-level records of an MCAP file's data section, up to
/// and including its Data End record.
std::vector<std::size_t> dataRecordOffsets(const Bytes& file) {
  std::vector<std::size_t> offsets;
  for (std::size_t offset = 8; offset + 9 <= file.size();) {
    offsets.push_back(offset);
    std::uint64_t length = 0;
    std::memcpy(&length, &file[offset + 1], 8);  // little-endian host
    if (file[offset] == 0x0F) break;
    offset += 9 + length;
  }
  return offsets;
}

class TruncatedMcap : public testing::TestWithParam<std::string> {};

TEST_P(TruncatedMcap, CutsAreReportedWithFileAndByte) {
  const Bytes file = readFile(kData / GetParam());
  const std::vector<std::size_t> records = dataRecordOffsets(file);
  ASSERT_GT(records.size(), 3u);
  std::set<std::size_t> cuts;
  for (std::size_t i = 0; i + 1 < records.size(); ++i) {
    const std::size_t begin = records[i], end = records[i + 1];
    for (std::size_t cut : {begin, begin + 1, begin + 9, begin + 20, (begin + end) / 2, end - 1}) {
      if (cut >= begin && cut < end) cuts.insert(cut);
    }
  }
  for (std::size_t cut = 0; cut < records.back(); cut += 61) cuts.insert(cut);
  const fs::path path = scratch("cut_" + GetParam());
  for (const std::size_t cut : cuts) {
    writeFile(path, Bytes(file.begin(), file.begin() + static_cast<std::ptrdiff_t>(cut)));
    const std::string error = errorOf(path);
    SCOPED_TRACE("cut at byte " + std::to_string(cut) + ": " + error);
    EXPECT_NE(error.find(path.string()), std::string::npos);
    if (cut >= 17) {
      EXPECT_NE(error.find("truncated at byte " + std::to_string(cut) + ":"), std::string::npos);
    } else {
      EXPECT_NE(error.find("not an MCAP file"), std::string::npos);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Variants, TruncatedMcap,
                         testing::Values("sample_uncompressed.mcap", "sample_lz4.mcap",
                                         "sample_zstd.mcap", "sample_unchunked.mcap",
                                         "sample_nosummary.mcap"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param.substr(7, info.param.size() - 12);
                         });

/// Offset of the first Chunk record's `records` field and its length.
std::pair<std::size_t, std::size_t> firstChunkRecords(const Bytes& file) {
  for (const std::size_t offset : dataRecordOffsets(file)) {
    if (file[offset] != 0x06) continue;
    std::uint32_t compression = 0;
    std::memcpy(&compression, &file[offset + 9 + 28], 4);
    const std::size_t records = offset + 9 + 32 + compression + 8;
    std::uint64_t size = 0;
    std::memcpy(&size, &file[records - 8], 8);
    return {records, size};
  }
  return {0, 0};
}

TEST(Ros2Bag, ReportsACorruptChunkCrc) {
  Bytes file = readFile(kData / "sample_uncompressed.mcap");
  const auto [records, size] = firstChunkRecords(file);
  ASSERT_GT(size, 0u);
  file[records + size - 1] ^= 0x40;  // the last byte of a message's data
  const fs::path path = scratch("bad_crc.mcap");
  writeFile(path, file);
  const std::string error = errorOf(path);
  EXPECT_NE(error.find(path.string()), std::string::npos) << error;
  EXPECT_NE(error.find("CRC-32"), std::string::npos) << error;
  EXPECT_NE(error.find("Chunk record at byte "), std::string::npos) << error;
}

TEST(Ros2Bag, ReportsDamagedCompressedChunks) {
  for (const std::string name : {"sample_lz4.mcap", "sample_zstd.mcap"}) {
    const Bytes file = readFile(kData / name);
    const auto [records, size] = firstChunkRecords(file);
    ASSERT_GT(size, 0u);
    const fs::path path = scratch("damaged_" + name);
    for (std::size_t at = records; at < records + size; at += 7) {
      Bytes damaged = file;
      damaged[at] ^= 0x5A;
      writeFile(path, damaged);
      const std::string error = errorOf(path);
      SCOPED_TRACE(name + " byte " + std::to_string(at) + ": " + error);
      // Flipped bits in compressed data cannot all be seen (a literal's
      // value changes), but the CRC of the records sees every one.
      EXPECT_NE(error.find("Chunk record at byte "), std::string::npos);
    }
  }
}

TEST(Ros2Bag, NamesAnUnknownCompression) {
  Bytes file = readFile(kData / "sample_lz4.mcap");
  const auto [records, size] = firstChunkRecords(file);
  ASSERT_GT(size, 0u);
  const std::size_t compression = records - 8 - 3;  // "lz4"
  ASSERT_EQ(std::string(file.begin() + compression, file.begin() + compression + 3), "lz4");
  file[compression + 2] = 'x';
  const fs::path path = scratch("unknown_compression.mcap");
  writeFile(path, file);
  const std::string error = errorOf(path);
  EXPECT_NE(error.find("unknown compression 'lzx'"), std::string::npos) << error;
}

TEST(Ros2Bag, RejectsWhatIsNotABag) {
  const fs::path text = scratch("not_a_bag.mcap");
  std::ofstream(text) << "hello, this is not an MCAP file\n";
  EXPECT_NE(errorOf(text).find("not an MCAP file"), std::string::npos);
  const fs::path db3 = scratch("not_a_bag.db3");
  std::ofstream(db3) << "hello, this is not an sqlite file either, but it is long enough\n";
  EXPECT_NE(errorOf(db3).find("not a readable rosbag2 sqlite3 file"), std::string::npos)
      << errorOf(db3);
  const fs::path other = scratch("other_tables.db3");
  fs::remove(other);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(other.c_str(), &db), SQLITE_OK);
  sqlite3_exec(db, "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT)", nullptr, nullptr,
               nullptr);
  sqlite3_close(db);
  EXPECT_NE(errorOf(other).find("no 'messages' table"), std::string::npos) << errorOf(other);
  EXPECT_NE(errorOf(scratch("missing.mcap")).find("no such file"), std::string::npos);
}

TEST(Ros2Bag, ReportsATruncatedDb3) {
  const Bytes file = readFile(kData / "sample_db3" / "sample_db3_0.db3");
  const fs::path path = scratch("cut.db3");
  for (const std::size_t cut : {std::size_t{100}, file.size() / 2, file.size() - 1024}) {
    writeFile(path, Bytes(file.begin(), file.begin() + static_cast<std::ptrdiff_t>(cut)));
    const std::string error = errorOf(path);
    EXPECT_NE(error.find(path.string()), std::string::npos) << "cut at " << cut << ": " << error;
  }
}

TEST(Ros2Bag, FolderWithoutMetadata) {
  const fs::path folder = scratch("no_metadata");
  fs::remove_all(folder);
  fs::create_directories(folder);
  fs::copy_file(kData / "sample_zstd.mcap", folder / "run.mcap");
  const std::unique_ptr<BagReader> bag = BagReader::open(folder);
  expectMessages(readAll(*bag), {});
  fs::copy_file(kData / "sample_lz4.mcap", folder / "run2.mcap");
  const std::string error = errorOf(folder);
  EXPECT_NE(error.find(folder.string()), std::string::npos) << error;
  EXPECT_NE(error.find("no metadata.yaml"), std::string::npos) << error;
}

// ---------------------------------------------------------------------------
// CDR on its own.

TEST(Ros2Cdr, DecodesBigEndian) {
  const Bytes cdr = readFile(kData / "pose_stamped_be.cdr");
  ASSERT_EQ(cdr.at(1), 0x00);  // CDR_BE
  const json& truth = expected()["pose_stamped_be"];
  const geometry_msgs::PoseStamped pose = decodePoseStamped(cdr);
  expectHeader(pose.header, truth["header"]);
  expectPose(pose.pose, truth["pose"]);
}

TEST(Ros2Cdr, EveryTruncationIsADecodeError) {
  const std::unique_ptr<BagReader> bag = BagReader::open(kData / "sample_uncompressed.mcap");
  Message message;
  while (bag->next({}, &message)) {
    for (std::size_t size = 0; size < message.data.size(); ++size) {
      const Bytes cut(message.data.begin(), message.data.begin() + static_cast<long>(size));
      try {
        decodeAny(cut, message.topic->type);
        ADD_FAILURE() << message.topic->type << " cut to " << size << " bytes decoded";
      } catch (const DecodeError& e) {
        const std::string what = e.what();
        if (size >= 4) {
          EXPECT_NE(what.find("truncated in field '"), std::string::npos) << what;
          EXPECT_NE(what.find(" of " + std::to_string(size)), std::string::npos) << what;
        }
      }
    }
  }
}

TEST(Ros2Cdr, NamesTheFieldAndTheByte) {
  const std::unique_ptr<BagReader> bag = BagReader::open(kData / "sample_uncompressed.mcap");
  Message message;
  ASSERT_TRUE(bag->next({"/fisheye/image_raw"}, &message));
  Bytes cut(message.data.begin(), message.data.end() - 1);
  try {
    decodeImage(cut);
    FAIL() << "decoded";
  } catch (const DecodeError& e) {
    // The 48 pixels are the last 48 bytes.
    const std::size_t at = message.data.size() - 48;
    EXPECT_NE(std::string(e.what()).find("truncated in field 'data' at byte " + std::to_string(at) +
                                         " of " + std::to_string(cut.size())),
              std::string::npos)
        << e.what();
  }
}

TEST(Ros2Cdr, RejectsBadEncapsulationAndValues) {
  Bytes pose = readFile(kData / "pose_stamped_be.cdr");
  Bytes bad = pose;
  bad[1] = 0x02;  // PL_CDR_BE
  EXPECT_THROW(decodePoseStamped(bad), DecodeError);
  try {
    decodePoseStamped(bad);
  } catch (const DecodeError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown encapsulation 0x0002"), std::string::npos);
  }
  bad = pose;
  bad[4] = 0x80;  // stamp.sec negative (big-endian)
  try {
    decodePoseStamped(bad);
    FAIL() << "decoded";
  } catch (const DecodeError& e) {
    EXPECT_NE(std::string(e.what()).find("header.stamp.sec"), std::string::npos) << e.what();
  }
  // A TFMessage whose count asks for 4 billion transforms.
  const Bytes huge = {0x00, 0x01, 0x00, 0x00, 0xff, 0xff, 0xff, 0xff, 0, 0, 0, 0};
  EXPECT_THROW(decodeTfMessage(huge), DecodeError);
  EXPECT_THROW(decodeImage({0x00, 0x01}), DecodeError);
}

TEST(Ros2Cdr, SupportedTypes) {
  EXPECT_EQ(supportedTypes().size(), 7u);
  for (const std::string& type : supportedTypes()) EXPECT_TRUE(isSupportedType(type));
  EXPECT_FALSE(isSupportedType("sensor_msgs/Image"));
  EXPECT_FALSE(isSupportedType("sensor_msgs/msg/PointCloud2"));
}

}  // namespace
}  // namespace lookboth::ros2
