#include "lookboth/report/overview.h"

#include <mrpt/opengl/CBox.h>
#include <mrpt/opengl/CFBORender.h>
#include <mrpt/opengl/CFrustum.h>
#include <mrpt/opengl/CGridPlaneXY.h>
#include <mrpt/opengl/COpenGLScene.h>
#include <mrpt/opengl/CPointCloud.h>
#include <mrpt/opengl/CSetOfLines.h>
#include <mrpt/opengl/CSetOfObjects.h>
#include <mrpt/opengl/CText.h>
#include <mrpt/opengl/stock_objects.h>
#include <mrpt/poses/CPose3D.h>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "lookboth/core/error.h"
#include "lookboth/geometry/pose_conversions.h"
#include "lookboth/report/draw.h"

namespace lookboth::report {
namespace {

void setColour(mrpt::opengl::CRenderizable& object, const unsigned char rgb[3]) {
  object.setColor_u8(rgb[0], rgb[1], rgb[2]);
}

cv::Scalar bgr(const unsigned char rgb[3]) { return cv::Scalar(rgb[2], rgb[1], rgb[0]); }

}  // namespace

cv::Mat renderOverview(const OverviewInput& input, cv::Size size) {
  using namespace mrpt::opengl;
  // Extent of everything drawn.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = Eigen::Vector3d::Constant(-1e300);
  const auto extend = [&](const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  };
  for (const auto& c : input.cameras) extend(c.world_from_camera.translation);
  for (const auto& p : input.trajectory) extend(p);
  for (const auto& [label, p] : input.reference) extend(p);
  if (lo.x() > hi.x()) lo = hi = Eigen::Vector3d::Zero();
  const double extent = std::max((hi - lo).norm(), 1.0);
  const Eigen::Vector3d centre = (lo + hi) / 2;

  COpenGLScene scene;
  scene.getViewport()->setCustomBackgroundColor({1.f, 1.f, 1.f, 1.f});

  // Floor grid at the lowest trajectory height (1 m cells).
  const double floor_z = input.trajectory.empty() ? lo.z() : [&] {
    double z = 1e300;
    for (const auto& p : input.trajectory) z = std::min(z, p.z());
    return z;
  }();
  auto grid = CGridPlaneXY::Create(std::floor(lo.x() - 1), std::ceil(hi.x() + 1),
                                   std::floor(lo.y() - 1), std::ceil(hi.y() + 1), floor_z, 1.0);
  grid->setColor_u8(205, 205, 205);
  scene.insert(grid);

  if (!input.rays.empty()) {
    auto rays = CSetOfLines::Create();
    setColour(*rays, OverviewColours::kRay);
    rays->setLineWidth(1.0f);
    for (const auto& [from, to] : input.rays) {
      rays->appendLine(from.x(), from.y(), from.z(), to.x(), to.y(), to.z());
    }
    scene.insert(rays);
  }
  if (input.trajectory.size() >= 2) {
    auto line = CSetOfLines::Create();
    setColour(*line, OverviewColours::kTrajectory);
    line->setLineWidth(2.0f);
    for (size_t i = 1; i < input.trajectory.size(); ++i) {
      const auto& a = input.trajectory[i - 1];
      const auto& b = input.trajectory[i];
      line->appendLine(a.x(), a.y(), a.z(), b.x(), b.y(), b.z());
    }
    scene.insert(line);
    auto dots = CPointCloud::Create();
    setColour(*dots, OverviewColours::kTrajectory);
    dots->setPointSize(3.0f);
    const size_t step = std::max<size_t>(1, input.trajectory.size() / 300);
    for (size_t i = 0; i < input.trajectory.size(); i += step) {
      const auto& p = input.trajectory[i];
      dots->insertPoint(p.x(), p.y(), p.z());
    }
    scene.insert(dots);
  }

  // MRPT's frustum points along its +X; the camera looks along its +Z:
  // camera_from_frustum maps frustum x -> camera z, y -> -camera x, z -> -camera y.
  Eigen::Matrix4d camera_from_frustum = Eigen::Matrix4d::Identity();
  camera_from_frustum.topLeftCorner<3, 3>() << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  const Rigid3d frustum_in_camera = rigid3FromMatrix(camera_from_frustum);
  const float far = static_cast<float>(std::clamp(0.04 * extent, 0.15, 2.0));
  for (const auto& c : input.cameras) {
    const unsigned char* colour = c.suspect ? OverviewColours::kSuspect : OverviewColours::kCamera;
    auto frustum = CFrustum::Create(0.01f, far, 70.0f, 45.0f, 2.0f, true, false);
    setColour(*frustum, colour);
    frustum->setPose(toMrptPose(c.world_from_camera * frustum_in_camera));
    scene.insert(frustum);
    auto axes = stock_objects::CornerXYZSimple(static_cast<float>(far * 0.8), 3.0f);
    axes->setPose(toMrptPose(c.world_from_camera));
    scene.insert(axes);
    auto label = CText::Create(c.label);
    label->setColor_u8(0, 0, 0);
    const Eigen::Vector3d& p = c.world_from_camera.translation;
    label->setLocation(p.x(), p.y(), p.z() + far * 0.6);
    scene.insert(label);
  }
  for (const auto& [label, p] : input.reference) {
    const double half = std::clamp(0.008 * extent, 0.04, 0.5);
    auto box = CBox::Create(mrpt::math::TPoint3D(p.x() - half, p.y() - half, p.z() - half),
                            mrpt::math::TPoint3D(p.x() + half, p.y() + half, p.z() + half));
    setColour(*box, OverviewColours::kReference);
    scene.insert(box);
  }

  mrpt::img::CImage rendered;
  try {
    CFBORender renderer(static_cast<unsigned>(size.width), static_cast<unsigned>(size.height));
    CCamera& camera = renderer.getCamera(scene);
    camera.setPointingAt(centre.x(), centre.y(), (centre.z() + floor_z) / 2);
    camera.setAzimuthDegrees(-65.0f);
    camera.setElevationDegrees(38.0f);
    camera.setProjectiveFOVdeg(40.0f);
    camera.setZoomDistance(static_cast<float>(1.1 * extent / (2 * std::tan(20.0 * M_PI / 180))));
    renderer.render_RGB(scene, rendered);
  } catch (const std::exception& e) {
    throw Error(std::string("off-screen rendering (MRPT CFBORender through EGL) failed: ") +
                e.what());
  }
  cv::Mat image = rendered.asCvMat<cv::Mat>(mrpt::img::DEEP_COPY);
  if (image.channels() == 1) cv::cvtColor(image, image, cv::COLOR_GRAY2BGR);
  if (image.size() != size) cv::resize(image, image, size);

  const double font = std::clamp(size.width / 1900.0, 0.33, 0.8);
  cv::putText(image, input.title, {10, 22}, cv::FONT_HERSHEY_SIMPLEX, font * 1.1,
              cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  std::vector<std::pair<std::string, cv::Scalar>> entries = {
      {"camera (frustum, axes x red y green z blue)", bgr(OverviewColours::kCamera)}};
  if (std::any_of(input.cameras.begin(), input.cameras.end(),
                  [](const auto& c) { return c.suspect; }))
    entries.push_back({"suspect camera", bgr(OverviewColours::kSuspect)});
  if (!input.trajectory.empty())
    entries.push_back({"robot trajectory", bgr(OverviewColours::kTrajectory)});
  if (!input.rays.empty())
    entries.push_back({"marker detections (camera to marker)", bgr(OverviewColours::kRay)});
  if (!input.reference.empty())
    entries.push_back({"reference camera positions", bgr(OverviewColours::kReference)});
  const cv::Size legend = measureLegend(entries, {"grid: 1 m"}, font);
  drawLegend(image, entries, {"grid: 1 m"}, font, cv::Point(8, size.height - legend.height - 8));
  return image;
}

}  // namespace lookboth::report
