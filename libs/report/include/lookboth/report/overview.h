// The 3-D overview of a registration (the paper's figure 1), rendered
// off-screen with MRPT's CFBORender (EGL: no display, no X server needed; it
// also works under Xvfb): the robot's trajectory, every camera as a frustum
// with its axes and label, and the marker detections as rays from the camera
// to the marker.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lookboth/geometry/rigid3.h"

namespace lookboth::report {

struct OverviewCamera {
  std::string label;
  Rigid3d world_from_camera;
  bool suspect = false;  ///< Drawn in orange instead of blue.
};

struct OverviewInput {
  std::string title;
  std::vector<OverviewCamera> cameras;
  std::vector<Eigen::Vector3d> trajectory;  ///< Robot (fisheye) positions [m], in time order.
  /// Detection rays: camera position -> detected marker position [m].
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> rays;
  /// Reference camera positions (ground truth, aligned), drawn as small orange boxes.
  std::vector<std::pair<std::string, Eigen::Vector3d>> reference;
};

/// Colours of the overview (RGB, 0-255) so that tests can look for them.
struct OverviewColours {
  static constexpr unsigned char kCamera[3] = {0, 90, 220};
  static constexpr unsigned char kSuspect[3] = {240, 140, 0};
  static constexpr unsigned char kTrajectory[3] = {40, 40, 40};
  static constexpr unsigned char kRay[3] = {90, 160, 255};
  static constexpr unsigned char kReference[3] = {255, 120, 0};
};

/// Renders the overview at `size` (BGR image). Throws lookboth::Error when
/// off-screen rendering is not available (no EGL device), with MRPT's message.
cv::Mat renderOverview(const OverviewInput& input, cv::Size size);

}  // namespace lookboth::report
