// Looking up: the environment cameras' housings as dark blobs in the
// upward fisheye's frames, found with OpenCV's SimpleBlobDetector as in the
// paper (parameters from the `detect: blobs:` section of the configuration).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lookboth/obs/CObservationBlobs.h"

namespace lookboth {

/// cv::SimpleBlobDetector::Params with lookboth's defaults for housings seen
/// from 2-4 m below (names follow OpenCV's).
struct BlobDetectorOptions {
  double min_threshold = 10;             ///< First binarisation threshold [grey level].
  double max_threshold = 110;            ///< Last one [grey level].
  double threshold_step = 10;            ///< Between thresholds [grey levels].
  int min_repeatability = 2;             ///< Thresholds at which a blob must be found.
  double min_dist_between_blobs_px = 4;  ///< [px].
  bool dark = true;                ///< Look for dark blobs (the housings) rather than bright ones.
  double min_area_px = 6;          ///< [px^2].
  double max_area_px = 5000;       ///< [px^2].
  double min_circularity = 0.7;    ///< 4 pi area / perimeter^2, in [0, 1].
  double min_convexity = 0.8;      ///< Area / convex hull area, in [0, 1].
  double min_inertia_ratio = 0.3;  ///< Minor / major inertia, in [0, 1].
  /// Blobs whose contrast with their surroundings is below this are dropped [grey levels].
  double min_contrast = 30;
  std::string check() const;
};

class BlobDetector {
 public:
  /// Throws lookboth::Error when the options are invalid.
  explicit BlobDetector(const BlobDetectorOptions& options = {});
  /// Blobs of a greyscale (CV_8UC1) frame, sorted by (v, u). `response` is
  /// the blob's contrast with a ring around it, divided by 255.
  std::vector<Blob> detect(const cv::Mat& grey) const;
  const BlobDetectorOptions& options() const { return options_; }

 private:
  BlobDetectorOptions options_;
};

}  // namespace lookboth
