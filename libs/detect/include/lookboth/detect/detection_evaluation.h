// Detections against a simulated dataset's ground truth (the manifest's
// `ground_truth` and the "ground_truth" trajectory: world_from_fisheye at the
// fisheye's frame times, robot clock).
//
// For an environment camera's frame stamped t in its own clock:
//   t_robot = t - clock_offset[camera]            (offset = node clock - robot clock)
//   camera_from_marker_true = world_from_camera^-1 * world_from_fisheye(t_robot)
//                             * fisheye_from_marker
// For a fisheye frame: each housing centre (the camera's optical centre,
// world_from_camera.translation) projected through the fisheye at
// world_from_fisheye(t).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/dataset/manifest.h"
#include "lookboth/dataset/records.h"
#include "lookboth/geometry/trajectory.h"

namespace lookboth {

/// The ground truth a dataset carries, ready for queries.
struct GroundTruthView {
  Manifest manifest;
  Trajectory world_from_fisheye;  ///< The "ground_truth" trajectory.
  /// True pose of the marker in `camera` at that camera's stamp t; nullopt
  /// when the trajectory does not cover it or the ground truth lacks the camera.
  std::optional<Rigid3d> cameraFromMarker(const std::string& camera, TimeNs t) const;
};

struct MarkerErrorBand {
  double min_distance_m = 0, max_distance_m = 0;
  int count = 0;
  double median_position_mm = 0, p90_position_mm = 0;
  double median_in_plane_deg = 0, median_tilt_deg = 0;
  double median_along_sight_mm = 0;  ///< Signed, + = too far.
};

struct MarkerEvaluation {
  std::vector<MarkerErrorBand> bands;  ///< Plus one "all" band at the end.
  int visible_frames = 0;   ///< Frames whose true marker is in view (see evaluateMarkers).
  int detected_frames = 0;  ///< Of those, frames with a correct detection.
  int false_positives =
      0;  ///< Detections further than 0.1 m from the truth, or in frames without the marker.
  int detections = 0;
  /// "cam03 @ 1700000012.300000000 s: 1.234 m off" for each false positive.
  std::vector<std::string> false_positive_notes;
  double mean_nees = 0;  ///< Mean of e^T I e over correct detections (6 degrees of freedom).
  /// Whether a pass's errors average out, as an adjustment that treats
  /// detections as independent assumes. Per pass (a camera's correct
  /// detections with no gap over 1 s, at least 3), each error is taken as a
  /// perturbation delta_i of the camera's pose (the bias a pass leaves in the
  /// camera), and the information-weighted mean delta_p = H^-1 sum I_i delta_i
  /// (H = sum I_i) gives the NEES delta_p^T H delta_p. Independent errors give
  /// 6 on average; errors shared across the pass (a bias of the detector or of
  /// the camera model at that viewing geometry) give more.
  double mean_pass_nees = 0;
  int passes = 0;
  double mean_pass_detections = 0;
  /// beta of the model "each detection's error has a part shared by its pass,
  /// of beta times its own covariance": E[NEES_p] = 6 s (1 + beta n_p), pooled
  /// over the passes, with s = mean_nees / 6 the detections' own scale. A pass is then worth at
  /// most 1/beta detections (CalibOptions' joint.pass_error_share uses it).
  double pass_error_share = 0;
  double recall() const { return visible_frames ? double(detected_frames) / visible_frames : 0.0; }
};

/// Scores marker observations. `frames` lists every environment-camera
/// frame (label, stamp) that was searched; a frame counts as visible when the
/// true marker's 4 corners project at least 2 px inside the image, it faces
/// the camera within 60 deg and its shortest projected side is >= min_side_px
/// (occlusion by other objects is not modelled). Bands are by true distance
/// [m], `band_edges` ascending.
MarkerEvaluation evaluateMarkers(const GroundTruthView& truth,
                                 const std::vector<MarkerObservation>& detections,
                                 const std::vector<std::pair<std::string, TimeNs>>& frames,
                                 const std::vector<double>& band_edges, double min_side_px = 12);

/// Housings by their distance from the fisheye (the camera's optical centre, true pose).
struct BlobBand {
  double min_distance_m = 0, max_distance_m = 0;
  int expected = 0, matched = 0;
  double median_error_px = 0;  ///< Of the matched ones.
  double recall() const { return expected ? double(matched) / expected : 0.0; }
};

struct BlobEvaluation {
  /// Per distance band (`band_edges`); false positives have no true
  /// distance and are counted only in all.
  std::vector<BlobBand> bands;
  int frames = 0;
  /// Housing centres projected inside the image (2 px margin), in front,
  /// and not hidden from the fisheye (GroundTruth::hidden_from_fisheye).
  int expected = 0;
  int matched = 0;          ///< Expected ones with a blob within `match_px`.
  int false_positives = 0;  ///< Blobs matched to no housing.
  /// Housings inside the image that the dataset's ground truth says the
  /// world hides from the fisheye, and how many of them had a blob anyway
  /// (a dome's rim showing past a beam): neither a miss nor a false positive.
  int hidden = 0, hidden_matched = 0;
  /// Whether the dataset says which housings are hidden; when not, hidden
  /// ones count as expected and recall is a lower bound.
  bool knows_hidden = false;
  double median_error_px = 0, p90_error_px = 0;
  /// As MarkerEvaluation's, for each housing's matched blobs (passes of at
  /// least 3 with no gap over 1 s; errors in pixels, scaled by one blob's
  /// error from their median): NEES of a pass's mean error (2 expected when
  /// independent) and the share of a blob's error its pass shares.
  int passes = 0;
  double mean_pass_nees = 0;
  double pass_error_share = 0;
  /// The shared part's sigma per coordinate [px]: the joint's
  /// blob_pass_error_share is its square over blob_sigma_px's.
  double shared_error_px = 0;
  double recall() const { return expected ? double(matched) / expected : 0.0; }
  /// Over every housing in the image, hidden or not, with the hidden ones
  /// that had a blob counted as found: what a dataset without the spans
  /// gives.
  double recallOfAllInImage() const {
    return expected + hidden ? double(matched + hidden_matched) / (expected + hidden) : 0.0;
  }
  double falsePositivesPerFrame() const { return frames ? double(false_positives) / frames : 0.0; }
  /// Matched / (matched + false positives); blobs on hidden housings are
  /// in neither (1 when there are none).
  double precision() const {
    return matched + false_positives ? double(matched) / (matched + false_positives) : 1.0;
  }
};

/// Scores blob observations of the fisheye against the housings the
/// ground truth says it sees (all in the image when the dataset does not
/// say which are hidden). Bands are by true distance from the fisheye [m],
/// `band_edges` ascending, of the housings not hidden.
BlobEvaluation evaluateBlobs(const GroundTruthView& truth,
                             const std::vector<BlobObservation>& observations,
                             double match_px = 6.0, const std::vector<double>& band_edges = {});

/// Reads the manifest and the "ground_truth" trajectory of a dataset;
/// throws lookboth::Error naming the dataset when it has no ground truth.
GroundTruthView loadGroundTruth(const std::filesystem::path& dataset);

/// Median of a list (0 when empty).
double medianOf(std::vector<double> values);
/// The q-quantile (0..1), nearest rank (0 when empty).
double quantileOf(std::vector<double> values, double q);

}  // namespace lookboth
