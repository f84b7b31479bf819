// Streams records out of an MRPT observations-only rawlog (also accepts
// sensory-frame rawlogs from other MRPT tools: their observations are read,
// their actions skipped).
//
// Corrupt input. MRPT's deserializers trust the lengths in the file: a
// string or array length turned into 0xFFFFFFFF makes MRPT allocate (and
// zero) 4 GB before it finds that the bytes are not there. While an entry
// is deserialized, one allocation larger than the rest of the file could
// hold (16 bytes of memory per byte left, plus 64 MiB) is refused, and the
// entry is reported as corrupt, as is an entry granted four times that in
// all (many small blocks). The refusal lives in this file's
// replacement of the global operator new (a per-thread limit, unlimited
// outside that read), of MRPT's aligned_malloc (MRPT's matrices) and in
// OpenCV's default matrix allocator (an image's pixels). Builds with
// AddressSanitizer keep the sanitizer's operator new, without the bound;
// the other two keep it. Errors name the file, the entry (1-based) and its
// byte offset in the uncompressed stream, its class, and the cause from
// MRPT's message (without its banner and call stack).
//
// Marker detections. The key of a marker observation is (camera, time,
// marker id): two markers seen in one frame are two records. The same key
// twice (a detector that reports one marker twice, a second marker printed
// with the same id) keeps the detection with the smaller uncertainty
// (the larger determinant of its information matrix; a detection without
// information has none to compare) and drops the other with an issue naming
// the camera, the time and the marker; when neither is smaller, the first
// is kept. The folder reader decides the same way. Records are handed out
// once an entry of another time has been read, so that a later detection
// can still replace an earlier one of the same time.
#include <mrpt/core/aligned_allocator.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CObservation6DFeatures.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationRobotPose.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <exception>
#include <fstream>
#include <limits>
#include <map>
#include <new>
#include <opencv2/core/mat.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include "internal.h"
#include "jpeg_errors.h"
#include "lookboth/core/error.h"
#include "lookboth/geometry/pose_conversions.h"
#include "lookboth/obs/CObservationMarkerCorners.h"

namespace lookboth::internal {

bool refuseAllocation(std::size_t size);  // below

namespace {

namespace fs = std::filesystem;

// The per-thread bound of the replacement operator new at the end of this
// file: unlimited except while an entry is deserialized.
thread_local std::size_t t_allocation_limit = std::numeric_limits<std::size_t>::max();
// The size of the last allocation refused under that bound; 0 for none.
thread_local std::size_t t_refused_allocation = 0;

// What the bounded allocations granted since the bound was set [bytes].
thread_local std::size_t t_allocated = 0;
/// An entry may be granted, in all, this many times what one allocation
/// may: a container grown element by element (a std::deque of a corrupt
/// length) asks for many small blocks, each within the bound. Frees are not
/// counted back; a container that doubles as it grows asks for twice its
/// final size in all.
constexpr std::size_t kAllocationTotalFactor = 4;

/// Bounds allocations on this thread for its lifetime.
class AllocationLimit {
 public:
  explicit AllocationLimit(std::size_t limit) : previous_(t_allocation_limit) {
    t_allocation_limit = limit;
    t_refused_allocation = 0;
    t_allocated = 0;
  }
  ~AllocationLimit() { t_allocation_limit = previous_; }
  AllocationLimit(const AllocationLimit&) = delete;
  AllocationLimit& operator=(const AllocationLimit&) = delete;

 private:
  std::size_t previous_;
};

/// OpenCV's matrices (the pixels of an image MRPT deserialises) allocate
/// through cv::Mat's default allocator, not operator new: this one refuses
/// what the bound excludes, as operator new does, and leaves everything else
/// to OpenCV's own allocator (which then also frees it).
class BoundedMatAllocator final : public cv::MatAllocator {
 public:
  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data, std::size_t* step,
                         cv::AccessFlag flags, cv::UMatUsageFlags usage) const override {
    if (!data) {
      constexpr std::size_t kMax = std::numeric_limits<std::size_t>::max();
      std::size_t bytes = CV_ELEM_SIZE(type);
      for (int i = 0; i < dims; ++i) {
        const auto n = static_cast<std::size_t>(std::max(sizes[i], 0));
        bytes = n != 0 && bytes > kMax / n ? kMax : bytes * n;
      }
      if (refuseAllocation(bytes)) throw std::bad_alloc();
    }
    return cv::Mat::getStdAllocator()->allocate(dims, sizes, type, data, step, flags, usage);
  }
  bool allocate(cv::UMatData* data, cv::AccessFlag flags, cv::UMatUsageFlags usage) const override {
    return cv::Mat::getStdAllocator()->allocate(data, flags, usage);
  }
  void deallocate(cv::UMatData* data) const override {
    cv::Mat::getStdAllocator()->deallocate(data);
  }
};

/// Makes BoundedMatAllocator OpenCV's default, once per process.
void boundOpenCvAllocations() {
  static BoundedMatAllocator allocator;
  static const bool installed = [] {
    cv::Mat::setDefaultAllocator(&allocator);
    return true;
  }();
  static_cast<void>(installed);
}

/// Memory an entry may take beyond 16 bytes per byte left in the file:
/// deserialized containers are larger than their serialized bytes (a
/// std::string per 4-byte empty string), never by more than that.
constexpr std::size_t kAllocationSlack = std::size_t{64} << 20;
constexpr std::size_t kAllocationPerByteLeft = 16;

std::string trim(const std::string& text) {
  const size_t begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  return text.substr(begin, text.find_last_not_of(" \t\r\n") + 1 - begin);
}

/// What an exception from MRPT says, without its decoration. MRPT's what()
/// is "==== MRPT exception ====", "Message: <cause>", "Location: ...", a
/// call stack, and, for an error while parsing an object, the inner
/// exception's text after "Original exception:", decorated the same way.
/// Keeps the message lines, innermost (the real cause) last, and drops the
/// "Exception while parsing typed object" wrappers (the caller names the
/// object itself).
std::string mrptCause(const std::string& what) {
  enum class State { kPlain, kMessage, kSkip };
  State state = State::kPlain;
  std::vector<std::string> parts;
  std::istringstream lines(what);
  std::string line;
  while (std::getline(lines, line)) {
    const std::string text = trim(line);
    if (text.size() >= 8 && text.rfind("====", 0) == 0 &&
        text.compare(text.size() - 4, 4, "====") == 0) {
      state = State::kSkip;
    } else if (text.rfind("Message:", 0) == 0) {
      state = State::kMessage;
      parts.push_back(trim(text.substr(8)));
    } else if (text.rfind("Location:", 0) == 0 || text == "Call stack backtrace:" ||
               text == "Original exception:") {
      state = State::kSkip;
    } else if (!text.empty() && state != State::kSkip) {
      if (parts.empty() || state == State::kPlain) {
        parts.push_back(text);
      } else {
        parts.back() += " " + text;
      }
    }
  }
  std::vector<std::string> causes;
  for (const std::string& part : parts) {
    if (part.empty() || part.rfind("Exception while parsing typed object", 0) == 0) continue;
    if (std::find(causes.begin(), causes.end(), part) == causes.end()) causes.push_back(part);
  }
  if (causes.empty()) {
    for (const std::string& part : parts)
      if (!part.empty()) causes.push_back(part);
  }
  std::string out;
  for (const std::string& cause : causes) out += (out.empty() ? "" : ": ") + cause;
  return out.empty() ? trim(what) : out;
}

/// log det of an information matrix: the larger, the smaller the
/// uncertainty; -infinity when it is not positive definite (none reported).
double certainty(const Eigen::Matrix<double, 6, 6>& information) {
  const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(information);
  if (llt.info() != Eigen::Success || !information.allFinite())
    return -std::numeric_limits<double>::infinity();
  return 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
}

/// Reads the rawlog for MRPT's deserializers and notes what happened to the
/// bytes: whether the file ended, and the first bytes of the entry (its
/// class name and version).
class EntryArchive final : public mrpt::serialization::CArchive {
 public:
  explicit EntryArchive(mrpt::io::CFileGZInputStream& stream) : stream_(stream) {}

  void startEntry() {
    hit_end_ = false;
    unreadable_ = false;
    head_.clear();
  }
  bool hitEnd() const { return hit_end_; }
  /// gzip data that zlib cannot decompress.
  bool unreadable() const { return unreadable_; }

  /// "<class> v<version>" from the entry's first bytes, or "" before them.
  std::string objectName() const {
    if (head_.empty() || !(head_[0] & 0x80)) return "";
    const size_t length = head_[0] & 0x7F;
    if (head_.size() < 1 + length) return "";
    std::string name(head_.begin() + 1, head_.begin() + 1 + static_cast<std::ptrdiff_t>(length));
    for (char& c : name)
      if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7E) c = '?';
    if (head_.size() > 1 + length) name += " v" + std::to_string(head_[1 + length]);
    return name;
  }

 protected:
  size_t write(const void*, size_t) override {
    throw std::logic_error("a rawlog is read-only here");
  }
  size_t read(void* buffer, size_t count) override {
    auto* out = static_cast<std::uint8_t*>(buffer);
    size_t got = 0;
    while (got < count) {
      const size_t n = stream_.Read(out + got, count - got);
      if (n == 0) break;
      if (n > count - got) {  // gzread's -1: corrupt compressed data
        unreadable_ = true;
        break;
      }
      got += n;
    }
    if (got < count) hit_end_ = !unreadable_;
    if (head_.size() < kHeadBytes) {
      head_.insert(head_.end(), out, out + std::min(got, kHeadBytes - head_.size()));
    }
    return got;
  }

 private:
  static constexpr size_t kHeadBytes = 130;  // length byte, <= 127 name bytes, version
  mrpt::io::CFileGZInputStream& stream_;
  std::vector<std::uint8_t> head_;
  bool hit_end_ = false;
  bool unreadable_ = false;
};

class RawlogReader : public DatasetReader {
 public:
  RawlogReader(const fs::path& rawlog, const DatasetReadOptions& options)
      : DatasetReader(rawlog, DatasetKind::kRawlog, options),
        images_dir_(imagesDirectoryFor(rawlog)),
        archive_(stream_) {
    registerLookbothObservations();
    // A corrupt embedded JPEG must throw, not exit (jpeg_errors.cpp); the
    // test dataset/rawlog_io checks that it does.
    useThrowingJpegErrors();
    boundOpenCvAllocations();
    const fs::path manifest_path = manifestPathFor(rawlog);
    if (!fs::exists(manifest_path)) {
      throw Error({rawlog.string(), 0, "", ""},
                  "its manifest '" + manifest_path.string() +
                      "' is missing (a lookboth dataset is <name>.rawlog + <name>.yaml)");
    }
    manifest_ = loadManifest(manifest_path);
    if (manifest_.name.empty()) manifest_.name = rawlog.stem().string();
    if (!stream_.open(rawlog.string())) {
      throw Error({rawlog.string(), 0, "", ""}, "cannot open for reading");
    }
    if (!isGzip(rawlog)) total_bytes_ = fs::file_size(rawlog);
  }

  std::int64_t expectedCount() const override { return manifest_.rawlog_entries; }

  std::optional<Record> next() override {
    // Records of the time of the last entry read may still be replaced (a
    // better detection of the same marker) or get their corners from the
    // next entries: read on until a record of another time comes.
    while (!at_end_ && group_begin_ == 0) readEntry();
    if (pending_.empty()) return std::nullopt;
    Record record = std::move(pending_.front());
    pending_.pop_front();
    if (group_begin_ > 0) --group_begin_;
    return record;
  }

 private:
  std::string where() const { return path_.string() + ": entry " + std::to_string(entry_); }

  /// "<file>: entry <n> (byte <offset>, <class>)" of the entry being read.
  std::string whereReading(std::uint64_t position) const {
    const std::string name = archive_.objectName();
    return path_.string() + ": entry " + std::to_string(entry_ + 1) + " (byte " +
           std::to_string(position) + (name.empty() ? "" : ", " + name) + ")";
  }

  static bool isGzip(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    char magic[2] = {0, 0};
    in.read(magic, 2);
    return in && static_cast<unsigned char>(magic[0]) == 0x1F &&
           static_cast<unsigned char>(magic[1]) == 0x8B;
  }

  /// Bytes of the uncompressed stream (what is readable of it): counted on
  /// first need only, since it means decompressing the whole file.
  std::uint64_t totalBytes() {
    if (!total_bytes_) {
      mrpt::io::CFileGZInputStream counter;
      std::uint64_t total = 0;
      if (counter.open(path_.string())) {
        std::vector<char> buffer(1 << 20);
        while (true) {
          const size_t n = counter.Read(buffer.data(), buffer.size());
          if (n == 0 || n > buffer.size()) break;
          total += n;
        }
      }
      total_bytes_ = total;
    }
    return *total_bytes_;
  }

  std::size_t allocationLimit(std::uint64_t position) {
    if (!total_bytes_) return kAllocationSlack;
    const std::uint64_t left = *total_bytes_ - std::min(*total_bytes_, position);
    const std::uint64_t limit = left * kAllocationPerByteLeft + kAllocationSlack;
    return limit > std::numeric_limits<std::size_t>::max() / 2
               ? std::numeric_limits<std::size_t>::max() / 2
               : static_cast<std::size_t>(limit);
  }

  /// Reopens the stream at `position` (the stream cannot seek).
  void reopenAt(std::uint64_t position) {
    stream_.close();
    if (!stream_.open(path_.string())) {
      throw Error({path_.string(), 0, "", ""}, "cannot reopen for reading");
    }
    std::vector<char> buffer(1 << 16);
    for (std::uint64_t left = position; left > 0;) {
      const size_t n = stream_.Read(
          buffer.data(), static_cast<size_t>(std::min<std::uint64_t>(left, buffer.size())));
      if (n == 0 || n > buffer.size())
        throw Error(whereReading(position) + ": cannot read up to it again");
      left -= n;
    }
  }

  /// One object of the rawlog, its allocations bounded by what the rest of
  /// the file can hold.
  mrpt::serialization::CSerializable::Ptr readObject(std::uint64_t position) {
    std::size_t limit = allocationLimit(position);
    while (true) {
      archive_.startEntry();
      takeJpegError();
      std::size_t refused = 0;
      try {
        const AllocationLimit bound(limit);
        return archive_.ReadObject();
      } catch (...) {
        refused = t_refused_allocation;
        if (refused == 0) throw;
      }
      if (!total_bytes_) {
        // The bound was the slack alone: with the file's real size it may
        // allow this allocation; then read the entry again.
        totalBytes();
        limit = allocationLimit(position);
        if (refused <= limit) {
          reopenAt(position);
          continue;
        }
      }
      const std::uint64_t left = *total_bytes_ - std::min(*total_bytes_, position);
      throw Error(whereReading(position) + ": corrupt: a length in it asks for " +
                  std::to_string(refused) + " bytes of memory, more than the " +
                  std::to_string(left) + " bytes left in the file can hold");
    }
  }

  void readEntry() {
    const std::uint64_t position = stream_.getPosition();
    mrpt::serialization::CSerializable::Ptr object;
    try {
      object = readObject(position);
    } catch (const Error&) {
      at_end_ = true;
      throw;
    } catch (const mrpt::serialization::CExceptionEOF&) {
      at_end_ = true;
      if (archive_.unreadable()) {
        throw Error(whereReading(position) +
                    ": the compressed data cannot be decompressed (corrupt file)");
      }
      if (stream_.getPosition() != position) {
        throw Error(whereReading(position) + ": the file is truncated inside this entry (" +
                    std::to_string(entry_) + " complete entries were read)");
      }
      if (manifest_.rawlog_entries >= 0 && entry_ < manifest_.rawlog_entries) {
        throw Error(path_.string() + ": truncated: " + std::to_string(entry_) + " of the " +
                    std::to_string(manifest_.rawlog_entries) +
                    " entries listed in the manifest were found");
      }
      return;
    } catch (const std::exception& e) {
      at_end_ = true;
      const std::string jpeg_error = takeJpegError();
      const std::string cause = jpeg_error.empty() ? mrptCause(e.what()) : jpeg_error;
      if (archive_.unreadable()) {
        throw Error(whereReading(position) +
                    ": the compressed data cannot be decompressed (corrupt file)");
      }
      if (archive_.hitEnd()) {
        throw Error(whereReading(position) + ": the file is truncated inside this entry (" +
                    std::to_string(entry_) + " complete entries were read): " + cause);
      }
      if (cause.find("not registered") != std::string::npos) {
        throw Error(whereReading(position) +
                    ": holds an object of a class that is not registered (an MRPT plugin "
                    "or a newer lookboth may be needed): " +
                    cause);
      }
      throw Error(whereReading(position) + ": corrupt: " + cause);
    }
    ++entry_;
    if (!object) {
      // MRPT's stream marker of an empty pointer: nothing to read in it.
      skippedOnce("empty (null) objects");
    } else if (auto frame = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(object)) {
      for (const auto& obs : *frame) convert(obs);
    } else if (auto obs = std::dynamic_pointer_cast<mrpt::obs::CObservation>(object)) {
      convert(obs);
    } else if (std::dynamic_pointer_cast<mrpt::obs::CActionCollection>(object)) {
      skippedOnce("actions (odometry increments of a sensory-frame rawlog)");
    } else {
      skippedOnce(std::string("objects of class ") + object->GetRuntimeClass()->className);
    }
  }

  void skippedOnce(const std::string& what) {
    if (skipped_.insert(what).second)
      reportIssue(where(), what + " are not used by lookboth; skipped");
  }

  // Drops duplicates and reports out-of-order stamps per (kind, label) stream.
  bool acceptTime(const Record& record) {
    const std::string key = std::string(recordKindName(record)) + "/" + recordLabel(record);
    const TimeNs t = recordTime(record);
    const auto it = last_time_.find(key);
    if (it != last_time_.end()) {
      if (t == it->second) {
        reportIssue(where(), std::string(recordKindName(record)) + " of '" + recordLabel(record) +
                                 "' repeats timestamp " + formatSeconds(t) + " s; dropped");
        return false;
      }
      if (t < it->second) {
        reportIssue(where(), std::string(recordKindName(record)) + " of '" + recordLabel(record) +
                                 "' at " + formatSeconds(t) +
                                 " s is earlier than the previous one (" +
                                 formatSeconds(it->second) + " s)");
      }
    }
    last_time_[key] = t;
    return true;
  }

  void append(Record record) {
    const TimeNs t = recordTime(record);
    if (!group_time_ || *group_time_ != t) {
      group_begin_ = pending_.size();
      group_time_ = t;
    }
    pending_.push_back(std::move(record));
  }

  bool push(Record record) {
    if (!acceptTime(record)) return false;
    append(std::move(record));
    return true;
  }

  /// The pending marker observation with this key, if it was not handed out yet.
  MarkerObservation* pendingMarker(const std::string& camera, TimeNs t, int id) {
    for (auto it = pending_.rbegin(); it != pending_.rend(); ++it) {
      auto* marker = std::get_if<MarkerObservation>(&*it);
      if (marker && marker->camera == camera && marker->t == t && marker->marker_id == id)
        return marker;
    }
    return nullptr;
  }

  /// A marker observation: key (camera, time, marker id); see the file's
  /// header for a key seen twice. False when it is dropped.
  bool pushMarker(MarkerObservation marker) {
    const std::string key = "marker/" + marker.camera;
    const auto it = last_time_.find(key);
    std::set<int>& ids = marker_ids_[marker.camera];
    if (it != last_time_.end() && it->second == marker.t) {
      if (ids.insert(marker.marker_id).second) {
        append(std::move(marker));
        return true;
      }
      const std::string what = "marker " + std::to_string(marker.marker_id) + " of '" +
                               marker.camera + "' repeats timestamp " + formatSeconds(marker.t) +
                               " s";
      MarkerObservation* earlier = pendingMarker(marker.camera, marker.t, marker.marker_id);
      if (!earlier) {
        reportIssue(where(), what + " after the first detection was passed on; this one dropped");
        return false;
      }
      if (certainty(marker.information) > certainty(earlier->information)) {
        reportIssue(where(), what +
                                 ": kept this detection (smaller uncertainty), dropped the "
                                 "earlier one");
        *earlier = std::move(marker);
        return true;
      }
      reportIssue(where(), what + ": kept the earlier detection (" +
                               (certainty(earlier->information) > certainty(marker.information)
                                    ? std::string("smaller uncertainty")
                                    : std::string("no smaller uncertainty reported")) +
                               "), dropped this one");
      return false;
    }
    if (it != last_time_.end() && marker.t < it->second) {
      reportIssue(where(), "marker of '" + marker.camera + "' at " + formatSeconds(marker.t) +
                               " s is earlier than the previous one (" + formatSeconds(it->second) +
                               " s)");
    }
    last_time_[key] = marker.t;
    ids = {marker.marker_id};
    append(std::move(marker));
    return true;
  }

  TimeNs timeOf(const mrpt::obs::CObservation& obs) {
    try {
      return fromMrptTime(obs.timestamp);
    } catch (const Error& e) {
      throw Error(where() + " ('" + obs.sensorLabel + "'): " + e.what());
    }
  }

  /// Gives the corners to the marker pose of the entry just before (same
  /// label, stamp and id; doc/formats.md).
  void attachCorners(const CObservationMarkerCorners& corners) {
    const TimeNs t = timeOf(corners);
    for (const auto& [label, time, id, kept] : last_features_) {
      if (label != corners.sensorLabel || time != t || id != corners.marker_id) continue;
      if (!kept) return;  // its pose was dropped (reported): so are its corners
      for (auto it = pending_.rbegin(); it != pending_.rend(); ++it) {
        auto* marker = std::get_if<MarkerObservation>(&*it);
        if (!marker || marker->camera != label || marker->t != t || marker->marker_id != id ||
            !marker->corners_px.empty()) {
          continue;
        }
        for (const CornerPixel& c : corners.corners) marker->corners_px.emplace_back(c.u, c.v);
        marker->corner_sigma_px = corners.corner_sigma_px;
        return;
      }
    }
    reportIssue(where(), "marker corners of '" + corners.sensorLabel + "' (marker " +
                             std::to_string(corners.marker_id) + ") at " + formatSeconds(t) +
                             " s do not follow their marker pose (a CObservation6DFeatures of "
                             "the same label, stamp and id); skipped");
  }

  void convert(const mrpt::obs::CObservation::Ptr& obs) {
    if (auto corners = std::dynamic_pointer_cast<CObservationMarkerCorners>(obs)) {
      attachCorners(*corners);
      return;
    }
    last_features_.clear();
    if (auto image = std::dynamic_pointer_cast<mrpt::obs::CObservationImage>(obs)) {
      ImageFrame frame;
      frame.t = timeOf(*image);
      frame.sensor = image->sensorLabel;
      // Stored as a file when it names one: isExternallyStored() would read
      // a flag that a corrupt rawlog sets to a byte no bool can hold
      // (undefined behaviour, found by fuzzing).
      if (const std::string external = image->image.getExternalStorageFile(); !external.empty()) {
        frame.image_file = images_dir_ / external;
        if (options_.check_images && !fs::exists(frame.image_file)) {
          reportIssue(where(), "image '" + frame.image_file.string() + "' of '" + frame.sensor +
                                   "' is missing; frame skipped");
          return;
        }
      } else {
        // Embedded in the rawlog (other tools do this): re-encode losslessly.
        std::vector<uchar> bytes;
        cv::imencode(".png", image->image.asCvMatRef(), bytes);
        frame.encoded =
            std::make_shared<const std::vector<std::uint8_t>>(bytes.begin(), bytes.end());
        frame.extension = ".png";
      }
      push(std::move(frame));
    } else if (auto features = std::dynamic_pointer_cast<mrpt::obs::CObservation6DFeatures>(obs)) {
      for (const auto& m : features->sensedFeatures) {
        MarkerObservation marker;
        marker.t = timeOf(*features);
        marker.camera = features->sensorLabel;
        marker.marker_id = m.id;
        marker.camera_from_marker = fromMrptPose(m.pose);
        for (int i = 0; i < 6; ++i) {
          for (int j = 0; j < 6; ++j) marker.information(i, j) = m.inf_matrix(i, j);
        }
        last_features_.emplace_back(marker.camera, marker.t, marker.marker_id, false);
        std::get<3>(last_features_.back()) = pushMarker(std::move(marker));
      }
    } else if (auto blobs = std::dynamic_pointer_cast<CObservationBlobs>(obs)) {
      BlobObservation record;
      record.t = timeOf(*blobs);
      record.camera = blobs->sensorLabel;
      record.image_width = blobs->image_width;
      record.image_height = blobs->image_height;
      record.blobs = blobs->blobs;
      push(std::move(record));
    } else if (auto pose = std::dynamic_pointer_cast<mrpt::obs::CObservationRobotPose>(obs)) {
      PoseSample sample;
      sample.t = timeOf(*pose);
      sample.label = pose->sensorLabel;
      sample.world_from_body = fromMrptPose(pose->pose.mean);
      push(std::move(sample));
    } else {
      skippedOnce(std::string("observations of class ") + obs->GetRuntimeClass()->className);
    }
  }

  fs::path images_dir_;
  mrpt::io::CFileGZInputStream stream_;
  EntryArchive archive_;
  /// Bytes of the uncompressed stream, once known.
  std::optional<std::uint64_t> total_bytes_;
  std::deque<Record> pending_;
  /// pending_[group_begin_..] are the records of the time of the last
  /// record appended (group_time_): held back until a record of another time.
  size_t group_begin_ = 0;
  std::optional<TimeNs> group_time_;
  std::map<std::string, TimeNs> last_time_;
  /// Camera -> the marker ids of its detections at its last marker time.
  std::map<std::string, std::set<int>> marker_ids_;
  std::set<std::string> skipped_;
  std::int64_t entry_ = 0;
  bool at_end_ = false;
  /// (label, stamp, id, kept) of the marker poses of the last 6DFeatures.
  std::vector<std::tuple<std::string, TimeNs, int, bool>> last_features_;
};

}  // namespace

/// Whether the reader's bound refuses `size` bytes now (then recording what
/// was asked for); counts what it grants. External: the rawlog fuzz target's
/// operator new (AddressSanitizer builds, where this file's is compiled
/// out) applies the same bound through it.
bool refuseAllocation(std::size_t size) {
  constexpr std::size_t kUnlimited = std::numeric_limits<std::size_t>::max();
  if (t_allocation_limit == kUnlimited) return false;
  const std::size_t total = t_allocation_limit > kUnlimited / kAllocationTotalFactor
                                ? kUnlimited
                                : t_allocation_limit * kAllocationTotalFactor;
  if (size > t_allocation_limit) {
    t_refused_allocation = size;
    return true;
  }
  if (size > total - std::min(total, t_allocated)) {
    t_refused_allocation = t_allocated + size;
    return true;
  }
  t_allocated += size;
  return false;
}

std::unique_ptr<DatasetReader> openRawlogReader(const fs::path& rawlog,
                                                const DatasetReadOptions& options) {
  return std::make_unique<RawlogReader>(rawlog, options);
}

}  // namespace lookboth::internal

// The bounded allocation of the reader (see the header comment): the global
// operator new, refusing on this thread what t_allocation_limit excludes.
// The other forms of new (array, nothrow) call this one or the aligned one
// below; delete stays the library's (free). AddressSanitizer brings its own operator new, which a
// second definition would clash with: sanitizer builds go without the bound.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define LOOKBOTH_SANITIZER_NEW 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define LOOKBOTH_SANITIZER_NEW 1
#endif
#endif

#ifndef LOOKBOTH_SANITIZER_NEW
void* operator new(std::size_t size) {
  if (lookboth::internal::refuseAllocation(size)) throw std::bad_alloc();
  while (true) {
    if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
    const std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
}

// The over-aligned form (Eigen members: MRPT's 6D-feature measurements), as
// libstdc++'s own does it: aligned_alloc of a multiple of the alignment,
// freed by its aligned delete (free).
void* operator new(std::size_t size, std::align_val_t alignment) {
  if (lookboth::internal::refuseAllocation(size)) throw std::bad_alloc();
  const auto align = static_cast<std::size_t>(alignment);
  const std::size_t rounded = (std::max<std::size_t>(size, 1) + align - 1) / align * align;
  while (true) {
    if (void* p = std::aligned_alloc(align, rounded)) return p;
    const std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
}
#endif

// MRPT's aligned containers (a CMatrixD's storage) allocate through
// mrpt::aligned_malloc, not operator new. This definition, which the
// dynamic linker binds in place of libmrpt-core's, applies the same bound;
// otherwise it does what MRPT's does: aligned_alloc of the size rounded up
// to a multiple of the alignment, freed by MRPT's aligned_free (free).
void* mrpt::aligned_malloc(std::size_t size, std::size_t alignment) {
  if (lookboth::internal::refuseAllocation(size)) throw std::bad_alloc();
  if (alignment != 0 && size % alignment != 0) size = (size / alignment + 1) * alignment;
  return std::aligned_alloc(alignment, size);
}

void* mrpt::aligned_calloc(std::size_t bytes, std::size_t alignment) {
  void* p = mrpt::aligned_malloc(bytes, alignment);
  if (p) std::memset(p, 0, bytes);
  return p;
}
