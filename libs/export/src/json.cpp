// JSON for web and edge systems: registration.json, described by
// share/lookboth/schema/registration_export.schema.json.
#include <nlohmann/json.hpp>

#include "formats.h"

namespace lookboth::export_detail {
namespace {

using Json = nlohmann::ordered_json;

Json poseJson(const Rigid3d& a_from_b) {
  const Eigen::Matrix4d m = a_from_b.matrix();
  Json matrix = Json::array();
  for (int r = 0; r < 4; ++r) matrix.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  const Eigen::Quaterniond& q = a_from_b.rotation;
  const Eigen::Vector3d& t = a_from_b.translation;
  return {{"translation", {{"x", t.x()}, {"y", t.y()}, {"z", t.z()}}},
          {"rotation", {{"qw", q.w()}, {"qx", q.x()}, {"qy", q.y()}, {"qz", q.z()}}},
          {"matrix", matrix}};
}

template <typename Matrix>
Json rowMajor(const Matrix& m) {
  Json values = Json::array();
  for (int r = 0; r < m.rows(); ++r) {
    for (int c = 0; c < m.cols(); ++c) values.push_back(m(r, c));
  }
  return values;
}

Json intrinsicsJson(const Camera* camera) {
  if (camera == nullptr) return nullptr;
  Json params = Json::object();
  const std::vector<std::string> names = camera->paramNames();
  for (std::size_t i = 0; i < names.size(); ++i) params[names[i]] = camera->params()[i];
  return {{"model", camera->modelName()},
          {"width", camera->width()},
          {"height", camera->height()},
          {"params", params}};
}

Json cameraJson(const ExportedCamera& c) {
  const CameraRegistration& r = *c.registration;
  Json camera = {{"label", r.label},
                 {"status", cameraStatusName(r.status)},
                 {"world_from_camera", poseJson(r.world_from_camera)}};
  camera["covariance"] = r.covariance ? rowMajor(*r.covariance) : Json(nullptr);
  camera["aligned_position_covariance"] =
      r.aligned_position_covariance ? rowMajor(*r.aligned_position_covariance) : Json(nullptr);
  camera["intrinsics"] = intrinsicsJson(c.intrinsics);
  return camera;
}

}  // namespace

void writeJson(const ExportContext& context) {
  const Registration& reg = context.registration;
  Json root = {{"format", "lookboth.registration_export"},
               {"version", 1},
               {"frame", reg.world_frame.name},
               {"frame_description", reg.world_frame.description},
               {"covariance_order", "[dx, dy, dz (m), dtheta_x, dtheta_y, dtheta_z (rad)]"},
               {"dataset", reg.dataset},
               {"created", reg.created},
               {"trajectory", reg.trajectory_label}};
  Json cameras = Json::array();
  for (const ExportedCamera& c : context.cameras) cameras.push_back(cameraJson(c));
  root["cameras"] = cameras;
  context.write("registration.json", root.dump(2) + "\n");
}

}  // namespace lookboth::export_detail
