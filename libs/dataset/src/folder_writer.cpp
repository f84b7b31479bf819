// Writer of the plain-folder dataset format (doc/formats.md, "Dataset folder
// format"). Everything is written into a temporary sibling folder: CSV and TUM
// rows as records arrive, image bytes copied unchanged into
// <camera folder>/frames/<timestamp_ns><ext>; calibrations, marker, ground
// truth and trajectory descriptions in finish(), which then moves the folder
// into place.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>

#include "internal.h"
#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/geometry/tum.h"

namespace lookboth::internal {
namespace {

namespace fs = std::filesystem;

constexpr const char* kFisheyeLabel = "fisheye";
constexpr const char* kOdometryLabel = "odometry";
constexpr const char* kGroundTruthLabel = "ground_truth";

/// A YAML double-quoted scalar (JSON escapes are valid YAML).
std::string yamlQuoted(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buffer[8];
          std::snprintf(buffer, sizeof(buffer), "\\x%02x", static_cast<unsigned char>(c));
          out += buffer;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

/// Empty when `label` can name a folder, a file and a CSV field; else why not.
std::string checkLabel(const std::string& label) {
  if (label.empty()) return "empty label";
  if (label == "." || label == "..") return "'" + label + "' cannot name a folder";
  if (label.front() == '#' || label.front() == '.') {
    return "'" + label + "' starts with '" + label.substr(0, 1) + "'";
  }
  for (const char c : label) {
    if (c == '/' || c == '\\' || c == ',' || c == ' ' || static_cast<unsigned char>(c) < 0x20) {
      return "'" + label +
             "' holds a character not allowed in a folder label ('/', '\\', ',', a "
             "space or a control character)";
    }
  }
  return "";
}

/// "tx,ty,tz,qx,qy,qz,qw" of a pose.
std::string poseFields(const Rigid3d& pose) {
  const Eigen::Vector4d q = pose.rotation.coeffs();  // x y z w
  std::string out;
  for (int i = 0; i < 3; ++i) out += formatDouble(pose.translation[i]) + ",";
  for (int i = 0; i < 4; ++i) out += formatDouble(q[i]) + (i < 3 ? "," : "");
  return out;
}

/// An output text file inside the temporary folder, opened on first use.
class OutputFile {
 public:
  /// True once opened (and still after close()).
  bool started() const { return started_; }
  void open(const fs::path& path, const std::string& header) {
    fs::create_directories(path.parent_path());
    path_ = path;
    started_ = true;
    stream_.open(path);
    if (!stream_) throw Error({path.string(), 0, "", ""}, "cannot open for writing");
    stream_ << header << '\n';
  }
  std::ostream& stream() { return stream_; }
  void close() {
    if (!stream_.is_open()) return;
    stream_.close();
    if (!stream_) throw Error({path_.string(), 0, "", ""}, "write error (disk full?)");
  }

 private:
  fs::path path_;
  std::ofstream stream_;
  bool started_ = false;
};

void writeTextFile(const fs::path& path, const std::string& contents) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path);
  out << contents;
  out.close();
  if (!out) throw Error({path.string(), 0, "", ""}, "cannot write (disk full?)");
}

class FolderWriter final : public DatasetWriter {
 public:
  FolderWriter(fs::path folder, const Manifest& manifest, const DatasetWriteOptions& options)
      : DatasetWriter(manifest),
        folder_(std::move(folder)),
        overwrite_(options.overwrite),
        link_images_(options.link_images) {
    checkOutputPath(folder_, overwrite_);
    fisheye_label_ = checkManifest(manifest_);
    temporary_ = temporarySibling(folder_);
    std::error_code ec;
    fs::create_directory(temporary_, ec);
    if (ec) {
      throw Error({folder_.string(), 0, "", ""}, "cannot create the temporary folder '" +
                                                     temporary_.string() + "': " + ec.message());
    }
  }

  ~FolderWriter() override {
    if (finished_) return;
    std::error_code ignored;
    fs::remove_all(temporary_, ignored);
  }

  using DatasetWriter::finish;

  void write(const Record& record) override {
    if (finished_) throw Error({folder_.string(), 0, "", ""}, "write after finish()");
    std::visit([this](const auto& r) { writeRecord(r); }, record);
    ++records_written_;
  }

  void finish(const Manifest& manifest) override {
    if (finished_) throw Error({folder_.string(), 0, "", ""}, "finish() called twice");
    const std::string fisheye_label = checkManifest(manifest);
    if (fisheye_label != fisheye_label_) {
      throw Error({folder_.string(), 0, "", ""}, "the fisheye's label changed from '" +
                                                     fisheye_label_ + "' to '" + fisheye_label +
                                                     "' between create() and finish()");
    }
    for (const auto& [label, file] : frames_) {
      if (!manifest.findCamera(label)) {
        throw Error({folder_.string(), 0, "", label},
                    "frames were written for a camera that the final manifest does not list");
      }
    }
    for (const auto& [label, video] : videos_) {
      if (!manifest.findCamera(label)) {
        throw Error({folder_.string(), 0, "", label},
                    "video frames were written for a camera that the final manifest does not "
                    "list");
      }
    }
    for (auto& [label, file] : frames_) file.close();
    for (auto& [label, video] : videos_) video.csv.close();
    markers_.close();
    blobs_.close();
    for (auto& [label, file] : trajectories_) file.close();

    // Cameras: lookboth YAML calibrations.
    for (const CameraSensor& sensor : manifest.cameras) {
      writeTextFile(temporary_ / cameraFolder(sensor.label, fisheye_label) / "calibration.yaml",
                    cameraToYaml(*sensor.camera));
    }
    const MarkerSpec& marker = manifest.marker;
    writeTextFile(temporary_ / "marker.yaml",
                  "# The robot's marker (lookboth dataset folder, doc/formats.md)\n"
                  "dictionary: " +
                      yamlQuoted(marker.dictionary) + "\nid: " + std::to_string(marker.id) +
                      "\nsize_m: " + formatDouble(marker.size_m) + "\n");

    // Trajectories: every one of the manifest gets a TUM file (possibly
    // without samples) and its description.
    for (const TrajectoryInfo& info : manifest.trajectories) {
      OutputFile& tum = trajectoryFile(info.label);
      tum.close();
      std::string yaml = "metric: " + std::string(info.metric ? "true" : "false") + "\n";
      if (!info.description.empty()) yaml += "description: " + yamlQuoted(info.description) + "\n";
      writeTextFile(temporary_ / trajectoryYaml(info.label), yaml);
    }
    // Samples with a label the manifest does not list: metric, no description.
    for (const auto& [label, file] : trajectories_) {
      if (!manifest.findTrajectory(label)) {
        writeTextFile(temporary_ / trajectoryYaml(label), "metric: true\n");
      }
    }

    writeGroundTruth(manifest.ground_truth, fisheye_label);
    finished_ = true;  // from here on the folder is no longer ours to remove
    try {
      moveIntoPlace(temporary_, folder_, overwrite_);
    } catch (...) {
      std::error_code ignored;
      fs::remove_all(temporary_, ignored);
      throw;
    }
  }

 private:
  /// Checks what the folder format needs beyond Manifest::check(); returns
  /// the fisheye's label (empty when there is none).
  std::string checkManifest(const Manifest& manifest) const {
    std::string fisheye;
    for (const CameraSensor& sensor : manifest.cameras) {
      if (const std::string why = checkLabel(sensor.label); !why.empty()) {
        throw Error({folder_.string(), 0, "", sensor.label}, "camera label: " + why);
      }
      if (!sensor.camera) {
        throw Error({folder_.string(), 0, "", sensor.label},
                    "the dataset folder format needs a calibration for every camera");
      }
      if (sensor.role == SensorRole::kFisheye) {
        if (!fisheye.empty()) {
          throw Error({folder_.string(), 0, "", sensor.label},
                      "the dataset folder format holds one fisheye, the manifest has two ('" +
                          fisheye + "' and '" + sensor.label + "')");
        }
        fisheye = sensor.label;
      } else if (sensor.label == kFisheyeLabel) {
        throw Error({folder_.string(), 0, "", sensor.label},
                    "an environment camera cannot be labelled 'fisheye' in the dataset folder "
                    "format (the label names the fisheye/ folder)");
      }
    }
    for (const TrajectoryInfo& info : manifest.trajectories) {
      if (const std::string why = checkLabel(info.label); !why.empty()) {
        throw Error({folder_.string(), 0, "", info.label}, "trajectory label: " + why);
      }
    }
    for (const auto& [label, offset] : manifest.ground_truth.clock_offset) {
      if (const std::string why = checkLabel(label); !why.empty()) {
        throw Error({folder_.string(), 0, "", label}, "clock offset label: " + why);
      }
    }
    return fisheye;
  }

  static fs::path cameraFolder(const std::string& label, const std::string& fisheye_label) {
    if (label == fisheye_label) return kFisheyeLabel;
    return fs::path("cameras") / label;
  }

  /// Label in the folder: the fisheye is always "fisheye".
  std::string folderLabel(const std::string& label, const std::string& fisheye_label) const {
    return label == fisheye_label ? std::string(kFisheyeLabel) : label;
  }

  static fs::path trajectoryTum(const std::string& label) {
    if (label == kOdometryLabel) return "odometry/trajectory.tum";
    if (label == kGroundTruthLabel) return "ground_truth/trajectory.tum";
    return fs::path("trajectories") / (label + ".tum");
  }
  static fs::path trajectoryYaml(const std::string& label) {
    if (label == kOdometryLabel) return "odometry/odometry.yaml";
    if (label == kGroundTruthLabel) return "ground_truth/trajectory.yaml";
    return fs::path("trajectories") / (label + ".yaml");
  }

  const CameraSensor& requireCamera(const std::string& label, const char* what) const {
    const CameraSensor* sensor = manifest_.findCamera(label);
    if (!sensor) {
      throw Error({folder_.string(), 0, "", label},
                  std::string(what) + " of a camera that the manifest does not list");
    }
    return *sensor;
  }

  void writeRecord(const ImageFrame& frame) {
    const CameraSensor& sensor = requireCamera(frame.sensor, "image");
    const fs::path folder = cameraFolder(sensor.label, fisheye_label_);
    if (!frame.encoded && !frame.video_file.empty()) {
      writeVideoFrame(sensor.label, folder, frame);
      return;
    }
    if (videos_.count(sensor.label)) throw mixedFrames(sensor.label);
    OutputFile& csv = frames_[sensor.label];
    if (!csv.started()) {
      csv.open(temporary_ / folder / "frames.csv", "timestamp_ns,file");
      fs::create_directories(temporary_ / folder / "frames");
    }
    std::string extension = frame.encoded ? frame.extension : frame.image_file.extension().string();
    if (!extension.empty() && extension.front() != '.') extension = "." + extension;
    // Frames of one camera with the same timestamp get a suffix.
    const std::string stem = std::to_string(frame.t);
    fs::path relative = fs::path("frames") / (stem + extension);
    for (int n = 2; fs::exists(temporary_ / folder / relative); ++n) {
      relative = fs::path("frames") / (stem + "_" + std::to_string(n) + extension);
    }
    const fs::path target = temporary_ / folder / relative;
    if (frame.encoded) {
      std::ofstream out(target, std::ios::binary);
      out.write(reinterpret_cast<const char*>(frame.encoded->data()),
                static_cast<std::streamsize>(frame.encoded->size()));
      out.close();
      if (!out) throw Error({target.string(), 0, "", ""}, "cannot write image (disk full?)");
    } else {
      if (frame.image_file.empty()) {
        throw Error(
            {folder_.string(), 0, "", sensor.label},
            "frame at " + std::to_string(frame.t) + " ns has neither an image file nor bytes");
      }
      placeImageFile(frame.image_file, target, link_images_, sensor.label);
    }
    csv.stream() << frame.t << ',' << relative.generic_string() << '\n';
  }

  /// A camera's video frames: the video file once (linked or copied, never
  /// re-encoded) and `video.csv` with each frame's time and index, so that
  /// reading it back needs no timestamps from the container.
  void writeVideoFrame(const std::string& label, const fs::path& folder, const ImageFrame& frame) {
    if (frames_.count(label)) throw mixedFrames(label);
    VideoOutput& video = videos_[label];
    if (!video.csv.started()) {
      std::string extension = frame.video_file.extension().string();
      std::transform(extension.begin(), extension.end(), extension.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      if (extension.empty() || extension == ".csv" || extension == ".yaml") extension = ".video";
      video.source = frame.video_file;
      fs::create_directories(temporary_ / folder);
      placeImageFile(frame.video_file, temporary_ / folder / ("video" + extension), link_images_,
                     label);
      video.csv.open(temporary_ / folder / "video.csv", "timestamp_ns,frame");
    } else if (video.source != frame.video_file) {
      throw Error({folder_.string(), 0, "", label},
                  "frames from two video files ('" + video.source.string() + "', '" +
                      frame.video_file.string() +
                      "'): a camera folder holds one video (join them first, e.g. with "
                      "ffmpeg -f concat -c copy)");
    }
    video.csv.stream() << frame.t << ',' << frame.video_frame << '\n';
  }

  Error mixedFrames(const std::string& label) const {
    return Error({folder_.string(), 0, "", label},
                 "image files and video frames for one camera: a camera folder holds either "
                 "frames.csv or a video");
  }

  void writeRecord(const MarkerObservation& obs) {
    const CameraSensor& sensor = requireCamera(obs.camera, "marker observation");
    if (sensor.role != SensorRole::kEnvCamera) {
      throw Error({folder_.string(), 0, "", obs.camera},
                  "marker observation by the fisheye: the dataset folder format holds marker "
                  "observations of environment cameras only");
    }
    if (!markers_.started()) {
      markers_.open(temporary_ / "detections/markers.csv",
                    "timestamp_ns,camera,marker_id,tx,ty,tz,qx,qy,qz,qw,information,corners,"
                    "corner_sigma_px");
    }
    if (!obs.corners_px.empty() && obs.corners_px.size() != 4) {
      throw Error({folder_.string(), 0, "", obs.camera},
                  "marker observation at " + std::to_string(obs.t) + " ns has " +
                      std::to_string(obs.corners_px.size()) + " corners (expected 0 or 4)");
    }
    std::ostream& out = markers_.stream();
    out << obs.t << ',' << obs.camera << ',' << obs.marker_id << ','
        << poseFields(obs.camera_from_marker) << ',';
    if ((obs.information.array() != 0.0).any()) {
      for (int row = 0; row < 6; ++row) {
        for (int col = row; col < 6; ++col) {
          out << formatDouble(obs.information(row, col)) << (row == 5 && col == 5 ? "" : " ");
        }
      }
    }
    out << ',';
    for (size_t k = 0; k < obs.corners_px.size(); ++k) {
      out << (k == 0 ? "" : " ") << formatDouble(obs.corners_px[k].x()) << ' '
          << formatDouble(obs.corners_px[k].y());
    }
    out << ',';
    if (obs.corner_sigma_px != 0) out << formatDouble(obs.corner_sigma_px);
    out << '\n';
  }

  void writeRecord(const BlobObservation& obs) {
    const CameraSensor& sensor = requireCamera(obs.camera, "blobs");
    if (sensor.role != SensorRole::kFisheye) {
      throw Error({folder_.string(), 0, "", obs.camera},
                  "blobs of an environment camera: the dataset folder format holds blobs of the "
                  "fisheye only");
    }
    if (!blobs_.started()) {
      blobs_.open(temporary_ / "detections/blobs.csv",
                  "timestamp_ns,u,v,diameter_px,response,image_width,image_height");
    }
    std::ostream& out = blobs_.stream();
    const std::string size =
        std::to_string(obs.image_width) + "," + std::to_string(obs.image_height);
    if (obs.blobs.empty()) out << obs.t << ",,,,," << size << '\n';  // a frame without blobs
    for (const Blob& blob : obs.blobs) {
      out << obs.t << ',' << formatDouble(blob.u) << ',' << formatDouble(blob.v) << ','
          << formatDouble(blob.diameter_px) << ',' << formatDouble(blob.response) << ',' << size
          << '\n';
    }
  }

  void writeRecord(const PoseSample& sample) {
    if (const std::string why = checkLabel(sample.label); !why.empty()) {
      throw Error({folder_.string(), 0, "", sample.label}, "trajectory label: " + why);
    }
    if (manifest_.findCamera(sample.label)) {
      throw Error({folder_.string(), 0, "", sample.label},
                  "poses labelled like a camera: a trajectory needs a label of its own");
    }
    trajectoryFile(sample.label).stream()
        << formatTumRow({sample.t, sample.world_from_body}) << '\n';
  }

  OutputFile& trajectoryFile(const std::string& label) {
    OutputFile& tum = trajectories_[label];
    if (!tum.started()) {
      const std::string body = label == kOdometryLabel || label == kGroundTruthLabel
                                   ? "world_from_fisheye"
                                   : "world_from_body";
      tum.open(temporary_ / trajectoryTum(label),
               "# timestamp[s] tx ty tz qx qy qz qw (" + body + ")");
    }
    return tum;
  }

  void writeGroundTruth(const GroundTruth& truth, const std::string& fisheye_label) {
    if (!truth.world_from_camera.empty()) {
      std::string csv = "label,tx,ty,tz,qx,qy,qz,qw\n";
      for (const auto& [label, pose] : truth.world_from_camera) {
        csv += label + "," + poseFields(pose) + "\n";
      }
      writeTextFile(temporary_ / "ground_truth/cameras.csv", csv);
    }
    if (truth.fisheye_from_marker) {
      const Rigid3d& pose = *truth.fisheye_from_marker;
      const Eigen::Vector4d q = pose.rotation.coeffs();
      std::string yaml = "# fisheye_from_marker: pose of the marker in the fisheye frame [m]\n";
      const char* names[7] = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};
      for (int i = 0; i < 7; ++i) {
        yaml += std::string(names[i]) + ": " +
                formatDouble(i < 3 ? pose.translation[i] : q[i - 3]) + "\n";
      }
      writeTextFile(temporary_ / "ground_truth/fisheye_from_marker.yaml", yaml);
    }
    if (!truth.clock_offset.empty()) {
      std::string csv = "label,offset_ns\n";
      for (const auto& [label, offset] : truth.clock_offset) {
        csv += folderLabel(label, fisheye_label) + "," + std::to_string(offset) + "\n";
      }
      writeTextFile(temporary_ / "ground_truth/clock_offsets.csv", csv);
    }
    if (!truth.hidden_from_fisheye.empty()) {
      std::string csv = "label,begin_ns,end_ns\n";
      for (const auto& [label, spans] : truth.hidden_from_fisheye) {
        for (const TimeSpan& span : spans) {
          csv += label + "," + std::to_string(span.begin) + "," + std::to_string(span.end) + "\n";
        }
      }
      writeTextFile(temporary_ / "ground_truth/hidden_from_fisheye.csv", csv);
    }
  }

  fs::path folder_;
  fs::path temporary_;
  bool overwrite_;
  bool link_images_;
  bool finished_ = false;
  std::string fisheye_label_;  ///< The fisheye's label in the manifest (written as "fisheye").
  std::map<std::string, OutputFile> frames_;  ///< By camera label.
  struct VideoOutput {
    fs::path source;
    OutputFile csv;
  };
  std::map<std::string, VideoOutput> videos_;  ///< By camera label.
  OutputFile markers_;
  OutputFile blobs_;
  std::map<std::string, OutputFile> trajectories_;  ///< By trajectory label.
};

}  // namespace

std::unique_ptr<DatasetWriter> createFolderWriter(const std::filesystem::path& folder,
                                                  const Manifest& manifest,
                                                  const DatasetWriteOptions& options) {
  return std::make_unique<FolderWriter>(folder, manifest, options);
}

}  // namespace lookboth::internal
