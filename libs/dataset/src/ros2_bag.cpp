#include "ros2_bag.h"

#include <lz4frame.h>
#include <sqlite3.h>
#include <yaml-cpp/yaml.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <unordered_map>

#include "lookboth/core/error.h"

namespace lookboth::ros2 {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const fs::path& file, const std::string& message) {
  throw Error(ErrorContext{file.string(), 0, "", ""}, message);
}

std::string str(std::uint64_t value) { return std::to_string(value); }

bool wanted(const std::set<std::string>& topics, const Topic& topic) {
  return topics.empty() || topics.count(topic.name) > 0;
}

/// The bag's topics by name, each name once, in the order first seen. The
/// vector is only appended to while the bag is opened, so pointers into it
/// stay valid once it is open.
class TopicTable {
 public:
  /// Index of `topic`, added if new; nullopt when its name is known with
  /// another type.
  std::optional<std::size_t> add(const Topic& topic) {
    const auto found = index_.find(topic.name);
    if (found != index_.end()) {
      const Topic& known = topics_[found->second];
      if (known.type != topic.type) return std::nullopt;
      return found->second;
    }
    index_.emplace(topic.name, topics_.size());
    topics_.push_back(topic);
    return topics_.size() - 1;
  }
  std::optional<std::size_t> find(const std::string& name) const {
    const auto found = index_.find(name);
    if (found == index_.end()) return std::nullopt;
    return found->second;
  }
  const std::vector<Topic>& topics() const { return topics_; }

 private:
  std::vector<Topic> topics_;
  std::map<std::string, std::size_t> index_;
};

// ---------------------------------------------------------------------------
// MCAP (https://mcap.dev/spec): little-endian records, each an opcode byte, a
// uint64 length and the content.

constexpr std::array<std::uint8_t, 8> kMcapMagic = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
constexpr std::uint64_t kRecordHeaderSize = 9;
constexpr std::uint64_t kFooterContentSize = 20;

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kStatistics = 0x0B,
  kDataEnd = 0x0F,
};

std::string recordName(std::uint8_t opcode) {
  static const std::map<std::uint8_t, std::string> kNames = {
      {0x01, "Header"},           {0x02, "Footer"},         {0x03, "Schema"},
      {0x04, "Channel"},          {0x05, "Message"},        {0x06, "Chunk"},
      {0x07, "Message Index"},    {0x08, "Chunk Index"},    {0x09, "Attachment"},
      {0x0A, "Attachment Index"}, {0x0B, "Statistics"},     {0x0C, "Metadata"},
      {0x0D, "Metadata Index"},   {0x0E, "Summary Offset"}, {0x0F, "Data End"}};
  const auto found = kNames.find(opcode);
  if (found != kNames.end()) return found->second;
  return "opcode 0x" + std::string(1, "0123456789abcdef"[opcode >> 4]) +
         std::string(1, "0123456789abcdef"[opcode & 15]);
}

std::uint64_t loadLittleEndian(const std::uint8_t* bytes, int count) {
  std::uint64_t value = 0;
  for (int i = count - 1; i >= 0; --i) value = (value << 8) | bytes[i];
  return value;
}

/// Fields of one record's content, bounds-checked; `what` names the record
/// in errors ("the Channel record at byte 1234").
class FieldReader {
 public:
  FieldReader(const std::uint8_t* data, std::uint64_t size, const fs::path& file, std::string what)
      : data_(data), size_(size), file_(file), what_(std::move(what)) {}

  std::uint64_t uint(const char* field, int bytes) {
    need(field, static_cast<std::uint64_t>(bytes));
    const std::uint64_t value = loadLittleEndian(data_ + offset_, bytes);
    offset_ += static_cast<std::uint64_t>(bytes);
    return value;
  }
  std::string string(const char* field) {
    const std::uint64_t length = uint(field, 4);
    need(field, length);
    std::string value(reinterpret_cast<const char*>(data_ + offset_), length);
    offset_ += length;
    return value;
  }
  /// Skips a uint32 length-prefixed map or byte array.
  void skipPrefixed(const char* field, int length_bytes) {
    const std::uint64_t length = uint(field, length_bytes);
    need(field, length);
    offset_ += length;
  }
  const std::uint8_t* here() const { return data_ + offset_; }
  std::uint64_t remaining() const { return size_ - offset_; }

 private:
  void need(const char* field, std::uint64_t bytes) const {
    if (bytes <= size_ - offset_) return;
    fail(file_, "corrupt " + what_ + ": field '" + field + "' at byte " + str(offset_) +
                    " of its content needs " + str(bytes) + " bytes, " + str(size_ - offset_) +
                    " remain");
  }

  const std::uint8_t* data_;
  std::uint64_t size_;
  std::uint64_t offset_ = 0;
  const fs::path& file_;
  std::string what_;
};

/// One record: in the file, or inside a chunk's uncompressed records.
struct McapRecord {
  std::uint8_t opcode = 0;
  const std::uint8_t* content = nullptr;
  std::uint64_t size = 0;
  std::uint64_t file_offset = 0;              ///< The record's, or its chunk's.
  std::optional<std::uint64_t> chunk_offset;  ///< Offset inside the chunk's records.
};

void decompressLz4(const std::uint8_t* in, std::size_t in_size, std::vector<std::uint8_t>* out,
                   const std::function<void(const std::string&)>& error) {
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) error("out of memory");
  std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> context(
      raw, &LZ4F_freeDecompressionContext);
  std::size_t in_pos = 0, out_pos = 0, status = 1;
  // A chunk may hold several frames one after another; LZ4F starts the next
  // frame after one ends (status 0).
  while (in_pos < in_size || status != 0) {
    std::size_t out_step = out->size() - out_pos;
    std::size_t in_step = in_size - in_pos;
    status = LZ4F_decompress(context.get(), out->data() + out_pos, &out_step, in + in_pos, &in_step,
                             nullptr);
    if (LZ4F_isError(status)) error(std::string("LZ4: ") + LZ4F_getErrorName(status));
    out_pos += out_step;
    in_pos += in_step;
    if (status != 0 && in_step == 0 && out_step == 0) {
      error(in_pos == in_size ? "the LZ4 data ends inside a frame"
                              : "the LZ4 data decompresses to more than uncompressed_size");
    }
  }
  if (out_pos != out->size()) {
    error("the LZ4 data decompresses to " + str(out_pos) + " bytes, uncompressed_size says " +
          str(out->size()));
  }
}

void decompressZstd(const std::uint8_t* in, std::size_t in_size, std::vector<std::uint8_t>* out,
                    const std::function<void(const std::string&)>& error) {
  const std::size_t result = ZSTD_decompress(out->data(), out->size(), in, in_size);
  if (ZSTD_isError(result)) error(std::string("zstd: ") + ZSTD_getErrorName(result));
  if (result != out->size()) {
    error("the zstd data decompresses to " + str(result) + " bytes, uncompressed_size says " +
          str(out->size()));
  }
}

/// One MCAP file, read record by record.
class McapFile final : public BagReader {
 public:
  explicit McapFile(fs::path path);

  const std::vector<Topic>& topics() const override { return table_.topics(); }
  std::int64_t messageCount(const std::set<std::string>& topics) override;
  bool next(const std::set<std::string>& topics, Message* message) override;
  void rewind() override;
  std::vector<std::string> notes() const override { return notes_; }

 private:
  void readBytes(std::uint64_t offset, std::uint64_t size, std::vector<std::uint8_t>* out);
  void checkMagicAndHeader();
  bool readSummary();
  bool endsWithMagic();
  void readSummaryRecords(std::uint64_t begin, std::uint64_t end);
  void scanForTopics();
  bool nextRecord(McapRecord* record);
  bool nextFileRecord(McapRecord* record);
  bool nextChunkRecord(McapRecord* record);
  void loadChunk(std::uint64_t offset, std::uint64_t size);
  void decompress(const std::string& compression, const std::uint8_t* in, std::uint64_t in_size,
                  const std::function<void(const std::string&)>& error);
  std::string describe(const McapRecord& record) const;
  void handleSchema(const McapRecord& record);
  void handleChannel(const McapRecord& record);
  void handleStatistics(const McapRecord& record);
  const Topic& messageTopic(const McapRecord& record, std::uint16_t channel_id) const;

  fs::path path_;
  std::string name_;
  std::ifstream in_;
  std::uint64_t file_size_ = 0;
  TopicTable table_;
  std::map<std::uint16_t, std::string> schemas_;   // id -> schema name (the type)
  std::map<std::uint16_t, std::size_t> channels_;  // id -> topic index
  std::optional<std::map<std::uint16_t, std::uint64_t>> channel_counts_;
  bool topics_fixed_ = false;
  std::vector<std::string> notes_;
  // Reading position.
  std::uint64_t position_ = 0;  // next record in the file
  bool data_ended_ = false;
  std::vector<std::uint8_t> record_;  // content of the current record read from the file
  std::vector<std::uint8_t> chunk_;   // the current chunk's uncompressed records
  std::uint64_t chunk_position_ = 0;
  std::uint64_t chunk_offset_ = 0;  // the chunk record's byte in the file
  bool in_chunk_ = false;
};

McapFile::McapFile(fs::path path) : path_(std::move(path)), name_(path_.filename().string()) {
  in_.open(path_, std::ios::binary);
  if (!in_) fail(path_, "cannot open the file for reading");
  std::error_code ec;
  file_size_ = fs::file_size(path_, ec);
  if (ec) fail(path_, "cannot read the file's size: " + ec.message());
  checkMagicAndHeader();
  if (!readSummary()) {
    scanForTopics();  // throws when a record is cut; past here every message is whole
    if (!endsWithMagic()) {
      notes_.push_back(name_ +
                       " ends without the MCAP footer: the recording was cut after its "
                       "last message (every message is read; the summary is lost)");
    }
  }
  topics_fixed_ = true;
  rewind();
}

void McapFile::readBytes(std::uint64_t offset, std::uint64_t size, std::vector<std::uint8_t>* out) {
  // Callers have checked offset + size <= file_size_.
  out->resize(size);
  in_.clear();
  in_.seekg(static_cast<std::streamoff>(offset));
  in_.read(reinterpret_cast<char*>(out->data()), static_cast<std::streamsize>(size));
  if (!in_) fail(path_, "read error at byte " + str(offset));
}

void McapFile::checkMagicAndHeader() {
  std::vector<std::uint8_t> start;
  if (file_size_ < kMcapMagic.size() + kRecordHeaderSize) {
    fail(path_, "not an MCAP file: " + str(file_size_) +
                    " bytes, less than the magic and a Header record");
  }
  readBytes(0, kMcapMagic.size() + 1, &start);
  if (!std::equal(kMcapMagic.begin(), kMcapMagic.end(), start.begin())) {
    fail(path_, "not an MCAP file: the first 8 bytes are not the MCAP magic \\x89MCAP0\\r\\n");
  }
  if (start[8] != kHeader) {
    fail(path_, "corrupt at byte 8: expected the Header record, found a " + recordName(start[8]) +
                    " record");
  }
}

bool McapFile::endsWithMagic() {
  if (file_size_ < 2 * kMcapMagic.size()) return false;
  std::vector<std::uint8_t> tail;
  readBytes(file_size_ - kMcapMagic.size(), kMcapMagic.size(), &tail);
  return std::equal(kMcapMagic.begin(), kMcapMagic.end(), tail.begin());
}

/// The summary section's channels and statistics, found through the footer;
/// false when the file has no usable summary (then the data section is
/// scanned).
bool McapFile::readSummary() {
  const std::uint64_t footer_size = kRecordHeaderSize + kFooterContentSize;
  if (file_size_ < 2 * kMcapMagic.size() + footer_size) return false;
  std::vector<std::uint8_t> tail;
  const std::uint64_t footer_offset = file_size_ - kMcapMagic.size() - footer_size;
  readBytes(footer_offset, footer_size + kMcapMagic.size(), &tail);
  if (!std::equal(kMcapMagic.begin(), kMcapMagic.end(), tail.begin() + footer_size)) return false;
  if (tail[0] != kFooter || loadLittleEndian(&tail[1], 8) != kFooterContentSize) return false;
  const std::uint64_t summary_start = loadLittleEndian(&tail[9], 8);
  const std::uint64_t summary_offset_start = loadLittleEndian(&tail[17], 8);
  if (summary_start == 0) return false;
  const std::uint64_t summary_end =
      summary_offset_start != 0 ? summary_offset_start : footer_offset;
  if (summary_start < kMcapMagic.size() || summary_start > summary_end ||
      summary_end > footer_offset) {
    fail(path_, "corrupt Footer at byte " + str(footer_offset) + ": summary_start " +
                    str(summary_start) + " is outside the file's records");
  }
  readSummaryRecords(summary_start, summary_end);
  return !channels_.empty() || (channel_counts_ && channel_counts_->empty());
}

void McapFile::readSummaryRecords(std::uint64_t begin, std::uint64_t end) {
  std::vector<std::uint8_t> header;
  for (std::uint64_t offset = begin; offset < end;) {
    if (end - offset < kRecordHeaderSize) {
      fail(path_, "corrupt summary section at byte " + str(offset) +
                      ": a record header needs 9 bytes, " + str(end - offset) + " remain");
    }
    readBytes(offset, kRecordHeaderSize, &header);
    const std::uint64_t size = loadLittleEndian(&header[1], 8);
    if (size > end - offset - kRecordHeaderSize) {
      fail(path_, "corrupt summary section at byte " + str(offset) + ": a " +
                      recordName(header[0]) + " record of " + str(size) +
                      " bytes runs past the section's end at byte " + str(end));
    }
    const McapRecord record{header[0], nullptr, size, offset, std::nullopt};
    if (record.opcode == kSchema || record.opcode == kChannel || record.opcode == kStatistics) {
      readBytes(offset + kRecordHeaderSize, size, &record_);
      McapRecord loaded = record;
      loaded.content = record_.data();
      if (record.opcode == kSchema) handleSchema(loaded);
      if (record.opcode == kChannel) handleChannel(loaded);
      if (record.opcode == kStatistics) handleStatistics(loaded);
    }
    offset += kRecordHeaderSize + size;
  }
}

/// Without a summary, one pass over the data section finds the channels
/// (which may sit inside chunks) and counts the messages.
void McapFile::scanForTopics() {
  std::map<std::uint16_t, std::uint64_t> counts;
  rewind();
  McapRecord record;
  while (nextRecord(&record)) {
    if (record.opcode == kSchema) handleSchema(record);
    if (record.opcode == kChannel) handleChannel(record);
    if (record.opcode == kMessage) {
      FieldReader fields(record.content, record.size, path_, describe(record));
      ++counts[static_cast<std::uint16_t>(fields.uint("channel_id", 2))];
    }
  }
  channel_counts_ = counts;
}

std::string McapFile::describe(const McapRecord& record) const {
  if (!record.chunk_offset) {
    return "the " + recordName(record.opcode) + " record at byte " + str(record.file_offset);
  }
  return "the " + recordName(record.opcode) + " record at byte " + str(*record.chunk_offset) +
         " of the uncompressed records of the Chunk at byte " + str(record.file_offset);
}

void McapFile::handleSchema(const McapRecord& record) {
  FieldReader fields(record.content, record.size, path_, describe(record));
  const auto id = static_cast<std::uint16_t>(fields.uint("id", 2));
  std::string name = fields.string("name");
  if (id != 0) schemas_.emplace(id, std::move(name));
}

void McapFile::handleChannel(const McapRecord& record) {
  FieldReader fields(record.content, record.size, path_, describe(record));
  const auto id = static_cast<std::uint16_t>(fields.uint("id", 2));
  const auto schema_id = static_cast<std::uint16_t>(fields.uint("schema_id", 2));
  Topic topic;
  topic.name = fields.string("topic");
  topic.serialization_format = fields.string("message_encoding");
  if (channels_.count(id) > 0) return;  // repeated in the summary or in a later chunk
  if (schema_id != 0) {
    const auto schema = schemas_.find(schema_id);
    if (schema == schemas_.end()) {
      fail(path_, "corrupt " + describe(record) + ": channel " + str(id) + " ('" + topic.name +
                      "') refers to schema " + str(schema_id) +
                      ", which no Schema record before it defines");
    }
    topic.type = schema->second;
  }
  std::optional<std::size_t> index = topics_fixed_ ? table_.find(topic.name) : table_.add(topic);
  if (index && table_.topics()[*index].type != topic.type) index.reset();
  if (!index) {
    fail(path_, describe(record) + " defines topic '" + topic.name + "' with type '" + topic.type +
                    "', which the summary does not list with that type");
  }
  channels_.emplace(id, *index);
}

void McapFile::handleStatistics(const McapRecord& record) {
  FieldReader fields(record.content, record.size, path_, describe(record));
  fields.uint("message_count", 8);
  fields.uint("schema_count", 2);
  fields.uint("channel_count", 4);
  fields.uint("attachment_count", 4);
  fields.uint("metadata_count", 4);
  fields.uint("chunk_count", 4);
  fields.uint("message_start_time", 8);
  fields.uint("message_end_time", 8);
  const std::uint64_t map_size = fields.uint("channel_message_counts", 4);
  if (map_size > fields.remaining() || map_size % 10 != 0) {
    fail(path_,
         "corrupt " + describe(record) + ": channel_message_counts of " + str(map_size) + " bytes");
  }
  std::map<std::uint16_t, std::uint64_t> counts;
  for (std::uint64_t i = 0; i < map_size / 10; ++i) {
    const auto channel = static_cast<std::uint16_t>(fields.uint("channel_message_counts", 2));
    counts[channel] = fields.uint("channel_message_counts", 8);
  }
  channel_counts_ = counts;
}

std::int64_t McapFile::messageCount(const std::set<std::string>& topics) {
  if (!channel_counts_) return -1;
  std::uint64_t total = 0;
  for (const auto& [channel, count] : *channel_counts_) {
    const auto topic = channels_.find(channel);
    if (topic == channels_.end()) continue;
    if (wanted(topics, table_.topics()[topic->second])) total += count;
  }
  return static_cast<std::int64_t>(total);
}

void McapFile::rewind() {
  position_ = kMcapMagic.size();
  data_ended_ = false;
  in_chunk_ = false;
  chunk_position_ = 0;
}

bool McapFile::nextRecord(McapRecord* record) {
  while (true) {
    if (in_chunk_) {
      if (nextChunkRecord(record)) return true;
      in_chunk_ = false;
      continue;
    }
    if (data_ended_) return false;
    if (nextFileRecord(record)) return true;
  }
}

/// The next record of the data section that may matter (Schema, Channel,
/// Message), or a chunk opened; false when the data section ended or the
/// record was skipped.
bool McapFile::nextFileRecord(McapRecord* record) {
  const std::uint64_t remaining = file_size_ - position_;
  if (remaining == 0) {
    fail(path_, "truncated at byte " + str(file_size_) +
                    ": the data section ends without a Data End record and the footer (a "
                    "recording cut off?)");
  }
  std::vector<std::uint8_t> header;
  if (remaining < kRecordHeaderSize) {
    fail(path_, "truncated at byte " + str(file_size_) + ": a record header at byte " +
                    str(position_) + " needs 9 bytes, " + str(remaining) +
                    " remain (a recording cut off?)");
  }
  readBytes(position_, kRecordHeaderSize, &header);
  const std::uint8_t opcode = header[0];
  const std::uint64_t size = loadLittleEndian(&header[1], 8);
  if (size > remaining - kRecordHeaderSize) {
    fail(path_, "truncated at byte " + str(file_size_) + ": a " + recordName(opcode) +
                    " record of " + str(kRecordHeaderSize + size) + " bytes at byte " +
                    str(position_) + " needs " + str(kRecordHeaderSize + size - remaining) +
                    " more (a recording cut off?)");
  }
  const std::uint64_t offset = position_;
  position_ += kRecordHeaderSize + size;
  if (opcode == kDataEnd || opcode == kFooter) {
    data_ended_ = true;
    return false;
  }
  if (opcode == kChunk) {
    loadChunk(offset, size);
    return false;
  }
  if (opcode != kSchema && opcode != kChannel && opcode != kMessage) return false;
  readBytes(offset + kRecordHeaderSize, size, &record_);
  *record = McapRecord{opcode, record_.data(), size, offset, std::nullopt};
  return true;
}

bool McapFile::nextChunkRecord(McapRecord* record) {
  while (chunk_position_ < chunk_.size()) {
    const std::uint64_t remaining = chunk_.size() - chunk_position_;
    const std::string where = "corrupt Chunk record at byte " + str(chunk_offset_) +
                              ": the record at byte " + str(chunk_position_) +
                              " of its uncompressed records ";
    if (remaining < kRecordHeaderSize) {
      fail(path_, where + "needs a 9-byte header, " + str(remaining) + " bytes remain");
    }
    const std::uint8_t opcode = chunk_[chunk_position_];
    const std::uint64_t size = loadLittleEndian(&chunk_[chunk_position_ + 1], 8);
    if (size > remaining - kRecordHeaderSize) {
      fail(path_, where + "(" + recordName(opcode) + ", " + str(kRecordHeaderSize + size) +
                      " bytes) runs " + str(kRecordHeaderSize + size - remaining) +
                      " bytes past the chunk's end");
    }
    const std::uint64_t offset = chunk_position_;
    chunk_position_ += kRecordHeaderSize + size;
    if (opcode == kSchema || opcode == kChannel || opcode == kMessage) {
      *record = McapRecord{opcode, chunk_.data() + offset + kRecordHeaderSize, size, chunk_offset_,
                           offset};
      return true;
    }
  }
  return false;
}

void McapFile::loadChunk(std::uint64_t offset, std::uint64_t size) {
  readBytes(offset + kRecordHeaderSize, size, &record_);
  const std::string what = "Chunk record at byte " + str(offset);
  FieldReader fields(record_.data(), size, path_, "the " + what);
  fields.uint("message_start_time", 8);
  fields.uint("message_end_time", 8);
  const std::uint64_t uncompressed_size = fields.uint("uncompressed_size", 8);
  const auto crc = static_cast<std::uint32_t>(fields.uint("uncompressed_crc", 4));
  const std::string compression = fields.string("compression");
  const std::uint64_t records_size = fields.uint("records", 8);
  const auto error = [&](const std::string& message) {
    fail(path_, "corrupt " + what + ": " + message);
  };
  if (records_size != fields.remaining()) {
    error("its records are " + str(records_size) + " bytes, the record holds " +
          str(fields.remaining()));
  }
  // A corrupt size must not become a huge allocation: no codec we read
  // expands data more than a few thousand times.
  const std::uint64_t limit = std::max<std::uint64_t>(std::uint64_t{1} << 28, records_size * 4096);
  if (uncompressed_size > limit) {
    error("uncompressed_size " + str(uncompressed_size) + " is implausible for " +
          str(records_size) + " compressed bytes");
  }
  chunk_.resize(uncompressed_size);
  decompress(compression, fields.here(), records_size, error);
  if (crc != 0) {
    const auto actual = static_cast<std::uint32_t>(crc32_z(0, chunk_.data(), chunk_.size()));
    if (actual != crc) {
      error("the CRC-32 of its uncompressed records is " + str(actual) +
            ", uncompressed_crc says " + str(crc) + " (the file is damaged)");
    }
  }
  chunk_offset_ = offset;
  chunk_position_ = 0;
  in_chunk_ = true;
}

void McapFile::decompress(const std::string& compression, const std::uint8_t* in,
                          std::uint64_t in_size,
                          const std::function<void(const std::string&)>& error) {
  if (compression.empty()) {
    if (in_size != chunk_.size()) {
      error("uncompressed records of " + str(in_size) + " bytes, uncompressed_size says " +
            str(chunk_.size()));
    }
    std::copy(in, in + in_size, chunk_.begin());
  } else if (compression == "lz4") {
    decompressLz4(in, in_size, &chunk_, error);
  } else if (compression == "zstd") {
    decompressZstd(in, in_size, &chunk_, error);
  } else {
    error("unknown compression '" + compression + "' (lookboth reads none, 'lz4' and 'zstd')");
  }
}

const Topic& McapFile::messageTopic(const McapRecord& record, std::uint16_t channel_id) const {
  const auto channel = channels_.find(channel_id);
  if (channel == channels_.end()) {
    fail(path_, "corrupt " + describe(record) + ": channel " + str(channel_id) +
                    " is not defined by any Channel record before it");
  }
  return table_.topics()[channel->second];
}

bool McapFile::next(const std::set<std::string>& topics, Message* message) {
  McapRecord record;
  while (nextRecord(&record)) {
    if (record.opcode == kSchema) handleSchema(record);
    if (record.opcode == kChannel) handleChannel(record);
    if (record.opcode != kMessage) continue;
    FieldReader fields(record.content, record.size, path_, describe(record));
    const auto channel_id = static_cast<std::uint16_t>(fields.uint("channel_id", 2));
    fields.uint("sequence", 4);
    const std::uint64_t log_time = fields.uint("log_time", 8);
    fields.uint("publish_time", 8);
    const Topic& topic = messageTopic(record, channel_id);
    if (!wanted(topics, topic)) continue;
    if (log_time > static_cast<std::uint64_t>(std::numeric_limits<TimeNs>::max())) {
      fail(path_, "corrupt " + describe(record) + ": log_time " + str(log_time) +
                      " ns is past the year 2262");
    }
    message->topic = &topic;
    message->log_time = static_cast<TimeNs>(log_time);
    message->data.assign(fields.here(), fields.here() + fields.remaining());
    message->where = name_ + ", byte " + str(record.file_offset);
    if (record.chunk_offset) message->where += " (chunk), record at " + str(*record.chunk_offset);
    return true;
  }
  // Nothing of the file stays in memory once it has been read.
  std::vector<std::uint8_t>().swap(chunk_);
  std::vector<std::uint8_t>().swap(record_);
  return false;
}

// ---------------------------------------------------------------------------
// sqlite3 (.db3): rosbag2's tables topics(id, name, type, serialization_format,
// ...) and messages(id, topic_id, timestamp, data).

struct SqliteCloser {
  void operator()(sqlite3* db) const { sqlite3_close_v2(db); }
};
struct StatementFinalizer {
  void operator()(sqlite3_stmt* statement) const { sqlite3_finalize(statement); }
};
using StatementPtr = std::unique_ptr<sqlite3_stmt, StatementFinalizer>;

/// A file URI that opens `path` read-only and immutable: sqlite then writes
/// no journal or lock file next to the input.
std::string immutableUri(const fs::path& path) {
  std::string uri = "file:";
  for (const char c : fs::absolute(path).string()) {
    if (c == '%' || c == '?' || c == '#') {
      static const char* kHex = "0123456789ABCDEF";
      const auto byte = static_cast<unsigned char>(c);
      uri += {'%', kHex[byte >> 4], kHex[byte & 15]};
    } else {
      uri += c;
    }
  }
  return uri + "?mode=ro&immutable=1";
}

class Db3File final : public BagReader {
 public:
  explicit Db3File(fs::path path);

  const std::vector<Topic>& topics() const override { return table_.topics(); }
  std::int64_t messageCount(const std::set<std::string>& topics) override;
  bool next(const std::set<std::string>& topics, Message* message) override;
  void rewind() override;

 private:
  StatementPtr prepare(const std::string& sql);
  [[noreturn]] void sqliteFail(const std::string& doing);
  void checkTables();
  void readTopics();

  fs::path path_;
  std::string name_;
  std::unique_ptr<sqlite3, SqliteCloser> db_;
  TopicTable table_;
  std::map<std::int64_t, std::size_t> topic_ids_;  // topics.id -> topic index
  std::optional<std::map<std::int64_t, std::int64_t>> counts_;
  StatementPtr order_;  // id, topic_id, timestamp in rosbag2's reading order
  StatementPtr data_;   // one message's data by id
  bool ended_ = false;
};

Db3File::Db3File(fs::path path) : path_(std::move(path)), name_(path_.filename().string()) {
  if (!fs::is_regular_file(path_)) fail(path_, "no such file");
  sqlite3* db = nullptr;
  const int status = sqlite3_open_v2(immutableUri(path_).c_str(), &db,
                                     SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
  db_.reset(db);
  if (status != SQLITE_OK) sqliteFail("opening it");
  checkTables();
  readTopics();
  // The order is sorted on small rows; each message's data is then read by
  // id, so no sort ever holds the blobs.
  order_ = prepare("SELECT id, topic_id, timestamp FROM messages ORDER BY timestamp, id");
  data_ = prepare("SELECT data FROM messages WHERE id = ?");
}

void Db3File::sqliteFail(const std::string& doing) {
  const std::string reason = db_ ? sqlite3_errmsg(db_.get()) : "out of memory";
  fail(path_, "not a readable rosbag2 sqlite3 file (" + doing + ": " + reason + ")");
}

StatementPtr Db3File::prepare(const std::string& sql) {
  sqlite3_stmt* statement = nullptr;
  if (sqlite3_prepare_v2(db_.get(), sql.c_str(), -1, &statement, nullptr) != SQLITE_OK) {
    sqliteFail("preparing '" + sql + "'");
  }
  return StatementPtr(statement);
}

void Db3File::checkTables() {
  StatementPtr tables = prepare("SELECT name FROM sqlite_master WHERE type = 'table'");
  std::set<std::string> names;
  int status;
  while ((status = sqlite3_step(tables.get())) == SQLITE_ROW) {
    names.insert(reinterpret_cast<const char*>(sqlite3_column_text(tables.get(), 0)));
  }
  if (status != SQLITE_DONE) sqliteFail("listing its tables");
  for (const char* table : {"topics", "messages"}) {
    if (names.count(table) == 0) {
      fail(path_, std::string("not a rosbag2 sqlite3 file: it has no '") + table + "' table");
    }
  }
}

void Db3File::readTopics() {
  StatementPtr statement =
      prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id");
  int status;
  const auto text = [&](int column) {
    const unsigned char* value = sqlite3_column_text(statement.get(), column);
    return value ? std::string(reinterpret_cast<const char*>(value)) : std::string();
  };
  while ((status = sqlite3_step(statement.get())) == SQLITE_ROW) {
    const std::int64_t id = sqlite3_column_int64(statement.get(), 0);
    const Topic topic{text(1), text(2), text(3)};
    const std::optional<std::size_t> index = table_.add(topic);
    if (!index) {
      fail(path_, "topic '" + topic.name +
                      "' is listed twice with different types (table "
                      "'topics', id " +
                      std::to_string(id) + ")");
    }
    topic_ids_[id] = *index;
  }
  if (status != SQLITE_DONE) sqliteFail("reading table 'topics'");
}

std::int64_t Db3File::messageCount(const std::set<std::string>& topics) {
  if (!counts_) {
    StatementPtr statement = prepare("SELECT topic_id, COUNT(*) FROM messages GROUP BY topic_id");
    counts_.emplace();
    int status;
    while ((status = sqlite3_step(statement.get())) == SQLITE_ROW) {
      (*counts_)[sqlite3_column_int64(statement.get(), 0)] =
          sqlite3_column_int64(statement.get(), 1);
    }
    if (status != SQLITE_DONE) sqliteFail("counting the messages");
  }
  std::int64_t total = 0;
  for (const auto& [topic_id, count] : *counts_) {
    const auto topic = topic_ids_.find(topic_id);
    if (topic != topic_ids_.end() && wanted(topics, table_.topics()[topic->second])) {
      total += count;
    }
  }
  return total;
}

bool Db3File::next(const std::set<std::string>& topics, Message* message) {
  if (ended_) return false;  // sqlite would start again after the last row
  int status;
  while ((status = sqlite3_step(order_.get())) == SQLITE_ROW) {
    const std::int64_t id = sqlite3_column_int64(order_.get(), 0);
    const std::int64_t topic_id = sqlite3_column_int64(order_.get(), 1);
    const auto topic = topic_ids_.find(topic_id);
    const std::string where = name_ + ", message id " + std::to_string(id);
    if (topic == topic_ids_.end()) {
      fail(path_, "message id " + std::to_string(id) + " has topic_id " + std::to_string(topic_id) +
                      ", which table 'topics' does not list");
    }
    const Topic& found = table_.topics()[topic->second];
    if (!wanted(topics, found)) continue;
    sqlite3_reset(data_.get());
    sqlite3_bind_int64(data_.get(), 1, id);
    if (sqlite3_step(data_.get()) != SQLITE_ROW) sqliteFail("reading " + where);
    const auto* bytes = static_cast<const std::uint8_t*>(sqlite3_column_blob(data_.get(), 0));
    const int size = sqlite3_column_bytes(data_.get(), 0);
    message->topic = &found;
    message->log_time = sqlite3_column_int64(order_.get(), 2);
    message->data.assign(bytes, bytes + size);
    message->where = where;
    return true;
  }
  if (status != SQLITE_DONE) sqliteFail("reading table 'messages'");
  ended_ = true;
  return false;
}

void Db3File::rewind() {
  sqlite3_reset(order_.get());
  ended_ = false;
}

// ---------------------------------------------------------------------------
// A bag folder: metadata.yaml and its storage files, read in order as one bag.

std::unique_ptr<BagReader> openStorageFile(const fs::path& path);

struct BagMetadata {
  std::vector<fs::path> files;
  std::optional<std::int64_t> message_count;
  std::map<std::string, std::int64_t> topic_counts;
};

fs::path storageFilePath(const fs::path& folder, const std::string& relative) {
  const fs::path direct = folder / relative;
  // Early rosbag2 releases wrote the paths with the bag folder's name in front.
  const fs::path leaf = folder / fs::path(relative).filename();
  return fs::exists(direct) || !fs::exists(leaf) ? direct : leaf;
}

BagMetadata readMetadata(const fs::path& folder, const fs::path& file) {
  BagMetadata metadata;
  try {
    const YAML::Node info = YAML::LoadFile(file.string())["rosbag2_bagfile_information"];
    if (!info) fail(file, "no 'rosbag2_bagfile_information' section: not a rosbag2 metadata file");
    const YAML::Node compression = info["compression_format"];
    if (compression && !compression.as<std::string>().empty()) {
      fail(file, "the bag is compressed (compression_format '" + compression.as<std::string>() +
                     "'), which lookboth does not read; 'ros2 bag convert' writes it uncompressed");
    }
    for (const YAML::Node& relative : info["relative_file_paths"]) {
      metadata.files.push_back(storageFilePath(folder, relative.as<std::string>()));
    }
    if (info["message_count"]) metadata.message_count = info["message_count"].as<std::int64_t>();
    for (const YAML::Node& entry : info["topics_with_message_count"]) {
      metadata.topic_counts[entry["topic_metadata"]["name"].as<std::string>()] =
          entry["message_count"].as<std::int64_t>();
    }
  } catch (const YAML::Exception& e) {
    fail(file, "line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  if (metadata.files.empty()) fail(file, "'relative_file_paths' lists no storage file");
  return metadata;
}

class FolderBag final : public BagReader {
 public:
  FolderBag(const fs::path& folder, BagMetadata metadata);

  const std::vector<Topic>& topics() const override { return table_.topics(); }
  std::int64_t messageCount(const std::set<std::string>& topics) override;
  bool next(const std::set<std::string>& topics, Message* message) override;
  void rewind() override;
  std::vector<std::string> notes() const override {
    std::vector<std::string> all;
    for (const auto& file : files_) {
      const std::vector<std::string> notes = file->notes();
      all.insert(all.end(), notes.begin(), notes.end());
    }
    return all;
  }

 private:
  BagMetadata metadata_;
  std::vector<std::unique_ptr<BagReader>> files_;
  TopicTable table_;
  std::size_t current_ = 0;
};

FolderBag::FolderBag(const fs::path& folder, BagMetadata metadata)
    : metadata_(std::move(metadata)) {
  for (const fs::path& file : metadata_.files) {
    if (!fs::is_regular_file(file)) {
      fail(folder / "metadata.yaml",
           "lists '" + file.filename().string() + "', which is not in the bag folder");
    }
    files_.push_back(openStorageFile(file));
    for (const Topic& topic : files_.back()->topics()) {
      if (!table_.add(topic)) {
        fail(file, "topic '" + topic.name + "' has type '" + topic.type +
                       "' here and another type in an earlier file of the bag");
      }
    }
  }
}

std::int64_t FolderBag::messageCount(const std::set<std::string>& topics) {
  if (topics.empty() && metadata_.message_count) return *metadata_.message_count;
  if (!metadata_.topic_counts.empty()) {
    std::int64_t total = 0;
    for (const auto& [name, count] : metadata_.topic_counts)
      total += topics.empty() || topics.count(name) ? count : 0;
    return total;
  }
  std::int64_t total = 0;
  for (const auto& file : files_) {
    const std::int64_t count = file->messageCount(topics);
    if (count < 0) return -1;
    total += count;
  }
  return total;
}

bool FolderBag::next(const std::set<std::string>& topics, Message* message) {
  for (; current_ < files_.size(); ++current_) {
    if (files_[current_]->next(topics, message)) {
      message->topic = &table_.topics()[*table_.find(message->topic->name)];
      return true;
    }
  }
  return false;
}

void FolderBag::rewind() {
  for (const auto& file : files_) file->rewind();
  current_ = 0;
}

bool startsWith(const fs::path& path, const std::string& prefix) {
  std::ifstream in(path, std::ios::binary);
  std::string start(prefix.size(), '\0');
  in.read(start.data(), static_cast<std::streamsize>(start.size()));
  return in && start == prefix;
}

std::unique_ptr<BagReader> openStorageFile(const fs::path& path) {
  const std::string extension = path.extension().string();
  if (extension == ".mcap") return std::make_unique<McapFile>(path);
  if (extension == ".db3") return std::make_unique<Db3File>(path);
  if (startsWith(path, std::string(kMcapMagic.begin(), kMcapMagic.end()))) {
    return std::make_unique<McapFile>(path);
  }
  if (startsWith(path, std::string("SQLite format 3\0", 16))) {
    return std::make_unique<Db3File>(path);
  }
  fail(path, "not a ROS 2 bag: neither an MCAP file nor an sqlite3 (.db3) file");
}

std::unique_ptr<BagReader> openFolder(const fs::path& folder) {
  const fs::path metadata = folder / "metadata.yaml";
  if (fs::exists(metadata)) {
    return std::make_unique<FolderBag>(folder, readMetadata(folder, metadata));
  }
  std::vector<fs::path> storage;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    const std::string extension = entry.path().extension().string();
    if (entry.is_regular_file() && (extension == ".mcap" || extension == ".db3")) {
      storage.push_back(entry.path());
    }
  }
  if (storage.size() != 1) {
    fail(folder, "not a rosbag2 folder: no metadata.yaml, and " + std::to_string(storage.size()) +
                     " .mcap/.db3 files where one could be read alone");
  }
  return openStorageFile(storage.front());
}

}  // namespace

std::unique_ptr<BagReader> BagReader::open(const fs::path& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (!fs::exists(status)) fail(path, "no such file or folder");
  if (fs::is_directory(status)) return openFolder(path);
  if (path.filename() == "metadata.yaml") return openFolder(path.parent_path());
  return openStorageFile(path);
}

}  // namespace lookboth::ros2
