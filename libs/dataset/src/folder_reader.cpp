// Reader of the plain-folder dataset format (doc/formats.md, "Dataset folder
// format"). Every CSV or TUM file is one stream read row by row; the streams
// are merged by timestamp (ties: the stream order fixed in the constructor), so
// memory does not grow with the length of the recording.
#include <yaml-cpp/yaml.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <utility>

#include "csv.h"
#include "internal.h"
#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/dataset/image_header.h"
#include "lookboth/geometry/tum.h"
#include "video_frames.h"

namespace lookboth::internal {
namespace {

namespace fs = std::filesystem;

/// Receives an issue (where, message); the reader records it or throws in strict mode.
using IssueSink = std::function<void(const std::string&, const std::string&)>;

constexpr const char* kFisheyeLabel = "fisheye";
constexpr const char* kOdometryLabel = "odometry";
constexpr const char* kGroundTruthLabel = "ground_truth";

// ---------------------------------------------------------------------------
// Small YAML files (marker.yaml, odometry.yaml, fisheye_from_marker.yaml...):
// strict keys, errors with the file, the line and the key.

YAML::Node loadYamlMapping(const fs::path& path, const std::vector<std::string>& allowed) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path.string());
  } catch (const YAML::BadFile&) {
    throw Error({path.string(), 0, "", ""}, "cannot open for reading");
  } catch (const YAML::Exception& e) {
    throw Error({path.string(), e.mark.line + 1, "", ""}, "YAML syntax error: " + e.msg);
  }
  std::string keys;
  for (const std::string& key : allowed) keys += (keys.empty() ? "" : ", ") + key;
  if (!root.IsMap()) {
    throw Error({path.string(), 0, "", ""}, "expected a YAML mapping with the keys " + keys);
  }
  for (const auto& entry : root) {
    const std::string key = entry.first.Scalar();
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      throw Error({path.string(), entry.first.Mark().line + 1, key, ""},
                  "unknown key (expected " + keys + ")");
    }
  }
  return root;
}

/// The scalar text of `key`, or nullopt when absent (an error when required).
std::optional<std::string> yamlScalar(const YAML::Node& map, const std::string& key,
                                      const fs::path& path, bool required) {
  const YAML::Node node = map[key];
  if (!node) {
    if (required) throw Error({path.string(), 0, key, ""}, "missing");
    return std::nullopt;
  }
  if (!node.IsScalar()) {
    throw Error({path.string(), node.Mark().line + 1, key, ""}, "expected a single value");
  }
  return node.Scalar();
}

int yamlLine(const YAML::Node& map, const std::string& key) { return map[key].Mark().line + 1; }

double yamlNumber(const YAML::Node& map, const std::string& key, const fs::path& path) {
  const std::string text = *yamlScalar(map, key, path, true);
  const std::optional<double> value = parseDouble(text);
  if (!value || !std::isfinite(*value)) {
    throw Error({path.string(), yamlLine(map, key), key, ""},
                "expected a finite number, got '" + text + "'");
  }
  return *value;
}

/// A quaternion (qx qy qz qw) checked the way TUM rows are: a norm off by
/// more than 1e-3 is an error, a smaller deviation is normalised away.
Eigen::Quaterniond checkedQuaternion(double qx, double qy, double qz, double qw,
                                     const ErrorContext& where) {
  Eigen::Quaterniond q(qw, qx, qy, qz);
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > 1e-3) {
    throw Error(where, "quaternion (qx qy qz qw) has norm " + formatFixed(norm, 6) +
                           ", expected a unit quaternion");
  }
  // Leave an exactly (to rounding) unit quaternion untouched, so that
  // write-then-read gives back the same bits.
  if (std::abs(norm - 1.0) > 4 * std::numeric_limits<double>::epsilon()) q.normalize();
  return q;
}

/// Pose from the columns tx ty tz qx qy qz qw of the current row.
Rigid3d csvPose(const CsvReader& csv) {
  const Eigen::Vector3d t(csv.number("tx"), csv.number("ty"), csv.number("tz"));
  const Eigen::Quaterniond q =
      checkedQuaternion(csv.number("qx"), csv.number("qy"), csv.number("qz"), csv.number("qw"),
                        csv.where("qx,qy,qz,qw"));
  return Rigid3d(q, t);
}

const std::vector<std::string> kPoseColumns = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};

std::vector<std::string> withPoseColumns(std::vector<std::string> columns) {
  columns.insert(columns.end(), kPoseColumns.begin(), kPoseColumns.end());
  return columns;
}

std::string location(const fs::path& path, int line) {
  return path.string() + ":" + std::to_string(line);
}

std::string timeOrderMessage(TimeNs t, TimeNs previous, const std::string& what) {
  if (t == previous) {
    return "timestamp " + std::to_string(t) + " repeats the previous one: " + what + " skipped";
  }
  return "timestamp " + std::to_string(t) + " is earlier than the previous one (" +
         std::to_string(previous) + "): " + what + " skipped";
}

// ---------------------------------------------------------------------------
// Streams: each yields its records in time order, skipping (as issues) rows
// that are out of order or duplicated.

class Stream {
 public:
  virtual ~Stream() = default;
  /// The next record, or nullopt at the end of the file.
  virtual std::optional<Record> next() = 0;
};

/// fisheye/frames.csv or cameras/<label>/frames.csv.
class FrameStream final : public Stream {
 public:
  FrameStream(const fs::path& csv_path, std::string label, std::optional<Camera> camera,
              fs::path calibration_file, bool check_images, IssueSink issue)
      : csv_(csv_path, {"timestamp_ns", "file"}),
        directory_(fs::absolute(csv_path.parent_path())),
        label_(std::move(label)),
        camera_(std::move(camera)),
        calibration_file_(std::move(calibration_file)),
        check_images_(check_images),
        issue_(std::move(issue)) {}

  std::optional<Record> next() override {
    while (csv_.next()) {
      const TimeNs t = csv_.integer("timestamp_ns");
      const std::string& file = csv_.text("file");
      if (file.empty()) throw Error(csv_.where("file"), "empty image file name");
      const std::string where = location(csv_.path(), csv_.line());
      if (last_ && t <= *last_) {
        issue_(where, timeOrderMessage(t, *last_, "frame"));
        continue;
      }
      last_ = t;
      ImageFrame frame;
      frame.t = t;
      frame.sensor = label_;
      frame.image_file = (directory_ / file).lexically_normal();
      if (check_images_ && !checkImage(frame.image_file, where)) continue;
      return frame;
    }
    return std::nullopt;
  }

 private:
  /// False when the frame must be skipped.
  bool checkImage(const fs::path& image, const std::string& where) {
    std::error_code ec;
    if (!fs::is_regular_file(image, ec)) {
      issue_(where, "image file '" + image.string() + "' does not exist: frame skipped");
      return false;
    }
    if (size_checked_ || !camera_) return true;
    // The first readable frame of each camera is compared with the
    // calibration's size: from its header when the format tells (a huge
    // image is not decoded into gigabytes), else decoded.
    std::optional<ImageSize> size = imageFileSize(image);
    if (!size) {
      const cv::Mat decoded = cv::imread(image.string(), cv::IMREAD_UNCHANGED);
      if (decoded.empty()) {
        issue_(where, "cannot decode image file '" + image.string() + "': frame skipped");
        return false;
      }
      size = ImageSize{decoded.cols, decoded.rows};
    }
    size_checked_ = true;
    if (size->width != camera_->width() || size->height != camera_->height()) {
      issue_(where, "image '" + image.string() + "' is " + std::to_string(size->width) + "x" +
                        std::to_string(size->height) + " px but the calibration of camera '" +
                        label_ + "' (" + calibration_file_.string() + ") is " +
                        std::to_string(camera_->width()) + "x" + std::to_string(camera_->height()) +
                        " px");
    }
    return true;
  }

  CsvReader csv_;
  fs::path directory_;
  std::string label_;
  std::optional<Camera> camera_;
  fs::path calibration_file_;
  bool check_images_;
  IssueSink issue_;
  std::optional<TimeNs> last_;
  bool size_checked_ = false;
};

/// cameras/<label>/video.<ext>, timed by video.csv or by the container from
/// video.yaml's start.
class VideoStream final : public Stream {
 public:
  VideoStream(const fs::path& video, const std::string& label, std::optional<Camera> camera,
              fs::path calibration_file, VideoTiming timing, IssueSink issue, IssueSink note)
      : source_(video, label, std::move(timing), issue, std::move(note)),
        label_(label),
        camera_(std::move(camera)),
        calibration_file_(std::move(calibration_file)),
        issue_(std::move(issue)) {}

  std::optional<Record> next() override {
    std::optional<ImageFrame> frame = source_.next();
    if (frame && !size_checked_) checkSize();
    if (!frame) return std::nullopt;
    return std::move(*frame);
  }

 private:
  void checkSize() {
    size_checked_ = true;
    const ImageSize size = source_.size();
    if (!camera_ || (size.width == camera_->width() && size.height == camera_->height())) return;
    issue_(source_.video().string(),
           "the video is " + std::to_string(size.width) + "x" + std::to_string(size.height) +
               " px but the calibration of camera '" + label_ + "' (" + calibration_file_.string() +
               ") is " + std::to_string(camera_->width()) + "x" +
               std::to_string(camera_->height()) + " px");
  }

  VideoFrameSource source_;
  std::string label_;
  std::optional<Camera> camera_;
  fs::path calibration_file_;
  IssueSink issue_;
  bool size_checked_ = false;
};

/// The camera folder's video file (video.<ext>, a video container's or raw
/// stream's extension), if any; an error naming the folder when there are several.
std::optional<fs::path> videoFile(const fs::path& folder) {
  static const std::set<std::string> kExtensions = {
      ".mp4", ".m4v",  ".mov", ".mkv",  ".webm", ".avi",  ".ts",    ".mts", ".m2ts",
      ".flv", ".h264", ".264", ".h265", ".265",  ".hevc", ".mjpeg", ".mjpg"};
  std::vector<fs::path> found;
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
    const fs::path& path = entry.path();
    if (path.stem() != "video" || !entry.is_regular_file()) continue;
    std::string extension = path.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (kExtensions.count(extension)) found.push_back(path);
  }
  if (found.empty()) return std::nullopt;
  if (found.size() > 1) {
    std::sort(found.begin(), found.end());
    throw Error({folder.string(), 0, "", ""},
                "several video files (" + found[0].filename().string() + ", " +
                    found[1].filename().string() + "): a camera folder holds one");
  }
  return found.front();
}

/// How the frames of `video` are timed: video.csv beside it, else the start in video.yaml.
VideoTiming videoTiming(const fs::path& folder) {
  VideoTiming timing;
  timing.how_to_time =
      "add video.csv beside it (timestamp_ns of each frame) or video.yaml (start_timestamp_ns: "
      "the first frame's time in ns; the container's timestamps give the others)";
  if (fs::exists(folder / "video.csv")) {
    timing.sidecar = folder / "video.csv";
    return timing;
  }
  const fs::path yaml = folder / "video.yaml";
  if (!fs::exists(yaml)) return timing;
  const YAML::Node map = loadYamlMapping(yaml, {"start_timestamp_ns"});
  const std::string text = *yamlScalar(map, "start_timestamp_ns", yaml, true);
  const std::optional<long long> start = parseInt(text);
  if (!start) {
    throw Error({yaml.string(), yamlLine(map, "start_timestamp_ns"), "start_timestamp_ns", ""},
                "expected an integer (ns), got '" + text + "'");
  }
  timing.start = *start;
  return timing;
}

/// log det of an information matrix: the larger, the smaller the
/// uncertainty; -infinity when it is not positive definite (none reported).
double certainty(const Eigen::Matrix<double, 6, 6>& information) {
  const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(information);
  if (llt.info() != Eigen::Success || !information.allFinite())
    return -std::numeric_limits<double>::infinity();
  return 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
}

/// detections/markers.csv: one MarkerObservation per row, keyed by
/// (timestamp, camera, marker_id): several cameras, and several markers in
/// one frame, share a timestamp. The same key twice keeps the row with the
/// smaller uncertainty (the larger determinant of its information; a row
/// without information has none to compare), the first one when neither is
/// smaller, and reports the other as an issue; the rawlog reader decides
/// the same way. The rows of one timestamp are read together for that.
class MarkerStream final : public Stream {
 public:
  MarkerStream(const fs::path& path, std::set<std::string> env_cameras, IssueSink issue)
      : csv_(path, withPoseColumns({"timestamp_ns", "camera", "marker_id"})),
        env_cameras_(std::move(env_cameras)),
        issue_(std::move(issue)) {}

  std::optional<Record> next() override {
    if (group_.empty()) readGroup();
    if (group_.empty()) return std::nullopt;
    MarkerObservation obs = std::move(group_.front());
    group_.erase(group_.begin());
    return obs;
  }

 private:
  /// The rows of the next timestamp. An error in a row after the first one
  /// waits for the next call, so that the rows before it are returned.
  void readGroup() {
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
    while (true) {
      std::optional<MarkerObservation> obs = std::move(lookahead_);
      lookahead_.reset();
      if (!obs) {
        try {
          obs = readRow();
        } catch (const Error&) {
          if (group_.empty()) throw;
          error_ = std::current_exception();
          return;
        }
        if (!obs) return;
      }
      if (!group_.empty() && obs->t != group_.front().t) {
        lookahead_ = std::move(obs);
        return;
      }
      add(std::move(*obs));
    }
  }

  void add(MarkerObservation obs) {
    const std::string where = location(csv_.path(), obs_line_);
    for (MarkerObservation& kept : group_) {
      if (kept.camera != obs.camera || kept.marker_id != obs.marker_id) continue;
      const std::string what = "timestamp " + std::to_string(obs.t) + " repeats a row of camera '" +
                               obs.camera + "' and marker " + std::to_string(obs.marker_id);
      if (certainty(obs.information) > certainty(kept.information)) {
        issue_(where, what + ": this row kept (smaller uncertainty), the earlier one skipped");
        kept = std::move(obs);
      } else {
        issue_(where, what + ": marker observation skipped (the earlier row " +
                          (certainty(kept.information) > certainty(obs.information)
                               ? std::string("has a smaller uncertainty")
                               : std::string("is kept: no smaller uncertainty reported")) +
                          ")");
      }
      return;
    }
    group_.push_back(std::move(obs));
  }

  /// The next row in time order (earlier rows are skipped as issues).
  std::optional<MarkerObservation> readRow() {
    while (csv_.next()) {
      MarkerObservation obs;
      obs.t = csv_.integer("timestamp_ns");
      obs.camera = csv_.text("camera");
      if (env_cameras_.count(obs.camera) == 0) {
        std::string known;
        for (const std::string& label : env_cameras_) known += (known.empty() ? "" : ", ") + label;
        throw Error(
            csv_.where("camera"),
            obs.camera == kFisheyeLabel
                ? "the fisheye cannot see the robot's marker: expected an environment camera"
                : "unknown camera '" + obs.camera +
                      "' (environment cameras: " + (known.empty() ? "none" : known) + ")");
      }
      const long long id = csv_.integer("marker_id");
      if (id < 0 || id > std::numeric_limits<int>::max()) {
        throw Error(csv_.where("marker_id"), "marker id " + std::to_string(id) + " out of range");
      }
      obs.marker_id = static_cast<int>(id);
      obs.camera_from_marker = csvPose(csv_);
      if (csv_.hasColumn("information") && !csv_.text("information").empty()) {
        obs.information = readInformation();
      }
      if (csv_.hasColumn("corners") && !csv_.text("corners").empty()) {
        obs.corners_px = readCorners();
      }
      if (csv_.hasColumn("corner_sigma_px") && !csv_.text("corner_sigma_px").empty()) {
        obs.corner_sigma_px = csv_.number("corner_sigma_px");
        if (obs.corner_sigma_px < 0) {
          throw Error(csv_.where("corner_sigma_px"),
                      "negative corner noise " + formatDouble(obs.corner_sigma_px));
        }
      }
      if (last_ && obs.t < *last_) {
        issue_(location(csv_.path(), csv_.line()),
               timeOrderMessage(obs.t, *last_, "marker observation"));
        continue;
      }
      last_ = obs.t;
      obs_line_ = csv_.line();
      return obs;
    }
    return std::nullopt;
  }

  /// 21 numbers: the upper triangle of the 6x6 information, row by row.
  Eigen::Matrix<double, 6, 6> readInformation() const {
    const std::vector<std::string> tokens = splitWhitespace(csv_.text("information"));
    if (tokens.size() != 21) {
      throw Error(csv_.where("information"),
                  "expected 21 space-separated numbers (upper triangle of the 6x6 information, "
                  "row by row), got " +
                      std::to_string(tokens.size()));
    }
    Eigen::Matrix<double, 6, 6> information;
    size_t k = 0;
    for (int row = 0; row < 6; ++row) {
      for (int col = row; col < 6; ++col, ++k) {
        const std::optional<double> value = parseDouble(tokens[k]);
        if (!value || !std::isfinite(*value)) {
          throw Error(csv_.where("information"), "value " + std::to_string(k + 1) + " '" +
                                                     tokens[k] + "' is not a finite number");
        }
        information(row, col) = *value;
        information(col, row) = *value;
      }
    }
    return information;
  }

  /// 8 numbers: u0 v0 u1 v1 u2 v2 u3 v3 [px], in the marker's corner order.
  std::vector<Eigen::Vector2d> readCorners() const {
    const std::vector<std::string> tokens = splitWhitespace(csv_.text("corners"));
    if (tokens.size() != 8) {
      throw Error(csv_.where("corners"),
                  "expected 8 space-separated numbers (u0 v0 u1 v1 u2 v2 u3 v3 of the marker's "
                  "4 corners, in pixels), got " +
                      std::to_string(tokens.size()));
    }
    std::vector<Eigen::Vector2d> corners(4);
    for (size_t k = 0; k < 8; ++k) {
      const std::optional<double> value = parseDouble(tokens[k]);
      if (!value || !std::isfinite(*value)) {
        throw Error(csv_.where("corners"), "value " + std::to_string(k + 1) + " '" + tokens[k] +
                                               "' is not a finite number");
      }
      corners[k / 2][static_cast<Eigen::Index>(k % 2)] = *value;
    }
    return corners;
  }

  CsvReader csv_;
  std::set<std::string> env_cameras_;
  IssueSink issue_;
  std::optional<TimeNs> last_;
  int obs_line_ = 0;                            ///< Line of the row readRow() returned.
  std::vector<MarkerObservation> group_;        ///< Rows of one timestamp, in file order.
  std::optional<MarkerObservation> lookahead_;  ///< First row of the next timestamp.
  std::exception_ptr error_;                    ///< Error of a row after group_'s.
};

/// detections/blobs.csv: consecutive rows with the same timestamp are the
/// blobs of one fisheye frame. A row whose u, v and diameter_px are all empty
/// stands for a frame in which no blob was found.
class BlobStream final : public Stream {
 public:
  BlobStream(const fs::path& path, std::string fisheye_label, IssueSink issue)
      : csv_(path, {"timestamp_ns", "u", "v", "diameter_px"}),
        fisheye_label_(std::move(fisheye_label)),
        issue_(std::move(issue)) {}

  std::optional<Record> next() override {
    while (true) {
      if (!has_row_) {
        if (!csv_.next()) return std::nullopt;
        has_row_ = true;
      }
      const TimeNs t = csv_.integer("timestamp_ns");
      if (last_ && t <= *last_) {
        issue_(location(csv_.path(), csv_.line()), timeOrderMessage(t, *last_, "blob row"));
        has_row_ = false;
        continue;
      }
      BlobObservation obs;
      obs.t = t;
      obs.camera = fisheye_label_;
      obs.image_width = sizeColumn("image_width");
      obs.image_height = sizeColumn("image_height");
      // Take every following row with the same timestamp.
      while (true) {
        addBlob(obs);
        has_row_ = false;
        if (!csv_.next()) break;
        has_row_ = true;
        if (csv_.integer("timestamp_ns") != t) break;
      }
      last_ = t;
      return obs;
    }
  }

 private:
  int sizeColumn(const std::string& column) const {
    if (!csv_.hasColumn(column) || csv_.text(column).empty()) return 0;
    const long long value = csv_.integer(column);
    if (value < 0 || value > std::numeric_limits<int>::max()) {
      throw Error(csv_.where(column), "image size " + std::to_string(value) + " out of range");
    }
    return static_cast<int>(value);
  }

  void addBlob(BlobObservation& obs) const {
    if (csv_.text("u").empty() && csv_.text("v").empty() && csv_.text("diameter_px").empty()) {
      return;  // a frame without blobs
    }
    Blob blob;
    blob.u = csv_.number("u");
    blob.v = csv_.number("v");
    blob.diameter_px = csv_.number("diameter_px");
    if (blob.diameter_px < 0) {
      throw Error(csv_.where("diameter_px"), "negative diameter " + formatDouble(blob.diameter_px));
    }
    if (csv_.hasColumn("response") && !csv_.text("response").empty()) {
      blob.response = csv_.number("response");
    }
    obs.blobs.push_back(blob);
  }

  CsvReader csv_;
  std::string fisheye_label_;
  IssueSink issue_;
  bool has_row_ = false;  ///< The reader's current row is read but not yet used.
  std::optional<TimeNs> last_;
};

/// A TUM file, read line by line.
class TumStream final : public Stream {
 public:
  TumStream(const fs::path& path, std::string label, IssueSink issue)
      : path_(path), in_(path), label_(std::move(label)), issue_(std::move(issue)) {
    if (!in_) throw Error({path_.string(), 0, "", ""}, "cannot open for reading");
  }

  std::optional<Record> next() override {
    std::string line;
    while (std::getline(in_, line)) {
      ++line_;
      const auto first = line.find_first_not_of(" \t\r");
      if (first == std::string::npos || line[first] == '#') continue;
      const StampedPose sample = parseTumRow(line, {path_.string(), line_, "", ""});
      if (last_ && sample.t <= *last_) {
        issue_(location(path_, line_), timeOrderMessage(sample.t, *last_, "pose"));
        continue;
      }
      last_ = sample.t;
      return PoseSample{sample.t, label_, sample.world_from_body};
    }
    if (in_.bad()) throw Error({path_.string(), line_, "", ""}, "read error");
    return std::nullopt;
  }

 private:
  fs::path path_;
  std::ifstream in_;
  std::string label_;
  IssueSink issue_;
  int line_ = 0;
  std::optional<TimeNs> last_;
};

// ---------------------------------------------------------------------------

class FolderReader final : public DatasetReader {
 public:
  FolderReader(const fs::path& folder, const DatasetReadOptions& options)
      : DatasetReader(folder, DatasetKind::kFolder, options) {
    if (!fs::is_directory(folder)) throw Error({folder.string(), 0, "", ""}, "not a folder");
    fs::path normal = fs::absolute(folder).lexically_normal();
    if (normal.filename().empty()) normal = normal.parent_path();
    manifest_.name = normal.filename().string();

    readMarker();
    readCameras();
    readTrajectoryInfos();
    readGroundTruth();
    if (const std::string why = manifest_.check(); !why.empty()) {
      throw Error({folder.string(), 0, "", ""}, "inconsistent dataset: " + why);
    }
    openStreams();
  }

  std::optional<Record> next() override {
    if (!primed_) {
      heads_.resize(streams_.size());
      for (size_t i = 0; i < streams_.size(); ++i) heads_[i] = streams_[i]->next();
      primed_ = true;
    }
    // The stream whose record was returned last is advanced only now, so that
    // an error in its next row never swallows a record already taken out.
    if (to_advance_) {
      const size_t i = *to_advance_;
      to_advance_.reset();
      heads_[i] = streams_[i]->next();
    }
    std::optional<size_t> best;
    for (size_t i = 0; i < heads_.size(); ++i) {
      if (heads_[i] && (!best || recordTime(*heads_[i]) < recordTime(*heads_[*best]))) best = i;
    }
    if (!best) return std::nullopt;
    std::optional<Record> record = std::move(heads_[*best]);
    heads_[*best].reset();
    to_advance_ = *best;
    return record;
  }

 private:
  fs::path file(const std::string& relative) const { return path_ / relative; }

  IssueSink issueSink() {
    return [this](const std::string& where, const std::string& message) {
      reportIssue(where, message);
    };
  }

  IssueSink noteSink() {
    return [this](const std::string& where, const std::string& message) {
      reportNote(where, message);
    };
  }

  void readMarker() {
    const fs::path path = file("marker.yaml");
    if (!fs::exists(path)) {
      throw Error({path.string(), 0, "", ""},
                  "missing: a dataset folder must describe the robot's marker (dictionary, id, "
                  "size_m)");
    }
    const YAML::Node map = loadYamlMapping(path, {"dictionary", "id", "size_m"});
    manifest_.marker.dictionary = *yamlScalar(map, "dictionary", path, true);
    const std::string id_text = *yamlScalar(map, "id", path, true);
    const std::optional<long long> id = parseInt(id_text);
    if (!id || *id < 0 || *id > std::numeric_limits<int>::max()) {
      throw Error({path.string(), yamlLine(map, "id"), "id", ""},
                  "expected a non-negative integer, got '" + id_text + "'");
    }
    manifest_.marker.id = static_cast<int>(*id);
    manifest_.marker.size_m = yamlNumber(map, "size_m", path);
    if (const std::string why = manifest_.marker.check(); !why.empty()) {
      throw Error({path.string(), 0, "", ""}, why);
    }
  }

  /// The calibration file of a camera folder; an error naming the folder when
  /// there is none or more than one.
  static fs::path calibrationFile(const fs::path& directory) {
    static const char* kNames[] = {"calibration.yaml", "calibration.yml", "calibration.xml",
                                   "calib_results.txt"};
    std::vector<fs::path> found;
    for (const char* name : kNames) {
      if (fs::is_regular_file(directory / name)) found.push_back(directory / name);
    }
    if (found.empty()) {
      throw Error({directory.string(), 0, "", ""},
                  "camera folder without a calibration file (expected calibration.yaml or "
                  "calib_results.txt)");
    }
    if (found.size() > 1) {
      throw Error({directory.string(), 0, "", ""},
                  "several calibration files (" + found[0].filename().string() + ", " +
                      found[1].filename().string() + "): keep one");
    }
    return found.front();
  }

  void addCamera(const fs::path& directory, const std::string& label, SensorRole role) {
    const fs::path calibration = calibrationFile(directory);
    CameraSensor sensor;
    sensor.label = label;
    sensor.role = role;
    sensor.camera = loadCamera(calibration);
    manifest_.cameras.push_back(sensor);
    camera_folders_.push_back({directory, calibration});
  }

  void readCameras() {
    const fs::path fisheye = file("fisheye");
    if (fs::exists(fisheye)) {
      if (!fs::is_directory(fisheye)) throw Error({fisheye.string(), 0, "", ""}, "not a folder");
      addCamera(fisheye, kFisheyeLabel, SensorRole::kFisheye);
    }
    const fs::path cameras = file("cameras");
    if (!fs::exists(cameras)) return;
    if (!fs::is_directory(cameras)) throw Error({cameras.string(), 0, "", ""}, "not a folder");
    std::vector<fs::path> directories;
    for (const fs::directory_entry& entry : fs::directory_iterator(cameras)) {
      const std::string name = entry.path().filename().string();
      if (entry.is_directory() && !name.empty() && name[0] != '.')
        directories.push_back(entry.path());
    }
    std::sort(directories.begin(), directories.end());
    for (const fs::path& directory : directories) {
      const std::string label = directory.filename().string();
      if (label == kFisheyeLabel) {
        throw Error({directory.string(), 0, "", ""},
                    "the label 'fisheye' is the robot's fisheye (folder fisheye/), not an "
                    "environment camera");
      }
      addCamera(directory, label, SensorRole::kEnvCamera);
    }
  }

  /// Reads the optional <name>.yaml of a trajectory ({metric, description}).
  static void readTrajectoryYaml(const fs::path& path, TrajectoryInfo& info) {
    if (!fs::exists(path)) return;
    const YAML::Node map = loadYamlMapping(path, {"metric", "description"});
    if (const auto metric = yamlScalar(map, "metric", path, false)) {
      if (*metric == "true") {
        info.metric = true;
      } else if (*metric == "false") {
        info.metric = false;
      } else {
        throw Error({path.string(), yamlLine(map, "metric"), "metric", ""},
                    "expected true or false, got '" + *metric + "'");
      }
    }
    if (const auto description = yamlScalar(map, "description", path, false)) {
      info.description = *description;
    }
  }

  void readTrajectoryInfos() {
    if (fs::exists(file("odometry/trajectory.tum"))) {
      TrajectoryInfo info{kOdometryLabel, true, ""};
      readTrajectoryYaml(file("odometry/odometry.yaml"), info);
      manifest_.trajectories.push_back(info);
      trajectory_files_.push_back(file("odometry/trajectory.tum"));
    }
    if (fs::exists(file("ground_truth/trajectory.tum"))) {
      TrajectoryInfo info{kGroundTruthLabel, true, ""};
      readTrajectoryYaml(file("ground_truth/trajectory.yaml"), info);
      manifest_.trajectories.push_back(info);
      trajectory_files_.push_back(file("ground_truth/trajectory.tum"));
    }
    const fs::path others = file("trajectories");
    if (!fs::is_directory(others)) return;
    std::vector<fs::path> tums;
    for (const fs::directory_entry& entry : fs::directory_iterator(others)) {
      if (entry.is_regular_file() && entry.path().extension() == ".tum")
        tums.push_back(entry.path());
    }
    std::sort(tums.begin(), tums.end());
    for (const fs::path& tum : tums) {
      const std::string label = tum.stem().string();
      if (label == kOdometryLabel || label == kGroundTruthLabel) {
        throw Error({tum.string(), 0, "", ""},
                    "the trajectory '" + label + "' belongs in " + label + "/trajectory.tum");
      }
      TrajectoryInfo info{label, true, ""};
      readTrajectoryYaml(others / (label + ".yaml"), info);
      manifest_.trajectories.push_back(info);
      trajectory_files_.push_back(tum);
    }
  }

  void readGroundTruth() {
    GroundTruth& truth = manifest_.ground_truth;
    const fs::path cameras = file("ground_truth/cameras.csv");
    if (fs::exists(cameras)) {
      CsvReader csv(cameras, withPoseColumns({"label"}));
      while (csv.next()) {
        const std::string& label = csv.text("label");
        const CameraSensor* sensor = manifest_.findCamera(label);
        if (!sensor || sensor->role != SensorRole::kEnvCamera) {
          throw Error(
              csv.where("label"),
              "'" + label + "' is not an environment camera (no folder cameras/" + label + "/)");
        }
        if (!truth.world_from_camera.emplace(label, csvPose(csv)).second) {
          throw Error(csv.where("label"), "camera '" + label + "' appears twice");
        }
      }
    }
    const fs::path marker = file("ground_truth/fisheye_from_marker.yaml");
    if (fs::exists(marker)) {
      const YAML::Node map = loadYamlMapping(marker, kPoseColumns);
      double v[7];
      for (int i = 0; i < 7; ++i) v[i] = yamlNumber(map, kPoseColumns[i], marker);
      const Eigen::Quaterniond q = checkedQuaternion(
          v[3], v[4], v[5], v[6], {marker.string(), yamlLine(map, "qx"), "qx", ""});
      truth.fisheye_from_marker = Rigid3d(q, Eigen::Vector3d(v[0], v[1], v[2]));
    }
    const fs::path offsets = file("ground_truth/clock_offsets.csv");
    if (fs::exists(offsets)) {
      CsvReader csv(offsets, {"label", "offset_ns"});
      while (csv.next()) {
        const std::string& label = csv.text("label");
        if (label.empty()) throw Error(csv.where("label"), "empty label");
        if (!truth.clock_offset.emplace(label, csv.integer("offset_ns")).second) {
          throw Error(csv.where("label"), "sensor '" + label + "' appears twice");
        }
      }
    }
    const fs::path hidden = file("ground_truth/hidden_from_fisheye.csv");
    if (fs::exists(hidden)) {
      CsvReader csv(hidden, {"label", "begin_ns", "end_ns"});
      while (csv.next()) {
        const std::string& label = csv.text("label");
        if (label.empty()) throw Error(csv.where("label"), "empty label");
        truth.hidden_from_fisheye[label].push_back(
            {csv.integer("begin_ns"), csv.integer("end_ns")});
      }
    }
  }

  /// Tie order (equal timestamps): fisheye frames, environment camera frames
  /// (by label), blobs, markers, odometry, ground truth, other trajectories (by label).
  void openStreams() {
    std::set<std::string> env_cameras;
    for (size_t i = 0; i < manifest_.cameras.size(); ++i) {
      const CameraSensor& sensor = manifest_.cameras[i];
      if (sensor.role == SensorRole::kEnvCamera) env_cameras.insert(sensor.label);
      const fs::path frames = camera_folders_[i].first / "frames.csv";
      if (const std::optional<fs::path> video = videoFile(camera_folders_[i].first)) {
        if (fs::exists(frames)) {
          throw Error({camera_folders_[i].first.string(), 0, "", ""},
                      "both frames.csv and " + video->filename().string() +
                          ": a camera's frames are image files or a video, not both");
        }
        streams_.push_back(std::make_unique<VideoStream>(
            *video, sensor.label, sensor.camera, camera_folders_[i].second,
            videoTiming(camera_folders_[i].first), issueSink(), noteSink()));
        continue;
      }
      if (!fs::exists(frames)) continue;
      streams_.push_back(std::make_unique<FrameStream>(frames, sensor.label, sensor.camera,
                                                       camera_folders_[i].second,
                                                       options_.check_images, issueSink()));
    }
    const fs::path blobs = file("detections/blobs.csv");
    if (fs::exists(blobs)) {
      if (!manifest_.fisheye()) {
        throw Error({blobs.string(), 0, "", ""},
                    "blobs are measured in fisheye frames but the folder has no fisheye/");
      }
      streams_.push_back(std::make_unique<BlobStream>(blobs, kFisheyeLabel, issueSink()));
    }
    const fs::path markers = file("detections/markers.csv");
    if (fs::exists(markers)) {
      streams_.push_back(std::make_unique<MarkerStream>(markers, env_cameras, issueSink()));
    }
    for (size_t i = 0; i < trajectory_files_.size(); ++i) {
      streams_.push_back(std::make_unique<TumStream>(trajectory_files_[i],
                                                     manifest_.trajectories[i].label, issueSink()));
    }
  }

  /// Per camera of the manifest, in order: its folder and calibration file.
  std::vector<std::pair<fs::path, fs::path>> camera_folders_;
  /// Per trajectory of the manifest, in order: its TUM file.
  std::vector<fs::path> trajectory_files_;
  std::vector<std::unique_ptr<Stream>> streams_;
  std::vector<std::optional<Record>> heads_;
  std::optional<size_t> to_advance_;
  bool primed_ = false;
};

}  // namespace

std::unique_ptr<DatasetReader> openFolderReader(const std::filesystem::path& folder,
                                                const DatasetReadOptions& options) {
  return std::make_unique<FolderReader>(folder, options);
}

}  // namespace lookboth::internal
