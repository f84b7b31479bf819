// Ray-cast rendering of the simulator's cameras through lookboth's camera
// models: every pixel is unprojected by the camera's own model, so the
// images have exactly the geometry the estimation will assume.
//
// How a frame is made: for each pixel, supersampling x supersampling rays on
// a regular sub-pixel grid (bearings from the camera's model; a per-camera
// table of the bearings of all pixel centres is cached, sub-pixel bearings
// are interpolated bilinearly in it, error < 1e-3 px, with the exact model
// at the edge of the valid field of view); each ray is cast into the world
// and shaded; the average is the pixel's radiance, times a vignetting
// factor. Then an optical blur (Gaussian PSF), an optional horizontal motion
// blur, the exposure gain, Gaussian-like sensor noise, rounding to 8 bits.
// Pixels whose centre has no valid ray are 0. Rows are rendered in parallel
// (cv::parallel_for_); the result does not depend on the number of threads.
#pragma once

#include <opencv2/core.hpp>
#include <random>

#include "lookboth/cameras/camera.h"
#include "lookboth/dataset/manifest.h"
#include "lookboth/dataset/marker_dictionary.h"
#include "lookboth/sim/world.h"

namespace lookboth::sim {

/// The robot as the environment cameras see it.
struct RobotAppearance {
  Rigid3d world_from_base;    ///< The robot's base frame (x forward, z up, origin on the floor) in
                              ///< the world.
  Rigid3d world_from_marker;  ///< The marker (OpenCV ArUco frame: z out of the face, up here).
  /// The body: a box centred on the base origin in x and y, from 2 cm above
  /// the floor up to its top plate at body_height_m.
  double body_length_m = 0.50, body_width_m = 0.43, body_height_m = 0.25;
  MarkerSpec marker;               ///< Dictionary, id, side of the black square [m].
  double marker_brightness = 1.0;  ///< Backlight level of the white cells [0, 1].
  /// White backlit quiet zone around the black square, on each side, as a
  /// fraction of marker.size_m (the panel's side is size * (1 + 2 * margin)).
  double marker_margin = 0.2;
};

struct RenderOptions {
  int supersampling = 2;  ///< Rays per pixel side (2 -> 4 rays per pixel), for anti-aliasing.
  int marker_supersampling = 4;  ///< Rays per pixel side around the robot (environment cameras).
  double noise_sigma = 2.0;      ///< Gaussian pixel noise [grey levels of 255].
  double exposure = 1.0;         ///< Gain on the rendered intensities.
  double motion_blur_px = 0.0;   ///< Length of a horizontal blur [px] (0 = none).
  double blur_sigma_px = 0.5;    ///< Optical blur: sigma of a Gaussian PSF [px] (0 = none).
  double vignetting =
      0.25;  ///< Relative light loss at 90 deg incidence: gain 1 - v (1 - cos angle).
  /// Full field of view of the fisheye's image circle [rad]: rays further
  /// from the axis than half of it are black; 0 = the camera's fieldOfView().
  double fisheye_fov_rad = 0.0;
  std::string check() const;
};

/// Renders a greyscale (CV_8UC1) frame of the upward fisheye at a pose: the
/// ceiling, its fixtures and the environment cameras' housings.
cv::Mat renderFisheye(const World& world, const Camera& fisheye, const Rigid3d& world_from_fisheye,
                      const RenderOptions& options, std::mt19937& rng);

/// What an environment camera sees of the static world (no robot), before
/// exposure, blur and noise: rendered once, it makes the frames of a full
/// recording, most of which do not show the robot, cost no rays outside the
/// robot's image box.
struct EnvBackground {
  cv::Mat1f radiance;  ///< Supersampled radiance of each pixel.
  cv::Mat1b valid;     ///< 255 where the pixel centre has a ray.
};

/// The static view at `options`' supersampling; the adaptive supersampling's
/// tolerance follows `options.exposure`, as in renderEnvCamera.
EnvBackground renderEnvBackground(const World& world, const Camera& camera,
                                  const Rigid3d& world_from_camera, const RenderOptions& options);

/// Renders a greyscale frame of an environment camera looking down: the
/// floor, the robot's body and its backlit marker (drawn from the real
/// dictionary bitmap, cv::aruco::drawMarker with a one-cell border), and
/// whatever of the static world is in view (walls, low fixtures). With a
/// `background` of this camera, only the pixels where the robot can appear
/// are cast again: the same frame when the background was rendered at this
/// frame's exposure; at another, the adaptive supersampling decides some
/// pixels the other way (1920x1080 at 0.9 against 1.1: 0.02 grey levels on
/// average, 186 pixels by more than 2, where the corners miss a fine feature).
cv::Mat renderEnvCamera(const World& world, const Camera& camera, const Rigid3d& world_from_camera,
                        const RobotAppearance& robot, const RenderOptions& options,
                        std::mt19937& rng, const EnvBackground* background = nullptr);

/// The marker's cells, one pixel per cell including the one-cell black
/// border (6 x 6 for a 4x4 dictionary): 0 black, 255 white, row 0 at the
/// top (marker +y). Throws lookboth::Error when marker.check() fails.
cv::Mat markerCells(const MarkerSpec& marker);

/// Drops the cached per-camera bearing tables (each about 12 bytes per pixel;
/// the cache keeps the 4 most recently used cameras).
void clearRenderCache();

}  // namespace lookboth::sim
