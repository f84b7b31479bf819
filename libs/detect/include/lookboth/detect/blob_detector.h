// Looking up: the environment cameras' housings as dark blobs in the
// upward fisheye's frames, found with OpenCV's SimpleBlobDetector as in the
// paper (parameters from the `detect: blobs:` section of the configuration),
// then kept only when they look like a housing: dark against the ceiling
// around them and of the size a housing has at that place in the image.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lookboth/cameras/camera.h"
#include "lookboth/obs/CObservationBlobs.h"

namespace lookboth {

/// cv::SimpleBlobDetector::Params with lookboth's defaults for housings seen
/// from 2-4 m below (names follow OpenCV's), and the housing's own tests.
/// Figures below: the renders `small` (640x360 fisheye) and `paper20` (the
/// first 20 s of `paper`, 1920x1080), blobs within 6 px of a housing whose
/// centre the fisheye sees.
struct BlobDetectorOptions {
  double min_threshold = 10;  ///< First binarisation threshold [grey level].
  /// Thresholds up to this, excluded [grey level]. A housing is near-black:
  /// the dark thresholds separate it from what surrounds it, the brighter
  /// ones merge it with darker surfaces (a cable tray's bay) into one blob
  /// too big for a housing, and add textures that the darkness test drops.
  double max_threshold = 60;
  /// Between thresholds [grey levels]: a housing in front of a darker
  /// surface stands apart from it over a few grey levels only. With the
  /// tests below, thresholds 10-55 by 5 matched 1653 (small) and 6852
  /// (paper20) housings where 10-100 by 10 matched 1537 and 6754, with as
  /// many thresholds.
  double threshold_step = 5;
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
  /// A housing is near-black whatever the light, the ceiling around it is
  /// not: the darkest grey of the blob's centre (the disc of half its
  /// radius) over the mean grey of a ring around it (1-1.6 radii) must be at
  /// most this (for bright blobs, the ring over the brightest centre grey);
  /// a ratio of grey levels, whatever the exposure. The housings' blobs
  /// measured 0.04-0.18 (small) and 0.03-0.12 (paper20), 1st to 99th
  /// percentile; the textures the contrast and size tests keep (cable
  /// trays, grilles, wall joints, tie holes) 0.26 and 0.29 at their 5th
  /// percentile, median 0.38 and 0.34. False positives per frame: 0.06
  /// and 0.11 at 0.2, 0.39 and 0.41 at 0.25; 0.15 lost 84 and 16 more
  /// housings. 1 = off [ratio].
  double max_darkness_ratio = 0.2;
  /// The housing the environment cameras are in, a dome of this radius
  /// around the camera [m]; with the fisheye's calibration and the range of
  /// heights below, it gives the diameter a housing's blob can have at each
  /// place of the image.
  double housing_radius_m = 0.06;
  /// Heights of the housings above the fisheye along its optical axis (the
  /// ceiling's lowest and highest cameras, with margin) [m].
  double min_housing_height_m = 2.0;
  double max_housing_height_m = 6.0;
  /// A blob whose diameter is more than this factor outside the range the
  /// heights give (plus the half pixel OpenCV's outline adds) is not a
  /// housing: tie holes and sprinkler-sized dots are too small, missing
  /// tiles and tray bays too big. The housings' blobs measured 0.87-1.19
  /// (small) and 0.94-1.08 (paper20) times that size at their true height,
  /// 5th to 95th percentile. At 1920x1080 the test drops 80 % of the
  /// candidates (the ceiling's tie holes) before the darkness test. 0 = off;
  /// off too when the fisheye has no calibration [factor >= 1].
  double housing_size_tolerance = 1.25;
  /// A recording's fisheye frames searched at most this often [Hz]; the
  /// others are not decoded when they are image files (a video's are, in
  /// order, but not searched). At 30 Hz consecutive frames see the same
  /// housings a few pixels apart, and the adjustments keep a few hundred
  /// blobs per camera spread over time (joint's max_blobs_per_camera)
  /// whatever the rate. 0 = every frame. On the `paper` facility's 60 s
  /// full recording (doc/benchmarks.md), 10 for its 30 Hz fisheye took
  /// `register` from 108 to 97 s and the cameras from 0.82 to 0.87 cm RMS:
  /// not the default, the accuracy not being shown unchanged.
  double max_rate_hz = 0;
  std::string check() const;
};

/// What became of the blobs OpenCV's search found (the sum over frames);
/// each is accepted or counted under one reason.
struct BlobDetectorStats {
  std::int64_t candidates = 0;
  std::int64_t too_small = 0;     ///< Smaller than a housing there.
  std::int64_t too_big = 0;       ///< Larger.
  std::int64_t low_contrast = 0;  ///< Below min_contrast (or at the frame's edge).
  std::int64_t not_dark = 0;      ///< Above max_darkness_ratio.
  void add(const BlobDetectorStats& more);
};

class BlobDetector {
 public:
  /// `fisheye`: the calibration of the frames' camera, for the housing's
  /// expected size (without it that test is off). Throws lookboth::Error
  /// when the options are invalid.
  explicit BlobDetector(const BlobDetectorOptions& options = {}, const Camera* fisheye = nullptr);
  /// Blobs of a greyscale (CV_8UC1) frame, sorted by (v, u). `response` is
  /// the blob's contrast with a ring around it, divided by 255. `stats`,
  /// when given, is added this frame's counts.
  std::vector<Blob> detect(const cv::Mat& grey, BlobDetectorStats* stats = nullptr) const;
  const BlobDetectorOptions& options() const { return options_; }
  /// Diameters [px] of a housing's image centred at pixel (u, v) (the circle
  /// of the same area as the sphere's image): at max_housing_height_m and at
  /// min_housing_height_m; nullopt without a calibration, or where the pixel
  /// has no ray or a housing there would not be in front of the fisheye.
  std::optional<std::pair<double, double>> housingDiameterRange(double u, double v) const;

 private:
  enum class Size { kFits, kTooSmall, kTooBig, kUnknown };
  /// The keypoint's diameter against a housing's there (kUnknown: test off).
  Size sizeFit(const cv::KeyPoint& k) const;
  enum class Verdict { kAccepted, kTooSmall, kTooBig, kLowContrast, kNotDark };
  /// The size, contrast and darkness tests in turn; `blob` is set when all pass.
  Verdict judge(const cv::Mat& grey, const cv::KeyPoint& k, Blob* blob) const;

  BlobDetectorOptions options_;
  std::optional<Camera> fisheye_;
};

}  // namespace lookboth
