// The 3-D view: trajectory, cameras as frustums with labels, detection rays.
// MRPT's wx OpenGL canvas with its mouse navigation (left drag rotates,
// right drag or wheel zooms, shift/middle drag pans); a click selects the
// camera nearest to the clicked ray.
#pragma once

#include <mrpt/gui/CWxGLCanvasBase.h>

#include <functional>
#include <string>
#include <vector>

#include "lookboth/geometry/rigid3.h"

namespace lookboth::studio_app {

struct SceneCamera {
  std::string label;
  Rigid3d world_from_camera;
  /// 0 registered / ground truth, 1 suspect, 2 unregistered (drawn grey, at its last estimate).
  int status = 0;
};

struct SceneContent {
  std::vector<Eigen::Vector3d> trajectory;  ///< Fisheye positions in the world [m].
  std::vector<SceneCamera> cameras;
  /// Detection rays: camera label -> marker positions in the world seen from it.
  std::vector<std::pair<std::string, Eigen::Vector3d>> rays;
  std::string caption;  ///< What is shown ("ground truth", "registration"...).
};

class SceneView : public mrpt::gui::CWxGLCanvasBase {
 public:
  explicit SceneView(wxWindow* parent);
  void setContent(const SceneContent& content);
  void setSelected(const std::string& label);
  void setOnSelect(std::function<void(const std::string&)> on_select) {
    on_select_ = std::move(on_select);
  }
  void topView();
  void sideView();
  void fitView();

 private:
  void rebuild();
  void onLeftDown(wxMouseEvent& event);
  void onLeftUp(wxMouseEvent& event);

  SceneContent content_;
  std::string selected_;
  std::function<void(const std::string&)> on_select_;
  wxPoint down_at_;
  Eigen::Vector3d centre_ = Eigen::Vector3d::Zero();
  double extent_ = 10;
};

}  // namespace lookboth::studio_app
