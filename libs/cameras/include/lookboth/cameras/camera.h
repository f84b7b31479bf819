// A calibrated camera: one projection model, its parameters and the image size.
//
// Conventions (doc/conventions.md): camera frame x right, y down, z forward
// (optical axis); pixel (0,0) is the centre of the top-left pixel, u to the
// right, v down. Bearings are unit vectors in the camera frame.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "lookboth/cameras/camera_models.h"

namespace lookboth {

/// Every model lookboth knows, as a value type. Model objects carry the
/// structural information a parameter vector cannot (e.g. the polynomial
/// degrees of a Scaramuzza model); the numbers live in `Camera::params()`.
using CameraModel =
    std::variant<PinholeModel, RadTanModel, RationalPolynomialModel, KannalaBrandtModel,
                 ScaramuzzaModel, DoubleSphereModel, EucmModel, MeiModel, FovModel>;

/// Name used in files and on the command line ("pinhole", "radtan", ...).
std::string cameraModelName(const CameraModel& model);
/// Identifier of the model held by the variant.
CameraModelId cameraModelId(const CameraModel& model);

class Camera {
 public:
  /// Checks the parameters (see `validate`) and precomputes the valid field of
  /// view. Throws lookboth::Error with the validation message on bad input.
  Camera(CameraModel model, int width, int height, std::vector<double> params);

  /// Returns an empty string when (model, size, params) make a usable camera,
  /// otherwise a message naming the offending parameter, e.g.
  /// "'fx': must be positive, got -3".
  static std::string validate(const CameraModel& model, int width, int height,
                              const std::vector<double>& params);

  const CameraModel& model() const { return model_; }
  CameraModelId modelId() const { return cameraModelId(model_); }
  std::string modelName() const { return cameraModelName(model_); }
  int width() const { return width_; }
  int height() const { return height_; }
  const std::vector<double>& params() const { return params_; }
  /// Parameter names in the order of `params()` ("fx", "fy", "cx", ...).
  std::vector<std::string> paramNames() const;

  /// Largest angle between a valid ray and the optical axis [rad]: the model
  /// is one-to-one and smooth for incidence angles in [0, maxIncidenceAngle].
  /// It is at most the model's own limit (e.g. pi/2 for pinhole models) and
  /// never more than needed to cover the image corners plus a margin.
  double maxIncidenceAngle() const { return max_incidence_angle_; }
  /// Full field of view across the widest image direction [rad] (approximately
  /// 2 * max incidence angle reached inside the image).
  double fieldOfView() const;

  /// Pixel of a point (or direction) in the camera frame; nullopt when it is
  /// behind the camera or outside the valid field of view. The pixel may lie
  /// outside the image: check `isInImage`.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_in_camera) const;
  /// Unit bearing of a pixel; nullopt when the pixel maps to no valid ray.
  std::optional<Eigen::Vector3d> unproject(const Eigen::Vector2d& pixel) const;

  /// True when the pixel is inside the image, `margin` pixels from the border.
  bool isInImage(const Eigen::Vector2d& pixel, double margin = 0.0) const;

  /// One-line human description, e.g. "kannala_brandt 1920x1080 fov 190.0 deg".
  std::string description() const;

 private:
  CameraModel model_;
  int width_ = 0;
  int height_ = 0;
  std::vector<double> params_;
  double max_incidence_angle_ = 0.0;
};

}  // namespace lookboth
