// 2-D pictures of a registration, drawn with OpenCV (no display needed):
//  - a fisheye reprojection check (the paper's figure 7): detected blobs, the
//    cameras' positions projected before and after the looking-up
//    refinement, labels, residual segments;
//  - an environment camera's view with the marker's axes (figure 5);
//  - top and side views of camera positions and trajectories (figures 8, 9).
// Every picture has a legend; plots have a scale bar in metres. Colours are
// fixed (below) so that a test can find the overlay at a known pixel.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/cameras/camera.h"
#include "lookboth/geometry/rigid3.h"
#include "lookboth/geometry/time.h"

namespace lookboth::report {

/// Overlay colours (OpenCV BGR order).
namespace colours {
inline const cv::Scalar kBlob(0, 200, 0);               // detected blob: green ring
inline const cv::Scalar kBefore(0, 0, 255);             // projected before refinement: red cross
inline const cv::Scalar kAfter(255, 128, 0);            // projected after refinement: blue disc
inline const cv::Scalar kResidual(0, 215, 255);         // residual segment blob -> after: yellow
inline const cv::Scalar kDetectedMarker(0, 215, 255);   // detected marker outline: yellow
inline const cv::Scalar kPredictedMarker(255, 0, 255);  // marker where the registration puts it
inline const cv::Scalar kEstimate(200, 90, 0);          // estimate in plots: blue
inline const cv::Scalar kReference(0, 120, 255);        // reference in plots: orange
inline const cv::Scalar kTrajectory(90, 90, 90);        // trajectory in plots: grey
}  // namespace colours

/// Where something was drawn, in output pixels (for tests and image maps).
struct OverlayMark {
  std::string kind;  ///< "blob", "before", "after", "marker_detected", "marker_predicted".
  std::string label;
  cv::Point2d at;
  cv::Scalar colour;
};

/// One fisheye frame's reprojection check. Pixels are in the fisheye image
/// (pixel (0,0) = centre of the top-left pixel).
struct FisheyeCheck {
  TimeNs t = 0;
  int frame_index = -1;                ///< Index among the dataset's fisheye frames.
  double seconds = 0;                  ///< Time since the first fisheye frame [s].
  std::string why;                     ///< Why this frame was chosen ("most cameras in view"...).
  cv::Size image_size;                 ///< The fisheye image size.
  std::vector<Eigen::Vector2d> blobs;  ///< Every blob detected in the frame.
  struct ProjectedCamera {
    std::string label;
    std::optional<Eigen::Vector2d> before;  ///< Position before the refinement, projected.
    std::optional<Eigen::Vector2d> after;   ///< Final position, projected.
    std::optional<Eigen::Vector2d> blob;    ///< The blob associated with it in this frame.
  };
  std::vector<ProjectedCamera> cameras;  ///< Cameras in view.
  int associated() const;
  /// Largest |blob - after| over associated cameras [px]; 0 when none.
  double worstResidualAfter() const;
};

/// Draws the check over `image` (grey or BGR; empty: a dark canvas with the
/// note "no image in the dataset") scaled to `out_size`. Marks drawn are
/// appended to `marks` when given.
cv::Mat drawFisheyeCheck(const FisheyeCheck& check, const cv::Mat& image, cv::Size out_size,
                         std::vector<OverlayMark>* marks = nullptr);

/// One environment camera frame with the marker.
struct EnvCameraView {
  std::string camera;
  TimeNs t = 0;
  double marker_size_m = 0.2;
  std::optional<Rigid3d> detected_camera_from_marker;  ///< The detection (MarkerObservation).
  /// Where the registration puts the marker: camera_from_world *
  /// world_from_fisheye(t) * fisheye_from_marker.
  std::optional<Rigid3d> predicted_camera_from_marker;
};

cv::Mat drawEnvCameraView(const EnvCameraView& view, const Camera& camera, const cv::Mat& image,
                          cv::Size out_size, std::vector<OverlayMark>* marks = nullptr);

/// A set of labelled points (camera positions) for the plots.
struct PlotCameras {
  std::string name;  ///< Legend text.
  cv::Scalar colour;
  std::vector<std::pair<std::string, Eigen::Vector3d>> positions;  ///< label, position [m].
  bool filled = true;  ///< Filled discs (true) or hollow squares.
};

struct PlotTrajectory {
  std::string name;
  cv::Scalar colour;
  std::vector<Eigen::Vector3d> positions;  ///< [m]
  int thickness = 1;
};

/// Top view (x-y) above a side view (x-z) of the same cameras and
/// trajectories, equal scale on both axes, a grid, a scale bar and a legend.
/// Corresponding cameras of the first two sets (same label) are joined by a
/// thin line. Returns the picture; `marks` gets one "camera" mark per plotted
/// camera in the top view.
cv::Mat drawTopSideView(const std::string& title, const std::vector<PlotCameras>& cameras,
                        const std::vector<PlotTrajectory>& trajectories, cv::Size out_size,
                        std::vector<OverlayMark>* marks = nullptr);

/// Top view (x-y) only, e.g. trajectories before and after loop closure.
cv::Mat drawTopView(const std::string& title, const std::vector<PlotCameras>& cameras,
                    const std::vector<PlotTrajectory>& trajectories, cv::Size out_size,
                    std::vector<OverlayMark>* marks = nullptr);

/// Size of the legend box drawLegend would draw.
cv::Size measureLegend(const std::vector<std::pair<std::string, cv::Scalar>>& entries,
                       const std::vector<std::string>& notes, double font_scale);

/// Draws a legend box of coloured entries and notes with its top left
/// corner at `origin`; returns its height.
int drawLegend(cv::Mat& image, const std::vector<std::pair<std::string, cv::Scalar>>& entries,
               const std::vector<std::string>& notes, double font_scale, cv::Point origin);

}  // namespace lookboth::report
