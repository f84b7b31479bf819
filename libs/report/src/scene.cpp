// The registration as an MRPT scene (SceneViewer3D opens it): each camera as
// a frustum and axes with its label (suspect cameras in orange) and, with its
// covariance, as MRPT's pose PDF (CPose3DPDFGaussian, drawn by MRPT as its
// 3-sigma position ellipsoid, named "<label> pdf"), the metric trajectory, and
// the detection rays (camera -> marker), as in the paper's figure 1.
#include <mrpt/opengl/CFrustum.h>
#include <mrpt/opengl/COpenGLScene.h>
#include <mrpt/opengl/CSetOfLines.h>
#include <mrpt/opengl/CSetOfObjects.h>
#include <mrpt/opengl/CText.h>
#include <mrpt/opengl/stock_objects.h>

#include "lookboth/core/error.h"
#include "lookboth/geometry/pose_conversions.h"
#include "lookboth/report/scene.h"

namespace lookboth {

void writeRegistrationScene(const RegistrationRun& run, const std::filesystem::path& file) {
  using namespace mrpt::opengl;
  COpenGLScene scene;
  const Registration& r = run.registration;

  auto trajectory = CSetOfLines::Create();
  trajectory->setName("trajectory");
  trajectory->setColor_u8(30, 90, 220);
  trajectory->setLineWidth(2);
  for (std::size_t i = 1; i < r.trajectory.size(); ++i) {
    const Eigen::Vector3d& a = r.trajectory[i - 1].world_from_body.translation;
    const Eigen::Vector3d& b = r.trajectory[i].world_from_body.translation;
    trajectory->appendLine(a.x(), a.y(), a.z(), b.x(), b.y(), b.z());
  }
  scene.insert(trajectory);

  auto rays = CSetOfLines::Create();
  rays->setName("detection rays");
  rays->setColor_u8(60, 170, 60, 90);
  for (const DetectionRay& ray : run.rays) {
    rays->appendLine(ray.from.x(), ray.from.y(), ray.from.z(), ray.to.x(), ray.to.y(), ray.to.z());
  }
  scene.insert(rays);

  for (const CameraRegistration& c : r.cameras) {
    if (c.status == CameraStatus::kUnregistered) continue;
    auto group = CSetOfObjects::Create();
    group->setName(c.label);
    group->setPose(toMrptPose(c.world_from_camera));
    auto frustum = CFrustum::Create(0.05f, 0.4f, 70.0f, 50.0f, 1.5f, true, false);
    // CFrustum looks along +x; the camera looks along +z: rotate x -> z.
    frustum->setPose(mrpt::poses::CPose3D(0, 0, 0, 0, -M_PI / 2, 0));
    if (c.status == CameraStatus::kSuspect) {
      frustum->setColor_u8(240, 140, 20);
    } else {
      frustum->setColor_u8(200, 30, 30);
    }
    group->insert(frustum);
    group->insert(stock_objects::CornerXYZSimple(0.3f, 2.0f));
    auto label = CText::Create(c.label);
    label->setLocation(0, 0, -0.15);
    group->insert(label);
    scene.insert(group);
    if (c.covariance) {
      auto pdf = CSetOfObjects::posePDF2opengl(toMrptPosePdf(c.world_from_camera, *c.covariance));
      pdf->setName(c.label + " pdf");
      scene.insert(pdf);
    }
  }
  if (!scene.saveToFile(file.string())) {
    throw Error(ErrorContext{file.string(), 0, "", ""}, "cannot write the scene");
  }
}

}  // namespace lookboth
