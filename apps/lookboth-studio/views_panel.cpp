#include "views_panel.h"

#include <wx/choice.h>
#include <wx/notebook.h>
#include <wx/panel.h>
#include <wx/sizer.h>
#include <wx/slider.h>
#include <wx/stattext.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "image_view.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/report/draw.h"
#include "lookboth/report/snapshot.h"
#include "scene_view.h"

namespace lookboth::studio_app {
namespace {

// Overlay colours (BGR for OpenCV), as the captions name them.
const cv::Scalar kBlobColour(60, 220, 60);        // detected blobs: green
const cv::Scalar kProjectedColour(255, 120, 30);  // cameras projected: blue
const cv::Scalar kSelectedColour(0, 200, 255);    // selected camera: amber

/// A marker detection counts for a frame within this time of it.
constexpr TimeNs kNearDetectionNs = 100'000'000;

wxImage toWxImage(const cv::Mat& image) {
  cv::Mat rgb;
  if (image.channels() == 1) {
    cv::cvtColor(image, rgb, cv::COLOR_GRAY2RGB);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, rgb, cv::COLOR_BGRA2RGB);
  } else {
    cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
  }
  wxImage out(rgb.cols, rgb.rows);
  for (int r = 0; r < rgb.rows; ++r)
    std::copy_n(rgb.ptr<unsigned char>(r), 3 * rgb.cols, out.GetData() + 3 * r * rgb.cols);
  return out;
}

cv::Point toCv(const Eigen::Vector2d& p) {
  return cv::Point(static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y())));
}

const MarkerObservation* nearestDetection(const std::vector<MarkerObservation>& markers, TimeNs t) {
  const MarkerObservation* nearest = nullptr;
  for (const auto& m : markers)
    if (std::llabs(m.t - t) < kNearDetectionNs &&
        (!nearest || std::llabs(m.t - t) < std::llabs(nearest->t - t)))
      nearest = &m;
  return nearest;
}

}  // namespace

ViewsPanel::ViewsPanel(wxWindow* parent, std::function<void(const std::string&)> on_select)
    : wxSplitterWindow(parent, wxID_ANY, wxDefaultPosition, wxDefaultSize,
                       wxSP_LIVE_UPDATE | wxSP_3DSASH) {
  auto* scene_panel = new wxPanel(this);
  auto* scene_sizer = new wxBoxSizer(wxVERTICAL);
  scene_ = new SceneView(scene_panel);
  scene_sizer->Add(scene_, 1, wxEXPAND);
  scene_sizer->Add(new wxStaticText(scene_panel, wxID_ANY,
                                    "Drag: rotate, wheel: zoom, shift+drag: pan, click: select. "
                                    "Ctrl+1 top, Ctrl+2 side, Ctrl+0 fit"),
                   0, wxALL, 3);
  scene_panel->SetSizer(scene_sizer);
  scene_->setOnSelect(std::move(on_select));
  SplitVertically(scene_panel, buildImages(), 0);
  SetSashGravity(0.5);
  SetMinimumPaneSize(200);
}

wxWindow* ViewsPanel::buildImages() {
  auto* panel = new wxPanel(this);
  auto* sizer = new wxBoxSizer(wxVERTICAL);
  image_tabs_ = new wxNotebook(panel, wxID_ANY);
  fisheye_view_ = new ImageView(image_tabs_, "Fisheye verification\n(open a dataset)");
  camera_view_ = new ImageView(image_tabs_, "Environment camera\n(select a camera)");
  image_tabs_->AddPage(fisheye_view_, "Fisheye verification");
  image_tabs_->AddPage(camera_view_, "Environment camera");
  sizer->Add(image_tabs_, 1, wxEXPAND);
  auto* row = new wxBoxSizer(wxHORIZONTAL);
  frame_slider_ = new wxSlider(panel, wxID_ANY, 0, 0, 1);
  frame_text_ = new wxStaticText(panel, wxID_ANY, "frame -", wxDefaultPosition, wxSize(170, -1));
  row->Add(frame_slider_, 1, wxEXPAND);
  row->Add(frame_text_, 0, wxALIGN_CENTER_VERTICAL | wxLEFT, 6);
  const wxString overlays[] = {"before + after", "after refinement", "before refinement"};
  overlay_choice_ = new wxChoice(panel, wxID_ANY, wxDefaultPosition, wxDefaultSize, 3, overlays);
  overlay_choice_->SetSelection(0);
  overlay_choice_->SetToolTip(
      "Cameras projected into the fisheye: before and/or after the "
      "looking-up refinement (Ctrl+B cycles)");
  overlay_choice_->Bind(wxEVT_CHOICE, [this](wxCommandEvent&) {
    overlay_mode_ = overlay_choice_->GetSelection();
    showFrame(frame());
  });
  row->Add(new wxStaticText(panel, wxID_ANY, "Overlay"), 0, wxALIGN_CENTER_VERTICAL | wxLEFT, 8);
  row->Add(overlay_choice_, 0, wxALIGN_CENTER_VERTICAL | wxLEFT, 4);
  sizer->Add(row, 0, wxALL | wxEXPAND, 3);
  panel->SetSizer(sizer);
  frame_slider_->Bind(wxEVT_SLIDER, [this](wxCommandEvent&) { showFrame(frame()); });
  return panel;
}

void ViewsPanel::show(Content content) {
  content_ = std::move(content);
  if (!content_.index) return;
  frame_slider_->SetRange(0, std::max<int>(0, static_cast<int>(frameCount()) - 1));
  refreshScene();
  showFrame(std::min<int>(bestFrame(), frame_slider_->GetMax()));
}

void ViewsPanel::setSelected(const std::string& label) {
  selected_ = label;
  scene_->setSelected(label);
  showFrame(frame());
}

int ViewsPanel::frame() const { return frame_slider_->GetValue(); }

void ViewsPanel::nextFrame() {
  if (frame() < frame_slider_->GetMax()) showFrame(frame() + 1);
}

void ViewsPanel::previousFrame() {
  if (frame() > 0) showFrame(frame() - 1);
}

void ViewsPanel::setOverlay(int mode) {
  overlay_mode_ = std::clamp(mode, 0, 2);
  overlay_choice_->SetSelection(overlay_mode_);
  showFrame(frame());
}

void ViewsPanel::cycleOverlay() {
  image_tabs_->SetSelection(0);
  setOverlay((overlay_mode_ + 1) % 3);
}

std::size_t ViewsPanel::frameCount() const {
  const auto& index = *content_.index;
  return !index.fisheyeFrames().empty() ? index.fisheyeFrames().size() : index.blobs().size();
}

TimeNs ViewsPanel::frameTime(int i) const {
  const auto& index = *content_.index;
  const size_t k = static_cast<size_t>(std::clamp<int>(i, 0, static_cast<int>(frameCount()) - 1));
  return !index.fisheyeFrames().empty() ? index.fisheyeFrames()[k].t : index.blobs()[k].t;
}

TimeNs ViewsPanel::firstFrameTime() const { return frameTime(0); }

void ViewsPanel::refreshScene() {
  const studio::DatasetIndex& index = *content_.index;
  SceneContent scene;
  auto add_trajectory = [&](const std::vector<StampedPose>& samples) {
    for (const auto& s : samples)
      if (scene.trajectory.empty() ||
          (scene.trajectory.back() - s.world_from_body.translation).norm() > 0.05)
        scene.trajectory.push_back(s.world_from_body.translation);
  };
  if (const Registration* registration = content_.registration.get()) {
    add_trajectory(registration->trajectory);
    for (const auto& c : registration->cameras) {
      const int status = c.status == CameraStatus::kRegistered ? 0
                         : c.status == CameraStatus::kSuspect  ? 1
                                                               : 2;
      if (c.status != CameraStatus::kUnregistered)
        scene.cameras.push_back(SceneCamera{c.label, c.world_from_camera, status});
    }
    // At most ~16 rays per camera: enough to see where it saw the marker from.
    const auto& rays = content_.rays;
    std::map<std::string, int> rays_per_camera;
    for (const auto& ray : rays) {
      // Rays are drawn from the camera nearest to their start.
      std::string nearest;
      double best = 0.05;
      for (const auto& c : scene.cameras) {
        const double d = (c.world_from_camera.translation - ray.from).norm();
        if (d < best) {
          best = d;
          nearest = c.label;
        }
      }
      if (nearest.empty()) continue;
      const int n = rays_per_camera[nearest]++;
      if (n % std::max<int>(1, static_cast<int>(rays.size() / scene.cameras.size() / 16)) == 0)
        scene.rays.emplace_back(nearest, ray.to);
    }
    scene.caption = "registration";
  } else {
    const Manifest& m = index.manifest();
    if (const Trajectory* trajectory = index.trajectory("ground_truth"))
      add_trajectory(trajectory->samples());
    for (const auto& [label, pose] : m.ground_truth.world_from_camera)
      scene.cameras.push_back(SceneCamera{label, pose, index.markers(label).empty() ? 2 : 0});
    // Detection rays: where the marker was when each camera saw it (a sample of them).
    for (const auto& [label, pose] : m.ground_truth.world_from_camera) {
      const auto& markers = index.markers(label);
      const size_t step = std::max<size_t>(1, markers.size() / 12);
      for (size_t i = 0; i < markers.size(); i += step)
        scene.rays.emplace_back(label, (pose * markers[i].camera_from_marker).translation);
    }
    scene.caption = "ground truth";
  }
  scene_->setContent(scene);
  scene_->setSelected(selected_);
}

int ViewsPanel::bestFrame() const {
  const studio::DatasetIndex& index = *content_.index;
  int best = 0;
  size_t most = 0;
  std::map<TimeNs, size_t> associated;
  if (content_.view)
    for (const auto& row : content_.view->blob_associations) ++associated[row.t];
  for (size_t i = 0; i < index.blobs().size(); ++i) {
    const auto it = associated.find(index.blobs()[i].t);
    const size_t n = associated.empty() ? index.blobs()[i].blobs.size()
                                        : (it == associated.end() ? 0 : it->second);
    if (n > most) {
      most = n;
      best = static_cast<int>(i);
    }
  }
  const auto& frames = index.fisheyeFrames();
  if (frames.empty() || index.blobs().empty()) return best;
  // The fisheye frame at that blob record's time.
  const TimeNs t = index.blobs()[static_cast<size_t>(best)].t;
  return static_cast<int>(
      std::lower_bound(frames.begin(), frames.end(), t,
                       [](const studio::FrameRef& a, TimeNs q) { return a.t < q; }) -
      frames.begin());
}

void ViewsPanel::showFrame(int i) {
  if (!content_.index) return;
  const studio::DatasetIndex& index = *content_.index;
  const auto& frames = index.fisheyeFrames();
  const bool has_images = !frames.empty();
  const size_t count = frameCount();
  if (count == 0) {
    fisheye_view_->setPlaceholder("This dataset has no fisheye frames or blobs.");
    return;
  }
  i = std::clamp(i, 0, static_cast<int>(count) - 1);
  frame_slider_->SetValue(i);
  const TimeNs t = frameTime(i);
  const double seconds = static_cast<double>(t - firstFrameTime()) * 1e-9;
  frame_text_->SetLabel(wxString::Format("frame %d (0-%zu)   %.2f s", i, count - 1, seconds));
  const CameraSensor* fisheye = index.manifest().fisheye();
  cv::Mat canvas;
  try {
    if (has_images) {
      canvas = studio::decodeFrame(frames[static_cast<size_t>(i)].image);
    } else if (fisheye && fisheye->camera) {
      canvas = cv::Mat(fisheye->camera->height(), fisheye->camera->width(), CV_8UC3,
                       cv::Scalar(40, 40, 40));
    }
  } catch (const Error& e) {
    fisheye_view_->setPlaceholder(wxString::FromUTF8(e.what()));
    fisheye_view_->setImage(wxImage());
    return;
  }
  if (canvas.empty()) return;
  if (canvas.channels() == 1) cv::cvtColor(canvas, canvas, cv::COLOR_GRAY2BGR);
  if (content_.view && fisheye && fisheye->camera)
    showRegisteredFisheye(has_images ? canvas : cv::Mat(), canvas.size(), i, t, seconds);
  else
    showTruthFisheye(canvas, t);
  showCameraView();
}

void ViewsPanel::showRegisteredFisheye(const cv::Mat& image, cv::Size size, int i, TimeNs t,
                                       double seconds) {
  const studio::DatasetIndex& index = *content_.index;
  std::vector<Eigen::Vector2d> blob_pixels;
  if (const BlobObservation* blobs = index.blobsAt(t))
    for (const Blob& b : blobs->blobs) blob_pixels.emplace_back(b.u, b.v);
  report::FisheyeCheck check =
      report::makeFisheyeCheck(*content_.view, *index.manifest().fisheye()->camera, t, blob_pixels);
  check.frame_index = i;
  check.seconds = seconds;
  // The overlay choice: cameras projected before, after the refinement, or both.
  for (auto& c : check.cameras) {
    if (overlay_mode_ == 1) c.before.reset();
    if (overlay_mode_ == 2) c.after.reset();
  }
  const char* highlighted = overlay_mode_ == 2 ? "before" : "after";
  std::vector<report::OverlayMark> marks;
  cv::Mat drawn = report::drawFisheyeCheck(check, image, size, &marks);
  const int thickness = std::max(1, size.width / 640);
  for (const auto& mark : marks)
    if (mark.label == selected_ && mark.kind == highlighted)
      cv::circle(drawn, cv::Point(static_cast<int>(mark.at.x), static_cast<int>(mark.at.y)),
                 14 * thickness, kSelectedColour, thickness + 1);
  fisheye_view_->setImage(
      toWxImage(drawn),
      wxString::Format("%d cameras in view, %d with their blob; %s; amber ring: selected",
                       static_cast<int>(check.cameras.size()), check.associated(),
                       overlay_mode_ == 0   ? "red: before, blue: after refinement"
                       : overlay_mode_ == 1 ? "blue: after refinement"
                                            : "red: before refinement"));
}

void ViewsPanel::showTruthFisheye(cv::Mat& canvas, TimeNs t) {
  const studio::DatasetIndex& index = *content_.index;
  const int thickness = std::max(1, canvas.cols / 640);
  int blob_count = 0;
  if (const BlobObservation* blobs = index.blobsAt(t)) {
    for (const Blob& b : blobs->blobs) {
      cv::circle(canvas, cv::Point(static_cast<int>(b.u), static_cast<int>(b.v)),
                 std::max(10 * thickness, static_cast<int>(b.diameter_px / 2 + 4)), kBlobColour,
                 thickness + 1);
      ++blob_count;
    }
  }
  const int projected = drawTruthProjections(canvas, t, thickness);
  fisheye_view_->setImage(
      toWxImage(canvas),
      wxString::Format("green o: %d blobs detected   blue x: %d cameras projected (truth)   "
                       "amber: selected",
                       blob_count, projected));
}

int ViewsPanel::drawTruthProjections(cv::Mat& canvas, TimeNs t, int thickness) const {
  const studio::DatasetIndex& index = *content_.index;
  const CameraSensor* fisheye = index.manifest().fisheye();
  const Trajectory* trajectory = index.trajectory("ground_truth");
  if (!fisheye || !fisheye->camera || !trajectory) return 0;
  const auto at = trajectory->interpolate(t, 0);
  if (!at.ok()) return 0;
  const Rigid3d fisheye_from_world = at.world_from_body.inverse();
  int projected = 0;
  for (const auto& [label, pose] : index.manifest().ground_truth.world_from_camera) {
    const auto pixel = fisheye->camera->project(fisheye_from_world * pose.translation);
    if (!pixel || !fisheye->camera->isInImage(*pixel)) continue;
    const cv::Scalar colour = label == selected_ ? kSelectedColour : kProjectedColour;
    const cv::Point p = toCv(*pixel);
    const int s = 5 * thickness;
    cv::line(canvas, p - cv::Point(s, s), p + cv::Point(s, s), colour, thickness + 1);
    cv::line(canvas, p - cv::Point(s, -s), p + cv::Point(s, -s), colour, thickness + 1);
    cv::putText(canvas, label, p + cv::Point(s + 2, -s), cv::FONT_HERSHEY_SIMPLEX, 0.45 * thickness,
                colour, thickness);
    ++projected;
  }
  return projected;
}

void ViewsPanel::showCameraView() {
  if (!content_.index || selected_.empty()) return;
  const studio::DatasetIndex& index = *content_.index;
  const CameraSensor* sensor = index.manifest().findCamera(selected_);
  const auto& frames = index.cameraFrames(selected_);
  // The camera's frame nearest in time to the fisheye frame shown.
  const TimeNs t = frameTime(frame());
  cv::Mat canvas;
  TimeNs frame_t = t;
  if (!frames.empty()) {
    auto it = std::lower_bound(frames.begin(), frames.end(), t,
                               [](const studio::FrameRef& a, TimeNs q) { return a.t < q; });
    if (it == frames.end()) --it;
    if (it != frames.begin() && std::llabs(std::prev(it)->t - t) < std::llabs(it->t - t)) --it;
    try {
      canvas = studio::decodeFrame(it->image);
      frame_t = it->t;
    } catch (const Error& e) {
      camera_view_->setPlaceholder(wxString::FromUTF8(e.what()));
      camera_view_->setImage(wxImage());
      return;
    }
  } else if (sensor && sensor->camera) {
    canvas =
        cv::Mat(sensor->camera->height(), sensor->camera->width(), CV_8UC3, cv::Scalar(40, 40, 40));
  }
  if (canvas.empty()) {
    camera_view_->setPlaceholder(wxString::FromUTF8(selected_ + ": no frames, no calibration"));
    camera_view_->setImage(wxImage());
    return;
  }
  // Times as in the fisheye view: seconds since its first frame.
  const std::string when =
      formatFixed(static_cast<double>(frame_t - firstFrameTime()) * 1e-9, 2) + " s";
  if (content_.view && sensor && sensor->camera)
    showRegisteredCamera(frames.empty() ? cv::Mat() : canvas, canvas.size(), frame_t, when);
  else
    showDetectedMarker(canvas, frame_t, when);
}

void ViewsPanel::showRegisteredCamera(const cv::Mat& image, cv::Size size, TimeNs t,
                                      const std::string& when) {
  const studio::DatasetIndex& index = *content_.index;
  const report::RegistrationView& view = *content_.view;
  report::EnvCameraView env;
  env.camera = selected_;
  env.t = t;
  env.marker_size_m = index.manifest().marker.size_m;
  if (const MarkerObservation* nearest = nearestDetection(index.markers(selected_), t))
    env.detected_camera_from_marker = nearest->camera_from_marker;
  const auto camera_pose = view.world_from_camera.find(selected_);
  const auto robot = view.trajectory.interpolate(t, 0);
  if (camera_pose != view.world_from_camera.end() && robot.ok() && view.fisheye_from_marker)
    env.predicted_camera_from_marker =
        camera_pose->second.inverse() * robot.world_from_body * *view.fisheye_from_marker;
  const cv::Mat drawn =
      report::drawEnvCameraView(env, *index.manifest().findCamera(selected_)->camera, image, size);
  camera_view_->setImage(
      toWxImage(drawn),
      wxString::FromUTF8(selected_ + "  " + when +
                         "   yellow: detected marker, magenta: where the registration puts it"));
}

void ViewsPanel::showDetectedMarker(cv::Mat& canvas, TimeNs t, const std::string& when) {
  const studio::DatasetIndex& index = *content_.index;
  const CameraSensor* sensor = index.manifest().findCamera(selected_);
  if (canvas.channels() == 1) cv::cvtColor(canvas, canvas, cv::COLOR_GRAY2BGR);
  // The marker detection nearest in time, with its axes.
  wxString caption = wxString::FromUTF8(selected_ + "  " + when);
  const MarkerObservation* nearest = nearestDetection(index.markers(selected_), t);
  if (!nearest || !sensor || !sensor->camera) {
    camera_view_->setImage(toWxImage(canvas), caption + "   no marker detection near this time");
    return;
  }
  const Camera& camera = *sensor->camera;
  const double size = index.manifest().marker.size_m;
  const Rigid3d& c = nearest->camera_from_marker;
  const int thickness = std::max(1, canvas.cols / 480);
  if (const auto origin = camera.project(c.translation)) {
    const Eigen::Vector3d axes[3] = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                                     Eigen::Vector3d::UnitZ()};
    const cv::Scalar colours[3] = {cv::Scalar(40, 40, 255), cv::Scalar(40, 220, 40),
                                   cv::Scalar(255, 80, 40)};
    for (int k = 0; k < 3; ++k)
      if (const auto end = camera.project(c * (axes[k] * size)))
        cv::line(canvas, toCv(*origin), toCv(*end), colours[k], thickness + 1);
    // The square's outline.
    std::vector<cv::Point> outline;
    for (const auto& corner : {Eigen::Vector3d(-1, 1, 0), Eigen::Vector3d(1, 1, 0),
                               Eigen::Vector3d(1, -1, 0), Eigen::Vector3d(-1, -1, 0)})
      if (const auto p = camera.project(c * (corner * size / 2))) outline.push_back(toCv(*p));
    if (outline.size() == 4) cv::polylines(canvas, outline, true, kSelectedColour, thickness);
  }
  caption +=
      wxString::Format("   marker at %.2f m   (axes x red, y green, z blue)", c.translation.norm());
  camera_view_->setImage(toWxImage(canvas), caption);
}

}  // namespace lookboth::studio_app
