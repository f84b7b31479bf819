#include "lookboth/detect/detect_dataset.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <deque>
#include <fstream>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "lookboth/core/config_layers.h"
#include "lookboth/core/error.h"
#include "lookboth/core/option_fields.h"
#include "lookboth/core/paths.h"
#include "lookboth/core/yaml_reader.h"
#include "lookboth/dataset/frame_decoder.h"
#include "lookboth/dataset/image_header.h"
#include "lookboth/detect/pass_search.h"

namespace lookboth {

namespace fs = std::filesystem;

std::string DetectConfig::check() const {
  if (std::string why = markers.check(); !why.empty()) return "markers." + why;
  if (std::string why = blobs.check(); !why.empty()) return "blobs." + why;
  return "";
}

// The keys of `detect.markers` and `detect.blobs`, in one list that reads
// and writes them (lookboth/core/option_fields.h; found by readOptions and
// writeOptions through argument-dependent lookup).
static void fields(MarkerDetectorOptions& o, OptionFields& f) {
  f.integer("detect_scale", o.detect_scale);
  f.flag("track_roi", o.track_roi);
  f.number("roi_margin", o.roi_margin);
  f.flag("refine_edges", o.refine_edges);
  f.number("corner_sigma_px", o.corner_sigma_px);
  f.number("min_corner_sigma_px", o.min_corner_sigma_px);
  f.number("fallback_corner_sigma_px", o.fallback_corner_sigma_px);
  f.number("min_side_px", o.min_side_px);
  f.number("max_reprojection_px", o.max_reprojection_px);
  f.number("ambiguity_ratio", o.ambiguity_ratio);
  f.number("max_speed_mps", o.max_speed_mps);
  f.number("track_window_s", o.track_window_s);
  f.number("coarse_period_s", o.coarse_period_s);
  f.number("coarse_key_frames_max_s", o.coarse_key_frames_max_s);
  f.number("coarse_change_grey", o.coarse_change_grey);
  f.number("coarse_change_max_s", o.coarse_change_max_s);
  f.flag("coarse_key_frame_previews", o.coarse_key_frame_previews);
  f.numbersByLabel("fixed_marker_sizes_m", o.fixed_marker_sizes_m, "id: side [m]");
  f.integer("fixed_marker_frames", o.fixed_marker_frames);
}

static void fields(BlobDetectorOptions& o, OptionFields& f) {
  f.number("min_threshold", o.min_threshold);
  f.number("max_threshold", o.max_threshold);
  f.number("threshold_step", o.threshold_step);
  f.integer("min_repeatability", o.min_repeatability);
  f.number("min_dist_between_blobs_px", o.min_dist_between_blobs_px);
  f.flag("dark", o.dark);
  f.number("min_area_px", o.min_area_px);
  f.number("max_area_px", o.max_area_px);
  f.number("min_circularity", o.min_circularity);
  f.number("min_convexity", o.min_convexity);
  f.number("min_inertia_ratio", o.min_inertia_ratio);
  f.number("min_contrast", o.min_contrast);
  f.number("max_darkness_ratio", o.max_darkness_ratio);
  f.number("housing_radius_m", o.housing_radius_m);
  f.number("min_housing_height_m", o.min_housing_height_m);
  f.number("max_housing_height_m", o.max_housing_height_m);
  f.number("housing_size_tolerance", o.housing_size_tolerance);
  f.number("max_rate_hz", o.max_rate_hz);
}

namespace {

/// Reads one section over `options`, then its check (naming the section's line).
template <typename Options>
void readSection(const YamlReader& r, const YAML::Node& node, const std::string& field,
                 Options& options) {
  readOptions(options, r, node, field);
  if (const std::string why = options.check(); !why.empty()) throw Error(r.at(node, field), why);
}

}  // namespace

namespace {

/// One layer's `detect:` section over `config`.
void readDetectLayer(const std::string& text, const std::string& source, DetectConfig& config) {
  const YamlReader reader(source);
  const YAML::Node root = reader.parse(text);
  reader.checkConfigRoot(root, text);
  const YAML::Node detect = root["detect"];
  if (!detect || detect.IsNull()) return;
  reader.rejectUnknownKeys(detect, {"markers", "blobs"}, "detect");
  if (detect["markers"] && !detect["markers"].IsNull())
    readSection(reader, detect["markers"], "detect.markers", config.markers);
  if (detect["blobs"] && !detect["blobs"].IsNull())
    readSection(reader, detect["blobs"], "detect.blobs", config.blobs);
}

}  // namespace

DetectConfig loadDetectConfig(const fs::path& yaml, const DetectConfig& base) {
  std::ifstream in(yaml);
  if (!in) throw Error({yaml.string(), 0, "", ""}, "cannot open the configuration file");
  std::stringstream text;
  text << in.rdbuf();
  DetectConfig config = base;
  readDetectLayer(text.str(), yaml.string(), config);
  return config;
}

DetectConfig detectConfigFrom(const std::vector<ConfigLayer>& layers) {
  DetectConfig config;
  for (const ConfigLayer& layer : layers) readDetectLayer(layer.text, layer.source, config);
  return config;
}

YAML::Node detectConfigYaml(const DetectConfig& config) {
  YAML::Node node, markers, blobs;
  writeOptions(config.markers, markers);
  writeOptions(config.blobs, blobs);
  node["markers"] = markers;
  node["blobs"] = blobs;
  return node;
}

DetectConfig defaultDetectConfig() {
  const fs::path file = shareDirectory() / "config" / "default.yaml";
  if (!fs::exists(file)) return DetectConfig{};
  return loadDetectConfig(file);
}

DetectConfig detectConfigFor(const std::optional<fs::path>& user_file) {
  return detectConfigFrom(configurationLayers(user_file));
}

std::string DetectOptions::check() const {
  if (dataset.empty()) return "'dataset': none given";
  if (threads < 0) return "'threads': must be >= 0";
  if (!markers && !blobs) return "nothing to detect (markers and blobs both off)";
  if (detections_only && out.empty())
    return "'detections_only': needs an output (--out); the dataset's frames stay where they are";
  return config.check();
}

namespace {

struct CameraWork {
  const CameraSensor* sensor = nullptr;
  bool fisheye = false;
  std::vector<ImageFrame> frames;
  /// The fisheye's frames searched for blobs (blobs.max_rate_hz), chosen
  /// over the whole recording: the same whatever its jobs.
  std::vector<bool> searched;
};

/// One job: a camera's frames [begin, end).
struct Job {
  size_t camera = 0;
  size_t begin = 0, end = 0;
};

struct JobResult {
  std::vector<Record> records;
  std::int64_t skipped = 0, blobs = 0, ambiguous = 0, unresolved = 0, rejected = 0;
  std::int64_t examined = 0;
  std::int64_t unchanged = 0;      ///< Of `examined`, coarse frames not searched (SceneChange).
  std::int64_t previews = 0;       ///< Coarse key frames searched as previews.
  std::int64_t fixed_markers = 0;  ///< Of `records`, the fixed markers' observations.
  bool coarse_key_frames = false;
  MarkerDetectorStats candidates;
  BlobDetectorStats blob_candidates;
  std::vector<DatasetIssue> issues;
};

/// Adds `more`'s counts to `total`.
void addStats(MarkerDetectorStats& total, const MarkerDetectorStats& more) {
  total.candidates += more.candidates;
  total.refined += more.refined;
  total.fallbacks += more.fallbacks;
  total.accepted += more.accepted;
  for (const auto& [why, n] : more.fallback_reasons) total.fallback_reasons[why] += n;
  for (const auto& [why, n] : more.rejected) total.rejected[why] += n;
}

/// Empty when the frame's size is the calibration's; else why it is skipped.
std::string sizeMismatch(const ImageFrame& frame, const Camera* camera, int width, int height) {
  if (!camera || (width == camera->width() && height == camera->height())) return "";
  return "image " + frameName(frame) + " is " + std::to_string(width) + "x" +
         std::to_string(height) + ", the calibration " + std::to_string(camera->width()) + "x" +
         std::to_string(camera->height()) + "; frame skipped";
}

/// A job's frames as grey pixels, each checked on the way (its size against
/// the calibration, a damaged file: the frame is then skipped with its
/// reason). Image files are decoded when asked for. A video's frames are
/// kept, the last `keep` of them, so that a pass found late is examined
/// backwards without a seek per frame: decoded one after the other, or,
/// when the coarse frames are key frames decoded alone (`keys`: the job's
/// frames that are), those before one asked for behind them decoded at once,
/// from the key frame before it when that is within `keep`. `done` counts the
/// frames of the job's range [begin, end) passed; a frame skipped is counted,
/// and its reason given, once.
class JobFrames {
 public:
  JobFrames(const CameraWork& work, const Job& job, JobResult& result,
            std::atomic<std::int64_t>& done, size_t keep, std::vector<size_t> keys = {},
            bool previews = false)
      : work_(work),
        result_(result),
        done_(done),
        keep_(keep),
        eager_(keys.empty()),
        previews_(previews),
        keys_(std::move(keys)),
        end_(job.end),
        passed_(job.begin) {}
  ~JobFrames() { done_ += static_cast<std::int64_t>(end_ - std::min(end_, passed_)); }
  JobFrames(const JobFrames&) = delete;
  JobFrames& operator=(const JobFrames&) = delete;

  /// Frame i's pixels; empty when it is skipped.
  cv::Mat grey(size_t i) {
    pass(i);
    if (const cv::Mat* image = findKept(i)) return *image;
    if (!isVideoFrame(work_.frames[i]) || keep_ == 0) return decodeChecked(i);
    const size_t window = i + 1 > keep_ ? i + 1 - keep_ : 0;
    size_t from = i;  // a jump ahead: that frame alone
    if (i < next_) {
      // Behind: the frames before it too, for a walk backwards.
      from = window;
      const auto key = std::upper_bound(keys_.begin(), keys_.end(), i);
      if (key != keys_.begin() && i - *std::prev(key) < keep_) from = *std::prev(key);
    } else if (eager_ && i < next_ + keep_) {
      from = std::max(next_, window);  // ahead: every frame up to it
    }
    if (from != next_) kept_.clear();
    for (size_t j = from; j <= i; ++j) {
      kept_.emplace_back(j, decodeChecked(j));
      if (kept_.size() > keep_) kept_.pop_front();
    }
    next_ = i + 1;
    return kept_.back().second;
  }

  /// Frame i as a preview when it is one of the key frames decoded alone
  /// (FrameDecoder::decodePreview: not its exact pixels, not kept), else as
  /// grey(i) (`exact`). Enough to tell whether the view changed or shows the marker.
  cv::Mat preview(size_t i, bool& exact) {
    exact = true;
    if (!previews_ || keys_.empty() || !isVideoFrame(work_.frames[i]) ||
        !std::binary_search(keys_.begin(), keys_.end(), i))
      return grey(i);
    pass(i);
    if (const cv::Mat* image = findKept(i)) return *image;
    const std::optional<ImageSize> size = decoder_.size(work_.frames[i]);
    if (!size || !sizeMismatch(work_.frames[i], camera(), size->width, size->height).empty())
      return grey(i);  // skipped there, with its reason
    cv::Mat image = decoder_.decodePreview(work_.frames[i]);
    if (image.empty()) return grey(i);
    if (i != next_) kept_.clear();
    next_ = i + 1;
    exact = false;
    return image;
  }

 private:
  /// Frames up to i count as passed.
  void pass(size_t i) {
    if (i >= passed_) {
      done_ += static_cast<std::int64_t>(i + 1 - passed_);
      passed_ = i + 1;
    }
  }

  const Camera* camera() const { return work_.sensor->camera ? &*work_.sensor->camera : nullptr; }

  const cv::Mat* findKept(size_t i) const {
    for (const auto& [index, image] : kept_) {
      if (index == i) return &image;
    }
    return nullptr;
  }

  cv::Mat decodeChecked(size_t i) {
    const ImageFrame& frame = work_.frames[i];
    const Camera* camera = this->camera();
    // A frame of the wrong size would give detections at pixels the camera
    // does not have; a huge one would be decoded into gigabytes first.
    if (const std::optional<ImageSize> size = decoder_.size(frame)) {
      if (std::string why = sizeMismatch(frame, camera, size->width, size->height); !why.empty())
        return skip(i, std::move(why));
    }
    cv::Mat grey = decoder_.decode(frame, FrameColour::kGrey);
    if (grey.empty())
      return skip(i, "cannot decode image " + frameName(frame) + " (corrupt?); frame skipped");
    if (std::string why = sizeMismatch(frame, camera, grey.cols, grey.rows); !why.empty())
      return skip(i, std::move(why));
    return grey;
  }

  cv::Mat skip(size_t i, std::string why) {
    if (skipped_.insert(i).second) {
      ++result_.skipped;
      result_.issues.push_back({work_.sensor->label, std::move(why)});
    }
    return {};
  }

  const CameraWork& work_;
  JobResult& result_;
  std::atomic<std::int64_t>& done_;
  size_t keep_;
  bool eager_;
  bool previews_;
  std::vector<size_t> keys_;
  std::set<size_t> skipped_;
  size_t end_;
  FrameDecoder decoder_;
  std::deque<std::pair<size_t, cv::Mat>> kept_;
  size_t next_ = 0;  ///< The video frame after the last one decoded.
  size_t passed_;    ///< Frames before this one are behind the job.
};

/// The indices of a camera's frames that are key frames of their video.
std::vector<size_t> keyFrameIndices(const CameraWork& work) {
  FrameDecoder decoder;
  std::map<std::string, std::set<std::int64_t>> keys;
  std::vector<size_t> found;
  for (size_t i = 0; i < work.frames.size(); ++i) {
    const ImageFrame& frame = work.frames[i];
    if (!isVideoFrame(frame)) continue;
    auto it = keys.find(frame.video_file.string());
    if (it == keys.end()) {
      const std::vector<std::int64_t> list = decoder.keyFrames(frame);
      it = keys.emplace(frame.video_file.string(), std::set<std::int64_t>(list.begin(), list.end()))
               .first;
    }
    if (it->second.count(frame.video_frame)) found.push_back(i);
  }
  return found;
}

/// The coarse frames of a camera's video: its key frames when they are at
/// most `max_s` apart (median) and further apart than `step` frames; else
/// none (every step-th frame, the frames between decoded).
std::vector<size_t> keyFrameCoarse(const CameraWork& work, const std::vector<TimeNs>& times,
                                   size_t step, double max_s) {
  if (!(max_s > 0) || step <= 1 || work.frames.empty() || !isVideoFrame(work.frames.front()))
    return {};
  std::vector<size_t> keys = keyFrameIndices(work);
  if (keys.size() < 2) return {};
  std::vector<TimeNs> key_times;
  for (size_t k : keys) key_times.push_back(times[k]);
  std::vector<TimeNs> gaps;
  std::vector<size_t> index_gaps;
  for (size_t k = 1; k < keys.size(); ++k) {
    gaps.push_back(key_times[k] - key_times[k - 1]);
    index_gaps.push_back(keys[k] - keys[k - 1]);
  }
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  std::nth_element(index_gaps.begin(), index_gaps.begin() + index_gaps.size() / 2,
                   index_gaps.end());
  if (static_cast<double>(gaps[gaps.size() / 2]) * 1e-9 > max_s) return {};
  if (index_gaps[index_gaps.size() / 2] <= step) return {};
  return keys;
}

/// One fisheye frame's blobs, as a record.
BlobObservation blobRecord(const BlobDetector& detector, TimeNs t, const std::string& label,
                           const cv::Mat& grey, BlobDetectorStats* stats) {
  BlobObservation obs;
  obs.t = t;
  obs.camera = label;
  obs.image_width = grey.cols;
  obs.image_height = grey.rows;
  obs.blobs = detector.detect(grey, stats);
  return obs;
}

JobResult runFisheyeJob(const CameraWork& work, const Job& job, const DetectConfig& config,
                        std::atomic<std::int64_t>& done, const std::atomic<bool>& stop) {
  JobResult result;
  BlobDetector detector(config.blobs, work.sensor->camera ? &*work.sensor->camera : nullptr);
  JobFrames frames(work, job, result, done, 0);
  for (size_t i = job.begin; i < job.end && !stop.load(); ++i) {
    if (!work.searched[i]) continue;
    const cv::Mat grey = frames.grey(i);
    if (grey.empty()) continue;
    BlobObservation obs =
        blobRecord(detector, work.frames[i].t, work.sensor->label, grey, &result.blob_candidates);
    result.blobs += static_cast<std::int64_t>(obs.blobs.size());
    result.records.push_back(std::move(obs));
  }
  return result;
}

/// The markers fixed in the facility (fixed_marker_sizes_m), each searched
/// in the whole of `fixed_marker_frames` frames spread over the camera's
/// recording; one marker's detections are a track of their own, over which
/// its pose ambiguity is resolved.
void detectFixedMarkers(const CameraWork& work, const DetectConfig& config, const MarkerSpec& robot,
                        JobFrames& frames, const std::vector<TimeNs>& times, JobResult& result) {
  const MarkerDetectorOptions& options = config.markers;
  if (options.fixed_marker_sizes_m.empty() || times.empty()) return;
  std::vector<MarkerDetector> detectors;
  for (const auto& [key, size] : options.fixed_marker_sizes_m) {
    MarkerSpec spec = robot;
    spec.id = parseFixedMarkerId(key).value_or(0);
    spec.size_m = size;
    detectors.emplace_back(spec, *work.sensor->camera, options);
  }
  const size_t n = times.size();
  const size_t count = std::min<size_t>(n, static_cast<size_t>(options.fixed_marker_frames));
  std::set<size_t> chosen;
  for (size_t k = 0; k < count; ++k) chosen.insert(count == 1 ? n / 2 : k * (n - 1) / (count - 1));
  std::vector<std::vector<std::pair<TimeNs, MarkerDetection>>> found(detectors.size());
  for (const size_t i : chosen) {
    const cv::Mat grey = frames.grey(i);
    if (grey.empty()) continue;
    for (size_t d = 0; d < detectors.size(); ++d) {
      detectors[d].resetTrack();
      for (MarkerDetection& m : detectors[d].detect(grey))
        found[d].emplace_back(times[i], std::move(m));
    }
  }
  for (auto& track : found) {
    std::vector<MarkerDetection*> pointers;
    for (auto& [t, m] : track) pointers.push_back(&m);
    resolveAmbiguity(pointers);
    for (const auto& [t, m] : track) {
      result.records.push_back(toMarkerObservation(m, t, work.sensor->label));
      ++result.fixed_markers;
    }
  }
}

/// Examines a camera's frames for the marker, one at a time as PassSearch
/// asks. A coarse frame is first compared with the last coarse frame searched
/// and found without a candidate (SceneChange) and, a video's key frame, seen
/// as a preview (decoded without the loop filter); the markers kept are
/// always those of the exact frame, decoded when the preview shows a candidate.
class MarkerExaminer {
 public:
  MarkerExaminer(MarkerDetector& detector, JobFrames& frames, const std::vector<TimeNs>& times,
                 const MarkerDetectorOptions& options, size_t step, JobResult& result)
      : detector_(detector),
        frames_(frames),
        times_(times),
        view_(step > 1 ? options.coarse_change_grey : 0.0),
        max_unchanged_ns_(static_cast<TimeNs>(std::llround(options.coarse_change_max_s * 1e9))),
        result_(result),
        found_(times.size()) {}

  /// PassSearch's examine(i, coarse): whether frame i shows the marker.
  bool operator()(size_t i, bool coarse) {
    // The track (where to look first) holds from one frame to the next only.
    if (!last_ || (i != *last_ + 1 && i + 1 != *last_)) detector_.resetTrack();
    last_ = i;
    if (!coarse) {
      view_.forget();
      const cv::Mat grey = frames_.grey(i);
      if (grey.empty()) return lost();
      found_[i] = detector_.detect(grey);
      return !found_[i].empty();
    }
    bool exact = true;
    const cv::Mat grey = frames_.preview(i, exact);
    if (grey.empty()) {
      view_.forget();
      return lost();
    }
    return examineCoarse(i, grey, exact);
  }

  /// The markers found in each frame, taken.
  std::vector<std::vector<MarkerDetection>> takeFound() { return std::move(found_); }

 private:
  bool lost() {
    detector_.resetTrack();
    return false;
  }

  /// A coarse frame: not searched while the view is unchanged (for at most
  /// coarse_change_max_s after the frame compared with); else searched on
  /// its preview, and on its exact pixels when the preview shows a candidate.
  bool examineCoarse(size_t i, const cv::Mat& grey, bool exact) {
    const bool changed = view_.changed(grey);
    if (!changed && times_[i] - reference_t_ <= max_unchanged_ns_) {
      ++result_.unchanged;
      return false;
    }
    const MarkerDetectorStats before = detector_.stats();
    found_[i] = detector_.detect(grey);
    const bool candidate = detector_.stats().candidates > before.candidates;
    result_.previews += exact ? 0 : 1;
    if (!exact && candidate) {
      // The preview's search counts once: the exact frame's is the one kept.
      detector_.setStats(before);
      detector_.resetTrack();
      const cv::Mat pixels = frames_.grey(i);
      if (pixels.empty()) return lost();
      found_[i] = detector_.detect(pixels);
    }
    // Only a view without a square of the marker's id is compared with: a
    // marker barely seen is searched for again in the frames after it.
    if (candidate) {
      view_.forget();
    } else {
      view_.keep();
      reference_t_ = times_[i];
    }
    return !found_[i].empty();
  }

  MarkerDetector& detector_;
  JobFrames& frames_;
  const std::vector<TimeNs>& times_;
  SceneChange view_;
  TimeNs max_unchanged_ns_;
  TimeNs reference_t_ = 0;
  JobResult& result_;
  std::vector<std::vector<MarkerDetection>> found_;
  std::optional<size_t> last_;
};

/// One environment camera's frames searched for the marker (PassSearch: one
/// frame in `coarse_period_s`, every frame around the passes; MarkerExaminer),
/// then its track: outliers rejected, the pose ambiguity resolved.
JobResult runMarkerJob(const CameraWork& work, const Job& job, const DetectConfig& config,
                       const MarkerSpec& marker, std::atomic<std::int64_t>& done,
                       const std::atomic<bool>& stop) {
  JobResult result;
  MarkerDetector detector(marker, *work.sensor->camera, config.markers);
  std::vector<TimeNs> times;
  for (const ImageFrame& frame : work.frames) times.push_back(frame.t);
  const size_t step = coarseStep(times, config.markers.coarse_period_s);
  // Key frames as coarse frames: the frames between them are not decoded;
  // a walk backwards from one then needs up to a key interval before it.
  const std::vector<size_t> keys =
      keyFrameCoarse(work, times, step, config.markers.coarse_key_frames_max_s);
  const size_t interval = keys.size() > 1 ? (keys.back() - keys.front()) / (keys.size() - 1) : 0;
  const size_t keep = step <= 1 ? 1 : std::min<size_t>(64, std::max(2 * step + 1, interval + step));
  JobFrames frames(work, job, result, done, keep, keys, config.markers.coarse_key_frame_previews);
  PassSearch search = keys.empty() ? PassSearch(work.frames.size(), step)
                                   : PassSearch(work.frames.size(), step, keys);
  result.coarse_key_frames = !keys.empty();
  MarkerExaminer examiner(detector, frames, times, config.markers, step, result);
  search.run([&](size_t i, bool coarse) { return examiner(i, coarse); }, stop);
  std::vector<std::vector<MarkerDetection>> found = examiner.takeFound();
  result.examined = static_cast<std::int64_t>(search.examined());
  std::vector<std::pair<TimeNs, MarkerDetection>> detections;
  for (size_t i = 0; i < found.size(); ++i) {
    for (MarkerDetection& d : found[i]) detections.emplace_back(times[i], std::move(d));
  }
  result.rejected =
      rejectTrackOutliers(detections, config.markers.max_speed_mps,
                          static_cast<TimeNs>(std::llround(config.markers.track_window_s * 1e9)));
  std::vector<MarkerDetection*> track;
  for (auto& [t, d] : detections) track.push_back(&d);
  result.unresolved = resolveAmbiguity(track);
  result.candidates = detector.stats();
  for (const auto& [t, d] : detections) {
    result.ambiguous += d.ambiguous ? 1 : 0;
    result.records.push_back(toMarkerObservation(d, t, work.sensor->label));
  }
  detectFixedMarkers(work, config, marker, frames, times, result);
  return result;
}

/// The robot's marker is never a fixed one (its detections would be written
/// under its id at the fixed marker's size).
void checkFixedMarkers(const MarkerDetectorOptions& options, const Manifest& manifest,
                       const std::string& source) {
  for (const auto& [key, size] : options.fixed_marker_sizes_m) {
    if (parseFixedMarkerId(key) == manifest.marker.id) {
      throw Error({source, 0, "detect.markers.fixed_marker_sizes_m", key},
                  "marker " + std::to_string(manifest.marker.id) +
                      " is the robot's (the manifest's marker), not a fixed one");
    }
  }
}

JobResult runJob(const CameraWork& work, const Job& job, const DetectConfig& config,
                 const MarkerSpec& marker, std::atomic<std::int64_t>& done,
                 const std::atomic<bool>& stop) {
  return work.fisheye ? runFisheyeJob(work, job, config, done, stop)
                      : runMarkerJob(work, job, config, marker, done, stop);
}

}  // namespace

std::vector<Record> runDetection(const DetectOptions& options, const ProgressReporter& progress,
                                 DetectSummary* summary) {
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  DatasetReadOptions read_options;
  read_options.on_issue = options.on_issue;
  std::unique_ptr<DatasetReader> reader = DatasetReader::open(options.dataset, read_options);
  const Manifest& manifest = reader->manifest();
  const std::string source = options.dataset.string();
  checkFixedMarkers(options.config.markers, manifest, source);

  // Which cameras.
  std::vector<CameraWork> work;
  std::map<std::string, size_t> index;
  std::set<std::string> wanted(options.cameras.begin(), options.cameras.end());
  for (const std::string& label : wanted) {
    if (!manifest.findCamera(label)) {
      throw Error({source, 0, "--cameras", label}, "the dataset has no camera with this label");
    }
  }
  for (const CameraSensor& sensor : manifest.cameras) {
    if (!wanted.empty() && !wanted.count(sensor.label)) continue;
    const bool fisheye = sensor.role == SensorRole::kFisheye;
    if (fisheye ? !options.blobs : !options.markers) continue;
    if (!fisheye && !sensor.camera) {
      const DatasetIssue issue{sensor.label, "no calibration in the manifest; camera skipped"};
      if (!wanted.empty()) throw Error({source, 0, "cameras", sensor.label}, issue.message);
      if (options.on_issue) options.on_issue(issue);
      if (summary) summary->issues.push_back(issue);
      continue;
    }
    index[sensor.label] = work.size();
    work.push_back({&sensor, fisheye, {}, {}});
  }

  // Read sequentially: the frames of the chosen cameras.
  std::int64_t read = 0;
  const std::int64_t expected = reader->expectedCount();
  while (std::optional<Record> record = reader->next()) {
    if (++read % 256 == 0) {
      progress.checkStop();
      progress.report("detect: read", read, std::max<std::int64_t>(0, expected));
    }
    auto* frame = std::get_if<ImageFrame>(&*record);
    if (!frame) continue;
    const auto it = index.find(frame->sensor);
    if (it == index.end()) continue;
    work[it->second].frames.push_back(std::move(*frame));
  }
  if (summary) {
    summary->issues.insert(summary->issues.end(), reader->issues().begin(), reader->issues().end());
  }
  // Jobs: one per environment camera, chunks of the fisheye's frames.
  std::vector<Job> jobs;
  std::int64_t total = 0;
  const int wanted_threads =
      options.threads > 0 ? options.threads
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (size_t c = 0; c < work.size(); ++c) {
    std::stable_sort(work[c].frames.begin(), work[c].frames.end(),
                     [](const ImageFrame& a, const ImageFrame& b) { return a.t < b.t; });
    total += static_cast<std::int64_t>(work[c].frames.size());
    const size_t n = work[c].frames.size();
    RateLimiter rate(work[c].fisheye ? options.config.blobs.max_rate_hz : 0);
    for (const ImageFrame& frame : work[c].frames) work[c].searched.push_back(rate.keep(frame.t));
    // A chunk of a video starts with a seek and decodes from the key frame
    // before it: a video's chunks are as long as the threads allow.
    const bool video = n > 0 && isVideoFrame(work[c].frames.front());
    const size_t threads = static_cast<size_t>(wanted_threads);
    const size_t chunk = !work[c].fisheye ? std::max<size_t>(n, 1)
                         : video          ? std::max<size_t>(64, (n + threads - 1) / threads)
                                          : 64;
    for (size_t begin = 0; begin < n; begin += chunk) {
      jobs.push_back({c, begin, std::min(n, begin + chunk)});
    }
  }
  // The longest jobs first (better balance); results are kept per job.
  std::vector<size_t> order(jobs.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return jobs[a].end - jobs[a].begin > jobs[b].end - jobs[b].begin;
  });
  std::vector<JobResult> results(jobs.size());
  std::atomic<size_t> next{0};
  std::atomic<std::int64_t> done{0};
  std::atomic<bool> stop{false};
  std::atomic<int> running{0};
  std::mutex error_mutex;
  std::exception_ptr error;
  const int threads = std::max(
      1, std::min<int>(wanted_threads, static_cast<int>(std::max<size_t>(1, jobs.size()))));
  // Workers leave as soon as the stop flag is up; the loop below waits for
  // all of them (not for the job queue to drain, which never happens then).
  auto worker = [&] {
    struct Leaving {
      std::atomic<int>& running;
      ~Leaving() { --running; }
    } leaving{running};
    for (;;) {
      const size_t k = next++;
      if (k >= order.size() || stop.load()) return;
      const Job& job = jobs[order[k]];
      try {
        results[order[k]] =
            runJob(work[job.camera], job, options.config, manifest.marker, done, stop);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        stop = true;
      }
    }
  };
  const auto started = std::chrono::steady_clock::now();
  std::vector<std::thread> pool;
  running = threads;
  for (int i = 0; i < threads; ++i) pool.emplace_back(worker);
  bool stopped = false;
  while (running.load() > 0) {
    progress.report("detect", done.load(), total);
    if (progress.stopRequested()) {
      stop = true;
      stopped = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  if (stopped || progress.stopRequested()) throw StopRequested();
  progress.report("detect", total, total);

  // Assemble in job order (deterministic), per camera.
  std::vector<Record> records;
  if (summary) summary->cameras.clear();
  std::vector<CameraDetectSummary> per_camera(work.size());
  for (size_t c = 0; c < work.size(); ++c) {
    per_camera[c].camera = work[c].sensor->label;
    per_camera[c].fisheye = work[c].fisheye;
    per_camera[c].frames = static_cast<std::int64_t>(work[c].frames.size());
  }
  for (size_t j = 0; j < jobs.size(); ++j) {
    JobResult& r = results[j];
    CameraDetectSummary& s = per_camera[jobs[j].camera];
    s.skipped += r.skipped;
    s.blobs += r.blobs;
    s.ambiguous += r.ambiguous;
    s.unresolved += r.unresolved;
    s.rejected += r.rejected;
    s.examined += r.examined;
    s.unchanged += r.unchanged;
    s.previews += r.previews;
    s.coarse_key_frames = s.coarse_key_frames || r.coarse_key_frames;
    addStats(s.marker_candidates, r.candidates);
    s.blob_candidates.add(r.blob_candidates);
    s.detections += static_cast<std::int64_t>(r.records.size()) - r.fixed_markers;
    s.fixed_markers += r.fixed_markers;
    for (DatasetIssue& issue : r.issues) {
      if (options.on_issue) options.on_issue(issue);
      if (summary) summary->issues.push_back(issue);
    }
    for (Record& record : r.records) records.push_back(std::move(record));
  }
  if (summary) {
    summary->cameras = per_camera;
    for (const CameraWork& w : work) {
      if (w.fisheye) continue;
      for (const ImageFrame& f : w.frames) summary->searched.emplace_back(w.sensor->label, f.t);
    }
    summary->detect_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  }
  return records;
}

FisheyeBlobSearch::FisheyeBlobSearch(const CameraSensor& fisheye, const DetectConfig& config)
    : label_(fisheye.label),
      camera_(fisheye.camera),
      detector_(config.blobs, fisheye.camera ? &*fisheye.camera : nullptr),
      rate_(config.blobs.max_rate_hz) {
  summary_.camera = fisheye.label;
  summary_.fisheye = true;
}

bool FisheyeBlobSearch::wants(TimeNs t) {
  ++summary_.frames;
  return rate_.keep(t);
}

void FisheyeBlobSearch::search(const ImageFrame& frame, const cv::Mat& grey) {
  const Camera* camera = camera_ ? &*camera_ : nullptr;
  if (std::string why = sizeMismatch(frame, camera, grey.cols, grey.rows); !why.empty()) {
    ++summary_.skipped;
    issues_.push_back({label_, std::move(why)});
    return;
  }
  BlobObservation obs = blobRecord(detector_, frame.t, label_, grey, &summary_.blob_candidates);
  summary_.blobs += static_cast<std::int64_t>(obs.blobs.size());
  ++summary_.detections;
  records_.push_back(std::move(obs));
}

AugmentSummary writeDetections(const DetectOptions& options, std::vector<Record> records,
                               const DetectSummary& summary, const ProgressReporter& progress) {
  // A camera without frames in the dataset was not detected again: its
  // detections (a detections-only dataset's, say) are its only ones and stay.
  std::set<std::string> marker_cameras, blob_cameras;
  for (const CameraDetectSummary& c : summary.cameras) {
    if (c.frames > 0) (c.fisheye ? blob_cameras : marker_cameras).insert(c.camera);
  }
  if (marker_cameras.empty() && blob_cameras.empty()) {
    throw Error({options.dataset.string(), 0, "", ""},
                "no frames to detect in (a detections-only dataset?); nothing written, its "
                "detections are kept");
  }
  AugmentOptions augment;
  augment.input = options.dataset;
  augment.output = options.out;
  augment.overwrite = options.overwrite;
  augment.on_issue = options.on_issue;
  if (options.detections_only) {
    Manifest manifest = DatasetReader::open(options.dataset)->manifest();
    manifest.trajectories.clear();
    augment.manifest = manifest;
  }
  augment.drop = [&](const Record& record) {
    const bool detection = std::holds_alternative<MarkerObservation>(record) ||
                           std::holds_alternative<BlobObservation>(record);
    if (options.detections_only && !detection) return true;
    if (const auto* m = std::get_if<MarkerObservation>(&record))
      return marker_cameras.count(m->camera) > 0;
    if (const auto* b = std::get_if<BlobObservation>(&record))
      return blob_cameras.count(b->camera) > 0;
    return false;
  };
  return augmentDataset(augment, std::move(records), progress);
}

DetectSummary detectDataset(const DetectOptions& options, const ProgressReporter& progress) {
  DetectSummary summary;
  std::vector<Record> records = runDetection(options, progress, &summary);
  summary.written = writeDetections(options, std::move(records), summary, progress);
  return summary;
}

}  // namespace lookboth
