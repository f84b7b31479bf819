// One OpenCV FileStorage YAML per camera (<label>.yaml), what its edge node
// needs: the calibration, world_from_camera and its covariance, readable by
// cv::FileStorage (C++, Python) without lookboth.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "formats.h"
#include "lookboth/core/error.h"

namespace lookboth::export_detail {
namespace {

/// OpenCV's distortion vector for the models OpenCV itself projects with:
/// cv::projectPoints (radtan, rational polynomial) and cv::fisheye (Kannala-Brandt).
std::vector<double> opencvDistortion(const Camera& camera) {
  const std::string model = camera.modelName();
  const std::vector<double>& p = camera.params();
  if (model == "radtan" || model == "rational_polynomial" || model == "kannala_brandt") {
    return {p.begin() + 4, p.end()};
  }
  return {};
}

void writeIntrinsics(cv::FileStorage& fs, const Camera& camera) {
  fs << "image_width" << camera.width() << "image_height" << camera.height();
  fs << "model" << camera.modelName();
  std::string names;
  for (const std::string& name : camera.paramNames()) names += (names.empty() ? "" : " ") + name;
  fs << "parameter_names" << names;
  fs << "parameters" << cv::Mat(camera.params(), true).reshape(1, 1);
  if (camera.modelName() == "scaramuzza") return;  // no focal length, no camera matrix
  const std::vector<double>& p = camera.params();
  const cv::Matx33d k(p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1);
  fs << "camera_matrix" << cv::Mat(k);
  const std::vector<double> distortion = opencvDistortion(camera);
  if (!distortion.empty())
    fs << "distortion_coefficients" << cv::Mat(distortion, true).reshape(1, 1);
}

std::string cameraFile(const ExportedCamera& c) {
  cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  const CameraRegistration& r = *c.registration;
  fs << "camera" << r.label << "status" << cameraStatusName(r.status);
  if (c.intrinsics != nullptr) writeIntrinsics(fs, *c.intrinsics);
  cv::Mat pose;
  cv::eigen2cv(Eigen::Matrix4d(r.world_from_camera.matrix()), pose);
  fs << "world_from_camera" << pose;
  if (r.covariance) {
    cv::Mat covariance;
    cv::eigen2cv(Eigen::Matrix<double, 6, 6>(*r.covariance), covariance);
    fs.writeComment(
        "covariance of world_from_camera over [dt (m); dtheta (rad)], "
        "t_true = t + dt, R_true = R Exp(dtheta)");
    fs << "covariance" << covariance;
  }
  return fs.releaseAndGetString();
}

}  // namespace

void writeOpenCv(const ExportContext& context) {
  for (const ExportedCamera& c : context.cameras) {
    context.write(c.registration->label + ".yaml", cameraFile(c));
  }
}

}  // namespace lookboth::export_detail
