// Looking down: the robot's marker in an environment camera's frame.
//
// Pipeline per frame (doc/architecture.md, module `detect`):
//  1. candidates: OpenCV's ArUco detector (the contrib module's old API,
//     cv::aruco::detectMarkers) on a region of interest predicted from the
//     camera's previous detection, else on the whole frame reduced by
//     `detect_scale`; only the manifest's id of the manifest's dictionary is kept;
//  2. corners at full resolution by fitting the square's four edges through
//     the camera's own model: edge points located across each edge (the
//     blurred step's area integral), unprojected to bearings, a plane through
//     the optical centre fitted to each edge's bearings (a straight 3D edge
//     is a great circle of bearings whatever the lens), corners where
//     adjacent planes meet;
//  3. pose: IPPE for a square (both hypotheses) on the corners' normalised
//     coordinates, each refined by Gauss-Newton on the pixel reprojection
//     error through the camera model; covariance J^T J / sigma^2 of that
//     reprojection (sigma = corner_sigma_px);
//  4. the two-fold ambiguity: both hypotheses are kept; `resolveAmbiguity`
//     chooses, over one camera's track, the one whose marker normal agrees
//     with the track's (the robot drives on a floor, so the marker's normal
//     in a fixed camera's frame is nearly constant).
#pragma once

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/cameras/camera.h"
#include "lookboth/dataset/manifest.h"
#include "lookboth/dataset/records.h"
#include "lookboth/geometry/rigid3.h"

namespace lookboth {

struct MarkerDetectorOptions {
  /// Reduction of the frame for the whole-frame candidate search (1 = full
  /// resolution; 2 = a quarter of the pixels; 0 = automatic: 2 for frames
  /// wider than 1280 px, else 1). Corners are always refined at full resolution.
  int detect_scale = 0;
  /// Search first around the previous detection of the same camera (a box
  /// `roi_margin` times the marker's size around it); the whole frame when
  /// that fails.
  bool track_roi = true;
  double roi_margin = 1.0;  ///< Extra size on each side of the last marker box, in marker sides.
  /// Fit the square's edges through the camera model (else OpenCV's corners are used as they are).
  bool refine_edges = true;
  /// Corner noise assumed for the covariance when it cannot be measured
  /// (refine_edges off) [px]; with edge fitting, the corners' noise is
  /// estimated per detection from the edge points' scatter, plus (in
  /// quadrature) `min_corner_sigma_px` for what the scatter cannot show
  /// (blur asymmetry, aliasing, calibration error).
  double corner_sigma_px = 0.1;
  double min_corner_sigma_px = 0.03;  ///< [px]
  /// When the edge fit fails on a candidate OpenCV found (low contrast, no
  /// quiet zone, a corner the fit moves by pixels), its corners are OpenCV's
  /// refined by cv::cornerSubPix, with this noise (or their disagreement with
  /// OpenCV's, if larger) [px]: a marker OpenCV finds is never lost.
  double fallback_corner_sigma_px = 0.5;
  double min_side_px = 10;           ///< Shortest side of an accepted marker [px].
  double max_reprojection_px = 1.5;  ///< RMS corner reprojection error of an accepted pose [px].
  /// Hypotheses whose reprojection errors differ by less than this ratio are
  /// "ambiguous" (both plausible from this frame alone).
  double ambiguity_ratio = 2.0;
  /// Track consistency: a detection that no other detection of the same
  /// camera within `track_window_s` agrees with (positions within
  /// max_speed_mps * dt + 5 cm) is a false positive (e.g. a look-alike
  /// marker elsewhere); 0 = keep everything.
  double max_speed_mps = 1.5;   ///< [m/s]
  double track_window_s = 1.0;  ///< [s]
  /// Where the robot is not, the marker is not: a camera's frames are
  /// examined one per `coarse_period_s`, and every frame around those that
  /// show the marker (detect/pass_search.h); a pass shorter than this can
  /// be missed. 0 = every frame [s].
  double coarse_period_s = 0.2;
  /// In a video whose key frames are at most this far apart (median), the
  /// coarse frames are its key frames, which decode alone: the frames
  /// between them are not decoded at all. A pass shorter than the interval
  /// is then what can be missed. 0 = never [s].
  double coarse_key_frames_max_s = 1.0;
  /// A coarse frame whose view differs from the last coarse frame searched
  /// (and found empty) by at most this at every pixel, both averaged over
  /// 4x4 pixels and the exposure matched, is not searched: the robot cannot
  /// come into a fixed camera's view without changing it
  /// (detect/pass_search.h, SceneChange). On a real fixed camera's
  /// recording (tests/data/views/bgslibrary_road) empty views differed by 6
  /// (median) and 9 (99th percentile), a vehicle coming into view by 26.9
  /// or more. 0 = every coarse frame searched [grey levels of 255].
  double coarse_change_grey = 12;
  /// ... for at most this long after the frame compared with, which is then
  /// searched again: a marker at the edge of detection, still, gets a new
  /// chance with new noise [s].
  double coarse_change_max_s = 5.0;
  /// A video's coarse key frames are first decoded as previews, without the
  /// codec's loop filter (about 15 % faster), and exactly only when the
  /// preview shows a candidate of the marker; false = always exactly.
  bool coarse_key_frame_previews = true;
  /// Markers fixed in the facility (printed on the floor; the robot
  /// marker's dictionary, other ids): their sides [m] by id ("20": 0.3).
  /// Each camera looks for them, the whole frame, in `fixed_marker_frames`
  /// of its frames spread over its recording: a marker that does not move
  /// needs no more. They locate control points of `lookboth align`
  /// ("marker:<id>"). Empty: none.
  std::map<std::string, double> fixed_marker_sizes_m;
  int fixed_marker_frames = 10;
  std::string check() const;
};

/// A fixed marker's id from its key in fixed_marker_sizes_m ("20"); nullopt
/// when the key is not a whole number of 0 or more.
std::optional<int> parseFixedMarkerId(const std::string& key);

/// One pose hypothesis of a detected square.
struct MarkerPoseHypothesis {
  Rigid3d camera_from_marker;
  double reprojection_rms_px = 0;  ///< Over the 4 corners.
  /// Information over [dt (m); dtheta (rad)] as in MarkerObservation.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
};

struct MarkerDetection {
  int marker_id = 0;
  /// Refined corners [px], OpenCV ArUco order: the marker's (-s/2, s/2),
  /// (s/2, s/2), (s/2, -s/2), (-s/2, -s/2) in its frame (x right, y up).
  std::array<Eigen::Vector2d, 4> corners_px = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(),
                                               Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  /// Standard deviation of one corner coordinate [px]: measured from the
  /// edge points' scatter (plus min_corner_sigma_px in quadrature) when edges
  /// are fitted, else the options' corner_sigma_px. The hypotheses'
  /// information assumes it.
  double corner_sigma_px = 0;
  /// Best first (lowest reprojection error); one or two hypotheses.
  std::vector<MarkerPoseHypothesis> hypotheses;
  /// Index of the chosen hypothesis (set by resolveAmbiguity; 0 before).
  int chosen = 0;
  /// True when the frame alone cannot tell the hypotheses apart
  /// (error ratio below MarkerDetectorOptions::ambiguity_ratio).
  bool ambiguous = false;
  /// True when resolveAmbiguity could not decide (no consistent track).
  bool unresolved = false;
  const MarkerPoseHypothesis& pose() const { return hypotheses.at(static_cast<size_t>(chosen)); }
};

/// What became of the candidates of the marker's id that OpenCV found, over
/// a detector's frames: the edge fit, the fallback to OpenCV's corners, and
/// the reason of each rejection (with a count).
struct MarkerDetectorStats {
  std::int64_t candidates = 0;  ///< Squares of the marker's id found by OpenCV.
  std::int64_t refined = 0;     ///< Corners from the edge fit.
  std::int64_t fallbacks = 0;   ///< Corners from cv::cornerSubPix: the edge fit failed.
  std::map<std::string, std::int64_t> fallback_reasons;  ///< Why the edge fit failed.
  std::map<std::string, std::int64_t> rejected;          ///< Why a candidate was dropped.
  std::int64_t accepted = 0;                             ///< Detections returned.
};

/// Detects the manifest's marker (or one of a custom dictionary: see
/// withDictionaryFile) in one camera's frames. Not thread-safe:
/// one detector per camera (it remembers where the marker was last seen).
class MarkerDetector {
 public:
  /// Throws lookboth::Error when the marker spec or the options are invalid.
  MarkerDetector(const MarkerSpec& marker, const Camera& camera,
                 const MarkerDetectorOptions& options = {});
  /// A marker of a custom ArUco dictionary, one MarkerSpec cannot name (it
  /// names OpenCV's predefined dictionaries only), e.g. the one of OpenCV's
  /// board tutorial. `dictionary_file`: OpenCV FileStorage YAML or XML as
  /// cv::aruco::Dictionary::readDictionary reads it (`nmarkers`,
  /// `markersize` in bits per side without the border, optional
  /// `maxCorrectionBits`, `marker_0`... each a string of markersize^2 '0'/'1'
  /// bits row by row); `id`: the marker's index in it; `size_m`: the side of
  /// its black square [m]. Throws lookboth::Error naming the file when it
  /// cannot be read as such a dictionary or holds no marker `id`, and when
  /// the size or the options are invalid.
  static MarkerDetector withDictionaryFile(const std::filesystem::path& dictionary_file, int id,
                                           double size_m, const Camera& camera,
                                           const MarkerDetectorOptions& options = {});
  ~MarkerDetector();
  MarkerDetector(MarkerDetector&&) noexcept;

  /// Detections of the marker (at most one per distinct square; usually 0 or 1)
  /// in a greyscale (CV_8UC1) frame of this camera's size.
  std::vector<MarkerDetection> detect(const cv::Mat& grey);
  /// Forgets the previous detection (the next frame is searched whole).
  void resetTrack();

  /// Step 2 alone: corners refined by edge fitting from approximate ones
  /// (within ~1 px); nullopt when an edge cannot be located. When
  /// `corner_sigma_px` is given, it receives the corners' standard deviation
  /// estimated from the scatter of the edge points about their fitted edges
  /// (per axis: sigma_edge * sqrt(1/N + (extrapolation)^2 / sum of squares)).
  std::optional<std::array<Eigen::Vector2d, 4>> refineCorners(
      const cv::Mat& grey, const std::array<Eigen::Vector2d, 4>& corners_px,
      double* corner_sigma_px = nullptr, std::string* why_not = nullptr) const;
  /// Step 3 alone: both pose hypotheses from 4 corners (ArUco order), best
  /// first; empty when degenerate. The information assumes corner noise
  /// `corner_sigma_px` (<= 0: the options' corner_sigma_px).
  std::vector<MarkerPoseHypothesis> solvePose(const std::array<Eigen::Vector2d, 4>& corners_px,
                                              double corner_sigma_px = 0) const;

  const MarkerDetectorOptions& options() const { return options_; }
  /// Counts over every frame detect() saw.
  const MarkerDetectorStats& stats() const { return stats_; }
  /// Sets the counts back (a frame searched twice, as a preview and then
  /// exactly, counts once).
  void setStats(MarkerDetectorStats stats) { stats_ = std::move(stats); }

 private:
  /// OpenCV's corners refined by cv::cornerSubPix at full resolution, and
  /// their noise (see fallback_corner_sigma_px).
  std::array<Eigen::Vector2d, 4> subPixelCorners(const cv::Mat& grey,
                                                 const std::array<Eigen::Vector2d, 4>& corners_px,
                                                 double* corner_sigma_px) const;
  /// The candidate's corners and noise, by the edge fit or the fallback.
  std::array<Eigen::Vector2d, 4> cornersOf(const cv::Mat& grey,
                                           const std::array<Eigen::Vector2d, 4>& candidate,
                                           double* corner_sigma_px);
  struct Impl;
  /// The construction common to both dictionary sources: `impl` holds the
  /// camera, the dictionary and the marker's id.
  MarkerDetector(std::unique_ptr<Impl> impl, double size_m, const MarkerDetectorOptions& options);
  MarkerDetectorStats stats_;
  std::unique_ptr<Impl> impl_;
  MarkerDetectorOptions options_;
};

/// Chooses among the hypotheses of one camera's detections (in time order)
/// by agreement of the marker's normal (its z axis in the camera frame)
/// with the track's: the normal that most detections have a hypothesis
/// within `agreement_deg` of (ties: lower reprojection errors). Every
/// detection with two hypotheses takes the one nearest that normal (even a
/// frame that looked unambiguous alone: noise can favour the wrong one by
/// more than the ratio); when neither agrees (or the track has fewer than two
/// agreeing detections) the best-fitting one is kept and an ambiguous
/// detection is marked `unresolved`. Returns the number of unresolved detections.
int resolveAmbiguity(std::vector<MarkerDetection*>& track, double agreement_deg = 10.0);

/// Removes the detections of one camera's track (in time order) that no
/// neighbour within `window` agrees with (see MarkerDetectorOptions::
/// max_speed_mps); a detection without neighbours is kept. Returns the number removed.
int rejectTrackOutliers(std::vector<std::pair<TimeNs, MarkerDetection>>& track,
                        double max_speed_mps, TimeNs window);

/// The MarkerObservation of a detection's chosen hypothesis, with the
/// detection's refined corners and their noise.
MarkerObservation toMarkerObservation(const MarkerDetection& detection, TimeNs t,
                                      const std::string& camera);

}  // namespace lookboth
