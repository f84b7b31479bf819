// The views: the 3-D scene (trajectory, cameras, detection rays) beside
// the fisheye verification (cameras projected into a fisheye frame, before
// and after the looking-up refinement, over the blobs detected) and the
// selected environment camera's frame (its marker detected, and where the
// registration puts it), with the frame slider and the overlay choice.
// Before a registration they show the ground truth of a simulated dataset.
#pragma once

#include <wx/splitter.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "lookboth/geometry/time.h"
#include "lookboth/registration/registration.h"
#include "lookboth/studio/dataset_index.h"

class wxChoice;
class wxNotebook;
class wxSlider;
class wxStaticText;

namespace lookboth::report {
struct RegistrationView;
}

namespace lookboth::studio_app {

class ImageView;
class SceneView;

class ViewsPanel : public wxSplitterWindow {
 public:
  /// What the views show: a dataset, and its registration once a stage has run.
  struct Content {
    std::shared_ptr<const studio::DatasetIndex> index;
    std::shared_ptr<const Registration> registration;
    std::shared_ptr<const report::RegistrationView> view;  ///< Of `registration`.
    std::vector<DetectionRay> rays;
  };

  /// `on_select`: a camera clicked in the scene.
  ViewsPanel(wxWindow* parent, std::function<void(const std::string&)> on_select);

  /// Shows `content` at the frame that verifies the most cameras.
  void show(Content content);
  void setSelected(const std::string& label);
  /// Fisheye frame `index` (clamped), and the selected camera at that time.
  void showFrame(int index);
  int frame() const;
  void nextFrame();
  void previousFrame();
  /// 0 before and after the refinement, 1 after only, 2 before only.
  void setOverlay(int mode);
  void cycleOverlay();

  SceneView* scene() const { return scene_; }
  ImageView* fisheyeView() const { return fisheye_view_; }
  ImageView* cameraView() const { return camera_view_; }
  wxNotebook* imageTabs() const { return image_tabs_; }

 private:
  wxWindow* buildImages();
  void refreshScene();
  /// The frame with the most blobs associated with cameras once looking up
  /// has run (the most cameras verified), else with the most blobs.
  int bestFrame() const;
  /// The fisheye frame with the registration's cameras projected, before
  /// and after the refinement (`image` empty: blobs only, on a grey canvas).
  void showRegisteredFisheye(const cv::Mat& image, cv::Size size, int index, TimeNs t,
                             double seconds);
  /// Before a registration: the blobs, and the cameras projected with the ground truth.
  void showTruthFisheye(cv::Mat& canvas, TimeNs t);
  /// The cameras the ground truth puts in the fisheye's view at `t`; how many.
  int drawTruthProjections(cv::Mat& canvas, TimeNs t, int thickness) const;
  /// The selected camera's frame nearest in time to the fisheye frame shown.
  void showCameraView();
  /// Its marker detected, and where the registration puts the marker.
  void showRegisteredCamera(const cv::Mat& image, cv::Size size, TimeNs t, const std::string& when);
  /// Before a registration: the marker detected, with its axes.
  void showDetectedMarker(cv::Mat& canvas, TimeNs t, const std::string& when);
  TimeNs frameTime(int index) const;
  TimeNs firstFrameTime() const;
  std::size_t frameCount() const;

  Content content_;
  std::string selected_;
  int overlay_mode_ = 0;

  SceneView* scene_ = nullptr;
  wxNotebook* image_tabs_ = nullptr;
  ImageView* fisheye_view_ = nullptr;
  ImageView* camera_view_ = nullptr;
  wxSlider* frame_slider_ = nullptr;
  wxStaticText* frame_text_ = nullptr;
  wxChoice* overlay_choice_ = nullptr;
};

}  // namespace lookboth::studio_app
