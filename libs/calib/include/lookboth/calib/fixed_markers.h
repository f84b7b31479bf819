// Markers fixed in the facility (printed on the floor) located by the
// registered cameras that detected them: control points of `lookboth align`
// ("marker:<id>", registration/site_frame.h) whose position a surveyor
// measures once, where a camera's optical centre cannot be reached.
#pragma once

#include <string>
#include <vector>

#include "lookboth/dataset/records.h"
#include "lookboth/registration/registration.h"
#include "lookboth/registration/site_frame.h"

namespace lookboth {

struct FixedMarkerOptions {
  /// A detection without an information matrix: this sigma per coordinate
  /// of its position in the camera [m].
  double default_translation_sigma_m = 0.01;
  /// The share of a detection's error that a camera's detections of one
  /// fixed marker have in common: the camera and the marker do not move, so
  /// the viewing geometry, and the detector's error from it, is the same in
  /// every frame. The mean of n detections then has (1 + share (n - 1)) / n
  /// of one detection's variance, not 1 / n. In [0, 1].
  double shared_error_share = 0.15;
  /// A detection whose squared Mahalanobis distance from its camera's mean
  /// exceeds this (3 dof) is left out: a false detection or a marker moved
  /// during the drive.
  double reject_chi2 = 100;
  /// Empty when usable; else what is wrong, naming the option.
  std::string check() const;
};

/// Every marker other than the robot's (`robot_marker_id`) that a registered
/// or suspect camera of `registration` detected, located in the
/// registration's world frame: per camera the mean of its detections'
/// positions (camera pose * the marker's position in the camera), its
/// covariance from the detections (their shared error included) and from the
/// camera's pose covariance through the lever to the marker; then the
/// information-weighted mean over the cameras. Keyed "marker:<id>".
LocatedPoints locateFixedMarkers(const Registration& registration,
                                 const std::vector<MarkerObservation>& detections,
                                 int robot_marker_id, const FixedMarkerOptions& options = {});

}  // namespace lookboth
