#include "lookboth/detect/blob_detector.h"

#include <algorithm>
#include <cmath>
#include <opencv2/features2d.hpp>

#include "lookboth/core/error.h"

namespace lookboth {

std::string BlobDetectorOptions::check() const {
  if (!(min_threshold >= 0 && min_threshold < max_threshold && max_threshold <= 255))
    return "'min_threshold', 'max_threshold': need 0 <= min < max <= 255";
  if (!(threshold_step > 0)) return "'threshold_step': must be positive";
  if (min_repeatability < 1) return "'min_repeatability': must be at least 1";
  if (!(min_dist_between_blobs_px >= 0)) return "'min_dist_between_blobs_px': must be >= 0";
  if (!(min_area_px > 0 && min_area_px < max_area_px))
    return "'min_area_px', 'max_area_px': need 0 < min < max";
  for (const auto& [name, value] :
       {std::pair<const char*, double>{"min_circularity", min_circularity},
        {"min_convexity", min_convexity},
        {"min_inertia_ratio", min_inertia_ratio}}) {
    if (!(value >= 0 && value <= 1)) return std::string("'") + name + "': must be in [0, 1]";
  }
  if (!(min_contrast >= 0)) return "'min_contrast': must be >= 0";
  const double thresholds = (max_threshold - min_threshold) / threshold_step;
  if (thresholds < min_repeatability - 1)
    return "'min_repeatability': more than the number of thresholds";
  return "";
}

BlobDetector::BlobDetector(const BlobDetectorOptions& options) : options_(options) {
  if (const std::string why = options.check(); !why.empty()) throw Error("detect.blobs: " + why);
}

std::vector<Blob> BlobDetector::detect(const cv::Mat& grey) const {
  if (grey.type() != CV_8UC1) throw Error("blob detection: expected a greyscale frame");
  cv::SimpleBlobDetector::Params p;
  p.minThreshold = static_cast<float>(options_.min_threshold);
  p.maxThreshold = static_cast<float>(options_.max_threshold);
  p.thresholdStep = static_cast<float>(options_.threshold_step);
  p.minRepeatability = static_cast<size_t>(options_.min_repeatability);
  p.minDistBetweenBlobs = static_cast<float>(options_.min_dist_between_blobs_px);
  p.filterByColor = true;
  p.blobColor = options_.dark ? 0 : 255;
  p.filterByArea = true;
  p.minArea = static_cast<float>(options_.min_area_px);
  p.maxArea = static_cast<float>(options_.max_area_px);
  p.filterByCircularity = options_.min_circularity > 0;
  p.minCircularity = static_cast<float>(options_.min_circularity);
  p.filterByConvexity = options_.min_convexity > 0;
  p.minConvexity = static_cast<float>(options_.min_convexity);
  p.filterByInertia = options_.min_inertia_ratio > 0;
  p.minInertiaRatio = static_cast<float>(options_.min_inertia_ratio);
  const cv::Ptr<cv::SimpleBlobDetector> detector = cv::SimpleBlobDetector::create(p);
  std::vector<cv::KeyPoint> keypoints;
  detector->detect(grey, keypoints);
  std::vector<Blob> blobs;
  for (const cv::KeyPoint& k : keypoints) {
    // Contrast: mean of a ring at 1-1.6 radii minus the mean of the inner half radius.
    const double radius = std::max(1.0, 0.5 * k.size);
    double inner = 0, ring = 0;
    int n_inner = 0, n_ring = 0;
    const int reach = static_cast<int>(std::ceil(1.6 * radius)) + 1;
    for (int dy = -reach; dy <= reach; ++dy) {
      for (int dx = -reach; dx <= reach; ++dx) {
        const int x = static_cast<int>(std::lround(k.pt.x)) + dx;
        const int y = static_cast<int>(std::lround(k.pt.y)) + dy;
        if (x < 0 || y < 0 || x >= grey.cols || y >= grey.rows) continue;
        const double r = std::hypot(x - k.pt.x, y - k.pt.y);
        const double value = grey.at<std::uint8_t>(y, x);
        if (r <= 0.5 * radius + 0.5) {
          inner += value;
          ++n_inner;
        } else if (r >= radius + 0.5 && r <= 1.6 * radius + 1.0) {
          ring += value;
          ++n_ring;
        }
      }
    }
    if (n_inner == 0 || n_ring == 0) continue;
    double contrast = ring / n_ring - inner / n_inner;
    if (!options_.dark) contrast = -contrast;
    if (contrast < options_.min_contrast) continue;
    blobs.push_back({k.pt.x, k.pt.y, k.size, contrast / 255.0});
  }
  std::sort(blobs.begin(), blobs.end(),
            [](const Blob& a, const Blob& b) { return a.v != b.v ? a.v < b.v : a.u < b.u; });
  return blobs;
}

}  // namespace lookboth
