#include "scene_view.h"

#include <mrpt/math/TLine3D.h>
#include <mrpt/opengl/CFrustum.h>
#include <mrpt/opengl/CGridPlaneXY.h>
#include <mrpt/opengl/COpenGLScene.h>
#include <mrpt/opengl/CSetOfLines.h>
#include <mrpt/opengl/CSetOfObjects.h>
#include <mrpt/opengl/CText.h>
#include <mrpt/opengl/stock_objects.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "lookboth/geometry/pose_conversions.h"

namespace lookboth::studio_app {
namespace {

mrpt::img::TColor statusColour(int status, bool selected) {
  if (selected) return mrpt::img::TColor(255, 200, 0);
  switch (status) {
    case 0:
      return mrpt::img::TColor(40, 200, 80);
    case 1:
      return mrpt::img::TColor(240, 140, 30);
    default:
      return mrpt::img::TColor(150, 150, 150);
  }
}

}  // namespace

SceneView::SceneView(wxWindow* parent) : mrpt::gui::CWxGLCanvasBase(parent, wxID_ANY) {
  Bind(wxEVT_LEFT_DOWN, &SceneView::onLeftDown, this);
  Bind(wxEVT_LEFT_UP, &SceneView::onLeftUp, this);
  setOpenGLSceneRef(mrpt::opengl::COpenGLScene::Create());
  rebuild();
}

void SceneView::setContent(const SceneContent& content) {
  content_ = content;
  // Frame everything: the trajectory and the cameras.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::max());
  Eigen::Vector3d hi = -lo;
  auto grow = [&](const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  };
  for (const auto& p : content_.trajectory) grow(p);
  for (const auto& c : content_.cameras) grow(c.world_from_camera.translation);
  if (lo.x() <= hi.x()) {
    centre_ = 0.5 * (lo + hi);
    extent_ = std::max(2.0, (hi - lo).norm());
  }
  rebuild();
  fitView();
}

void SceneView::setSelected(const std::string& label) {
  if (label == selected_) return;
  selected_ = label;
  rebuild();
}

void SceneView::topView() {
  setCameraPointing(centre_.x(), centre_.y(), centre_.z());
  setAzimuthDegrees(-90);
  setElevationDegrees(89.9f);
  setZoomDistance(static_cast<float>(extent_ * 2.0));
  Refresh(false);
}

void SceneView::sideView() {
  setCameraPointing(centre_.x(), centre_.y(), centre_.z());
  setAzimuthDegrees(-90);
  setElevationDegrees(0.5f);
  setZoomDistance(static_cast<float>(extent_ * 2.0));
  Refresh(false);
}

void SceneView::fitView() {
  setCameraPointing(centre_.x(), centre_.y(), centre_.z());
  setAzimuthDegrees(-60);
  setElevationDegrees(45);
  setZoomDistance(static_cast<float>(extent_ * 2.2));
  Refresh(false);
}

void SceneView::rebuild() {
  using namespace mrpt::opengl;
  auto scene = COpenGLScene::Create();
  scene->getViewport()->setCustomBackgroundColor(mrpt::img::TColorf(0.13f, 0.14f, 0.16f));

  const double half = std::ceil(extent_ * 0.6);
  auto grid = CGridPlaneXY::Create(
      static_cast<float>(centre_.x() - half), static_cast<float>(centre_.x() + half),
      static_cast<float>(centre_.y() - half), static_cast<float>(centre_.y() + half), 0, 1.0f);
  grid->setColor_u8(mrpt::img::TColor(70, 70, 80));
  scene->insert(grid);
  scene->insert(stock_objects::CornerXYZSimple(1.0f, 3.0f));

  if (content_.trajectory.size() >= 2) {
    auto lines = CSetOfLines::Create();
    for (size_t i = 1; i < content_.trajectory.size(); ++i) {
      const auto& a = content_.trajectory[i - 1];
      const auto& b = content_.trajectory[i];
      lines->appendLine(a.x(), a.y(), a.z(), b.x(), b.y(), b.z());
    }
    lines->setLineWidth(2.0f);
    lines->setColor_u8(mrpt::img::TColor(80, 160, 255));
    scene->insert(lines);
  }
  if (!content_.rays.empty()) {
    auto rays = CSetOfLines::Create();
    for (const auto& [label, p] : content_.rays) {
      for (const auto& c : content_.cameras) {
        if (c.label != label) continue;
        const auto& o = c.world_from_camera.translation;
        rays->appendLine(o.x(), o.y(), o.z(), p.x(), p.y(), p.z());
      }
    }
    rays->setColor_u8(mrpt::img::TColor(255, 255, 255, 40));
    scene->insert(rays);
  }
  for (const auto& c : content_.cameras) {
    const bool selected = c.label == selected_;
    auto group = CSetOfObjects::Create();
    auto frustum = CFrustum::Create(0.05f, selected ? 0.9f : 0.6f, 70.0f, 45.0f,
                                    selected ? 3.0f : 1.5f, true, false);
    // CFrustum looks along +X; a camera looks along +Z (x right, y down).
    frustum->setPose(mrpt::poses::CPose3D(0, 0, 0, 0, -M_PI / 2, -M_PI / 2));
    frustum->setColor_u8(statusColour(c.status, selected));
    group->insert(frustum);
    group->insert(stock_objects::CornerXYZSimple(0.3f, 2.0f));
    group->setPose(toMrptPose(c.world_from_camera));
    scene->insert(group);
    auto text = CText::Create(c.label);
    const auto& t = c.world_from_camera.translation;
    text->setLocation(t.x(), t.y(), t.z() + 0.25);
    text->setColor_u8(statusColour(c.status, selected));
    scene->insert(text);
  }
  getOpenGLSceneRef() = scene;
  Refresh(false);
}

void SceneView::onLeftDown(wxMouseEvent& event) {
  down_at_ = event.GetPosition();
  event.Skip();
}

void SceneView::onLeftUp(wxMouseEvent& event) {
  event.Skip();
  const wxPoint up = event.GetPosition();
  if (std::abs(up.x - down_at_.x) + std::abs(up.y - down_at_.y) > 3 || content_.cameras.empty())
    return;
  auto scene = getOpenGLSceneRef();
  if (!scene) return;
  mrpt::math::TLine3D ray;
  const wxSize size = GetClientSize();
  // MRPT's viewport pixel coordinates have their origin at the bottom left.
  scene->getViewport()->get3DRayForPixelCoord(up.x, size.y - 1 - up.y, ray);
  const Eigen::Vector3d o(ray.pBase.x, ray.pBase.y, ray.pBase.z);
  Eigen::Vector3d d(ray.director[0], ray.director[1], ray.director[2]);
  d.normalize();
  double best = std::numeric_limits<double>::max();
  std::string best_label;
  for (const auto& c : content_.cameras) {
    const Eigen::Vector3d v = c.world_from_camera.translation - o;
    const double along = v.dot(d);
    if (along <= 0) continue;
    const double angle = std::atan2((v - along * d).norm(), along);
    if (angle < best) {
      best = angle;
      best_label = c.label;
    }
  }
  if (!best_label.empty() && best < 0.05 && on_select_) on_select_(best_label);
}

}  // namespace lookboth::studio_app
