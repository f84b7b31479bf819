// ROS 1 bags (format 2.0) through Debian's rosbag_storage, after a structure
// check that keeps rosbag_storage from reading outside its buffers.
#include <bzlib.h>
#include <ros/serialization.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <roslz4/lz4s.h>
#include <tf2_msgs/TFMessage.h>

#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <type_traits>

#include "bag_source.h"
#include "lookboth/core/error.h"

namespace lookboth::bag {

namespace fs = std::filesystem;

namespace {
// ---------------------------------------------------------------------------
// Structure check of a ROS bag 2.0 before rosbag_storage reads it.
//
// rosbag_storage trusts the lengths and positions written in a bag: a
// corrupt length makes it read or parse past its buffers and crash, which no
// exception handler can catch. So the bag is first walked here the way
// rosbag_storage will walk it (file header -> index position -> connection
// and chunk info records -> each chunk and the index records after it ->
// the message records the indexes point to), with every length bounded by
// the bytes that are really there. A bag that passes holds nothing that
// makes rosbag_storage read outside what it allocated.

constexpr std::uint8_t kOpMessageData = 0x02;
constexpr std::uint8_t kOpFileHeader = 0x03;
constexpr std::uint8_t kOpIndexData = 0x04;
constexpr std::uint8_t kOpChunk = 0x05;
constexpr std::uint8_t kOpChunkInfo = 0x06;
constexpr std::uint8_t kOpConnection = 0x07;

/// Largest uncompressed chunk accepted: rosbag_storage allocates the size a
/// chunk declares before decompressing it (recorders write chunks of about
/// 768 KiB; one message larger than that makes one chunk as large).
constexpr std::uint32_t kMaxChunkBytes = 1u << 30;

std::uint32_t le32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

std::uint64_t le64(const std::uint8_t* p) {
  return static_cast<std::uint64_t>(le32(p)) | static_cast<std::uint64_t>(le32(p + 4)) << 32;
}

/// Bytes that records are read from: the bag file, or one uncompressed chunk.
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  virtual std::uint64_t size() const = 0;
  /// Reads exactly `n` bytes at `offset` (the caller has checked the range).
  virtual void read(std::uint64_t offset, std::size_t n, std::uint8_t* out) = 0;
};

class FileSource final : public ByteSource {
 public:
  FileSource(const fs::path& path, std::uint64_t size)
      : path_(path), in_(path, std::ios::binary), size_(size) {
    if (!in_) throw Error({path.string(), 0, "", ""}, "cannot open for reading");
  }
  std::uint64_t size() const override { return size_; }
  void read(std::uint64_t offset, std::size_t n, std::uint8_t* out) override {
    in_.seekg(static_cast<std::streamoff>(offset));
    in_.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n));
    if (!in_) {
      throw Error({path_.string(), 0, "", ""},
                  "cannot read " + std::to_string(n) + " bytes at byte " + std::to_string(offset));
    }
  }

 private:
  fs::path path_;
  std::ifstream in_;
  std::uint64_t size_;
};

/// A window [begin, begin + size) of another source.
class WindowSource final : public ByteSource {
 public:
  WindowSource(ByteSource& base, std::uint64_t begin, std::uint64_t size)
      : base_(base), begin_(begin), size_(size) {}
  std::uint64_t size() const override { return size_; }
  void read(std::uint64_t offset, std::size_t n, std::uint8_t* out) override {
    base_.read(begin_ + offset, n, out);
  }

 private:
  ByteSource& base_;
  std::uint64_t begin_, size_;
};

class MemorySource final : public ByteSource {
 public:
  explicit MemorySource(std::vector<std::uint8_t> bytes) : bytes_(std::move(bytes)) {}
  std::uint64_t size() const override { return bytes_.size(); }
  void read(std::uint64_t offset, std::size_t n, std::uint8_t* out) override {
    std::memcpy(out, bytes_.data() + offset, n);
  }

 private:
  std::vector<std::uint8_t> bytes_;
};

/// One record: <header length><header fields><data length><data>.
struct BagRecord {
  std::uint64_t offset = 0;  ///< Of the header length, in its source.
  std::map<std::string, std::string> fields;
  std::uint64_t data_offset = 0;
  std::uint32_t data_length = 0;
  std::uint64_t end() const { return data_offset + data_length; }
};

class BagStructureCheck {
 public:
  explicit BagStructureCheck(const fs::path& path) : path_(path) {}

  void run() {
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(path_, ec);
    if (ec) throw Error({path_.string(), 0, "", ""}, "cannot read its size: " + ec.message());
    FileSource file(path_, size);
    checkVersion(file);
    const BagRecord header = readRecord(file, 13, "the file header record");
    requireOp(header, kOpFileHeader, "the file header record");
    if (const auto it = header.fields.find("encryptor");
        it != header.fields.end() && !it->second.empty()) {
      throw Error(context(), "the bag is encrypted ('" + it->second +
                                 "'); lookboth reads unencrypted bags only (decrypt it first)");
    }
    const std::uint64_t index_position = u64(header, "index_pos", "the file header record");
    if (index_position == 0) return;  // unindexed: rosbag_storage says so before reading on
    const std::uint32_t connection_count = u32(header, "conn_count", "the file header record");
    const std::uint32_t chunk_count = u32(header, "chunk_count", "the file header record");
    if (index_position < header.end() || index_position >= size) {
      throw Error(context(), "the file header record gives the index position " +
                                 std::to_string(index_position) + ", outside the file's " +
                                 std::to_string(header.end()) + ".." + std::to_string(size) +
                                 " bytes (a truncated bag? 'rosbag reindex' may repair it)");
    }

    std::uint64_t offset = index_position;
    for (std::uint32_t i = 0; i < connection_count; ++i) {
      const std::string what = "connection record " + std::to_string(i + 1) + " of " +
                               std::to_string(connection_count) + " (index section)";
      const BagRecord record = readRecord(file, offset, what);
      checkConnection(file, record, what, 0, true);
      offset = record.end();
    }
    std::vector<std::pair<std::uint64_t, std::set<std::uint32_t>>> chunks;  // position, connections
    for (std::uint32_t i = 0; i < chunk_count; ++i) {
      const std::string what =
          "chunk info record " + std::to_string(i + 1) + " of " + std::to_string(chunk_count);
      const BagRecord record = readRecord(file, offset, what);
      chunks.emplace_back(checkChunkInfo(file, record, what));
      offset = record.end();
    }
    for (size_t i = 0; i < chunks.size(); ++i) {
      const auto& [position, connections] = chunks[i];
      const std::string what =
          "chunk " + std::to_string(i + 1) + " of " + std::to_string(chunks.size());
      if (position < header.end() || position >= index_position) {
        corrupt(what, position,
                "its position lies outside the chunk section (bytes " +
                    std::to_string(header.end()) + ".." + std::to_string(index_position) + ")");
      }
      checkChunk(file, position, connections.size(), index_position, what);
    }
  }

 private:
  ErrorContext context() const { return {path_.string(), 0, "", ""}; }

  [[noreturn]] void corrupt(const std::string& what, std::uint64_t offset,
                            const std::string& why) const {
    throw Error(context(),
                "corrupt ROS bag: " + what + " at byte " + std::to_string(offset) + ": " + why);
  }

  void checkVersion(ByteSource& file) const {
    static const std::string kVersion = "#ROSBAG V2.0\n";
    std::string line(kVersion.size(), '\0');
    if (file.size() >= line.size())
      file.read(0, line.size(), reinterpret_cast<std::uint8_t*>(line.data()));
    if (line == kVersion) return;
    if (line.rfind("#ROSBAG V", 0) == 0) {
      throw Error(context(), "a ROS bag of format " + line.substr(9, 3) +
                                 "; lookboth reads format 2.0 ('rosbag fix' converts old bags)");
    }
    throw Error(context(), "not a ROS 1 bag (it does not start with '#ROSBAG V2.0')");
  }

  /// Reads and bounds one record of `source` at `offset`.
  BagRecord readRecord(ByteSource& source, std::uint64_t offset, const std::string& what,
                       std::uint64_t base = 0) const {
    BagRecord record;
    record.offset = offset;
    const std::uint64_t size = source.size();
    auto at = [&](std::uint64_t o) { return base + o; };
    if (offset > size || size - offset < 4) {
      corrupt(what, at(offset),
              "the record's header length lies past the end (" +
                  std::to_string(size - std::min(size, offset)) + " bytes left)");
    }
    std::uint8_t word[8];
    source.read(offset, 4, word);
    const std::uint32_t header_length = le32(word);
    const std::uint64_t left = size - offset - 4;
    if (header_length > left || left - header_length < 4) {
      corrupt(what, at(offset),
              "the header length " + std::to_string(header_length) + " leaves no room for it and " +
                  "the data length in the " + std::to_string(left) + " bytes left");
    }
    std::vector<std::uint8_t> header(header_length);
    if (header_length > 0) source.read(offset + 4, header_length, header.data());
    std::size_t i = 0;
    while (i < header.size()) {
      if (header.size() - i < 4) corrupt(what, at(offset), "a header field's length is cut off");
      const std::uint32_t field_length = le32(header.data() + i);
      i += 4;
      if (field_length > header.size() - i) {
        corrupt(what, at(offset),
                "a header field of " + std::to_string(field_length) + " bytes runs past the " +
                    std::to_string(header_length) + "-byte header");
      }
      const std::string field(reinterpret_cast<const char*>(header.data() + i), field_length);
      i += field_length;
      const size_t equals = field.find('=');
      if (equals == std::string::npos)
        corrupt(what, at(offset), "a header field has no '=' (not a record header)");
      record.fields[field.substr(0, equals)] = field.substr(equals + 1);
    }
    source.read(offset + 4 + header_length, 4, word);
    record.data_length = le32(word);
    record.data_offset = offset + 4 + header_length + 4;
    if (record.data_length > size - record.data_offset) {
      corrupt(what, at(offset),
              "the data length " + std::to_string(record.data_length) + " runs past the end (" +
                  std::to_string(size - record.data_offset) + " bytes left)");
    }
    return record;
  }

  const std::string& field(const BagRecord& record, const std::string& name, std::size_t length,
                           const std::string& what, std::uint64_t base = 0) const {
    const auto it = record.fields.find(name);
    if (it == record.fields.end())
      corrupt(what, base + record.offset, "its header has no '" + name + "' field");
    if (length > 0 && it->second.size() != length) {
      corrupt(what, base + record.offset,
              "its '" + name + "' field has " + std::to_string(it->second.size()) +
                  " bytes, expected " + std::to_string(length));
    }
    return it->second;
  }
  std::uint8_t op(const BagRecord& record, const std::string& what, std::uint64_t base = 0) const {
    return static_cast<std::uint8_t>(field(record, "op", 1, what, base)[0]);
  }
  void requireOp(const BagRecord& record, std::uint8_t expected, const std::string& what,
                 std::uint64_t base = 0) const {
    const std::uint8_t found = op(record, what, base);
    if (found != expected) {
      corrupt(
          what, base + record.offset,
          "record type (op) " + std::to_string(found) + ", expected " + std::to_string(expected));
    }
  }
  std::uint32_t u32(const BagRecord& record, const std::string& name, const std::string& what,
                    std::uint64_t base = 0) const {
    return le32(reinterpret_cast<const std::uint8_t*>(field(record, name, 4, what, base).data()));
  }
  std::uint64_t u64(const BagRecord& record, const std::string& name, const std::string& what,
                    std::uint64_t base = 0) const {
    return le64(reinterpret_cast<const std::uint8_t*>(field(record, name, 8, what, base).data()));
  }

  /// A connection record: its header names the connection, its data is the
  /// connection header (type, md5sum, message definition...).
  /// The connections rosbag_storage knows are those of the index section
  /// (`known`); the copies inside chunks are only checked.
  void checkConnection(ByteSource& source, const BagRecord& record, const std::string& what,
                       std::uint64_t base, bool known) {
    requireOp(record, kOpConnection, what, base);
    const std::uint32_t id = u32(record, "conn", what, base);
    if (known) connections_.insert(id);
    field(record, "topic", 0, what, base);
    // rosbag_storage reads the data length and data as one more header:
    // <length><fields>.
    WindowSource data(source, record.data_offset - 4, std::uint64_t{record.data_length} + 4);
    checkFields(data, what + " (connection header)", base + record.data_offset - 4);
  }

  /// <length><fields> at the start of `source`, bounded by it.
  void checkFields(ByteSource& source, const std::string& what, std::uint64_t base) const {
    std::uint8_t word[4];
    source.read(0, 4, word);
    const std::uint32_t length = le32(word);
    if (length > source.size() - 4) {
      corrupt(what, base,
              "a header of " + std::to_string(length) + " bytes in " +
                  std::to_string(source.size() - 4));
    }
    std::vector<std::uint8_t> bytes(length);
    if (length > 0) source.read(4, length, bytes.data());
    std::size_t i = 0;
    while (i < bytes.size()) {
      if (bytes.size() - i < 4) corrupt(what, base, "a header field's length is cut off");
      const std::uint32_t field_length = le32(bytes.data() + i);
      i += 4;
      if (field_length > bytes.size() - i)
        corrupt(what, base, "a header field runs past the header");
      if (std::memchr(bytes.data() + i, '=', field_length) == nullptr)
        corrupt(what, base, "a header field has no '='");
      i += field_length;
    }
  }

  /// The data of a record that lists `count` entries of `entry_bytes` each
  /// (a chunk info's connections, an index's messages): the count must
  /// account for the data exactly, before anything is read or allocated.
  std::vector<std::uint8_t> readEntries(ByteSource& file, const BagRecord& record,
                                        std::uint32_t count, std::uint64_t entry_bytes,
                                        const char* noun, const std::string& what) {
    if (std::uint64_t{count} * entry_bytes != record.data_length) {
      corrupt(what, record.offset,
              "it lists " + std::to_string(count) + " " + noun + " (" +
                  std::to_string(count * entry_bytes) + " bytes) in " +
                  std::to_string(record.data_length) + " bytes of data");
    }
    std::vector<std::uint8_t> data(record.data_length);
    if (!data.empty()) file.read(record.data_offset, data.size(), data.data());
    return data;
  }

  std::pair<std::uint64_t, std::set<std::uint32_t>> checkChunkInfo(ByteSource& file,
                                                                   const BagRecord& record,
                                                                   const std::string& what) {
    requireOp(record, kOpChunkInfo, what);
    if (const std::uint32_t version = u32(record, "ver", what); version != 1)
      corrupt(what, record.offset,
              "chunk info version " + std::to_string(version) + ", expected 1");
    const std::uint64_t position = u64(record, "chunk_pos", what);
    u64(record, "start_time", what);
    u64(record, "end_time", what);
    const std::uint32_t count = u32(record, "count", what);
    const std::vector<std::uint8_t> data = readEntries(file, record, count, 8, "connections", what);
    std::set<std::uint32_t> connections;
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint32_t id = le32(data.data() + 8 * i);
      if (!connections_.count(id))
        corrupt(what, record.offset,
                "it names connection " + std::to_string(id) + ", not in the bag");
      connections.insert(id);
    }
    return {position, connections};
  }

  /// The chunk record at `position`, the `index_records` index records after
  /// it, and the message records they point to.
  void checkChunk(ByteSource& file, std::uint64_t position, std::size_t index_records,
                  std::uint64_t index_position, const std::string& what) {
    const BagRecord chunk = readRecord(file, position, what);
    requireOp(chunk, kOpChunk, what);
    const std::string compression = field(chunk, "compression", 0, what);
    const std::uint32_t size = u32(chunk, "size", what);
    if (chunk.end() > index_position)
      corrupt(what, position, "its data runs into the index section");

    // index data records: connection -> (offset in the uncompressed chunk)
    std::vector<std::pair<std::uint32_t, std::uint32_t>> entries;
    std::uint64_t offset = chunk.end();
    for (std::size_t i = 0; i < index_records; ++i) {
      const std::string index_what = "index record " + std::to_string(i + 1) + " of " + what;
      const BagRecord record = readRecord(file, offset, index_what);
      requireOp(record, kOpIndexData, index_what);
      if (const std::uint32_t version = u32(record, "ver", index_what); version != 1) {
        corrupt(index_what, record.offset,
                "index version " + std::to_string(version) + ", expected 1");
      }
      const std::uint32_t connection = u32(record, "conn", index_what);
      if (!connections_.count(connection)) {
        corrupt(index_what, record.offset,
                "it indexes connection " + std::to_string(connection) + ", not in the bag");
      }
      const std::uint32_t count = u32(record, "count", index_what);
      const std::vector<std::uint8_t> data =
          readEntries(file, record, count, 12, "messages", index_what);
      for (std::uint32_t k = 0; k < count; ++k)
        entries.emplace_back(connection, le32(data.data() + 12 * k + 8));
      offset = record.end();
    }

    // The uncompressed chunk, and its records: message data and connections.
    std::unique_ptr<ByteSource> body;
    if (compression == "none") {
      if (size != chunk.data_length) {
        corrupt(what, position,
                "uncompressed, yet its size field says " + std::to_string(size) + " bytes and " +
                    "its data has " + std::to_string(chunk.data_length));
      }
      body = std::make_unique<WindowSource>(file, chunk.data_offset, chunk.data_length);
    } else if (compression == "bz2" || compression == "lz4") {
      if (size > kMaxChunkBytes) {
        corrupt(what, position,
                "it declares " + std::to_string(size) + " uncompressed bytes (more than " +
                    std::to_string(kMaxChunkBytes) + ")");
      }
      std::vector<std::uint8_t> packed(chunk.data_length);
      if (!packed.empty()) file.read(chunk.data_offset, packed.size(), packed.data());
      std::vector<std::uint8_t> unpacked(size);
      unsigned int produced = size;
      bool ok = false;
      if (compression == "bz2") {
        ok = BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(unpacked.data()), &produced,
                                        reinterpret_cast<char*>(packed.data()),
                                        static_cast<unsigned int>(packed.size()), 0, 0) == BZ_OK;
      } else {
        ok = roslz4_buffToBuffDecompress(
                 reinterpret_cast<char*>(packed.data()), static_cast<unsigned int>(packed.size()),
                 reinterpret_cast<char*>(unpacked.data()), &produced) == ROSLZ4_OK;
      }
      if (!ok) corrupt(what, position, "its " + compression + " data cannot be decompressed");
      if (produced != size) {
        corrupt(what, position,
                "it decompresses to " + std::to_string(produced) + " bytes, not the " +
                    std::to_string(size) + " its size field says");
      }
      body = std::make_unique<MemorySource>(std::move(unpacked));
    } else {
      corrupt(what, position, "unknown compression '" + compression + "'");
    }

    // Offsets in errors: of the file for an uncompressed chunk; of the
    // chunk's uncompressed bytes otherwise (said so in the message).
    const bool plain = compression == "none";
    const std::uint64_t base = plain ? chunk.data_offset : 0;
    const std::string inside = plain ? "a record inside " + what
                                     : "a record of the uncompressed " + what + ", at its offset";
    std::map<std::uint64_t, std::uint32_t> messages;  // offset in the chunk -> connection
    for (std::uint64_t at = 0; at < body->size();) {
      const BagRecord record = readRecord(*body, at, inside, base);
      const std::uint8_t record_op = op(record, inside, base);
      if (record_op == kOpMessageData) {
        const std::uint32_t connection = u32(record, "conn", inside, base);
        u64(record, "time", inside, base);
        messages.emplace(at, connection);
      } else if (record_op == kOpConnection) {
        checkConnection(*body, record, inside, base, false);
      } else {
        corrupt(inside, base + at,
                "record type (op) " + std::to_string(record_op) +
                    " inside a chunk (expected message data or a connection)");
      }
      at = record.end();
    }
    for (const auto& [connection, message_offset] : entries) {
      const auto it = messages.find(message_offset);
      if (it == messages.end()) {
        corrupt(what, position,
                "an index entry of connection " + std::to_string(connection) +
                    " points to chunk offset " + std::to_string(message_offset) +
                    ", where no message record starts");
      }
      if (it->second != connection) {
        corrupt(what, position,
                "the message at chunk offset " + std::to_string(message_offset) +
                    " belongs to connection " + std::to_string(it->second) +
                    ", its index entry says " + std::to_string(connection));
      }
    }
  }

  fs::path path_;
  std::set<std::uint32_t> connections_;
};

// Bounds of a serialized message of the types lookboth converts: every
// string and array length within the message's bytes, so that deserializing
// never allocates more than the message holds.
class MessageBounds {
 public:
  MessageBounds(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  void skip(std::size_t n, const char* what) {
    if (n > size_ - at_) fail(what, n);
    at_ += n;
  }
  std::uint32_t u32(const char* what) {
    if (size_ - at_ < 4) fail(what, 4);
    const std::uint32_t value = le32(data_ + at_);
    at_ += 4;
    return value;
  }
  void array(std::size_t element, const char* what) {
    const std::uint32_t count = u32(what);
    if (count > (size_ - at_) / element) fail(what, std::uint64_t{count} * element);
    at_ += count * element;
  }
  void header() {
    skip(4 + 8, "header.seq/stamp");
    array(1, "header.frame_id");
  }

 private:
  [[noreturn]] void fail(const char* what, std::uint64_t needed) const {
    throw Problem(std::string("the message is corrupt: '") + what + "' needs " +
                  std::to_string(needed) + " bytes at byte " + std::to_string(at_) + " of " +
                  std::to_string(size_));
  }

  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

/// Throws Problem when a length in the serialized `T` runs past its bytes.
template <typename T>
void checkMessageBounds(const std::vector<std::uint8_t>& bytes) {
  MessageBounds m(bytes.data(), bytes.size());
  if constexpr (!std::is_same_v<T, tf2_msgs::TFMessage>) m.header();  // a TFMessage has none
  if constexpr (std::is_same_v<T, sensor_msgs::Image>) {
    m.skip(8, "height/width");
    m.array(1, "encoding");
    m.skip(1 + 4, "is_bigendian/step");
    m.array(1, "data");
  } else if constexpr (std::is_same_v<T, sensor_msgs::CompressedImage>) {
    m.array(1, "format");
    m.array(1, "data");
  } else if constexpr (std::is_same_v<T, sensor_msgs::CameraInfo>) {
    m.skip(8, "height/width");
    m.array(1, "distortion_model");
    m.array(8, "D");
    m.skip(8 * (9 + 9 + 12) + 4 * 2 + 4 * 4 + 1, "K/R/P/binning/roi");
  } else if constexpr (std::is_same_v<T, nav_msgs::Odometry>) {
    m.array(1, "child_frame_id");
    m.skip(8 * (7 + 36 + 6 + 36), "pose/twist");
  } else if constexpr (std::is_same_v<T, geometry_msgs::PoseWithCovarianceStamped>) {
    m.skip(8 * (7 + 36), "pose/covariance");
  } else if constexpr (std::is_same_v<T, tf2_msgs::TFMessage>) {
    // transforms[]: each a header, child_frame_id and 7 doubles.
    for (std::uint32_t i = 0, n = m.u32("transforms"); i < n; ++i) {
      m.header();
      m.array(1, "child_frame_id");
      m.skip(8 * 7, "transform");
    }
  } else {
    static_assert(std::is_same_v<T, geometry_msgs::PoseStamped>, "a message type lookboth reads");
    m.skip(8 * 7, "pose");
  }
}

/// A message of a ROS 1 bag: deserialized on request, once its md5sum is the
/// one lookboth knows and its lengths stay within its bytes.
class Ros1Message final : public BagMessage {
 public:
  explicit Ros1Message(const rosbag::MessageInstance& message)
      : message_(message), topic_(message.getTopic()) {}

  const std::string& topic() const override { return topic_; }
  TimeNs receiveTime() const override { return rosTimeToNs(message_.getTime()); }
  sensor_msgs::Image image() const override { return decode<sensor_msgs::Image>(); }
  sensor_msgs::CompressedImage compressedImage() const override {
    return decode<sensor_msgs::CompressedImage>();
  }
  sensor_msgs::CameraInfo cameraInfo() const override { return decode<sensor_msgs::CameraInfo>(); }
  nav_msgs::Odometry odometry() const override { return decode<nav_msgs::Odometry>(); }
  geometry_msgs::PoseStamped poseStamped() const override {
    return decode<geometry_msgs::PoseStamped>();
  }
  geometry_msgs::PoseWithCovarianceStamped poseWithCovarianceStamped() const override {
    return decode<geometry_msgs::PoseWithCovarianceStamped>();
  }
  std::vector<geometry_msgs::TransformStamped> transforms() const override {
    return decode<tf2_msgs::TFMessage>().transforms;
  }

 private:
  template <typename T>
  T decode() const {
    if (!message_.isType<T>()) {
      throw Problem("the message definition of " + message_.getDataType() + " in the bag (md5sum " +
                    message_.getMD5Sum() + ") differs from the one lookboth knows (" +
                    ros::message_traits::MD5Sum<T>::value() + ")");
    }
    std::vector<std::uint8_t> bytes(message_.size());
    ros::serialization::OStream out(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
    message_.write(out);
    checkMessageBounds<T>(bytes);
    T msg;
    ros::serialization::IStream in(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
    ros::serialization::deserialize(in, msg);
    return msg;
  }

  const rosbag::MessageInstance& message_;
  std::string topic_;
};

class Ros1BagSource final : public BagSource {
 public:
  explicit Ros1BagSource(const fs::path& path) : path_(path) {
    BagStructureCheck(path_).run();
    try {
      bag_.open(path_.string(), rosbag::bagmode::Read);
    } catch (const rosbag::BagUnindexedException&) {
      throw Error(context(),
                  "not a usable ROS bag: it has no index (an interrupted recording?); "
                  "run 'rosbag reindex' on it first");
    } catch (const std::exception& e) {
      throw Error(
          context(),
          std::string("cannot read it as a ROS 1 bag (corrupt or truncated?): ") + e.what());
    }
  }

  std::string formatName() const override { return "ROS 1 bag"; }
  bool ros2() const override { return false; }

  std::map<std::string, std::set<std::string>> topicTypes() override {
    std::map<std::string, std::set<std::string>> present;
    rosbag::View all(bag_);
    for (const rosbag::ConnectionInfo* c : all.getConnections())
      present[c->topic].insert(c->datatype);
    return present;
  }

  std::int64_t count(const std::vector<std::string>& topics) override {
    rosbag::View view(bag_, rosbag::TopicQuery(topics));
    return static_cast<std::int64_t>(view.size());
  }

  void forEach(const std::vector<std::string>& topics,
               const std::function<bool(const BagMessage&)>& visit) override {
    rosbag::View view(bag_, rosbag::TopicQuery(topics));
    for (const rosbag::MessageInstance& message : view) {
      if (!visit(Ros1Message(message))) return;
    }
  }

 private:
  ErrorContext context() const { return {path_.string(), 0, "", ""}; }

  fs::path path_;
  rosbag::Bag bag_;
};

}  // namespace

TimeNs rosTimeToNs(const ros::Time& t) {
  return static_cast<TimeNs>(t.sec) * kNanosecondsPerSecond + static_cast<TimeNs>(t.nsec);
}

std::unique_ptr<BagSource> openRos1Bag(const fs::path& path) {
  return std::make_unique<Ros1BagSource>(path);
}

}  // namespace lookboth::bag
