#include "lookboth/detect/blob_detector.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/features2d.hpp>

#include "lookboth/core/error.h"

namespace lookboth {

std::string BlobDetectorOptions::check() const {
  if (!(min_threshold >= 0 && min_threshold < max_threshold && max_threshold <= 255))
    return "'min_threshold', 'max_threshold': need 0 <= min < max <= 255";
  if (!(threshold_step > 0)) return "'threshold_step': must be positive";
  if (!(max_rate_hz >= 0 && max_rate_hz <= 1000))
    return "'max_rate_hz': must be between 0 (every frame) and 1000";
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
  if (!(max_darkness_ratio > 0 && max_darkness_ratio <= 1))
    return "'max_darkness_ratio': must be in (0, 1]";
  if (!(housing_radius_m > 0)) return "'housing_radius_m': must be positive";
  if (!(min_housing_height_m > 0 && min_housing_height_m <= max_housing_height_m &&
        std::isfinite(max_housing_height_m)))
    return "'min_housing_height_m', 'max_housing_height_m': need 0 < min <= max";
  if (!(housing_size_tolerance == 0 || housing_size_tolerance >= 1))
    return "'housing_size_tolerance': must be 0 (off) or >= 1";
  const double thresholds = (max_threshold - min_threshold) / threshold_step;
  if (thresholds < min_repeatability - 1)
    return "'min_repeatability': more than the number of thresholds";
  return "";
}

BlobDetector::BlobDetector(const BlobDetectorOptions& options, const Camera* fisheye)
    : options_(options) {
  if (const std::string why = options.check(); !why.empty()) throw Error("detect.blobs: " + why);
  if (fisheye) fisheye_ = *fisheye;
}

namespace {

/// OpenCV's diameter of a dark blob is that of the outline of the bright
/// pixels around it, wider than the dark region, which the dark thresholds
/// find smaller than its blurred extent: the housings' blobs in the renders
/// measured 0.99 (640x360) and 1.02 (1920x1080) times their image's
/// diameter plus this (medians; 0.87-1.19 and 0.94-1.08 from the 5th to the
/// 95th percentile), against 1.08 times the diameter alone [px].
constexpr double kOutlinePx = 0.5;

/// OpenCV's multi-threshold blob search with the options' shape filters.
std::vector<cv::KeyPoint> findKeypoints(const cv::Mat& grey, const BlobDetectorOptions& o) {
  cv::SimpleBlobDetector::Params p;
  p.minThreshold = static_cast<float>(o.min_threshold);
  p.maxThreshold = static_cast<float>(o.max_threshold);
  p.thresholdStep = static_cast<float>(o.threshold_step);
  p.minRepeatability = static_cast<size_t>(o.min_repeatability);
  p.minDistBetweenBlobs = static_cast<float>(o.min_dist_between_blobs_px);
  p.filterByColor = true;
  p.blobColor = o.dark ? 0 : 255;
  p.filterByArea = true;
  p.minArea = static_cast<float>(o.min_area_px);
  p.maxArea = static_cast<float>(o.max_area_px);
  p.filterByCircularity = o.min_circularity > 0;
  p.minCircularity = static_cast<float>(o.min_circularity);
  p.filterByConvexity = o.min_convexity > 0;
  p.minConvexity = static_cast<float>(o.min_convexity);
  p.filterByInertia = o.min_inertia_ratio > 0;
  p.minInertiaRatio = static_cast<float>(o.min_inertia_ratio);
  std::vector<cv::KeyPoint> keypoints;
  cv::SimpleBlobDetector::create(p)->detect(grey, keypoints);
  return keypoints;
}

/// Grey levels of a blob's centre (the disc of half its radius) and of a
/// ring around it (1-1.6 radii); empty when either has no pixel in the frame.
struct CentreAndRing {
  double centre_mean = 0, darkest = 255, brightest = 0, ring_mean = 0;
};

std::optional<CentreAndRing> centreAndRing(const cv::Mat& grey, const cv::KeyPoint& k) {
  const double radius = std::max(1.0, 0.5 * k.size);
  CentreAndRing out;
  double centre = 0, ring = 0;
  int n_centre = 0, n_ring = 0;
  const int reach = static_cast<int>(std::ceil(1.6 * radius)) + 1;
  for (int dy = -reach; dy <= reach; ++dy) {
    for (int dx = -reach; dx <= reach; ++dx) {
      const int x = static_cast<int>(std::lround(k.pt.x)) + dx;
      const int y = static_cast<int>(std::lround(k.pt.y)) + dy;
      if (x < 0 || y < 0 || x >= grey.cols || y >= grey.rows) continue;
      const double r = std::hypot(x - k.pt.x, y - k.pt.y);
      const double value = grey.at<std::uint8_t>(y, x);
      if (r <= 0.5 * radius + 0.5) {
        centre += value;
        ++n_centre;
        out.darkest = std::min(out.darkest, value);
        out.brightest = std::max(out.brightest, value);
      } else if (r >= radius + 0.5 && r <= 1.6 * radius + 1.0) {
        ring += value;
        ++n_ring;
      }
    }
  }
  if (n_centre == 0 || n_ring == 0) return std::nullopt;
  out.centre_mean = centre / n_centre;
  out.ring_mean = ring / n_ring;
  return out;
}

}  // namespace

std::optional<std::pair<double, double>> BlobDetector::housingDiameterRange(double u,
                                                                            double v) const {
  if (!fisheye_) return std::nullopt;
  const std::optional<Eigen::Vector3d> ray = fisheye_->unproject({u, v});
  // A housing on the ceiling is in front of the upward fisheye.
  if (!ray || !(ray->z() > 0)) return std::nullopt;
  // Two directions across the ray: the blob's extent along and across the
  // image radius (a fisheye squeezes the first); the diameter of the circle
  // of the same area.
  Eigen::Vector3d across = ray->cross(Eigen::Vector3d::UnitZ());
  if (across.norm() < 1e-9) across = Eigen::Vector3d::UnitX();
  across.normalize();
  const Eigen::Vector3d along = ray->cross(across).normalized();
  const double radius = options_.housing_radius_m;
  auto diameter = [&](double height) -> std::optional<double> {
    const Eigen::Vector3d centre = (height / ray->z()) * *ray;
    double product = 1;
    for (const Eigen::Vector3d& side : {across, along}) {
      const auto a = fisheye_->project(centre + radius * side);
      const auto b = fisheye_->project(centre - radius * side);
      if (!a || !b) return std::nullopt;
      product *= (*a - *b).norm();
    }
    return std::sqrt(product);
  };
  const std::optional<double> far = diameter(options_.max_housing_height_m);
  const std::optional<double> near = diameter(options_.min_housing_height_m);
  if (!far || !near) return std::nullopt;
  return std::make_pair(*far, *near);
}

BlobDetector::Size BlobDetector::sizeFit(const cv::KeyPoint& k) const {
  const double tolerance = options_.housing_size_tolerance;
  if (!(tolerance > 0)) return Size::kUnknown;
  const auto range = housingDiameterRange(k.pt.x, k.pt.y);
  if (!range) return Size::kUnknown;
  if (k.size < (range->first + kOutlinePx) / tolerance) return Size::kTooSmall;
  if (k.size > (range->second + kOutlinePx) * tolerance) return Size::kTooBig;
  return Size::kFits;
}

BlobDetector::Verdict BlobDetector::judge(const cv::Mat& grey, const cv::KeyPoint& k,
                                          Blob* blob) const {
  const Size size = sizeFit(k);
  if (size == Size::kTooSmall) return Verdict::kTooSmall;
  if (size == Size::kTooBig) return Verdict::kTooBig;
  const std::optional<CentreAndRing> levels = centreAndRing(grey, k);
  if (!levels) return Verdict::kLowContrast;
  const double contrast = options_.dark ? levels->ring_mean - levels->centre_mean
                                        : levels->centre_mean - levels->ring_mean;
  if (contrast < options_.min_contrast) return Verdict::kLowContrast;
  // Ratios of grey levels, so that the exposure does not change them.
  const bool dark_enough =
      options_.dark ? levels->darkest <= options_.max_darkness_ratio * levels->ring_mean
                    : levels->ring_mean <= options_.max_darkness_ratio * levels->brightest;
  if (options_.max_darkness_ratio < 1 && !dark_enough) return Verdict::kNotDark;
  *blob = Blob{k.pt.x, k.pt.y, k.size, contrast / 255.0};
  return Verdict::kAccepted;
}

std::vector<Blob> BlobDetector::detect(const cv::Mat& grey, BlobDetectorStats* stats) const {
  if (grey.type() != CV_8UC1) throw Error("blob detection: expected a greyscale frame");
  BlobDetectorStats counts;
  std::vector<Blob> blobs;
  for (const cv::KeyPoint& k : findKeypoints(grey, options_)) {
    ++counts.candidates;
    Blob blob;
    switch (judge(grey, k, &blob)) {
      case Verdict::kAccepted:
        blobs.push_back(blob);
        break;
      case Verdict::kTooSmall:
        ++counts.too_small;
        break;
      case Verdict::kTooBig:
        ++counts.too_big;
        break;
      case Verdict::kLowContrast:
        ++counts.low_contrast;
        break;
      case Verdict::kNotDark:
        ++counts.not_dark;
        break;
    }
  }
  std::sort(blobs.begin(), blobs.end(),
            [](const Blob& a, const Blob& b) { return a.v != b.v ? a.v < b.v : a.u < b.u; });
  if (stats) stats->add(counts);
  return blobs;
}

void BlobDetectorStats::add(const BlobDetectorStats& more) {
  candidates += more.candidates;
  too_small += more.too_small;
  too_big += more.too_big;
  low_contrast += more.low_contrast;
  not_dark += more.not_dark;
}

}  // namespace lookboth
