#include "lookboth/report/snapshot.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <functional>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <thread>
#include <tuple>

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/dataset/frame_decoder.h"
#include "lookboth/report/overview.h"

namespace lookboth::report {
namespace fs = std::filesystem;

CameraPoseSet RegistrationView::poseSet() const {
  CameraPoseSet set;
  set.source = name;
  set.world_from_camera = world_from_camera;
  set.without_pose = unregistered;
  return set;
}

FrameSelection FrameSelection::parse(const std::string& text) {
  FrameSelection selection;
  const ErrorContext where{"", 0, "--frames", ""};
  if (text.empty() || text == "auto") return selection;
  if (const size_t colon = text.find(':'); colon != std::string::npos) {
    const auto t0 = parseDouble(text.substr(0, colon));
    const auto t1 = parseDouble(text.substr(colon + 1));
    if (!t0 || !t1 || !(*t1 >= *t0) || *t0 < 0) {
      throw Error(where,
                  "expected 'auto', indices 'i,j,k' or seconds 't0:t1' with 0 <= t0 <= t1, "
                  "got '" +
                      text + "'");
    }
    selection.mode = Mode::kTimeRange;
    selection.t0_s = *t0;
    selection.t1_s = *t1;
    return selection;
  }
  selection.mode = Mode::kIndices;
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const auto index = parseInt(item);
    if (!index || *index < 0 || *index > 100000000) {
      throw Error(where, "expected 'auto', indices 'i,j,k' or seconds 't0:t1', got '" + text + "'");
    }
    selection.indices.push_back(static_cast<int>(*index));
  }
  if (selection.indices.empty()) throw Error(where, "no frame index in '" + text + "'");
  return selection;
}

cv::Size parseSize(const std::string& text) {
  const size_t x = text.find('x');
  const auto w = x == std::string::npos ? std::nullopt : parseInt(text.substr(0, x));
  const auto h = x == std::string::npos ? std::nullopt : parseInt(text.substr(x + 1));
  if (!w || !h || *w < 64 || *h < 64 || *w > 8192 || *h > 8192) {
    throw Error({"", 0, "--size", ""},
                "expected WIDTHxHEIGHT between 64x64 and 8192x8192, got '" + text + "'");
  }
  return cv::Size(static_cast<int>(*w), static_cast<int>(*h));
}

std::string SnapshotOptions::check() const {
  if (out.empty()) return "'out': an output folder is required";
  if (auto_frames < 1 || auto_frames > 1000) return "'auto_frames': must be in [1, 1000]";
  if (max_env_views < 0) return "'max_env_views': must be >= 0";
  if (size.width < 0 || size.height < 0) return "'size': must not be negative";
  return {};
}

namespace {

/// Everything the pictures need from the dataset, read in one pass.
struct DatasetContents {
  Manifest manifest;
  std::string fisheye_label;
  std::vector<ImageFrame> fisheye_frames;                ///< In time order.
  std::map<TimeNs, std::vector<Eigen::Vector2d>> blobs;  ///< By fisheye frame time.
  std::map<std::string, std::vector<ImageFrame>> env_frames;
  std::map<std::string, std::vector<MarkerObservation>> markers;
  std::map<std::string, std::vector<StampedPose>> trajectories;
  /// Fisheye frame times: of the images, else of the blob observations.
  std::vector<TimeNs> frame_times;
};

DatasetContents readDataset(const fs::path& path, const ProgressReporter& progress) {
  DatasetReadOptions read_options;
  read_options.check_images = false;
  const std::unique_ptr<DatasetReader> reader = DatasetReader::open(path, read_options);
  DatasetContents data;
  data.manifest = reader->manifest();
  if (const CameraSensor* fisheye = data.manifest.fisheye()) data.fisheye_label = fisheye->label;
  std::int64_t count = 0;
  const std::int64_t expected = reader->expectedCount();
  while (std::optional<Record> record = reader->next()) {
    if (++count % 500 == 0) {
      progress.checkStop();
      progress.report("snapshot: read dataset", count, std::max<std::int64_t>(expected, 0));
    }
    if (auto* frame = std::get_if<ImageFrame>(&*record)) {
      if (frame->sensor == data.fisheye_label) {
        data.fisheye_frames.push_back(*frame);
      } else {
        data.env_frames[frame->sensor].push_back(*frame);
      }
    } else if (auto* blobs = std::get_if<BlobObservation>(&*record)) {
      auto& list = data.blobs[blobs->t];
      for (const Blob& blob : blobs->blobs) list.emplace_back(blob.u, blob.v);
    } else if (auto* marker = std::get_if<MarkerObservation>(&*record)) {
      if (marker->marker_id == data.manifest.marker.id)
        data.markers[marker->camera].push_back(*marker);
    } else if (auto* pose = std::get_if<PoseSample>(&*record)) {
      data.trajectories[pose->label].push_back({pose->t, pose->world_from_body});
    }
  }
  const auto by_time = [](const auto& a, const auto& b) { return a.t < b.t; };
  std::stable_sort(data.fisheye_frames.begin(), data.fisheye_frames.end(), by_time);
  for (auto& [camera, frames] : data.env_frames)
    std::stable_sort(frames.begin(), frames.end(), by_time);
  for (auto& [label, samples] : data.trajectories)
    std::stable_sort(samples.begin(), samples.end(), by_time);
  if (!data.fisheye_frames.empty()) {
    for (const ImageFrame& frame : data.fisheye_frames) data.frame_times.push_back(frame.t);
  } else {
    for (const auto& [t, blobs] : data.blobs) data.frame_times.push_back(t);
  }
  return data;
}

cv::Mat decodeImage(const ImageFrame& frame) {
  if (!frame.encoded && !isVideoFrame(frame)) {
    std::error_code ec;
    if (!fs::is_regular_file(frame.image_file, ec)) {
      throw Error({frame.image_file.string(), 0, "", frame.sensor}, "image file missing");
    }
  }
  // One decoder per thread keeps a video open between the frames asked for.
  thread_local FrameDecoder decoder;
  cv::Mat image = decoder.decode(frame, FrameColour::kAsStored);
  if (image.empty())
    throw Error("cannot read the image " + frameName(frame) + " of '" + frame.sensor + "'");
  if (image.depth() != CV_8U) {
    double max_value = 0;
    cv::minMaxLoc(image.reshape(1), nullptr, &max_value);
    image.convertTo(image, CV_8U, max_value > 0 ? 255.0 / max_value : 1.0);
  }
  return image;
}

void writePng(const fs::path& path, const cv::Mat& image) {
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", image, bytes, {cv::IMWRITE_PNG_COMPRESSION, 1})) {
    throw Error({path.string(), 0, "", ""}, "cannot encode the PNG");
  }
  AtomicOutputFile file(path, true);
  file.stream().write(reinterpret_cast<const char*>(bytes.data()),
                      static_cast<std::streamsize>(bytes.size()));
  file.commit();
}

std::string secondsText(double seconds) { return formatFixed(seconds, 2); }

std::string safeName(std::string text) {
  for (char& c : text) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '.') c = '_';
  }
  return text;
}

/// The reprojection check of the frame at `t`.
FisheyeCheck makeCheck(const RegistrationView& reg, const Camera& fisheye, TimeNs t,
                       const std::vector<Eigen::Vector2d>& frame_blobs,
                       const std::multimap<TimeNs, const ReprojectionRow*>& rows_by_time) {
  FisheyeCheck check;
  check.t = t;
  check.image_size = cv::Size(fisheye.width(), fisheye.height());
  check.blobs = frame_blobs;
  const InterpolationResult pose = reg.trajectory.interpolate(t, 0);
  std::map<std::string, FisheyeCheck::ProjectedCamera> cameras;
  if (pose.ok()) {
    const Rigid3d fisheye_from_world = pose.world_from_body.inverse();
    const auto project = [&](const Rigid3d& world_from_camera) -> std::optional<Eigen::Vector2d> {
      const auto uv = fisheye.project(fisheye_from_world * world_from_camera.translation);
      if (uv && fisheye.isInImage(*uv)) return uv;
      return std::nullopt;
    };
    for (const auto& [label, world_from_camera] : reg.world_from_camera) {
      FisheyeCheck::ProjectedCamera c;
      c.label = label;
      c.after = project(world_from_camera);
      if (const auto before = reg.world_from_camera_before.find(label);
          before != reg.world_from_camera_before.end()) {
        c.before = project(before->second);
      }
      if (c.after || c.before) cameras[label] = c;
    }
  }
  // The registration's own associations (what stage 4 used) win.
  const auto [begin, end] = rows_by_time.equal_range(t);
  for (auto it = begin; it != end; ++it) {
    const ReprojectionRow& row = *it->second;
    FisheyeCheck::ProjectedCamera& c = cameras[row.camera];
    c.label = row.camera;
    c.blob = Eigen::Vector2d(row.u, row.v);
    if (row.before) c.before = row.before;
    if (row.after) c.after = row.after;
  }
  for (auto& [label, c] : cameras) check.cameras.push_back(c);
  return check;
}

/// Indices of the frames to draw.
std::vector<std::pair<int, std::string>> chooseFrames(
    const FrameSelection& selection, int auto_frames, const std::vector<TimeNs>& times,
    const std::function<FisheyeCheck(int)>& check_at, std::vector<std::string>& notes) {
  std::vector<std::pair<int, std::string>> chosen;
  if (times.empty()) return chosen;
  const int n = static_cast<int>(times.size());
  if (selection.mode == FrameSelection::Mode::kIndices) {
    for (int index : selection.indices) {
      if (index >= n) {
        throw Error({"", 0, "--frames", ""},
                    "frame " + std::to_string(index) + " does not exist: the dataset has " +
                        std::to_string(n) + " fisheye frames (0 to " + std::to_string(n - 1) + ")");
      }
      chosen.push_back({index, "requested"});
    }
    return chosen;
  }
  if (selection.mode == FrameSelection::Mode::kTimeRange) {
    const TimeNs start = times.front();
    for (int i = 0; i < n; ++i) {
      const double s = nsToSeconds(times[i] - start);
      if (s >= selection.t0_s - 1e-9 && s <= selection.t1_s + 1e-9)
        chosen.push_back({i, "requested"});
    }
    if (chosen.empty()) {
      throw Error({"", 0, "--frames", ""},
                  "no fisheye frame between " + formatFixed(selection.t0_s, 3) + " s and " +
                      formatFixed(selection.t1_s, 3) + " s (the frames span 0 to " +
                      formatFixed(nsToSeconds(times.back() - start), 3) + " s)");
    }
    return chosen;
  }
  // Automatic: score every frame (cheap: projections only), then take the
  // frames with most cameras in view and those with the worst residuals,
  // at least 1 s apart so that the pictures differ.
  struct Score {
    int index;
    int in_view;
    int associated;
    double worst;
  };
  std::vector<Score> scores;
  for (int i = 0; i < n; ++i) {
    const FisheyeCheck check = check_at(i);
    scores.push_back({i, static_cast<int>(check.cameras.size()), check.associated(),
                      check.worstResidualAfter()});
  }
  const auto far_enough = [&](int index) {
    for (const auto& [other, why] : chosen) {
      if (std::llabs(times[index] - times[other]) < kNanosecondsPerSecond) return false;
    }
    return true;
  };
  std::vector<Score> by_view = scores;
  std::stable_sort(by_view.begin(), by_view.end(), [](const Score& a, const Score& b) {
    return std::tie(a.in_view, a.associated) > std::tie(b.in_view, b.associated);
  });
  const int wanted_view = (auto_frames + 1) / 2;
  for (const Score& s : by_view) {
    if (static_cast<int>(chosen.size()) >= wanted_view || s.in_view == 0) break;
    if (far_enough(s.index)) chosen.push_back({s.index, "most cameras in view"});
  }
  std::vector<Score> by_residual = scores;
  std::stable_sort(by_residual.begin(), by_residual.end(),
                   [](const Score& a, const Score& b) { return a.worst > b.worst; });
  for (const Score& s : by_residual) {
    if (static_cast<int>(chosen.size()) >= auto_frames || s.associated == 0) break;
    if (far_enough(s.index)) chosen.push_back({s.index, "worst residual"});
  }
  if (chosen.empty()) {
    notes.push_back("no fisheye frame sees a registered camera: fisheye checks skipped");
  }
  std::sort(chosen.begin(), chosen.end());
  return chosen;
}

// writeSnapshots' pictures, one method per kind, in the order they are made.
class SnapshotWriter {
 public:
  SnapshotWriter(const fs::path& dataset, const RegistrationView& reg,
                 const SnapshotOptions& options, const ProgressReporter& progress)
      : reg_(reg), options_(options), progress_(progress), data_(readDataset(dataset, progress)) {
    std::error_code ec;
    fs::create_directories(options.out, ec);
    if (!fs::is_directory(options.out)) {
      throw Error({options.out.string(), 0, "", ""}, "cannot create the output folder");
    }
    plot_size_ = options.size.width > 0 ? options.size : cv::Size(1280, 720);
    start_ = data_.frame_times.empty() ? 0 : data_.frame_times.front();
    for (const StampedPose& s : reg.trajectory.samples())
      trajectory_.push_back(s.world_from_body.translation);
  }

  SnapshotResult write() {
    fisheyeChecks();
    envViews();
    if (options_.overview) overview();
    for (const SnapshotOptions::Reference& ref : options_.references) comparison(ref);
    loopClosures();
    return std::move(result_);
  }

 private:
  void add(SnapshotPicture picture, const cv::Mat& image) {
    writePng(picture.file, image);
    picture.size = image.size();
    result_.pictures.push_back(std::move(picture));
  }

  /// 1. Fisheye reprojection checks.
  void fisheyeChecks() {
    const CameraSensor* fisheye_sensor = data_.manifest.fisheye();
    if (!fisheye_sensor || !fisheye_sensor->camera) {
      result_.notes.push_back("the dataset has no calibrated fisheye: fisheye checks skipped");
      return;
    }
    if (data_.frame_times.empty()) {
      result_.notes.push_back("the dataset has no fisheye frame or blob: fisheye checks skipped");
      return;
    }
    const DatasetContents& data = data_;
    const RegistrationView& reg = reg_;
    const SnapshotOptions& options = options_;
    const ProgressReporter& progress = progress_;
    SnapshotResult& result = result_;
    const TimeNs start = start_;
    const Camera& fisheye = *fisheye_sensor->camera;
    std::multimap<TimeNs, const ReprojectionRow*> rows_by_time;
    for (const ReprojectionRow& row : reg.blob_associations) rows_by_time.emplace(row.t, &row);
    static const std::vector<Eigen::Vector2d> kNoBlobs;
    const auto check_at = [&](int index) {
      const TimeNs t = data.frame_times[index];
      const auto blobs = data.blobs.find(t);
      FisheyeCheck check = makeCheck(
          reg, fisheye, t, blobs == data.blobs.end() ? kNoBlobs : blobs->second, rows_by_time);
      check.frame_index = index;
      check.seconds = nsToSeconds(t - start);
      return check;
    };
    const auto chosen =
        chooseFrames(options.frames, options.auto_frames, data.frame_times, check_at, result.notes);
    // Frames are independent: decode, draw, encode and write them on a few
    // threads (pictures are returned in frame order whatever the threads).
    const int total = static_cast<int>(chosen.size());
    std::vector<std::optional<SnapshotPicture>> pictures(chosen.size());
    std::atomic<int> next{0}, done{0};
    std::mutex mutex;  // progress callback and the first error
    std::exception_ptr error;
    const auto work = [&] {
      for (int k = next++; k < total; k = next++) {
        if (progress.stopRequested()) return;
        try {
          const auto& [index, why] = chosen[k];
          FisheyeCheck check = check_at(index);
          check.why = why;
          cv::Mat image;
          if (!data.fisheye_frames.empty()) image = decodeImage(data.fisheye_frames[index]);
          SnapshotPicture picture;
          picture.kind = "fisheye_check";
          picture.t = check.t;
          char index_text[16];
          std::snprintf(index_text, sizeof index_text, "%04d", index);
          picture.file = options.out / ("fisheye_check_f" + std::string(index_text) + "_t" +
                                        secondsText(check.seconds) + "s.png");
          picture.caption = "Fisheye frame " + std::to_string(index) + " at " +
                            secondsText(check.seconds) + " s (" + why +
                            "): " + std::to_string(check.cameras.size()) + " cameras in view, " +
                            std::to_string(check.associated()) + " with a detected blob.";
          const cv::Mat drawn = drawFisheyeCheck(check, image, options.size, &picture.marks);
          writePng(picture.file, drawn);
          picture.size = drawn.size();
          pictures[k] = std::move(picture);
          const std::lock_guard<std::mutex> lock(mutex);
          progress.report("snapshot: fisheye checks", ++done, total);
        } catch (...) {
          const std::lock_guard<std::mutex> lock(mutex);
          if (!error) error = std::current_exception();
          return;
        }
      }
    };
    const int threads =
        std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, std::min(4, total));
    std::vector<std::thread> workers;
    for (int i = 1; i < threads; ++i) workers.emplace_back(work);
    work();
    for (std::thread& worker : workers) worker.join();
    if (error) std::rethrow_exception(error);
    progress.checkStop();
    for (auto& picture : pictures) {
      if (picture) result.pictures.push_back(std::move(*picture));
    }
  }

  /// The detection of the marker nearest the image centre (with its frame
  /// when there are images); else the frame where the registration puts the
  /// marker most centrally. False when there is neither.
  template <typename Distance, typename Predicted>
  bool chooseEnvFrame(const CameraSensor& sensor, const Distance& distance_to_centre,
                      const Predicted& predicted, EnvCameraView& view,
                      const ImageFrame*& image_frame) const {
    const auto frames = data_.env_frames.find(sensor.label);
    const auto markers = data_.markers.find(sensor.label);
    double best = 1e300;
    if (markers != data_.markers.end()) {
      for (const MarkerObservation& m : markers->second) {
        const ImageFrame* frame = nullptr;
        if (frames != data_.env_frames.end()) {
          const auto found =
              std::lower_bound(frames->second.begin(), frames->second.end(), m.t,
                               [](const ImageFrame& f, TimeNs t) { return f.t < t; });
          if (found == frames->second.end() || found->t != m.t) continue;
          frame = &*found;
        }
        const double d = distance_to_centre(m.camera_from_marker);
        if (d < best) {
          best = d;
          view.t = m.t;
          view.detected_camera_from_marker = m.camera_from_marker;
          image_frame = frame;
        }
      }
    }
    if (best == 1e300 && frames != data_.env_frames.end()) {
      for (const ImageFrame& frame : frames->second) {
        const auto p = predicted(frame.t);
        if (!p) continue;
        const double d = distance_to_centre(*p);
        if (d < best) {
          best = d;
          view.t = frame.t;
          image_frame = &frame;
        }
      }
    }
    return best != 1e300;
  }

  /// 2. An environment camera's view of the marker; false when it has none.
  bool envView(const CameraSensor& sensor, const Rigid3d& world_from_camera) {
    const RegistrationView& reg = reg_;
    const SnapshotOptions& options = options_;
    const TimeNs start = start_;
    const Camera& camera = *sensor.camera;
    const Rigid3d camera_from_world = world_from_camera.inverse();
    const auto predicted = [&](TimeNs t) -> std::optional<Rigid3d> {
      if (!reg.fisheye_from_marker) return std::nullopt;
      const InterpolationResult robot = reg.trajectory.interpolate(t, 0);
      if (!robot.ok()) return std::nullopt;
      return camera_from_world * robot.world_from_body * *reg.fisheye_from_marker;
    };
    const Eigen::Vector2d centre(camera.width() / 2.0, camera.height() / 2.0);
    const auto distance_to_centre = [&](const Rigid3d& camera_from_marker) {
      const auto uv = camera.project(camera_from_marker.translation);
      return uv ? (*uv - centre).norm() : 1e300;
    };
    EnvCameraView view;
    view.camera = sensor.label;
    view.marker_size_m = data_.manifest.marker.size_m;
    const ImageFrame* image_frame = nullptr;
    if (!chooseEnvFrame(sensor, distance_to_centre, predicted, view, image_frame)) return false;
    view.predicted_camera_from_marker = predicted(view.t);
    const cv::Mat image = image_frame ? decodeImage(*image_frame) : cv::Mat();
    SnapshotPicture picture;
    picture.kind = "env_view";
    picture.t = view.t;
    const double seconds = nsToSeconds(view.t - start);
    picture.file = options.out /
                   ("env_view_" + safeName(sensor.label) + "_t" + secondsText(seconds) + "s.png");
    picture.caption =
        "Camera " + sensor.label + " at " + secondsText(seconds) + " s: " +
        (view.detected_camera_from_marker ? "the detected marker with its axes, and " : "") +
        "the marker where the registration puts it.";
    const cv::Mat drawn = drawEnvCameraView(view, camera, image, options.size, &picture.marks);
    add(std::move(picture), drawn);
    return true;
  }

  void envViews() {
    int env_views = 0;
    for (const CameraSensor& sensor : data_.manifest.cameras) {
      if (env_views >= options_.max_env_views) break;
      if (sensor.role != SensorRole::kEnvCamera || !sensor.camera) continue;
      const auto pose = reg_.world_from_camera.find(sensor.label);
      if (pose == reg_.world_from_camera.end()) continue;
      progress_.checkStop();
      if (envView(sensor, pose->second)) ++env_views;
    }
  }

  /// 3. The 3-D overview.
  void overview() {
    const DatasetContents& data = data_;
    const RegistrationView& reg = reg_;
    const SnapshotOptions& options = options_;
    const ProgressReporter& progress = progress_;
    SnapshotResult& result = result_;
    const std::vector<Eigen::Vector3d>& trajectory = trajectory_;
    const cv::Size plot_size = plot_size_;
    progress.checkStop();
    progress.report("snapshot: 3-D overview", 0, 1);
    OverviewInput input;
    input.title = "Registration overview: " + std::to_string(reg.world_from_camera.size()) +
                  " cameras, trajectory and marker detections";
    for (const auto& [label, pose] : reg.world_from_camera) {
      input.cameras.push_back({label, pose, reg.suspect.count(label) > 0});
    }
    input.trajectory = trajectory;
    std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> rays;
    for (const auto& [camera, observations] : data.markers) {
      const auto pose = reg.world_from_camera.find(camera);
      if (pose == reg.world_from_camera.end()) continue;
      for (const MarkerObservation& m : observations) {
        rays.push_back({pose->second.translation, pose->second * m.camera_from_marker.translation});
      }
    }
    const size_t step =
        std::max<size_t>(1, (rays.size() + options.max_rays - 1) / std::max(1, options.max_rays));
    for (size_t i = 0; i < rays.size(); i += step) input.rays.push_back(rays[i]);
    if (rays.empty())
      result.notes.push_back("no marker detection in the dataset: no rays in the 3-D overview");
    SnapshotPicture picture;
    picture.kind = "overview_3d";
    picture.file = options.out / "overview_3d.png";
    picture.caption =
        "3-D overview: the robot's trajectory, every registered camera (frustum, "
        "axes, label) and marker detections as rays.";
    add(std::move(picture), renderOverview(input, plot_size));
    progress.report("snapshot: 3-D overview", 1, 1);
  }

  /// 4. Comparison with a reference (top and side views), ground truth trajectory.
  void comparison(const SnapshotOptions::Reference& ref) {
    const DatasetContents& data = data_;
    const RegistrationView& reg = reg_;
    const SnapshotOptions& options = options_;
    const ProgressReporter& progress = progress_;
    SnapshotResult& result = result_;
    const std::vector<Eigen::Vector3d>& trajectory = trajectory_;
    const cv::Size plot_size = plot_size_;
    progress.checkStop();
    const PoseComparison comparison =
        comparePoses(ref.poses, reg.poseSet(), CompareOptions{options.reference_with_scale});
    result.comparisons.push_back(comparison);
    // Draw in the reference's frame: the estimate is mapped by the alignment.
    PlotCameras estimate{reg.name, colours::kEstimate, {}, true};
    for (const auto& [label, pose] : reg.world_from_camera) {
      estimate.positions.push_back({label, comparison.reference_from_estimate * pose.translation});
    }
    PlotCameras reference{ref.name, colours::kReference, {}, false};
    for (const auto& [label, pose] : ref.poses.world_from_camera) {
      reference.positions.push_back({label, pose.translation});
    }
    std::vector<PlotTrajectory> trajectories;
    if (const auto gt = data.trajectories.find("ground_truth");
        gt != data.trajectories.end() && ref.name == "ground_truth") {
      PlotTrajectory truth{"ground truth trajectory", cv::Scalar(120, 200, 255), {}, 3};
      for (const StampedPose& s : gt->second) {
        truth.positions.push_back(s.world_from_body.translation);
      }
      trajectories.push_back(truth);
    }
    PlotTrajectory estimate_trajectory{reg.name + " trajectory", colours::kTrajectory, {}, 1};
    for (const auto& p : trajectory) {
      estimate_trajectory.positions.push_back(comparison.reference_from_estimate * p);
    }
    trajectories.push_back(estimate_trajectory);
    SnapshotPicture picture;
    picture.kind = "compare";
    picture.file = options.out / ("compare_top_side_vs_" + safeName(ref.name) + ".png");
    picture.caption = "Camera positions of " + reg.name + " (blue discs) against " + ref.name +
                      " (orange squares), top and side views, after " +
                      (options.reference_with_scale ? "Sim(3)" : "SE(3)") +
                      " alignment: position RMS " +
                      formatFixed(comparison.rms.position_m_total, 3) + " m, rotation RMS " +
                      formatFixed(comparison.rms.rotation_deg_total, 2) + " deg.";
    const cv::Mat drawn =
        drawTopSideView(reg.name + " vs " + ref.name + ": position RMS " +
                            formatFixed(comparison.rms.position_m_total, 3) + " m, rotation RMS " +
                            formatFixed(comparison.rms.rotation_deg_total, 2) + " deg",
                        {estimate, reference}, trajectories, plot_size, &picture.marks);
    add(std::move(picture), drawn);
  }

  /// Trajectories before and after loop closure (figure 8), when the dataset has both.
  void loopClosures() {
    const DatasetContents& data = data_;
    const SnapshotOptions& options = options_;
    const cv::Size plot_size = plot_size_;
    for (const auto& [label, samples] : data.trajectories) {
      static const std::string kSuffix = "_before_loop_closure";
      if (label.size() <= kSuffix.size() ||
          label.compare(label.size() - kSuffix.size(), kSuffix.size(), kSuffix) != 0) {
        continue;
      }
      const std::string closed = label.substr(0, label.size() - kSuffix.size());
      const auto after = data.trajectories.find(closed);
      if (after == data.trajectories.end()) continue;
      PlotTrajectory before_plot{label, colours::kBefore, {}, 2};
      for (const StampedPose& s : samples)
        before_plot.positions.push_back(s.world_from_body.translation);
      PlotTrajectory after_plot{closed + " (after loop closure)", cv::Scalar(0, 160, 0), {}, 2};
      for (const StampedPose& s : after->second)
        after_plot.positions.push_back(s.world_from_body.translation);
      SnapshotPicture picture;
      picture.kind = "loop_closure";
      picture.file = options.out / ("trajectory_loop_closure_" + safeName(closed) + ".png");
      picture.caption =
          "Trajectory " + closed + " before (red) and after (green) loop closure, top view.";
      const cv::Mat drawn = drawTopView("Trajectory " + closed + " before and after loop closure",
                                        {}, {before_plot, after_plot}, plot_size, &picture.marks);
      add(std::move(picture), drawn);
    }
  }

  const RegistrationView& reg_;
  const SnapshotOptions& options_;
  const ProgressReporter& progress_;
  const DatasetContents data_;
  cv::Size plot_size_;
  TimeNs start_ = 0;
  std::vector<Eigen::Vector3d> trajectory_;  ///< The registration's, for the plots.
  SnapshotResult result_;
};

}  // namespace

FisheyeCheck makeFisheyeCheck(const RegistrationView& reg, const Camera& fisheye, TimeNs t,
                              const std::vector<Eigen::Vector2d>& frame_blobs) {
  std::multimap<TimeNs, const ReprojectionRow*> rows_by_time;
  for (const ReprojectionRow& row : reg.blob_associations)
    if (row.t == t) rows_by_time.emplace(row.t, &row);
  return makeCheck(reg, fisheye, t, frame_blobs, rows_by_time);
}

SnapshotResult writeSnapshots(const fs::path& dataset, const RegistrationView& reg,
                              const SnapshotOptions& options, const ProgressReporter& progress) {
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  return SnapshotWriter(dataset, reg, options, progress).write();
}

}  // namespace lookboth::report
